/* loomfmu shared runtime: the start values before the solver starts:
 * states declared by a start expression evaluated for the parameters set,
 * the modes made consistent (lf_modes.c).  What a read before
 * initialization sees is where initialization will start. */
#include <math.h>

#include "lf_start.h"
#include "lf_base.h"
#include "lf_eval.h"
#include "lf_instance.h"
#include "lf_modes.h"

/* States declared with a start expression (e.g. a static equilibrium) start
 * there for the parameters actually set, unless the importer set them. */
LfStatus lf_initial_states(LfInstance *c) {
    double x0[LF_DIM(LF_NX)];
    int i;
    if (lf_eval_fn(c, LF_FN_INIT, c->run.t, &c->val.r[LF_VR_X0], c->val.w_cur, x0, NULL, NULL) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "initial states cannot be evaluated");
        return LF_ERROR;
    }
    for (i = 0; i < LF_NX; i++) {
        if (c->val.x_set[i]) continue;
        if (!isfinite(x0[i])) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "initial value of %s is %g for these parameters",
                   lf_model.real_names[LF_VR_X0 + i], x0[i]);
            return LF_ERROR;
        }
        c->val.r[LF_VR_X0 + i] = x0[i];
    }
    return LF_OK;
}

/* Before the solver starts, the states and modes read (and the outputs
 * computed from them) are those initialization will start from. */
LfStatus lf_prepare_initial(LfInstance *c) {
    if (!(c->run.state & (LF_ST_INSTANTIATED | LF_ST_INIT)) || c->run.solver_ready) return LF_OK;
    if (lf_initial_states(c) != LF_OK) return LF_ERROR;
    return LF_NQ > 0 ? lf_initial_modes(c) : LF_OK;
}
