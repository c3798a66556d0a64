/* loomfmu shared runtime: the unknowns w = [der(x); z] of the model
 * equations (closed form, or Newton with the exact dF/dw for algebraic
 * loops), and the right-hand side and Jacobian the solvers integrate. */
#include <math.h>
#include <string.h>

#include "lf_internal.h"
#include "lf_linalg.h"
#include "lf_wcache.h"

#define LF_NEWTON_MAX_ITER 30
#define LF_NEWTON_RTOL 1e-10
#define LF_NEWTON_ATOL 1e-12

/* Factor dF/dw at (t, x, w) into c->jac_ww (implicit models). */
static LfStatus factor_dFdw(LfInstance *c, double t, const double *x, const double *w) {
    if (lf_eval_fn(c, LF_FN_RJAC, t, x, w, c->jac_ww, c->jac_wx, c->jac_wt) != LF_OK)
        return LF_ERROR;
    if (lf_lu_factor(c->jac_ww, LF_NW, c->piv) != 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
               "t = %.17g: algebraic loop has no unique solution (dF/dw singular)", t);
        return LF_DISCARD;
    }
    return LF_OK;
}

/* Newton on F(t, x, w) = 0 from c->w_cur, with the exact dF/dw.  Converged
 * when every |dw_i| <= LF_NEWTON_ATOL + LF_NEWTON_RTOL max(|w_i|, |w_cur_i|),
 * or when the scaled step stops shrinking at rounding level (a component
 * near 0 coupled to large terms cannot get below its terms' rounding). */
static LfStatus newton(LfInstance *c, double t, const double *x, double *w) {
    int it, i;
    double prev = INFINITY;
    LfStatus st;
    memcpy(w, c->w_cur, sizeof(double) * LF_NW);
    for (it = 0; it < LF_NEWTON_MAX_ITER; it++) {
        int done = 1;
        double size = 0.0;
        if (lf_eval_fn(c, LF_FN_RES, t, x, w, c->res_F, NULL, NULL) != LF_OK) return LF_ERROR;
        if (lf_first_nonfinite(c->res_F, LF_NW) >= 0) {
            lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: algebraic loop: residual of "
                   "equation %d is not finite at Newton iteration %d", t,
                   lf_first_nonfinite(c->res_F, LF_NW), it);
            return LF_DISCARD;
        }
        st = factor_dFdw(c, t, x, w);
        if (st != LF_OK) return st;
        lf_lu_solve(c->jac_ww, LF_NW, c->piv, c->res_F);
        for (i = 0; i < LF_NW; i++) {
            double scale = fmax(fabs(w[i]), fabs(c->w_cur[i]));
            w[i] -= c->res_F[i];
            if (fabs(c->res_F[i]) > LF_NEWTON_ATOL + LF_NEWTON_RTOL * scale) done = 0;
            size = fmax(size, fabs(c->res_F[i]) / (LF_NEWTON_ATOL + scale));
        }
        if (lf_first_nonfinite(w, LF_NW) >= 0) break;
        if (done || (size < 1e-8 && size >= 0.5 * prev)) return LF_OK;
        prev = size;
    }
    c->n_newton_fail++;
    lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
           "t = %.17g: algebraic loop: Newton did not converge in %d iterations", t,
           LF_NEWTON_MAX_ITER);
    return LF_DISCARD;
}

/* The unknowns w = [der(x); z] at (t, x) (inline in lf_rhs, the solvers'
 * hot path). */
static inline LfStatus solve_w(LfInstance *c, double t, const double *x, double *w) {
    LfStatus st;
    int bad;
    if (LF_WC_USED && c->wc_on && lf_wc_take(c, t, x, w)) return LF_OK;
    if (LF_WK_USED && c->wc_on && lf_wk_take(c, t, x, w)) return LF_OK;
    if (LF_IMPLICIT) {
        st = newton(c, t, x, w);
        if (st != LF_OK) return st;
    } else if (lf_eval_fn(c, LF_FN_WSOL, t, x, w, w, NULL, NULL) != LF_OK) {
        return LF_ERROR;
    }
    bad = lf_first_nonfinite(w, LF_NW);
    if (bad >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: unknown %d of the model equations "
               "(derivative or algebraic variable) is %g", t, bad, w[bad]);
        return LF_DISCARD;
    }
    memcpy(c->w_cur, w, sizeof(double) * LF_NW);
    if (LF_WC_USED && c->wc_on) lf_wc_keep(c, t, x, w);
    if (LF_WK_USED && c->wc_on) lf_wk_keep(c, t, x);
    return LF_OK;
}

LfStatus lf_solve_w(LfInstance *c, double t, const double *x, double *w) {
    return solve_w(c, t, x, w);
}

