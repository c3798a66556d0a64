/* loomfmu shared runtime: the model-exchange core (lf_me.h), independent of
 * the FMI version.
 *
 * The importer's solver integrates; the FMU evaluates at the time and
 * states the importer set: the unknowns w = [der(x); z] by lf_solve_w
 * (closed form, or Newton for algebraic loops, as in co-simulation), the
 * event indicators of the current modes (LF_FN_EVT), and in event mode the
 * modes chosen again by the rules of co-simulation (lf_events.c).
 *
 * The reference signs of the indicators are c->ev.e_old (part of the FMU
 * state): set at the start, at every completed step without a sign change,
 * after an event update and on entering continuous-time mode.  An event
 * update chooses again the mode of every indicator whose sign differs from
 * the reference (lf_event_update of lf_events.c, as co-simulation does).
 *
 * The solver of co-simulation is not used, but kept at (t, x) so that an
 * FMU state taken in model exchange is consistent (lf_state.c checks it). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_me.h"
#include "lf_base.h"
#include "lf_delay.h"
#include "lf_eval.h"
#include "lf_instance.h"
#include "lf_internal.h"
#include "lf_modes.h"
#include "lf_newton.h"
#include "lf_start.h"
#include "lf_step.h"

/* ---- checks ---------------------------------------------------------------- */

static LfStatus bad_size(LfInstance *c, const char *fn, const char *what, size_t n,
                         unsigned expected) {
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: %s = %lu, expected %u (this FMU's "
           "number); nothing done", c->run.t, fn, what, (unsigned long)n, expected);
    return LF_ERROR;
}

static LfStatus null_array(LfInstance *c, const char *fn, const char *what) {
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: %s is NULL; nothing done", c->run.t, fn,
           what);
    return LF_ERROR;
}

/* the array of n values the call reads or writes: present if n > 0 and n
 * the model's count */
static LfStatus check_array(LfInstance *c, const char *fn, const void *a, const char *what,
                            size_t n, unsigned expected, const char *count) {
    if (n != expected) return bad_size(c, fn, count, n, expected);
    if (n > 0 && !a) return null_array(c, fn, what);
    return LF_OK;
}

/* keep the (unused) co-simulation solver at the instance's (t, x) */
static void sync_solver(LfInstance *c) {
    if (c->run.solver_ready) lf_solver_reset(&c->solver, c->run.t, &c->val.r[LF_VR_X0]);
}

/* ---- delays: the history the importer's completed steps made ---------------- */

/* time of the last sample of delay k's history (lf_delay.c's ring) */
static double hist_last_time(const LfInstance *c, int k) {
    long i = (c->dl.hist_start[k] + c->dl.hist_count[k] - 1) % LF_HIST_CAP;
    return c->dl.hist[((size_t)k * LF_HIST_CAP + (size_t)i) * 3];
}

/* the end of the history (the last point any delay > 0 holds), or -inf */
static double hist_end(const LfInstance *c) {
    double end = -INFINITY;
    int k;
    for (k = 0; k < LF_ND; k++)
        if (c->dl.tau[k] > 0 && c->dl.hist_count[k] > 0) end = fmax(end, hist_last_time(c, k));
    return end;
}

LfStatus lf_me_check_time(LfInstance *c, const char *fn) {
    double end = hist_end(c);
    if (!(c->run.t < end)) return LF_OK;
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: the delays' history already ends at "
           "t = %.17g; a step completed at an earlier time needs the FMU state of that time "
           "set first; nothing done, the instance goes on from where it was", c->run.t, fn, end);
    return LF_ERROR;
}

/* time of the first sample of delay k's history */
static double hist_first_time(const LfInstance *c, int k) {
    return c->dl.hist[((size_t)k * LF_HIST_CAP + (size_t)c->dl.hist_start[k]) * 3];
}

/* Model exchange with delays: the delayed value at t - tau after the last
 * completed step comes from the history's Taylor line there (lf_eval.c),
 * for at most LF_ME_EXTRAPOLATE tau, with one warning per instance; further
 * out the evaluation is refused.  FMPy's CVode steps in CV_NORMAL mode to
 * each output point, completing a step only there, and its internal steps
 * run past it: up to (stop - start) / 50, 0.6 s over the drive's 30 s, longer
 * than its tau = 0.5 s by 0.1 s. */
