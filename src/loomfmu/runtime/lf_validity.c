/* loomfmu shared runtime: validity conditions (Model.require): expressions
 * that must stay >= 0 while the model runs (e.g. a warp tension: a warp in
 * compression is outside what the model describes).
 *
 * Every internal step the solver takes is checked on its dense output, by
 * the rules of the event indicators (lf_events.c): the conditions at the
 * step's start (kept from the step before), midpoint and end; where the
 * quadratic through these samples comes near zero inside the step (a dip
 * between the samples), the halves again, down to LF_EVENT_SCAN_DEPTH
 * levels; and the next step bounded so that a condition's second
 * difference over it stays below LF_EVENT_CURV of its size, so a step
 * cannot jump over a whole dip.  In the earliest interval where a condition
 * fails, the first time any condition fails is located by bisection to a
 * few ulps of t.  A step that ends at an event is redone up to the event
 * (lf_events.c): the redone steps are checked the same way, and so is the
 * point where the solver restarts after the event (lf_validity_restart).
 * Hence the time found does not depend on where the communication points
 * fall.
 *
 * Where a condition fails the step ends at the last valid time: the state
 * of that time, the solver restarted there, fmi2Discard, fmi2Terminated
 * true (the model cannot go on from there with these inputs) and one log
 * line "<name>: <message>: value <v> at t = <t> s" in category
 * logStatusDiscard.  A condition already violated where a communication
 * step starts discards that step with no progress. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_validity.h"
#include "lf_base.h"
#include "lf_delay.h"
#include "lf_eval.h"
#include "lf_instance.h"
#include "lf_internal.h"
#include "lf_modes.h"
#include "lf_newton.h"

#define LF_VALIDITY_BISECTIONS 200

static int first_bad(const double *v) {
    int k;
    for (k = 0; k < LF_NV; k++)
        if (!(v[k] >= 0)) return k;
    return -1;
}

/* the conditions at (t, x); *bad: the first violated (or NaN), -1 if none */
static LfStatus eval_validity(LfInstance *c, double t, const double *x, double *v, int *bad) {
    LfStatus st = lf_solve_w(c, t, x, c->unsaved.w_tmp);
    if (st != LF_OK) return st;
    if (lf_eval_fn(c, LF_FN_VLD, t, x, c->unsaved.w_tmp, v, NULL, NULL) != LF_OK) return LF_ERROR;
    *bad = first_bad(v);
    return LF_OK;
}

static LfStatus violated(LfInstance *c, int k, double value, double t_bad, double t_ok,
                         const char *where) {
    lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
           "%s: %s: value %g at t = %.17g s; the model is not valid there: %s, at the last "
           "valid time t = %.17g s (fmi2Discard; fmi2Terminated is true)",
           lf_model.validity_names[k], lf_model.validity_messages[k], value, t_bad, where,
           t_ok);
    c->run.wants_terminate = 1;
    c->run.t = c->run.last_successful_time = t_ok;
    c->run.outputs_valid = 0;
    return LF_DISCARD;
}

/* End the step at the last valid time t_ok with state x_ok: the solver
 * restarted there, its event indicators and history (an FMU state taken
 * here is consistent), then the log line. */
static LfStatus end_at(LfInstance *c, double t_ok, const double *x_ok, int k, double value,
                       double t_bad, const char *where) {
    LfSolver *s = &c->solver;
    memcpy(c->unsaved.x_tmp, x_ok, sizeof(double) * LF_NX);
    memcpy(&c->val.r[LF_VR_X0], c->unsaved.x_tmp, sizeof(double) * LF_NX);
    lf_solver_reset(s, t_ok, c->unsaved.x_tmp);
    c->unsaved.vld_t = NAN;
    c->kb.ready = 0;
    if (LF_NE > 0 && lf_eval_events(c, t_ok, s->x, c->ev.e_old) != LF_OK) return LF_DISCARD;
    if (lf_hist_push(c, t_ok, s->x, 0) != LF_OK) return LF_DISCARD;
    return violated(c, k, value, t_bad, t_ok, where);
}

/* the conditions vld_v hold at time t */
static void keep(LfInstance *c, double t, const double *v) {
    c->unsaved.vld_t = t;
    memcpy(c->unsaved.vld_v, v, sizeof(double) * LF_NV);
}

LfStatus lf_validity_at_start(LfInstance *c) {
    double v[LF_DIM(LF_NV)];
    int bad;
    LfStatus st;
    if (LF_NV == 0) return LF_OK;
    /* evaluated again even where the last step ended: taking the values kept
     * there would skip a solve, and a Newton model's next steps would then
     * differ by rounding from those after a restored FMU state */
    st = eval_validity(c, c->solver.t, c->solver.x, v, &bad);
    if (st != LF_OK) return st;
    if (bad < 0) {
        keep(c, c->solver.t, v);
        return LF_OK;
    }
    return violated(c, bad, v[bad], c->solver.t, c->solver.t,
                    "already violated where the step starts; no progress");
}

LfStatus lf_validity_restart(LfInstance *c, double t_ok, const double *x_ok,
                             const double *q_ok) {
    double v[LF_DIM(LF_NV)];
    int bad;
    LfStatus st;
    if (LF_NV == 0) return LF_OK;
    st = eval_validity(c, c->solver.t, c->solver.x, v, &bad);
    if (st != LF_OK) return st;
    if (bad < 0) {
        keep(c, c->solver.t, v);
        return LF_OK;
    }
    if (LF_NQ > 0) { /* the modes before */
        memcpy(c->val.q, q_ok, sizeof(double) * LF_NQ);
        c->unsaved.wc_gen++;
    }
    return end_at(c, t_ok, x_ok, bad, v[bad], c->solver.t,
                  "fails across the event where the solver restarted; the step ends before "
                  "the event");
}