LfStatus lf_rhs(void *ctx, double t, const double *x, double *dx) {
    LfInstance *c = (LfInstance *)ctx;
    LfStatus st = solve_w(c, t, x, c->w_tmp);
    if (st != LF_OK) return st;
    memcpy(dx, c->w_tmp, sizeof(double) * LF_NX);
    return LF_OK;
}

/* The delayed values' part of df/dx and df/dt, added to c->jac_wx and
 * c->jac_wt through dw/dd (for implicit models dw/dd = -(dF/dw)^-1 dF/dd,
 * with dF/dw factored in c->jac_ww):
 *  - a zero delay reads d = g(t, x) now: dd/dx = dg/dx, dd/dt = dg/dt;
 *  - a delay tau > 0 reads d = g(t - tau) from the history: dd/dx = 0,
 *    dd/dt = the history's dg/dt at t - tau (its interpolant's slope).
 * Without them Rosenbrock methods lose their order (rodas4 fell to first
 * order on x' = -x(t - 1): error 3e-5 at rtol 1e-6, 3e-6 at 1e-8). */
static LfStatus delay_jacobian(LfInstance *c, double t, const double *x) {
    double wd[LF_DIM(LF_NW * LF_ND)], gx[LF_DIM(LF_ND * LF_NX)], gt[LF_DIM(LF_ND)];
    double rate[LF_DIM(LF_ND)];
    int i, j, k;
    if (lf_delayed_rates(c, t, x, rate) != LF_OK) return LF_ERROR;
    if (lf_eval_fn(c, LF_FN_DJAC, t, x, c->w_cur, wd, gx, gt) != LF_OK) return LF_ERROR;
    for (k = 0; k < LF_ND; k++) {
        double *col = &wd[k * LF_NW], dd_dt = c->tau[k] == 0 ? gt[k] : rate[k];
        if (LF_IMPLICIT) {
            lf_lu_solve(c->jac_ww, LF_NW, c->piv, col);
            for (i = 0; i < LF_NW; i++) col[i] = -col[i];
        }
        if (c->tau[k] == 0)
            for (j = 0; j < LF_NX; j++)
                for (i = 0; i < LF_NW; i++) c->jac_wx[i + j * LF_NW] += col[i] * gx[k + j * LF_ND];
        for (i = 0; i < LF_NW; i++) c->jac_wt[i] += col[i] * dd_dt;
    }
    return LF_OK;
}

/* df/dx and df/dt: the first LF_NX rows of dw/dx, dw/dt, which implicit
 * models get from the implicit function theorem, dw = -(dF/dw)^-1 dF. */
static LfStatus jac_cb(void *ctx, double t, const double *x, double *J, double *dfdt) {
    LfInstance *c = (LfInstance *)ctx;
    int i, j;
    LfStatus st;
    if (LF_IMPLICIT) {
        st = lf_solve_w(c, t, x, c->w_tmp);
        if (st == LF_OK) st = factor_dFdw(c, t, x, c->w_tmp);
        if (st != LF_OK) return st;
        for (j = 0; j < LF_NX; j++) lf_lu_solve(c->jac_ww, LF_NW, c->piv, &c->jac_wx[j * LF_NW]);
        lf_lu_solve(c->jac_ww, LF_NW, c->piv, c->jac_wt);
        for (i = 0; i < LF_NW * LF_NX; i++) c->jac_wx[i] = -c->jac_wx[i];
        for (i = 0; i < LF_NW; i++) c->jac_wt[i] = -c->jac_wt[i];
    } else if (lf_eval_fn(c, LF_FN_WJAC, t, x, c->w_cur, c->jac_wx, c->jac_wt, NULL) != LF_OK) {
        return LF_ERROR;
    }
    if (LF_ND > 0) {
        st = delay_jacobian(c, t, x);
        if (st != LF_OK) return st;
    }
    for (j = 0; j < LF_NX; j++)
        for (i = 0; i < LF_NX; i++) J[i + j * LF_NX] = c->jac_wx[i + j * LF_NW];
    memcpy(dfdt, c->jac_wt, sizeof(double) * LF_NX);
    if (lf_first_nonfinite(J, (size_t)LF_NX * LF_NX) >= 0 || lf_first_nonfinite(dfdt, LF_NX) >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: Jacobian is not finite", t);
        return LF_DISCARD;
    }
    return LF_OK;
}

LfOde lf_ode_of(LfInstance *c) {
    LfOde ode;
    ode.n = LF_NX;
    ode.ctx = c;
    ode.rhs = lf_rhs;
    ode.jac = jac_cb;
    return ode;
}

/* b := (dF/dw)^-1 b at (t, x, w) (implicit models; output derivatives). */
LfStatus lf_solve_dFdw(LfInstance *c, double t, const double *x, const double *w, double *b) {
    LfStatus st = factor_dFdw(c, t, x, w);
    if (st != LF_OK) return st;
    lf_lu_solve(c->jac_ww, LF_NW, c->piv, b);
    return LF_OK;
}
