/* loomfmu shared runtime: calls of the generated functions.  Every call
 * passes here (lf_eval_fn; lf_eval_fn1 in lf_eval.h is its inline hot
 * path) with the arguments it needs: the inputs at t (lf_inputs.c), the
 * folded parameter subexpressions, and the delayed values at t, read from
 * the history the step loop keeps (lf_delay.c writes it; the lookup is
 * here because a zero delay evaluates its expression now, through
 * lf_eval_fn again).  Calls lf_base.c and lf_inputs.c only. */
#include <math.h>
#include <string.h>

#include "lf_eval.h"
#include "lf_base.h"
#include "lf_inputs.h"
#include "lf_instance.h"
#include "lf_internal.h"

/* ---- evaluating the generated functions ------------------------------- */

/* k := pre(p): the parameter-only subexpressions (parameter folding). */
static LfStatus fold_parameters(LfInstance *c) {
    int i, bad;
    for (i = 0; i < 10; i++) c->unsaved.arg[i] = NULL; /* pre reads p only */
    c->unsaved.args_set = 0;
    c->unsaved.arg[4] = &c->val.r[LF_VR_P0];
    c->unsaved.res[0] = c->unsaved.k;
    if (lf_model.fn[LF_FN_PRE].eval(c->unsaved.arg, c->unsaved.res, c->unsaved.iw, c->unsaved.w, 0)) return LF_ERROR;
    /* a non-finite k is not an error by itself (e.g. a term of a branch not
     * taken); the functions that use it report their own non-finite results */
    bad = lf_first_nonfinite(c->unsaved.k, LF_NK);
    if (bad >= 0)
        lf_log(c, LF_OK, LF_LOG_SOLVER, "t = %.17g: parameter-only subexpression %d is %g",
               c->run.t, bad, c->unsaved.k[bad]);
    c->unsaved.k_stale = 0;
    return LF_OK;
}

/* Call generated function `fn` at (t, x, w) with the instance's inputs at t
 * (held, or their polynomials) and their rates, p, q, the delayed values
 * at t and the folded parameter subexpressions k (recomputed first when a
 * parameter changed: every call of a generated function passes here). */
LfStatus lf_eval_fn(LfInstance *c, int fn, double t, const double *x, const double *w,
                        double *out0, double *out1, double *out2) {
    const double *u, *u_rate;
    if (LF_NK > 0 && c->unsaved.k_stale && fold_parameters(c) != LF_OK) return LF_ERROR;
    if (LF_ND > 0 && fn != LF_FN_HIST && fn != LF_FN_TAU && lf_delayed_values(c, t, x) != LF_OK)
        return LF_ERROR;
    if (!c->unsaved.args_set) { /* the arguments at fixed places, once (fold_parameters clears them) */
        c->unsaved.arg[4] = &c->val.r[LF_VR_P0];
        c->unsaved.arg[5] = c->val.q;
        c->unsaved.arg[6] = c->dl.dval;
        c->unsaved.arg[8] = c->unsaved.d_rate;
        c->unsaved.arg[9] = c->unsaved.k;
        c->unsaved.args_set = 1;
    }
    if (c->unsaved.u_poly) {
        lf_inputs_at(c, t, &u, &u_rate);
    } else { /* held: lf_inputs_at's own answer, without the call */
        u = &c->val.r[LF_VR_U0];
        u_rate = c->unsaved.u_zero;
    }
    c->unsaved.arg[0] = &t;
    c->unsaved.arg[1] = x;
    c->unsaved.arg[2] = w;
    c->unsaved.arg[3] = u;
    c->unsaved.arg[7] = u_rate;
    c->unsaved.res[0] = out0; /* functions with fewer outputs do not read the rest */
    c->unsaved.res[1] = out1;
    c->unsaved.res[2] = out2;
    return lf_function_of(fn)->eval(c->unsaved.arg, c->unsaved.res, c->unsaved.iw, c->unsaved.w, 0) ? LF_ERROR : LF_OK;
}

/* ---- delayed values at t: the history lookup ----------------------------- */

/* g_k at time s from the history: constant before the first sample, the
 * last sample's Taylor line after it (not reached with steps <= tau), else
 * cubic Hermite (or linear) between the samples around s.  At a jump (two
 * samples at one time) `left` selects the value before it (the earlier
 * sample), otherwise the value after it.  s = t - tau is known to rounding
 * only (t_jump + tau - tau need not be t_jump): samples within `eps` of s
 * count as at s.  (Elsewhere the choice is immaterial: the interpolant is
 * continuous at a sample.)  *rate: the interpolant's time derivative at s,
 * dg/dt there, which Rosenbrock methods need in df/dt. */
/* Is sample i of delay k before s (left: t_i < s - eps; else t_i <= s + eps)? */
static int sample_before(const LfInstance *c, int k, long i, double s, int left, double eps) {
    return left ? LF_HT(c, k, i) < s - eps : LF_HT(c, k, i) <= s + eps;
}

