/* loomfmu shared runtime: initialization and the co-simulation step loop,
 * the top of the runtime's layers: it calls the files below (events,
 * validity, known breaks, delays, the unknowns, inputs, outputs, start
 * values) and none of them calls it.
 *
 * Inputs are held constant over a communication step (zero-order hold), or
 * follow their polynomials where the importer set input derivatives
 * (lf_inputs.c); a change of an input's value or derivatives restarts the
 * solver at the communication point.  Validity conditions are checked
 * after every accepted step (lf_validity.c). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_step.h"
#include "lf_base.h"
#include "lf_breaks.h"
#include "lf_delay.h"
#include "lf_eval.h"
#include "lf_events.h"
#include "lf_inputs.h"
#include "lf_instance.h"
#include "lf_modes.h"
#include "lf_newton.h"
#include "lf_outputs.h"
#include "lf_start.h"
#include "lf_validity.h"

/* Constraints across parameters (each >= 0), which ranges cannot express. */
static LfStatus check_constraints(LfInstance *c) {
    double v[LF_DIM(LF_NC)];
    int k, ok = 1;
    if (LF_NC == 0) return LF_OK;
    if (lf_eval_fn(c, LF_FN_CONS, c->run.t, &c->val.r[LF_VR_X0], c->val.w_cur, v, NULL, NULL) != LF_OK)
        return LF_ERROR;
    for (k = 0; k < LF_NC; k++)
        if (!(v[k] >= 0)) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "parameters violate %s (value %g, must be >= 0)",
                   lf_model.constraint_messages[k], v[k]);
            ok = 0;
        }
    return ok ? LF_OK : LF_ERROR;
}

LfStatus lf_initialize(LfInstance *c) {
    LfOde ode = lf_ode_of(c);
    LfSolverOptions opt;
    LfStatus st;
    opt.rtol = c->run.rtol_importer > 0 ? c->run.rtol_importer : c->val.r[LF_SET_RTOL];
    opt.atol = c->val.r[LF_SET_ATOL];
    opt.h_max = c->val.r[LF_SET_H_MAX];
    opt.h_fixed = c->val.r[LF_SET_H_FIXED];
    c->run.max_steps = (long)c->val.r[LF_SET_MAX_STEPS];
    opt.max_steps = c->run.max_steps;
    c->run.t = c->run.last_successful_time = c->run.t_start;
    if (c->run.solver_index > 0) c->run.solver_id = c->run.solver_index; /* set after `solver`: it wins */
    if (check_constraints(c) != LF_OK) return LF_ERROR;
    if (lf_initial_states(c) != LF_OK) return LF_ERROR;
    if (lf_init_delays(c, &opt) != LF_OK) return LF_ERROR;
    if (LF_NQ > 0 && lf_initial_modes(c) != LF_OK) return LF_ERROR;
    st = lf_solver_init(&c->solver, lf_methods[c->run.solver_id - 1], ode, opt, c->run.t_start,
                        &c->val.r[LF_VR_X0], &c->unsaved.alloc);
    if (st != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "solver %s: %s", lf_methods[c->run.solver_id - 1]->name,
               c->solver.message);
        return LF_ERROR;
    }
    c->solver.dense_unused = LF_DENSE_UNUSED;
    c->solver.rhs_finite = 1;
    c->run.solver_ready = 1;
    c->kb.ready = 0;
    c->kb.index = -1;
    c->unsaved.kb_sure = -INFINITY;
    c->ev.pending = 0;
    c->ev.index = -1;
    c->run.inputs_changed = 0;
    lf_inputs_seen(c);
    c->run.outputs_valid = 0;
    if (lf_hist_push(c, c->run.t, &c->val.r[LF_VR_X0], 1) != LF_OK) return LF_ERROR;
    st = lf_eval_events(c, c->run.t, &c->val.r[LF_VR_X0], c->ev.e_old);
    if (st != LF_OK) return LF_ERROR;
    return lf_update_outputs(c);
}

