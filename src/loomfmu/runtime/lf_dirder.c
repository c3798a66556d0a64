/* loomfmu shared runtime: exact directional derivatives (lf_dirder.h).
 *
 * With the seeds split into dx (states) and du (inputs), and dd the
 * delayed values' change (dd = dg/dx dx + dg/du du for tau = 0, else 0):
 *   explicit models: dw = dw/dx dx + dw/du du + dw/dd dd;
 *   implicit models: dF/dw dw = -(dF/dx dx + dF/du du + dF/dd dd), solved
 *     with the LU factors of dF/dw (lf_linalg);
 *   outputs and locals: dy = dy/dx dx + dy/dw dw + dy/du du + dy/dd dd;
 * der(x_k) = dw_k.  The matrices are the generated dense Jacobians:
 * wjac/rjac (dw/dx or dF/dw, dF/dx), djac (dW/dd, dg/dx), dirw (dW/du,
 * dg/du, dy/dd), diry (dy/dx, dy/dw, dy/du). */
#include <math.h>
#include <string.h>

#include "lf_dirder.h"
#include "lf_base.h"
#include "lf_eval.h"
#include "lf_instance.h"
#include "lf_linalg.h"
#include "lf_newton.h"
#include "lf_start.h"

#define NOUT (LF_NY + LF_NZ)
#define VR_DER0 ((unsigned)LF_NREAL)
/* most unknowns or knowns in one call (a value reference may repeat): the
 * getters' bound, checked before any array is read */
#define DIRDER_N_LIMIT (16 * (size_t)(LF_NREAL + LF_NX) + 16)

/* y += A v, A m x n column-major */
static void gemv_add(const double *a, size_t m, size_t n, const double *v, double *y) {
    size_t i, j;
    for (j = 0; j < n; j++) {
        if (v[j] == 0.0) continue;
        for (i = 0; i < m; i++) y[i] += a[i + j * m] * v[j];
    }
}

static LfStatus check_args(LfInstance *c, const unsigned *unknown_vr, size_t nu,
                           const unsigned *known_vr, size_t nk, const double *seed,
                           const double *out) {
    size_t i;
    if (nu > DIRDER_N_LIMIT || nk > DIRDER_N_LIMIT) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: directional derivative: %zu unknowns and "
               "%zu knowns; allowed: at most %zu each (the model has %d Real variables and "
               "%d state derivatives); nothing read", c->run.t, nu, nk, DIRDER_N_LIMIT,
               LF_NREAL, LF_NX);
        return LF_ERROR;
    }
    if (nu > 0 && (!unknown_vr || !out)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: directional derivative: %s is NULL with "
               "%zu unknowns; allowed: an array of %zu", c->run.t, unknown_vr ? "dvUnknown" :
               "vUnknown_ref", nu, nu);
        return LF_ERROR;
    }
    if (nk > 0 && (!known_vr || !seed)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: directional derivative: %s is NULL with "
               "%zu knowns; allowed: an array of %zu", c->run.t, known_vr ? "dvKnown" :
               "vKnown_ref", nk, nk);
        return LF_ERROR;
    }
    for (i = 0; i < nu; i++) {
        unsigned vr = unknown_vr[i];
        if (!((vr >= LF_VR_Y0 && vr < LF_NREAL) || (vr >= VR_DER0 && vr < VR_DER0 + LF_NX))) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: directional derivative: unknown %zu "
                   "has value reference %u (%s); allowed: outputs and algebraic locals %u..%d, "
                   "state derivatives der(x) %u..%d", c->run.t, i, vr,
                   vr < LF_NREAL ? lf_model.real_names[vr] : "not a Real of the model",
                   (unsigned)LF_VR_Y0, LF_NREAL - 1, VR_DER0, LF_NREAL + LF_NX - 1);
            return LF_ERROR;
        }
    }
    for (i = 0; i < nk; i++) {
        unsigned vr = known_vr[i];
        if (!(vr >= LF_VR_X0 && vr < LF_VR_Y0)) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: directional derivative: known %zu "
                   "has value reference %u (%s); allowed: states and inputs %u..%d", c->run.t, i, vr,
                   vr < LF_NREAL ? lf_model.real_names[vr] :
                   vr < VR_DER0 + LF_NX ? "a state derivative" : "not a Real of the model",
                   (unsigned)LF_VR_X0, LF_VR_Y0 - 1);
            return LF_ERROR;
        }
        if (!isfinite(seed[i])) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: directional derivative: seed %zu "
                   "(of %s) is %g; allowed: a finite number", c->run.t, i, lf_model.real_names[vr],
                   seed[i]);
            return LF_ERROR;
        }
    }
    return LF_OK;
}

/* The change of the unknowns w for state and input changes dx, du, and of
 * the delayed values dd (filled here); wu, gu: dW/du, dg/du (from dirw). */