/* The last sample before s (sample_before), or -1.  The queries of one
 * step move forward through the ring: the search starts at the previous
 * answer (c->unsaved.hist_cursor[k]) and its neighbours, then bisects. */
static long hist_find(LfInstance *c, int k, double s, int left, double eps) {
    long lo = -1, hi = c->dl.hist_count[k], cur = c->unsaved.hist_cursor[k];
    if (cur >= 0 && cur < hi && sample_before(c, k, cur, s, left, eps)) {
        if (cur + 1 == hi || !sample_before(c, k, cur + 1, s, left, eps)) return cur;
        if (cur + 2 == hi || !sample_before(c, k, cur + 2, s, left, eps)) {
            c->unsaved.hist_cursor[k] = cur + 1;
            return cur + 1;
        }
        lo = cur + 1;
    } else if (cur >= 0 && cur < hi) {
        hi = cur;
    }
    while (hi - lo > 1) {
        long mid = (lo + hi) / 2;
        if (sample_before(c, k, mid, s, left, eps)) lo = mid;
        else hi = mid;
    }
    c->unsaved.hist_cursor[k] = lo;
    return lo;
}

/* (rate NULL: the slope is not needed, as in every call but Rosenbrock's
 * df/dt, and is not computed) */
static double hist_interp(LfInstance *c, int k, double s, int left, double eps,
                          double *rate) {
    long lo = hist_find(c, k, s, left, eps), hi, n = c->dl.hist_count[k];
    double t0, t1, h, th, th2, th3, g0, g1, d0, d1;
    if (lo < 0) {
        if (rate) *rate = 0.0;
        return LF_HG(c, k, 0);
    }
    if (lo == n - 1) {
        if (rate) *rate = LF_HD(c, k, n - 1);
        return LF_HG(c, k, n - 1) + LF_HD(c, k, n - 1) * (s - LF_HT(c, k, n - 1));
    }
    hi = lo + 1;
    t0 = LF_HT(c, k, lo);
    t1 = LF_HT(c, k, hi);
    g0 = LF_HG(c, k, lo);
    g1 = LF_HG(c, k, hi);
    d0 = LF_HD(c, k, lo);
    d1 = LF_HD(c, k, hi);
    h = t1 - t0;
    th = (s - t0) / h;
    if (c->dl.delay_interp == LF_DELAY_LINEAR) {
        if (rate) *rate = (g1 - g0) / h;
        return g0 + (g1 - g0) * th;
    }
    th2 = th * th;
    th3 = th2 * th;
    if (rate)
        *rate = ((6 * th2 - 6 * th) * (g0 - g1) / h + (3 * th2 - 4 * th + 1) * d0 +
                 (3 * th2 - 2 * th) * d1);
    return (2 * th3 - 3 * th2 + 1) * g0 + (th3 - 2 * th2 + th) * h * d0 + (3 * th2 - 2 * th3) * g1 +
           (th3 - th2) * h * d1;
}

/* The delayed values at t (and, if rate != NULL, their time derivatives
 * for delays > 0).  Steps end at every breakpoint t_jump + tau and the
 * solver restarts there.  The stages of the step ending at a breakpoint
 * that run at its end take the value before the jump; the restarted solver
 * (t = its last accepted point) takes the value after it.  Only there is
 * s = t - tau taken as equal to a sample within rounding. */
static LfStatus delayed(LfInstance *c, double t, const double *x, double *rate) {
    double g[LF_DIM(2 * LF_ND)], r;
    int k, need_now = 0, left = c->run.solver_ready && t > c->solver.t && t >= c->unsaved.t_bp_step;
    double eps = (left || (c->run.solver_ready && t == c->solver.t))
                     ? 8 * LF_EPS * (fabs(t) > 1.0 ? fabs(t) : 1.0) /* fmax, inline */
                     : 0.0;
    for (k = 0; k < LF_ND; k++)
        if (c->dl.tau[k] == 0 || c->dl.hist_count[k] == 0) need_now = 1;
    if (need_now) { /* zero delay, or no history yet: the value now */
        c->unsaved.arg[6] = c->dl.dval;
        if (lf_eval_fn(c, LF_FN_HIST, t, x, c->val.w_cur, g, &g[LF_ND], NULL) != LF_OK) return LF_ERROR;
    }
    for (k = 0; k < LF_ND; k++) {
        r = 0.0;
        c->dl.dval[k] = (c->dl.tau[k] == 0 || c->dl.hist_count[k] == 0)
                         ? g[k]
                         : hist_interp(c, k, t - c->dl.tau[k], left, eps, rate ? &r : NULL);
        if (rate) rate[k] = r;
    }
    return LF_OK;
}

LfStatus lf_delayed_values(LfInstance *c, double t, const double *x) {
    return delayed(c, t, x, NULL);
}

LfStatus lf_delayed_rates(LfInstance *c, double t, const double *x, double *rate) {
    return delayed(c, t, x, rate);
}