typedef struct {
    double ta, tb;                  /* earliest interval: valid at ta, not at tb */
    double vb[LF_DIM(LF_NV)];
    int found;
    double h_bound;                 /* bound on the next step */
} VldScan;

/* Could a condition fail between the samples va (valid), vm, vb? */
static int may_fail(const double *va, const double *vm, const double *vb) {
    int k;
    double th;
    if (first_bad(vm) >= 0 || first_bad(vb) >= 0) return 1;
    for (k = 0; k < LF_NV; k++)
        if (lf_near_zero_extremum(va[k], vm[k], vb[k], &th) && th > -0.5 && th < 1.5) return 1;
    return 0;
}

/* the bound on the next step from the samples of this one (depth 0) */
static double step_bound(const double *va, const double *vm, const double *vb, double h) {
    double bound = INFINITY, th;
    int k;
    for (k = 0; k < LF_NV; k++) {
        double d2 = fabs(va[k] - 2.0 * vm[k] + vb[k]);
        double size = fmax(fabs(va[k]), fmax(fabs(vm[k]), fabs(vb[k])));
        if (d2 > 0 && size > 0) bound = fmin(bound, h * sqrt(LF_EVENT_CURV * size / d2));
        if (fabs(vb[k] - va[k]) > LF_EVENT_CURV * size) bound = fmin(bound, LF_EVENT_GROWTH * h);
        if (lf_near_zero_extremum(va[k], vm[k], vb[k], &th) && th > 1.0 && th < 2.0)
            bound = fmin(bound, 2.0 * (th - 1.0) * h);
    }
    return bound;
}

/* Scan (ta, tb] of the accepted step, the conditions valid at ta; stops at
 * the earliest interval where one fails. */
static LfStatus scan(LfInstance *c, double ta, const double *va, double tb, const double *vb,
                     int depth, VldScan *out) {
    double vm[LF_DIM(LF_NV)], xm[LF_DIM(LF_NX)], tm = 0.5 * (ta + tb);
    int bad;
    LfStatus st;
    if (depth < LF_EVENT_SCAN_DEPTH && tm > ta && tm < tb) {
        c->solver.method->dense(&c->solver, tm, xm);
        st = eval_validity(c, tm, xm, vm, &bad);
        if (st != LF_OK) return st;
        if (depth == 0) out->h_bound = step_bound(va, vm, vb, tb - ta);
        if (!may_fail(va, vm, vb)) return LF_OK;
        st = scan(c, ta, va, tm, vm, depth + 1, out);
        if (st != LF_OK || out->found || bad >= 0) return st;
        return scan(c, tm, vm, tb, vb, depth + 1, out);
    }
    if (first_bad(vb) >= 0) {
        out->found = 1;
        out->ta = ta;
        out->tb = tb;
        memcpy(out->vb, vb, sizeof(double) * LF_NV);
    }
    return LF_OK;
}

LfStatus lf_check_validity(LfInstance *c) {
    LfSolver *s = &c->solver;
    double va[LF_DIM(LF_NV)], vb[LF_DIM(LF_NV)], xs[LF_DIM(LF_NX)], ta, tb, h = s->t - s->t_old;
    int bad, i;
    VldScan sc;
    LfStatus st;
    if (LF_NV == 0 || !(s->t > s->t_old)) return LF_OK;
    if (c->unsaved.vld_t == s->t_old) {
        memcpy(va, c->unsaved.vld_v, sizeof va);
    } else { /* not kept (cannot happen after a checked step): evaluate */
        st = eval_validity(c, s->t_old, s->x_old, va, &bad);
        if (st != LF_OK) return st;
        if (bad >= 0)
            return end_at(c, s->t_old, s->x_old, bad, va[bad], s->t_old,
                          "already violated where the internal step starts");
    }
    st = eval_validity(c, s->t, s->x, vb, &bad);
    if (st != LF_OK) return st;
    sc.found = 0;
    sc.h_bound = INFINITY;
    st = scan(c, s->t_old, va, s->t, vb, 0, &sc);
    if (st != LF_OK) return st;
    if (!sc.found) {
        keep(c, s->t, vb);
        /* the next step resolves the conditions (at most 4 times shorter) */
        if (s->h > sc.h_bound) s->h = fmax(sc.h_bound, 0.25 * h);
        return LF_OK;
    }
    /* bisection: ta valid, tb not */
    ta = sc.ta;
    tb = sc.tb;
    memcpy(vb, sc.vb, sizeof vb);
    bad = first_bad(vb);
    for (i = 0; i < LF_VALIDITY_BISECTIONS &&
                tb - ta > 4 * LF_EPS * fmax(1.0, fmax(fabs(ta), fabs(tb)));
         i++) {
        double vm[LF_DIM(LF_NV)], tm = 0.5 * (ta + tb);
        int bm;
        s->method->dense(s, tm, xs);
        st = eval_validity(c, tm, xs, vm, &bm);
        if (st != LF_OK) return st;
        if (bm >= 0) {
            tb = tm;
            bad = bm;
            memcpy(vb, vm, sizeof vb);
        } else {
            ta = tm;
        }
    }
    s->method->dense(s, ta, xs);
    return end_at(c, ta, xs, bad, vb[bad], tb, "the step ends");
}