static LfStatus fail_step(LfInstance *c, LfStatus st, const char *what) {
    LfSolver *s = &c->solver;
    memcpy(&c->val.r[LF_VR_X0], s->x, sizeof(double) * LF_NX);
    c->run.t = c->run.last_successful_time = s->t;
    c->run.outputs_valid = 0;
    lf_log(c, st, st == LF_DISCARD ? LF_LOG_DISCARD : LF_LOG_ERROR,
           "t = %.17g: step not completed (solver %s): %s; state and outputs kept at the last "
           "accepted time t = %.17g", s->t, s->method->name, what, s->t);
    return st;
}

LfStatus lf_check_step(LfInstance *c, double t0, double h) {
    if (!(h > 0) || !isfinite(h)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "fmi2DoStep: communicationStepSize = %g, expected a finite value > 0", h);
        return LF_ERROR;
    }
    if (t0 + h > c->run.t_stop * (1 + 1e-12) + 1e-12) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "fmi2DoStep: step to %.17g goes past stopTime = %.17g of fmi2SetupExperiment",
               t0 + h, c->run.t_stop);
        return LF_ERROR;
    }
    if (fabs(t0 - c->run.t) > 1e-9 * (fabs(c->run.t) > 1.0 ? fabs(c->run.t) : 1.0)) { /* no fmax call */
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "fmi2DoStep: currentCommunicationPoint = %.17g, expected %.17g", t0, c->run.t);
        return LF_ERROR;
    }
    return LF_OK;
}

/* Largest magnitude a state may reach: beyond sqrt(DBL_MAX) ~ 1.3e154 its
 * square (energies, norms, reactions) overflows; no quantity of these
 * models in SI units comes near.  Declared finite ranges are checked too. */
#define LF_HUGE 1e150

/* Index of the first state that is not finite, beyond LF_HUGE or outside
 * its declared range, or -1. */
#ifndef LF_X_RANGED
#define LF_X_RANGED 1 /* (model_decl.h says whether a state has a finite range) */
#endif
static int runaway_state(const double *x) {
    int i;
    for (i = 0; i < LF_NX; i++) {
        unsigned vr = LF_VR_X0 + (unsigned)i;
        if (!LF_X_RANGED) { /* every range infinite: the magnitude only */
            if (!(fabs(x[i]) <= LF_HUGE)) return i;
            continue;
        }
        /* (not finite or beyond LF_HUGE in one comparison: false for NaN) */
        if (!(fabs(x[i]) <= LF_HUGE) || x[i] < lf_model.real_min[vr] ||
            x[i] > lf_model.real_max[vr])
            return i;
    }
    return -1;
}

/* The accepted step ended with a state out of bounds: take it back (the
 * solver restarts at its previous point, where events and history are
 * still consistent) and discard the communication step there. */
static LfStatus refuse_runaway(LfInstance *c, int i) {
    LfSolver *s = &c->solver;
    unsigned vr = LF_VR_X0 + (unsigned)i;
    char why[256];
    if (LF_X_RANGED) /* (a model without declared ranges names none) */
        snprintf(why, sizeof why, "state %s = %g at t = %.17g is not finite, beyond %g in "
                 "magnitude or outside its range [%g, %g] (a runaway input or parameter?)",
                 lf_model.real_names[vr], s->x[i], s->t, LF_HUGE, lf_model.real_min[vr],
                 lf_model.real_max[vr]);
    else
        snprintf(why, sizeof why, "state %s = %g at t = %.17g is not finite or beyond %g in "
                 "magnitude (a runaway input or parameter?)", lf_model.real_names[vr],
                 s->x[i], s->t, LF_HUGE);
    memcpy(c->unsaved.x_tmp, s->x_old, sizeof(double) * LF_NX);
    lf_solver_reset(s, s->t_old, c->unsaved.x_tmp);
    return fail_step(c, LF_DISCARD, why);
}

/* The work of one fmi2DoStep is bounded by the setting solver_max_steps:
 * the solver's steps, accepted and rejected (event location's redone steps
 * included), counted from the solver's own counters.  Past it the call
 * returns fmi2Discard at the last accepted time, whose outputs stay
 * readable (fmi2GetRealStatus(fmi2LastSuccessfulTime) tells the time). */
static long solver_work(const LfSolver *s) { return s->n_steps + s->n_rejected; }