#define LF_ME_EXTRAPOLATE 0.5

LfStatus lf_me_delays_known(LfInstance *c, const char *fn) {
    int k;
    for (k = 0; k < LF_ND; k++) {
        double s, first, last, eps = 8 * LF_EPS * fmax(1.0, fabs(c->run.t));
        if (!(c->dl.tau[k] > 0) || c->dl.hist_count[k] == 0) continue; /* read now (tau = 0, start) */
        s = c->run.t - c->dl.tau[k];
        first = hist_first_time(c, k);
        last = hist_last_time(c, k);
        if (s > last + LF_ME_EXTRAPOLATE * c->dl.tau[k] + eps) {
            lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
                   "t = %.17g: %s: delay %s needs its value at t - tau = %.17g, but the history "
                   "ends at t = %.17g (the last completed integrator step), more than tau / %g "
                   "before; model exchange with delays needs a completed integrator step "
                   "after every accepted step and steps no longer than tau = %g s", c->run.t,
                   fn, lf_model.delay_names[k], s, last, 1.0 / LF_ME_EXTRAPOLATE,
                   c->dl.tau[k]);
            return LF_DISCARD;
        }
        if (s > last + eps && !c->unsaved.me_extrapolated) {
            c->unsaved.me_extrapolated = 1;
            lf_log(c, LF_WARNING, LF_LOG_WARNING,
                   "t = %.17g: %s: delay %s extrapolated from the last completed integrator "
                   "step (t = %.17g) to t - tau = %.17g: the importer's solver steps past "
                   "tau = %g s between completed steps (said once per instance)", c->run.t,
                   fn, lf_model.delay_names[k], last, s, c->dl.tau[k]);
        }
        /* before the start the history is constant; after it, only what is kept */
        if (s < first - eps && first > c->run.t_start) {
            lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
                   "t = %.17g: %s: delay %s needs its value at t - tau = %.17g, but the history "
                   "kept starts at t = %.17g (older points were dropped as the completed steps "
                   "moved on); to go back in time set the FMU state of that time first",
                   c->run.t, fn, lf_model.delay_names[k], s, first);
            return LF_DISCARD;
        }
    }
    return LF_OK;
}

/* ---- values at (t, x) --------------------------------------------------------- */

LfStatus lf_state_derivatives(LfInstance *c, double *dx) {
    if (lf_prepare_initial(c) != LF_OK) return LF_ERROR;
    if (lf_solve_w(c, c->run.t, &c->val.r[LF_VR_X0], c->unsaved.w_tmp) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: model equations cannot be solved (state "
               "derivatives)", c->run.t);
        return LF_ERROR;
    }
    memcpy(dx, c->unsaved.w_tmp, sizeof(double) * LF_NX); /* w = [der(x); z] */
    return LF_OK;
}

LfStatus lf_me_initialize(LfInstance *c) { return lf_initialize(c); }

LfStatus lf_me_set_time(LfInstance *c, const char *fn, double t) {
    if (!isfinite(t) || t < c->run.t_start) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: time = %g, expected a finite time "
               ">= the start time %.17g; nothing set", c->run.t, fn, t, c->run.t_start);
        return LF_ERROR;
    }
    c->run.t = t;
    c->run.outputs_valid = 0;
    sync_solver(c);
    return LF_OK;
}

LfStatus lf_me_set_states(LfInstance *c, const char *fn, const double *x, size_t nx) {
    int bad;
    LfStatus st = check_array(c, fn, x, "x", nx, LF_NX, "nx");
    if (st != LF_OK) return st;
    bad = lf_first_nonfinite(x, nx);
    if (bad >= 0) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: x[%d] (%s) = %g is not finite; "
               "nothing set", c->run.t, fn, bad, lf_model.real_names[LF_VR_X0 + bad], x[bad]);
        return LF_ERROR;
    }
    if (nx > 0) memcpy(&c->val.r[LF_VR_X0], x, sizeof(double) * nx);
    c->run.outputs_valid = 0;
    sync_solver(c);
    return LF_OK;
}

LfStatus lf_me_get_states(LfInstance *c, const char *fn, double *x, size_t nx) {
    LfStatus st = check_array(c, fn, x, "x", nx, LF_NX, "nx");
    if (st != LF_OK) return st;
    if (lf_prepare_initial(c) != LF_OK) return LF_ERROR;
    if (nx > 0) memcpy(x, &c->val.r[LF_VR_X0], sizeof(double) * nx);
    return LF_OK;
}

