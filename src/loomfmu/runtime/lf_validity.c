/* loomfmu shared runtime: validity conditions (Model.require): expressions
 * that must stay >= 0 while the model runs (e.g. a warp tension: a warp in
 * compression is outside what the model describes).
 *
 * After every accepted internal step (events handled, before the history
 * takes the step) the conditions are evaluated at the step's midpoint and
 * end on the dense output; where one is negative, the first time any
 * condition fails is located by bisection on the dense output to a few
 * ulps of t.  The step ends there, at the last valid time: the state of
 * that time, the solver restarted there, fmi2Discard, fmi2Terminated true
 * (the model cannot go on from there with these inputs) and one log line
 * "<name>: <message>: value <v> at t = <t> s" in category logStatusDiscard.
 * A condition already violated where a step starts discards that step with
 * no progress. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_internal.h"

#define LF_VALIDITY_BISECTIONS 200

/* the conditions at (t, x); *bad: the first violated (or NaN), -1 if none */
static LfStatus eval_validity(LfInstance *c, double t, const double *x, double *v, int *bad) {
    int k;
    LfStatus st = lf_solve_w(c, t, x, c->w_tmp);
    if (st != LF_OK) return st;
    if (lf_eval_fn(c, LF_FN_VLD, t, x, c->w_tmp, v, NULL, NULL) != LF_OK) return LF_ERROR;
    *bad = -1;
    for (k = 0; k < LF_NV && *bad < 0; k++)
        if (!(v[k] >= 0)) *bad = k;
    return LF_OK;
}

static LfStatus violated(LfInstance *c, int k, double value, double t_bad, double t_ok,
                         const char *where) {
    lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
           "%s: %s: value %g at t = %.17g s; the model is not valid there: %s, at the last "
           "valid time t = %.17g s (fmi2Discard; fmi2Terminated is true)",
           lf_model.validity_names[k], lf_model.validity_messages[k], value, t_bad, where,
           t_ok);
    c->wants_terminate = 1;
    c->t = c->last_successful_time = t_ok;
    c->outputs_valid = 0;
    return LF_DISCARD;
}

LfStatus lf_validity_at_start(LfInstance *c) {
    double v[LF_DIM(LF_NV)];
    int bad;
    LfStatus st;
    if (LF_NV == 0) return LF_OK;
    st = eval_validity(c, c->solver.t, c->solver.x, v, &bad);
    if (st != LF_OK) return st;
    if (bad < 0) return LF_OK;
    return violated(c, bad, v[bad], c->solver.t, c->solver.t,
                    "already violated where the step starts; no progress");
}

LfStatus lf_check_validity(LfInstance *c) {
    LfSolver *s = &c->solver;
    double v[LF_DIM(LF_NV)], xs[LF_DIM(LF_NX)], ta = s->t_old, tb, tm;
    int bad, i;
    LfStatus st;
    if (LF_NV == 0 || !(s->t > s->t_old)) return LF_OK;
    /* the first sample (midpoint, end) where a condition fails */
    tm = 0.5 * (s->t_old + s->t);
    s->method->dense(s, tm, xs);
    st = eval_validity(c, tm, xs, v, &bad);
    if (st != LF_OK) return st;
    if (bad >= 0) {
        tb = tm;
    } else {
        ta = tm;
        st = eval_validity(c, s->t, s->x, v, &bad);
        if (st != LF_OK || bad < 0) return st;
        tb = s->t;
    }
    /* bisection: ta valid, tb not */
    for (i = 0; i < LF_VALIDITY_BISECTIONS &&
                tb - ta > 4 * LF_EPS * fmax(1.0, fmax(fabs(ta), fabs(tb)));
         i++) {
        double vm[LF_DIM(LF_NV)];
        int bm;
        tm = 0.5 * (ta + tb);
        s->method->dense(s, tm, xs);
        st = eval_validity(c, tm, xs, vm, &bm);
        if (st != LF_OK) return st;
        if (bm >= 0) {
            tb = tm;
            bad = bm;
            memcpy(v, vm, sizeof v);
        } else {
            ta = tm;
        }
    }
    s->method->dense(s, ta, xs);
    memcpy(&c->r[LF_VR_X0], xs, sizeof(double) * LF_NX);
    lf_solver_reset(s, ta, xs);
    /* indicators and history of the last valid time (an FMU state taken
     * here is consistent) */
    if (LF_NE > 0 && lf_eval_events(c, ta, s->x, c->e_old) != LF_OK) return LF_DISCARD;
    if (lf_hist_push(c, ta, s->x, 0) != LF_OK) return LF_DISCARD;
    return violated(c, bad, v[bad], tb, ta, "the step ends");
}