/* The deferred event (lf_step.h), then what the step loop does after an
 * event inside a step (the history up to the restart point), so that the
 * trajectory is the one without early return. */
static LfStatus run_pending_event(LfInstance *c, int *changed) {
    LfStatus st = lf_apply_pending_event(c, changed);
    if (st == LF_OK && LF_ND > 0) st = lf_hist_step(c, 0);
    return st;
}

LfStatus lf_handle_pending_event(LfInstance *c, int *values_changed) {
    LfStatus st;
    if (values_changed) *values_changed = 0;
    if (!c->ev.pending) return LF_OK;
    st = run_pending_event(c, values_changed);
    if (st != LF_OK)
        return c->run.wants_terminate ? st : fail_step(c, st, "event handling failed");
    memcpy(&c->val.r[LF_VR_X0], c->solver.x, sizeof(double) * LF_NX);
    c->run.outputs_valid = 0;
    return lf_update_outputs(c);
}

/* Early return: the step ends at the event just located (its handling
 * deferred), the outputs there with the modes before it. */
static LfStatus return_at_event(LfInstance *c) {
    double w_keep[LF_DIM(LF_NW)];
    LfStatus st;
    memcpy(&c->val.r[LF_VR_X0], c->solver.x, sizeof(double) * LF_NX);
    c->run.t = c->solver.t;
    c->run.outputs_valid = 0;
    /* Newton's start stays that of the step loop (as without early return) */
    memcpy(w_keep, c->val.w_cur, sizeof w_keep);
    st = lf_update_outputs(c);
    memcpy(c->val.w_cur, w_keep, sizeof w_keep);
    c->unsaved.wk_g = 0; /* w_cur is no longer the last solve's (lf_wcache.h) */
    if (st != LF_OK) return st;
    c->run.last_successful_time = c->run.t;
    return LF_OK;
}

/* The inputs jump (or their derivatives change) at the solver's point:
 * modes made invalid by the jump (a stuck joint now loaded beyond its
 * static limit) are chosen again, the solver restarts, the history takes
 * the jump.  On failure *what says what failed. */
static LfStatus restart_for_inputs(LfInstance *c, const char **what) {
    LfSolver *s = &c->solver;
    LfStatus st;
    memcpy(c->unsaved.x_tmp, s->x, sizeof(double) * LF_NX);
    if (LF_NQ > 0) {
        double q0[LF_DIM(LF_NQ)];
        memcpy(q0, c->val.q, sizeof q0);
        st = lf_consistent_modes(c, s->t, c->unsaved.x_tmp, -1);
        if (st != LF_OK) { /* the modes as they were: the step is not done */
            memcpy(c->val.q, q0, sizeof q0);
            c->unsaved.wc_gen++;
            *what = "no consistent mode after the input change";
            return st;
        }
    }
    lf_solver_reset(s, s->t, c->unsaved.x_tmp);
    st = lf_hist_push(c, s->t, s->x, 1);
    if (st != LF_OK) {
        *what = "history update failed";
        return st;
    }
    st = lf_eval_events(c, s->t, s->x, c->ev.e_old);
    if (st != LF_OK) {
        *what = "event indicators not finite";
        return st;
    }
    c->run.inputs_changed = 0;
    c->kb.ready = 0; /* the clock states' rates may change with the inputs */
    lf_inputs_seen(c);
    return LF_OK;
}

LfStatus lf_settle_inputs(LfInstance *c) {
    const char *what = "";
    LfStatus st;
    if (!c->run.solver_ready || c->ev.pending || !(c->run.inputs_changed || lf_inputs_moved(c)))
        return LF_OK;
    st = restart_for_inputs(c, &what);
    if (st != LF_OK) {
        lf_log(c, st, st == LF_DISCARD ? LF_LOG_DISCARD : LF_LOG_ERROR,
               "t = %.17g: inputs set: %s", c->run.t, what);
        return st;
    }
    memcpy(&c->val.r[LF_VR_X0], c->solver.x, sizeof(double) * LF_NX);
    c->run.outputs_valid = 0;
    return LF_OK;
}

LfStatus lf_do_step(LfInstance *c, double t0, double h) {
    LfStatus st = lf_check_step(c, t0, h);
    if (st != LF_OK) return st;
    return lf_do_checked_step(c, t0, h);
}