LfStatus lf_me_nominals(LfInstance *c, const char *fn, double *x_nominal, size_t nx) {
    size_t i;
    LfStatus st = check_array(c, fn, x_nominal, "x_nominal", nx, LF_NX, "nx");
    if (st != LF_OK) return st;
    for (i = 0; i < nx; i++) x_nominal[i] = lf_model.x_nominal[i];
    return LF_OK;
}

/* the unknowns at (c->run.t, x), or LF_DISCARD with the time and `fn` */
static LfStatus solve_here(LfInstance *c, const char *fn, const double *x, double *w) {
    LfStatus st = lf_me_delays_known(c, fn);
    if (st != LF_OK) return st;
    if (lf_prepare_initial(c) != LF_OK) return LF_ERROR;
    st = lf_solve_w(c, c->run.t, x, w);
    if (st == LF_OK) return LF_OK;
    lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: %s: the model equations cannot be "
           "solved at these states and inputs; the importer may retry with a shorter step",
           c->run.t, fn);
    return LF_DISCARD;
}

LfStatus lf_me_derivatives(LfInstance *c, const char *fn, double *dx, size_t nx) {
    LfStatus st = check_array(c, fn, dx, "derivatives", nx, LF_NX, "nx");
    if (st != LF_OK) return st;
    st = solve_here(c, fn, &c->val.r[LF_VR_X0], c->unsaved.w_tmp);
    if (st != LF_OK) return st;
    /* Newton's next start (implicit models): the last solution */
    if (LF_IMPLICIT) memcpy(c->val.w_cur, c->unsaved.w_tmp, sizeof c->val.w_cur);
    if (nx > 0) memcpy(dx, c->unsaved.w_tmp, sizeof(double) * nx);
    return LF_OK;
}

/* indicators at (c->run.t, x) into e */
static LfStatus indicators_at(LfInstance *c, const char *fn, const double *x, double *e) {
    LfStatus st;
    if (LF_NE == 0) return LF_OK;
    st = solve_here(c, fn, x, c->unsaved.w_tmp);
    if (st != LF_OK) return st;
    if (lf_eval_fn(c, LF_FN_EVT, c->run.t, x, c->unsaved.w_tmp, e, NULL, NULL) != LF_OK ||
        lf_first_nonfinite(e, LF_NE) >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: %s: event indicators not finite",
               c->run.t, fn);
        return LF_DISCARD;
    }
    return LF_OK;
}

LfStatus lf_me_event_indicators(LfInstance *c, const char *fn, double *e, size_t ne) {
    LfStatus st = check_array(c, fn, e, "eventIndicators", ne, LF_NE, "ni");
    if (st != LF_OK) return st;
    return indicators_at(c, fn, &c->val.r[LF_VR_X0], e);
}

/* ---- validity conditions, completed steps, events --------------------------------- */

/* Model.require at (c->run.t, x): where one fails, log it and ask to terminate */
static LfStatus check_validity(LfInstance *c, const char *fn, int *terminate) {
    double v[LF_DIM(LF_NV)];
    int k;
    LfStatus st;
    if (LF_NV == 0) return LF_OK;
    st = solve_here(c, fn, &c->val.r[LF_VR_X0], c->unsaved.w_tmp);
    if (st != LF_OK) return st;
    if (lf_eval_fn(c, LF_FN_VLD, c->run.t, &c->val.r[LF_VR_X0], c->unsaved.w_tmp, v, NULL, NULL) != LF_OK)
        return LF_ERROR;
    for (k = 0; k < LF_NV; k++)
        if (!(v[k] >= 0)) {
            lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "%s: %s: value %g at t = %.17g s; the model "
                   "is not valid there (%s: terminateSimulation is true)",
                   lf_model.validity_names[k], lf_model.validity_messages[k], v[k], c->run.t, fn);
            c->run.wants_terminate = 1;
            *terminate = 1;
            return LF_OK;
        }
    return LF_OK;
}

static int crossed(double a, double b) { return (a > 0 && b <= 0) || (a < 0 && b >= 0); }

