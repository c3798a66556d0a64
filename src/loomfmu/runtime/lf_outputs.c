/* loomfmu shared runtime: the outputs (and algebraic locals) at the
 * current point, and their first time derivatives
 * (fmi2GetRealOutputDerivatives, order 1). */
#include <math.h>
#include <string.h>

#include "lf_outputs.h"
#include "lf_base.h"
#include "lf_delay.h"
#include "lf_eval.h"
#include "lf_instance.h"
#include "lf_internal.h"
#include "lf_newton.h"
#include "lf_start.h"
#include "lf_wcache.h"

LfStatus lf_update_outputs(LfInstance *c) {
    double y[LF_DIM(LF_NY + LF_NZ)];
    const double *x = &c->val.r[LF_VR_X0], *w = c->unsaved.w_tmp;
    int bad, kept;
    if (c->run.outputs_valid || LF_NY + LF_NZ == 0) return LF_OK;
    if (!c->run.solver_ready && lf_prepare_initial(c) != LF_OK) return LF_ERROR;
    /* the outputs kept by the history sample at this point, if any (explicit
     * models: w is a function of the point; implicit: w compared too) */
    kept = !LF_IMPLICIT && LF_ND > 0 && lf_hist_outputs(c, NULL, y);
    /* (after a step: the solver's last stage solved w here, and w_cur holds
     * it, lf_wcache.h; read there, without the copy a solve would make) */
    if (!kept && LF_WK_USED && c->unsaved.wc_on && lf_wk_take(c, c->run.t, x, c->val.w_cur)) {
        w = c->val.w_cur;
    } else if (!kept && lf_solve_w(c, c->run.t, x, c->unsaved.w_tmp) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: model equations cannot be solved", c->run.t);
        return LF_ERROR;
    }
    if (!kept && LF_IMPLICIT) kept = lf_hist_outputs(c, c->unsaved.w_tmp, y);
    if (!kept && lf_eval_fn1(c, LF_FN_OUT, c->run.t, x, w, y) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: output function failed", c->run.t);
        return LF_ERROR;
    }
    bad = lf_first_nonfinite(y, LF_NY + LF_NZ);
    if (bad >= 0) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: output %s is %g (not finite)",
               c->run.t, lf_model.real_names[LF_VR_Y0 + bad], y[bad]);
        return LF_ERROR;
    }
    memcpy(&c->val.r[LF_VR_Y0], y, sizeof(double) * (LF_NY + LF_NZ));
    c->run.outputs_valid = 1;
    return LF_OK;
}

/* ---- output derivatives -------------------------------------------------- */

/* The delayed values' time derivatives at (t, x): the history's slope at
 * t - tau, or for tau = 0 the total derivative of g now. */
static LfStatus delayed_rates(LfInstance *c, double t, const double *x, const double *w) {
    double g[LF_DIM(2 * LF_ND)];
    int k;
    if (LF_ND == 0) return LF_OK;
    if (lf_delayed_rates(c, t, x, c->unsaved.d_rate) != LF_OK) return LF_ERROR;
    if (lf_eval_fn(c, LF_FN_HIST, t, x, w, g, &g[LF_ND], NULL) != LF_OK) return LF_ERROR;
    for (k = 0; k < LF_ND; k++)
        if (c->dl.tau[k] == 0) c->unsaved.d_rate[k] = g[LF_ND + k];
    return LF_OK;
}

#define LF_NYZ LF_DIM(LF_NY + LF_NZ)

LfStatus lf_output_derivative(LfInstance *c, unsigned vr, double *value) {
    double rate[LF_NYZ], dydw[LF_IMPLICIT ? LF_NYZ * LF_DIM(LF_NW) : 1];
    double wrate[LF_IMPLICIT ? LF_DIM(LF_NW) : 1], w[LF_DIM(LF_NW)];
    const double *x = &c->val.r[LF_VR_X0];
    int i = (int)vr - (int)LF_VR_Y0, j;
    LfStatus st = lf_solve_w(c, c->run.t, x, w);
    if (st == LF_OK) st = delayed_rates(c, c->run.t, x, w);
    if (st == LF_OK)
        st = lf_eval_fn(c, LF_FN_YDER, c->run.t, x, w, rate, dydw, wrate);
    if (LF_IMPLICIT && st == LF_OK) {
        st = lf_solve_dFdw(c, c->run.t, x, w, wrate);
        for (j = 0; st == LF_OK && j < LF_NW; j++) rate[i] -= dydw[i + j * (LF_NY + LF_NZ)] * wrate[j];
    }
    memset(c->unsaved.d_rate, 0, sizeof c->unsaved.d_rate);
    if (st != LF_OK || !isfinite(rate[i])) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi2GetRealOutputDerivatives: the time "
               "derivative of %s cannot be evaluated here (%s)", c->run.t, lf_model.real_names[vr],
               st != LF_OK ? "model equations not solvable" : "not finite");
        return LF_ERROR;
    }
    *value = rate[i];
    return LF_OK;
}
