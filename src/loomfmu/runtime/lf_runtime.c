/* loomfmu shared runtime: the model instance's life cycle (instantiate,
 * reset, free) and getting/setting values: what the FMI facades call,
 * above the step loop's files (the layers: lf_internal.h, docs/guides/runtime.md).
 * Logging and the work arrays are lf_base.c's, calls of the generated
 * functions lf_eval.c's, the outputs lf_outputs.c's. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_runtime.h"
#include "lf_base.h"
#include "lf_inputs.h"
#include "lf_instance.h"
#include "lf_outputs.h"
#include "lf_start.h"

void lf_free(LfInstance *c) {
    if (!c) return;
    if (c->run.solver_ready) lf_solver_free(&c->solver, &c->unsaved.alloc);
    c->unsaved.alloc.free((void *)c->unsaved.arg);
    c->unsaved.alloc.free(c->unsaved.res);
    c->unsaved.alloc.free(c->unsaved.iw);
    c->unsaved.alloc.free(c->unsaved.w);
    c->unsaved.alloc.free(c->dl.hist);
    c->unsaved.alloc.free(c->unsaved.name);
    c->unsaved.alloc.free(c);
}

void lf_reset_values(LfInstance *c) {
    unsigned vr;
    int k;
    for (vr = 0; vr < LF_NREAL; vr++) c->val.r[vr] = lf_model.real_start[vr];
    for (k = 0; k < LF_NQ; k++) c->val.q[k] = lf_model.mode_start[k];
    memset(c->val.x_set, 0, sizeof c->val.x_set);
    memset(c->dl.hist_count, 0, sizeof c->dl.hist_count);
    memset(c->dl.hist_start, 0, sizeof c->dl.hist_start);
    c->dl.n_bp = 0;
    c->unsaved.t_bp_step = INFINITY;
    c->dl.delay_interp = LF_DELAY_HERMITE;
    memset(c->val.w_cur, 0, sizeof c->val.w_cur);
    c->run.solver_id = 1;
    c->run.solver_index = 0;
    c->run.t = c->run.t_start = c->run.last_successful_time = 0.0;
    c->run.t_stop = INFINITY;
    c->run.rtol_importer = 0.0;
    for (k = 0; k < LF_N_LOG; k++) c->unsaved.log_on[k] = c->unsaved.log_on_start;
    c->run.outputs_valid = 0;
    c->unsaved.ho_valid = 0;
    c->run.inputs_changed = 0;
    c->run.wants_terminate = 0;
    c->unsaved.vld_t = NAN;
    lf_inputs_reset(c, 0.0);
    c->stats.n_events = 0;
    c->run.max_steps = (long)lf_model.real_start[LF_SET_MAX_STEPS];
    c->unsaved.k_stale = 1;
    if (c->run.solver_ready) {
        lf_solver_free(&c->solver, &c->unsaved.alloc);
        c->run.solver_ready = 0;
    }
    c->run.state = LF_ST_INSTANTIATED;
}

LfInstance *lf_instantiate(const char *name, LfLogFn log, void *log_env,
                           LfAllocator alloc) {
    LfInstance *c;
    size_t k, len = strlen(name);
    if (lf_n_methods != LF_N_SOLVERS) return NULL;
    for (k = 0; k < lf_n_methods; k++)
        if (strcmp(lf_methods[k]->name, lf_model.solver_names[k]) != 0) return NULL;
    c = (LfInstance *)alloc.calloc(1, sizeof(LfInstance));
    if (!c) return NULL;
    c->unsaved.alloc = alloc;
    c->unsaved.log = log;
    c->unsaved.log_env = log_env;
    c->unsaved.name = (char *)alloc.calloc(len + 1, 1);
    if (LF_ND > 0) c->dl.hist = (double *)alloc.calloc((size_t)LF_ND * LF_HIST_CAP * 3, sizeof(double));
    if (!c->unsaved.name || !lf_alloc_casadi_work(c) || (LF_ND > 0 && !c->dl.hist)) {
        lf_free(c);
        return NULL;
    }
    memcpy(c->unsaved.name, name, len + 1);
    lf_reset_values(c);
    return c;
}

/* ---- values ------------------------------------------------------------ */

LfStatus lf_set_real(LfInstance *c, unsigned vr, double value) {
    const char *name;
    LfKind kind;
    if (vr >= LF_NREAL) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "fmi2SetReal: value reference %u is not a Real (expected < %u)", vr,
               (unsigned)LF_NREAL);
        return LF_ERROR;
    }
    name = lf_model.real_names[vr];
    kind = lf_model.real_kind[vr];
    c->unsaved.ho_valid = 0; /* (the kept outputs' key would tell too: lf_hist_outputs) */
    if (kind == LF_KIND_OUTPUT || kind == LF_KIND_LOCAL) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s is calculated and cannot be set",
               c->run.t, name);
        return LF_ERROR;
    }
    if (kind != LF_KIND_INPUT && !(c->run.state & (LF_ST_INSTANTIATED | LF_ST_INIT))) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: %s can only be set before fmi2ExitInitializationMode", c->run.t, name);
        return LF_ERROR;
    }
    if (kind == LF_KIND_STATE && lf_model.x_computed[vr - LF_VR_X0] &&
        !(c->run.state & LF_ST_INSTANTIATED)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "%s has initial=\"approx\" (start computed from the "
               "parameters): it can only be set before fmi2EnterInitializationMode", name);
        return LF_ERROR;
    }
    if (kind == LF_KIND_INPUT && isfinite(value) &&
        (value < lf_model.real_min[vr] || value > lf_model.real_max[vr])) {
        lf_log(c, LF_WARNING, LF_LOG_WARNING,
               "t = %.17g: input %s = %g is outside its range [%g, %g]; the model may not be "
               "valid there", c->run.t, name, value, lf_model.real_min[vr], lf_model.real_max[vr]);
        lf_input_set(c, vr, value);
        return LF_WARNING;
    }
    if (!isfinite(value) || value < lf_model.real_min[vr] || value > lf_model.real_max[vr]) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: %s = %g is outside its range [%g, %g]; value not set", c->run.t,
               name, value, lf_model.real_min[vr], lf_model.real_max[vr]);
        return LF_ERROR;
    }
    if (kind == LF_KIND_INPUT) {
        lf_input_set(c, vr, value);
        return LF_OK;
    }
    if (kind == LF_KIND_STATE) c->val.x_set[vr - LF_VR_X0] = 1;
    if (kind == LF_KIND_PARAMETER && c->val.r[vr] != value) c->unsaved.k_stale = 1;
    c->val.r[vr] = value;
    c->run.outputs_valid = 0;
    return LF_OK;
}