static LfStatus step_loop(LfInstance *c, double t0, double h);

/* the step loop with the solve cache on (lf_wcache.h), empty at the start */
LfStatus lf_do_checked_step(LfInstance *c, double t0, double h) {
    LfStatus st;
    c->unsaved.wc_gen++;
    c->unsaved.wc_on = 1;
    st = step_loop(c, t0, h);
    c->unsaved.wc_on = 0;
    return st;
}

static LfStatus step_loop(LfInstance *c, double t0, double h) {
    LfSolver *s = &c->solver;
    double t_end = t0 + h;
    long work0 = solver_work(s);
    int bad;
    LfStatus st;
    c->run.wants_terminate = 0;
    if (c->ev.pending) { /* returned early, the importer did not handle it */
        st = run_pending_event(c, NULL);
        if (st != LF_OK)
            return c->run.wants_terminate ? st : fail_step(c, st, "event handling failed");
    }
    if (c->run.inputs_changed || (!lf_inputs_still(c) && lf_inputs_moved(c))) {
        const char *what = "";
        st = restart_for_inputs(c, &what);
        if (st != LF_OK) return fail_step(c, st, what);
    }
    st = LF_NV > 0 ? lf_validity_at_start(c) : LF_OK;
    if (st != LF_OK)
        return c->run.wants_terminate ? st : fail_step(c, st, "validity conditions not evaluable");
    while (s->t < t_end) {
        int is_bp = 0;
        double t_bound = LF_ND > 0 ? lf_next_breakpoint(c, s->t, t_end, &is_bp) : t_end;
        if (LF_NE > 0) {
            double t_kb = lf_known_break(c, t_bound);
            if (t_kb < t_bound) {
                t_bound = t_kb;
                is_bp = 0; /* the step lands before the delay's breakpoint */
            }
        }
        s->message[0] = '\0';
        c->unsaved.t_bp_step = is_bp ? t_bound : INFINITY;
        st = s->method->step(s, t_bound);
        c->unsaved.t_bp_step = INFINITY;
        if (st != LF_OK) return fail_step(c, st, s->message);
        bad = runaway_state(s->x);
        if (bad >= 0) return refuse_runaway(c, bad);
        if (LF_NE > 0) {
            st = lf_handle_events(c);
            if (st != LF_OK)
                return c->run.wants_terminate ? st : fail_step(c, st, "event handling failed");
            if (c->ev.pending) return return_at_event(c);
        }
        if (LF_NV > 0) {
            st = lf_check_validity(c);
            if (st != LF_OK)
                return c->run.wants_terminate ? st
                                          : fail_step(c, st, "validity conditions not evaluable");
        }
        if (LF_ND > 0) {
            int at_bp = is_bp && s->t == t_bound;
            st = lf_hist_step(c, !at_bp);
            if (st != LF_OK) return fail_step(c, st, "history update failed");
            if (at_bp) lf_solver_reset(s, s->t, s->x); /* a delayed value jumps here */
        }
        if (LF_NE > 0 && c->kb.index >= 0) { /* landed before a known break: cross it */
            st = lf_cross_known_break(c, t_end);
            if (st != LF_OK)
                return c->run.wants_terminate ? st : fail_step(c, st, "event handling failed");
            if (c->ev.pending) return return_at_event(c);
        }
        if (s->t < t_end && solver_work(s) - work0 >= c->run.max_steps) {
            char why[256];
            snprintf(why, sizeof why, "solver_max_steps = %ld steps spent in this doStep call "
                     "at t = %.17g of its end %.17g (step size now %g s); raise "
                     "solver_max_steps, or check the tolerances, solver_h_max and the delays",
                     c->run.max_steps, s->t, t_end, s->h > 0 ? s->h : s->t - s->t_old);
            return fail_step(c, LF_DISCARD, why);
        }
    }
    memcpy(&c->val.r[LF_VR_X0], s->x, sizeof(double) * LF_NX);
    c->run.t = t_end;
    c->run.outputs_valid = 0;
    st = lf_update_outputs(c);
    if (st != LF_OK) return st;
    c->run.last_successful_time = t_end;
    return LF_OK;
}
