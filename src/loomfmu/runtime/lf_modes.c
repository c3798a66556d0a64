/* loomfmu shared runtime: event indicators at a point and the discrete
 * modes: a mode chosen again in its priority order, all modes made
 * consistent together (after an event, an input change, at the start), and
 * the event update without a solver (model exchange).  Locating events in a
 * step is lf_events.c's, on top of this. */
#include <math.h>
#include <string.h>

#include "lf_modes.h"
#include "lf_base.h"
#include "lf_eval.h"
#include "lf_instance.h"
#include "lf_internal.h"
#include "lf_newton.h"
#include "lf_wcache.h"

LfStatus lf_eval_events(LfInstance *c, double t, const double *x, double *e) {
    const double *w = c->unsaved.w_tmp;
    LfStatus st;
    if (LF_NE == 0) return LF_OK;
    /* (at a step's end: the solver's last stage solved w there, and w_cur
     * holds it, lf_wcache.h; read there, without the copy a solve makes) */
    if (LF_WK_USED && c->unsaved.wc_on && lf_wk_take(c, t, x, c->val.w_cur)) {
        w = c->val.w_cur;
    } else {
        st = lf_solve_w(c, t, x, c->unsaved.w_tmp);
        if (st != LF_OK) return st;
    }
    if (lf_eval_fn1(c, LF_FN_EVT, t, x, w, e) != LF_OK ||
        lf_first_nonfinite(e, LF_NE) >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: event indicators not finite", t);
        return LF_DISCARD;
    }
    return LF_OK;
}

/* Choose the value of mode k at (t, x): the first value, in the declared
 * priority order, that is consistent (validity >= 0) once the states are
 * reinitialized for it.  x is updated with the reinitialized states. */
static LfStatus choose_mode(LfInstance *c, int k, double t, double *x) {
    double old = c->val.q[k], x_try[LF_DIM(LF_NX)], valid[LF_DIM(LF_NQ)];
    int j;
    for (j = lf_model.mode_value_offset[k]; j < lf_model.mode_value_offset[k + 1]; j++) {
        LfStatus st;
        c->val.q[k] = lf_model.mode_values[j];
        c->unsaved.wc_gen++; /* solves of another mode (lf_wcache.h) */
        if (lf_eval_fn(c, LF_FN_REINIT, t, x, c->val.w_cur, x_try, NULL, NULL) != LF_OK)
            return LF_ERROR;
        c->unsaved.quiet++;
        st = lf_solve_w(c, t, x_try, c->unsaved.w_tmp);
        c->unsaved.quiet--;
        if (st != LF_OK) continue; /* cannot be solved in this mode */
        if (lf_eval_fn(c, LF_FN_VALID, t, x_try, c->unsaved.w_tmp, valid, NULL, NULL) != LF_OK)
            return LF_ERROR;
        if (valid[k] >= 0) {
            memcpy(x, x_try, sizeof(double) * LF_NX);
            if (c->val.q[k] != old)
                lf_log(c, LF_OK, LF_LOG_EVENTS, "t = %.17g: mode %s: %g -> %g", t,
                       lf_model.mode_names[k], old, c->val.q[k]);
            return LF_OK;
        }
    }
    c->val.q[k] = old;
    c->unsaved.wc_gen++;
    /* a point the model cannot go on from (an input or a state far outside
     * what the model was made for): the step is not done, the caller puts
     * the modes back (Discard; at the start of the simulation an Error) */
    lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
           "t = %.17g: no value of mode %s is consistent here (the model has no "
           "solution with any of its declared values)", t, lf_model.mode_names[k]);
    return LF_DISCARD;
}

#define LF_MODE_ROUNDS (2 * LF_NQ + 2)

/* Make every mode consistent at (t, x).  A mode is chosen again
 * (choose_mode: the first valid value in priority order) when its validity
 * is < 0, and, once chosen, again in every later round: a mode chosen here
 * sits at its boundary (a joint that just broke away or stuck, its speed
 * 0), and another mode's change can make a value of higher priority valid
 * again (coupled friction joints: with joint 2 slipping, joint 1 can stay
 * stuck).  Rounds repeat until one changes nothing.  `touched`: a mode
 * already chosen at this point (the event's), or -1.  x is updated with the
 * reinitialized states.  Used at the start, after an input change and
 * after every event. */
LfStatus lf_consistent_modes(LfInstance *c, double t, double *x, int touched) {
    double valid[LF_DIM(LF_NQ)];
    unsigned char chosen[LF_DIM(LF_NQ)];
    int k, round;
    LfStatus st;
    for (k = 0; k < LF_NQ; k++) chosen[k] = (unsigned char)(k == touched);
    for (round = 0; LF_NQ > 0; round++) {
        int changed = 0;
        for (k = 0; k < LF_NQ; k++) {
            double old = c->val.q[k];
            if (!chosen[k]) {
                c->unsaved.quiet++;
                st = lf_solve_w(c, t, x, c->unsaved.w_tmp);
                c->unsaved.quiet--;
                if (st == LF_OK &&
                    lf_eval_fn(c, LF_FN_VALID, t, x, c->unsaved.w_tmp, valid, NULL, NULL) == LF_OK &&
                    valid[k] >= 0)
                    continue;
            }
            st = choose_mode(c, k, t, x);
            if (st != LF_OK) return st;
            chosen[k] = 1;
            if (c->val.q[k] != old) changed = 1;
        }
        if (!changed) break;
        if (round == LF_MODE_ROUNDS) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR,
                   "t = %.17g: the modes do not settle (%d rounds of choosing them again)", t,
                   LF_MODE_ROUNDS);
            return LF_ERROR;
        }
    }
    return LF_OK;
}

/* The modes at the start: from their start values, every one made
 * consistent (a start value that is valid is kept).  Starting from the
 * start values each time makes the result independent of earlier reads. */
LfStatus lf_initial_modes(LfInstance *c) {
    int k;
    for (k = 0; k < LF_NQ; k++) c->val.q[k] = lf_model.mode_start[k];
    c->unsaved.wc_gen++;
    return lf_consistent_modes(c, c->run.t, &c->val.r[LF_VR_X0], -1);
}

/* The modes after event k at (t, x) without a solver: the event's own mode
 * (if it has one) chosen first, then every mode made consistent; x is
 * updated with the reinitialized states.  *changed (if not NULL): a mode
 * or a state changed. */
LfStatus lf_event_update(LfInstance *c, int k, double t, double *x, int *changed) {
    double q0[LF_DIM(LF_NQ)], x0[LF_DIM(LF_NX)];
    int touched = k >= 0 && k < LF_NE ? lf_model.event_mode[k] : -1;
    LfStatus st;
    memcpy(q0, c->val.q, sizeof q0);
    memcpy(x0, x, sizeof(double) * LF_NX);
    if (changed) *changed = 0;
    if (LF_NQ == 0) return LF_OK;
    if (touched >= 0) st = choose_mode(c, touched, t, x);
    else st = LF_OK;
    if (st == LF_OK) st = lf_consistent_modes(c, t, x, touched);
    if (st != LF_OK) { /* the modes and states as they were */
        memcpy(c->val.q, q0, sizeof q0);
        memcpy(x, x0, sizeof(double) * LF_NX);
        c->unsaved.wc_gen++;
        return st;
    }
    if (changed)
        *changed = memcmp(q0, c->val.q, sizeof(double) * LF_NQ) != 0 ||
                   memcmp(x0, x, sizeof(double) * LF_NX) != 0;
    return LF_OK;
}