LfStatus lf_get_real(LfInstance *c, unsigned vr, double *value) {
    LfKind kind;
    if (vr >= LF_NREAL) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "fmi2GetReal: value reference %u is not a Real (expected < %u)", vr,
               (unsigned)LF_NREAL);
        return LF_ERROR;
    }
    kind = lf_model.real_kind[vr];
    if ((kind == LF_KIND_OUTPUT || kind == LF_KIND_LOCAL) && !c->run.outputs_valid &&
        lf_update_outputs(c) != LF_OK)
        return LF_ERROR;
    if (kind == LF_KIND_STATE && lf_prepare_initial(c) != LF_OK) return LF_ERROR;
    *value = kind == LF_KIND_INPUT ? lf_input_now(c, vr) : c->val.r[vr];
    return LF_OK;
}

LfStatus lf_get_integer(LfInstance *c, unsigned vr, int *value) {
    if (vr == LF_VR_SOLVER) {
        *value = c->run.solver_id;
        return LF_OK;
    }
    if (vr >= LF_VR_Q0 && vr < LF_VR_Q0 + LF_NQ) {
        *value = (int)c->val.q[vr - LF_VR_Q0];
        return LF_OK;
    }
    if (LF_ND > 0 && vr == LF_VR_DINTERP) {
        *value = c->dl.delay_interp;
        return LF_OK;
    }
    if (vr == LF_VR_SOLVER_INDEX) {
        *value = c->run.solver_index;
        return LF_OK;
    }
    lf_log(c, LF_ERROR, LF_LOG_ERROR,
           "fmi2GetInteger: value reference %u is not an Integer (expected < %d)", vr,
           LF_N_INTEGER);
    return LF_ERROR;
}

static LfStatus set_solver(LfInstance *c, const char *name, int id, int lowest);

LfStatus lf_set_integer(LfInstance *c, unsigned vr, int value) {
    if (vr == LF_VR_SOLVER) return set_solver(c, "solver", value, 1);
    if (vr == LF_VR_SOLVER_INDEX) {
        if (set_solver(c, "solver_index", value, 0) != LF_OK) return LF_ERROR;
        c->run.solver_index = value; /* set_solver set solver_id too: both say the same */
        return LF_OK;
    }
    if (LF_ND > 0 && vr == LF_VR_DINTERP) {
        if (value != LF_DELAY_HERMITE && value != LF_DELAY_LINEAR) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR,
                   "delay_interpolation = %d: allowed 1 (hermite) or 2 (linear)", value);
            return LF_ERROR;
        }
        if (!(c->run.state & (LF_ST_INSTANTIATED | LF_ST_INIT))) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR,
                   "delay_interpolation can only be set before fmi2ExitInitializationMode");
            return LF_ERROR;
        }
        c->dl.delay_interp = value;
        return LF_OK;
    }
    lf_log(c, LF_ERROR, LF_LOG_ERROR,
           "fmi2SetInteger: value reference %u cannot be set (solver: %d, solver_index: %d%s)",
           vr, LF_VR_SOLVER, LF_VR_SOLVER_INDEX, LF_ND > 0 ? ", delay_interpolation" : "");
    return LF_ERROR;
}

LfStatus lf_set_solver(LfInstance *c, int id) { return set_solver(c, "solver", id, 1); }

/* Set variable `name` (solver, or solver_index whose 0 leaves `solver` in
 * charge: lowest = 0) to id; the log names the variable, its allowed range
 * and the solvers. */
static LfStatus set_solver(LfInstance *c, const char *name, int id, int lowest) {
    if (id < lowest || id > (int)lf_n_methods) {
        char list[128];
        size_t used = 0;
        unsigned i;
        list[0] = '\0';
        for (i = 0; i < lf_n_methods && used < sizeof list; i++) {
            int n = snprintf(list + used, sizeof list - used, "%s%u %s", i ? ", " : "", i + 1,
                             lf_methods[i]->name);
            if (n < 0) break;
            used += (size_t)n;
        }
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "%s = %d is not a solver: allowed %d..%d (%s%s)", name,
               id, lowest, (int)lf_n_methods, lowest == 0 ? "0 leaves solver in charge, " : "",
               list);
        return LF_ERROR;
    }
    if (!(c->run.state & (LF_ST_INSTANTIATED | LF_ST_INIT))) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "%s can only be set before fmi2ExitInitializationMode", name);
        return LF_ERROR;
    }
    if (id == 0) return LF_OK;
    c->run.solver_id = id;
    return LF_OK;
}
