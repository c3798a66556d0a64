/* loomfmu shared runtime: calls of the generated functions (lf_eval.c)
 * with their arguments: inputs at t, folded parameters, delayed values. */
#ifndef LF_EVAL_H
#define LF_EVAL_H

#include "lf_instance.h"

/* Generated function `fn` at (t, x, w) with the instance's u,
 * p, q and the delayed values at t; index of the first non-finite value. */
LfStatus lf_eval_fn(LfInstance *c, int fn, double t, const double *x, const double *w,
                    double *out0, double *out1, double *out2);
/* lf_eval_fn of a generated function with one output (wsol, out, evt: an
 * LfFunctionId, not LF_FN_HISTOUT), inline where nothing is to be prepared
 * (no delays, the folded terms current, the fixed arguments set, the inputs
 * held): the same call with the same arguments, without lf_eval_fn's own
 * call (the hot path: every right-hand side and output evaluation).  The
 * outputs past res[0] are not set: a function with one output reads none. */
static inline LfStatus lf_eval_fn1(LfInstance *c, int fn, double t, const double *x,
                                   const double *w, double *out0) {
    if (LF_ND > 0 || (LF_NK > 0 && c->unsaved.k_stale) || !c->unsaved.args_set || c->unsaved.u_poly)
        return lf_eval_fn(c, fn, t, x, w, out0, NULL, NULL);
    c->unsaved.arg[0] = &t;
    c->unsaved.arg[1] = x;
    c->unsaved.arg[2] = w;
    c->unsaved.arg[3] = &c->val.r[LF_VR_U0];
    c->unsaved.arg[7] = c->unsaved.u_zero;
    c->unsaved.res[0] = out0;
    return lf_model.fn[fn].eval(c->unsaved.arg, c->unsaved.res, c->unsaved.iw, c->unsaved.w, 0) ? LF_ERROR : LF_OK;
}

/* The delayed values at t, from the history (c->dl.dval) */
LfStatus lf_delayed_values(LfInstance *c, double t, const double *x);
/* the same, and d/dt of each delayed value with tau > 0 (0 for tau = 0) */
LfStatus lf_delayed_rates(LfInstance *c, double t, const double *x, double *rate);

#endif