LfStatus lf_me_completed_step(LfInstance *c, const char *fn, int *enter_event_mode,
                              int *terminate) {
    double e[LF_DIM(LF_NE)];
    int k;
    LfStatus st;
    *enter_event_mode = 0;
    *terminate = 0;
    st = lf_me_delays_known(c, fn);
    if (st != LF_OK) return st;
    if (LF_ND > 0) {
        st = lf_me_check_time(c, fn);
        if (st == LF_OK) st = lf_hist_push(c, c->run.t, &c->val.r[LF_VR_X0], 0);
        if (st != LF_OK) return st;
    }
    st = check_validity(c, fn, terminate);
    if (st != LF_OK) return st;
    st = indicators_at(c, fn, &c->val.r[LF_VR_X0], e);
    if (st != LF_OK) return st;
    for (k = 0; k < LF_NE; k++)
        if (crossed(c->ev.e_old[k], e[k])) *enter_event_mode = 1;
    /* a sign change keeps the reference: the event update looks for it */
    if (!*enter_event_mode && LF_NE > 0) memcpy(c->ev.e_old, e, sizeof(double) * LF_NE);
    c->run.last_successful_time = c->run.t;
    c->run.inputs_changed = 0; /* inputs set between steps change continuously */
    return LF_OK;
}

LfStatus lf_me_event_update(LfInstance *c, const char *fn, LfMeEventInfo *info) {
    double e[LF_DIM(LF_NE)], x[LF_DIM(LF_NX)];
    int k, any = 0, touched = 0, jump, is_bp = 0;
    LfStatus st;
    memset(info, 0, sizeof *info);
    if (LF_ND > 0 && (st = lf_me_check_time(c, fn)) != LF_OK) return st;
    st = indicators_at(c, fn, &c->val.r[LF_VR_X0], e);
    if (st != LF_OK) return st;
    if (LF_NX > 0) memcpy(x, &c->val.r[LF_VR_X0], sizeof(double) * LF_NX);
    /* the mode of each indicator that changed sign, chosen again, then every
     * mode made consistent: lf_event_update, as at an event in co-simulation */
    for (k = 0; k < LF_NE; k++) {
        if (!crossed(c->ev.e_old[k], e[k])) continue;
        lf_log(c, LF_OK, LF_LOG_EVENTS, "t = %.17g: %s: event %s", c->run.t, fn,
               lf_model.event_names[k]);
        any = 1;
        if (lf_model.event_mode[k] < 0) continue;
        touched = 1;
        st = lf_event_update(c, k, c->run.t, x, NULL);
        if (st != LF_OK) return st;
    }
    if (any) c->stats.n_events++;
    if (!touched) { /* an input set in event mode may call for other modes */
        st = lf_event_update(c, -1, c->run.t, x, NULL);
        if (st != LF_OK) return st;
    }
    for (k = 0; k < LF_NX; k++)
        if (x[k] != c->val.r[LF_VR_X0 + k]) info->states_changed = 1;
    if (LF_NX > 0) memcpy(&c->val.r[LF_VR_X0], x, sizeof(double) * LF_NX);
    c->run.outputs_valid = 0;
    sync_solver(c);
    /* the history jumps here (a breakpoint tau later) where a mode was chosen
     * again (states reinitialized) or an input was set in event mode */
    jump = touched || c->run.inputs_changed;
    c->run.inputs_changed = 0;
    if (LF_ND > 0) {
        /* the point, unless a completed step gave it already and nothing jumped */
        st = jump || hist_end(c) != c->run.t ? lf_hist_push(c, c->run.t, &c->val.r[LF_VR_X0], jump) : LF_OK;
        if (st != LF_OK) return st;
        /* a jump of a delayed value: a time event for the importer */
        info->next_time = lf_next_breakpoint(c, c->run.t, INFINITY, &is_bp);
        info->next_time_defined = is_bp;
    }
    st = check_validity(c, fn, &info->terminate);
    if (st != LF_OK) return st;
    return lf_me_enter_continuous(c, fn);
}

LfStatus lf_me_enter_continuous(LfInstance *c, const char *fn) {
    double e[LF_DIM(LF_NE)];
    LfStatus st = indicators_at(c, fn, &c->val.r[LF_VR_X0], e);
    if (st != LF_OK) return st;
    if (LF_NE > 0) memcpy(c->ev.e_old, e, sizeof(double) * LF_NE);
    return LF_OK;
}