static LfStatus unknowns_change(LfInstance *c, const double *x, const double *w,
                                const double *dx, const double *du, const double *wu,
                                const double *gu, double *dd, double *dw) {
    double wd[LF_DIM(LF_NW * LF_ND)], gx[LF_DIM(LF_ND * LF_NX)], gt[LF_DIM(LF_ND)];
    double wx[LF_DIM(LF_NW * LF_NX)], ww[LF_IMPLICIT ? LF_DIM(LF_NW * LF_NW) : 1];
    double wt[LF_DIM(LF_NW)];
    size_t piv[LF_DIM(LF_NW)];
    int k, i;
    memset(dw, 0, sizeof(double) * LF_DIM(LF_NW));
    memset(dd, 0, sizeof(double) * LF_DIM(LF_ND));
    if (LF_ND > 0) {
        if (lf_eval_fn(c, LF_FN_DJAC, c->run.t, x, w, wd, gx, gt) != LF_OK) return LF_ERROR;
        gemv_add(gx, LF_ND, LF_NX, dx, dd);
        gemv_add(gu, LF_ND, LF_NU, du, dd);
        for (k = 0; k < LF_ND; k++)
            if (c->dl.tau[k] > 0) dd[k] = 0.0; /* read from the history: held */
    }
    if (LF_IMPLICIT) {
        if (lf_eval_fn(c, LF_FN_RJAC, c->run.t, x, w, ww, wx, wt) != LF_OK) return LF_ERROR;
    } else if (lf_eval_fn(c, LF_FN_WJAC, c->run.t, x, w, wx, wt, NULL) != LF_OK) {
        return LF_ERROR;
    }
    gemv_add(wx, LF_NW, LF_NX, dx, dw);
    gemv_add(wu, LF_NW, LF_NU, du, dw);
    if (LF_ND > 0) gemv_add(wd, LF_NW, LF_ND, dd, dw);
    if (LF_IMPLICIT) {
        if (lf_lu_factor(ww, LF_NW, piv) != 0) {
            lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: directional derivative: dF/dw "
                   "is singular (the algebraic loop has no unique solution here)", c->run.t);
            return LF_DISCARD;
        }
        lf_lu_solve(ww, LF_NW, piv, dw);
        for (i = 0; i < LF_NW; i++) dw[i] = -dw[i];
    }
    return LF_OK;
}

/* The change of the outputs and locals; yd: dy/dd (from dirw). */
static LfStatus outputs_change(LfInstance *c, const double *x, const double *w,
                               const double *dx, const double *du, const double *dd,
                               const double *dw, const double *yd, double *dy) {
    double yx[LF_DIM(NOUT * LF_NX)], yw[LF_DIM(NOUT * LF_NW)], yu[LF_DIM(NOUT * LF_NU)];
    memset(dy, 0, sizeof(double) * NOUT);
    if (lf_eval_fn(c, LF_FN_DIRY, c->run.t, x, w, yx, yw, yu) != LF_OK) return LF_ERROR;
    gemv_add(yx, NOUT, LF_NX, dx, dy);
    gemv_add(yw, NOUT, LF_NW, dw, dy);
    gemv_add(yu, NOUT, LF_NU, du, dy);
    gemv_add(yd, NOUT, LF_ND, dd, dy);
    return LF_OK;
}

/* The value of unknown vr among res = [der(x); outputs; locals]. */
static double pick(const double *res, unsigned vr) {
    return vr >= VR_DER0 ? res[vr - VR_DER0] : res[LF_NX + (vr - LF_VR_Y0)];
}

LfStatus lf_directional_derivative(LfInstance *c, const unsigned *unknown_vr, size_t nu,
                                   const unsigned *known_vr, size_t nk, const double *seed,
                                   double *out) {
    double dx[LF_DIM(LF_NX)], du[LF_DIM(LF_NU)], dd[LF_DIM(LF_ND)], dw[LF_DIM(LF_NW)];
    double w[LF_DIM(LF_NW)], res[LF_DIM(LF_NX + NOUT)];
    double wu[LF_DIM(LF_NW * LF_NU)], gu[LF_DIM(LF_ND * LF_NU)], yd[LF_DIM(NOUT * LF_ND)];
    const double *x;
    size_t i;
    int need_y = 0;
    LfStatus st;
    if (check_args(c, unknown_vr, nu, known_vr, nk, seed, out) != LF_OK) return LF_ERROR;
    if (nu == 0) return LF_OK;
    memset(dx, 0, sizeof dx);
    memset(du, 0, sizeof du);
    memset(res, 0, sizeof res);
    for (i = 0; i < nk; i++) {
        unsigned vr = known_vr[i];
        if (vr < LF_VR_U0) {
            if (LF_NX > 0) dx[vr - LF_VR_X0] += seed[i];
        } else if (LF_NU > 0) {
            du[vr - LF_VR_U0] += seed[i];
        }
    }
    for (i = 0; i < nu; i++) need_y |= unknown_vr[i] < LF_NREAL;
    if (lf_prepare_initial(c) != LF_OK) return LF_ERROR;
    x = &c->val.r[LF_VR_X0];
    st = lf_solve_w(c, c->run.t, x, w);
    if (st != LF_OK) {
        lf_log(c, st, st == LF_ERROR ? LF_LOG_ERROR : LF_LOG_DISCARD, "t = %.17g: directional "
               "derivative: the model equations cannot be solved here", c->run.t);
        return st;
    }
    if (lf_eval_fn(c, LF_FN_DIRW, c->run.t, x, w, wu, gu, yd) != LF_OK) return LF_ERROR;
    st = unknowns_change(c, x, w, dx, du, wu, gu, dd, dw);
    if (st == LF_OK && need_y) st = outputs_change(c, x, w, dx, du, dd, dw, yd, res + LF_NX);
    if (st != LF_OK) return st;
    memcpy(res, dw, sizeof(double) * LF_NX);
    for (i = 0; i < nu; i++) {
        double v = pick(res, unknown_vr[i]);
        if (!isfinite(v)) {
            lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: directional derivative of "
                   "unknown %zu (%s) is %g (not finite)", c->run.t, i,
                   unknown_vr[i] >= VR_DER0 ? "a state derivative" :
                   lf_model.real_names[unknown_vr[i]], v);
            return LF_DISCARD;
        }
    }
    for (i = 0; i < nu; i++) out[i] = pick(res, unknown_vr[i]);
    return LF_OK;
}
