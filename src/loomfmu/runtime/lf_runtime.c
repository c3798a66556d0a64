/* loomfmu shared runtime: the model instance (allocation, logging), calls
 * of the generated functions, and getting/setting values.
 *
 * The runtime is split by concern: lf_newton.c (the unknowns: closed form or
 * Newton, Jacobians), lf_delay.c (history of delayed values), lf_events.c
 * (modes, event location), lf_step.c (initialization and the step loop). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_internal.h"
#include "lf_wcache.h"

const char *const lf_log_category_names[LF_N_LOG] = LF_LOG_CATEGORY_NAMES;

void lf_log(LfInstance *c, LfStatus status, LfLogCategory cat, const char *fmt, ...) {
    char buf[512];
    va_list ap;
    /* warnings, discards and errors are always reported; the rest on request */
    if (!c || !c->log) return;
    if (!c->log_on[cat] && cat != LF_LOG_ERROR && cat != LF_LOG_DISCARD &&
        cat != LF_LOG_WARNING)
        return;
    if (c->quiet && cat == LF_LOG_DISCARD) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    c->log(c->log_env, c->name, status, lf_log_category_names[cat], buf);
}

static void *lf_calloc(LfInstance *c, size_t n, size_t size) {
    return c->alloc.calloc(n > 0 ? n : 1, size);
}

/* Generated function `fn` (an LfFunctionId, or LF_FN_HISTOUT). */
static const LfFunction *function_of(int fn) {
#ifdef LF_HISTOUT_FN
    if (fn == LF_FN_HISTOUT) return &LF_HISTOUT_FN;
#endif
    return &lf_model.fn[fn];
}

#ifdef LF_HISTOUT_FN
#define LF_N_FN_ALL (LF_N_FN + 1)
#else
#define LF_N_FN_ALL LF_N_FN
#endif

/* Size the CasADi work arrays for the largest of the generated functions. */
static int alloc_casadi_work(LfInstance *c) {
    long long n_arg = 0, n_res = 0, n_iw = 0, n_w = 0;
    int k;
    for (k = 0; k < LF_N_FN_ALL; k++) {
        long long a = 0, r = 0, i = 0, w = 0;
        if (function_of(k)->work(&a, &r, &i, &w)) return 0;
        if (a > n_arg) n_arg = a;
        if (r > n_res) n_res = r;
        if (i > n_iw) n_iw = i;
        if (w > n_w) n_w = w;
    }
    c->arg = (const double **)lf_calloc(c, (size_t)n_arg, sizeof(double *));
    c->res = (double **)lf_calloc(c, (size_t)n_res, sizeof(double *));
    c->iw = (long long *)lf_calloc(c, (size_t)n_iw, sizeof(long long));
    c->w = (double *)lf_calloc(c, (size_t)n_w, sizeof(double));
    return c->arg && c->res && c->iw && c->w;
}

void lf_free(LfInstance *c) {
    if (!c) return;
    if (c->solver_ready) lf_solver_free(&c->solver, &c->alloc);
    c->alloc.free((void *)c->arg);
    c->alloc.free(c->res);
    c->alloc.free(c->iw);
    c->alloc.free(c->w);
    c->alloc.free(c->hist);
    c->alloc.free(c->name);
    c->alloc.free(c);
}

void lf_reset_values(LfInstance *c) {
    unsigned vr;
    int k;
    for (vr = 0; vr < LF_NREAL; vr++) c->r[vr] = lf_model.real_start[vr];
    for (k = 0; k < LF_NQ; k++) c->q[k] = lf_model.mode_start[k];
    memset(c->x_set, 0, sizeof c->x_set);
    memset(c->hist_count, 0, sizeof c->hist_count);
    memset(c->hist_start, 0, sizeof c->hist_start);
    c->n_bp = 0;
    c->t_bp_step = INFINITY;
    c->delay_interp = LF_DELAY_HERMITE;
    memset(c->w_cur, 0, sizeof c->w_cur);
    c->solver_id = 1;
    c->solver_index = 0;
    c->t = c->t_start = c->last_successful_time = 0.0;
    c->t_stop = INFINITY;
    c->rtol_importer = 0.0;
    for (k = 0; k < LF_N_LOG; k++) c->log_on[k] = c->log_on_start;
    c->outputs_valid = 0;
    c->ho_valid = 0;
    c->inputs_changed = 0;
    c->wants_terminate = 0;
    c->vld_t = NAN;
    lf_inputs_reset(c, 0.0);
    c->n_events = 0;
    c->max_steps = (long)lf_model.real_start[LF_SET_MAX_STEPS];
    c->k_stale = 1;
    if (c->solver_ready) {
        lf_solver_free(&c->solver, &c->alloc);
        c->solver_ready = 0;
    }
    c->state = LF_ST_INSTANTIATED;
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
    c->alloc = alloc;
    c->log = log;
    c->log_env = log_env;
    c->name = (char *)alloc.calloc(len + 1, 1);
    if (LF_ND > 0) c->hist = (double *)alloc.calloc((size_t)LF_ND * LF_HIST_CAP * 3, sizeof(double));
    if (!c->name || !alloc_casadi_work(c) || (LF_ND > 0 && !c->hist)) {
        lf_free(c);
        return NULL;
    }
    memcpy(c->name, name, len + 1);
    lf_reset_values(c);
    return c;
}

/* ---- evaluating the generated functions ------------------------------- */

/* k := pre(p): the parameter-only subexpressions (parameter folding). */
static LfStatus fold_parameters(LfInstance *c) {
    int i, bad;
    for (i = 0; i < 10; i++) c->arg[i] = NULL; /* pre reads p only */
    c->args_set = 0;
    c->arg[4] = &c->r[LF_VR_P0];
    c->res[0] = c->k;
    if (lf_model.fn[LF_FN_PRE].eval(c->arg, c->res, c->iw, c->w, 0)) return LF_ERROR;
    /* a non-finite k is not an error by itself (e.g. a term of a branch not
     * taken); the functions that use it report their own non-finite results */
    bad = lf_first_nonfinite(c->k, LF_NK);
    if (bad >= 0)
        lf_log(c, LF_OK, LF_LOG_SOLVER, "t = %.17g: parameter-only subexpression %d is %g",
               c->t, bad, c->k[bad]);
    c->k_stale = 0;
    return LF_OK;
}

/* Call generated function `fn` at (t, x, w) with the instance's inputs at t
 * (held, or their polynomials) and their rates, p, q, the delayed values
 * at t and the folded parameter subexpressions k (recomputed first when a
 * parameter changed: every call of a generated function passes here). */
LfStatus lf_eval_fn(LfInstance *c, int fn, double t, const double *x, const double *w,
                        double *out0, double *out1, double *out2) {
    const double *u, *u_rate;
    if (LF_NK > 0 && c->k_stale && fold_parameters(c) != LF_OK) return LF_ERROR;
    if (LF_ND > 0 && fn != LF_FN_HIST && fn != LF_FN_TAU && lf_delayed_values(c, t, x) != LF_OK)
        return LF_ERROR;
    if (!c->args_set) { /* the arguments at fixed places, once (fold_parameters clears them) */
        c->arg[4] = &c->r[LF_VR_P0];
        c->arg[5] = c->q;
        c->arg[6] = c->dval;
        c->arg[8] = c->d_rate;
        c->arg[9] = c->k;
        c->args_set = 1;
    }
    if (c->u_poly) {
        lf_inputs_at(c, t, &u, &u_rate);
    } else { /* held: lf_inputs_at's own answer, without the call */
        u = &c->r[LF_VR_U0];
        u_rate = c->u_zero;
    }
    c->arg[0] = &t;
    c->arg[1] = x;
    c->arg[2] = w;
    c->arg[3] = u;
    c->arg[7] = u_rate;
    c->res[0] = out0; /* functions with fewer outputs do not read the rest */
    c->res[1] = out1;
    c->res[2] = out2;
    return function_of(fn)->eval(c->arg, c->res, c->iw, c->w, 0) ? LF_ERROR : LF_OK;
}

/* Before the solver starts, the states and modes read (and the outputs
 * computed from them) are those initialization will start from. */
LfStatus lf_prepare_initial(LfInstance *c) {
    if (!(c->state & (LF_ST_INSTANTIATED | LF_ST_INIT)) || c->solver_ready) return LF_OK;
    if (lf_initial_states(c) != LF_OK) return LF_ERROR;
    return LF_NQ > 0 ? lf_initial_modes(c) : LF_OK;
}

LfStatus lf_update_outputs(LfInstance *c) {
    double y[LF_DIM(LF_NY + LF_NZ)];
    const double *x = &c->r[LF_VR_X0], *w = c->w_tmp;
    int bad, kept;
    if (c->outputs_valid || LF_NY + LF_NZ == 0) return LF_OK;
    if (!c->solver_ready && lf_prepare_initial(c) != LF_OK) return LF_ERROR;
    /* the outputs kept by the history sample at this point, if any (explicit
     * models: w is a function of the point; implicit: w compared too) */
    kept = !LF_IMPLICIT && LF_ND > 0 && lf_hist_outputs(c, NULL, y);
    /* (after a step: the solver's last stage solved w here, and w_cur holds
     * it, lf_wcache.h; read there, without the copy a solve would make) */
    if (!kept && LF_WK_USED && c->wc_on && lf_wk_take(c, c->t, x, c->w_cur)) {
        w = c->w_cur;
    } else if (!kept && lf_solve_w(c, c->t, x, c->w_tmp) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: model equations cannot be solved", c->t);
        return LF_ERROR;
    }
    if (!kept && LF_IMPLICIT) kept = lf_hist_outputs(c, c->w_tmp, y);
    if (!kept && lf_eval_fn1(c, LF_FN_OUT, c->t, x, w, y) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: output function failed", c->t);
        return LF_ERROR;
    }
    bad = lf_first_nonfinite(y, LF_NY + LF_NZ);
    if (bad >= 0) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: output %s is %g (not finite)",
               c->t, lf_model.real_names[LF_VR_Y0 + bad], y[bad]);
        return LF_ERROR;
    }
    memcpy(&c->r[LF_VR_Y0], y, sizeof(double) * (LF_NY + LF_NZ));
    c->outputs_valid = 1;
    return LF_OK;
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
    c->ho_valid = 0; /* (the kept outputs' key would tell too: lf_hist_outputs) */
    if (kind == LF_KIND_OUTPUT || kind == LF_KIND_LOCAL) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s is calculated and cannot be set",
               c->t, name);
        return LF_ERROR;
    }
    if (kind != LF_KIND_INPUT && !(c->state & (LF_ST_INSTANTIATED | LF_ST_INIT))) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: %s can only be set before fmi2ExitInitializationMode", c->t, name);
        return LF_ERROR;
    }
    if (kind == LF_KIND_STATE && lf_model.x_computed[vr - LF_VR_X0] &&
        !(c->state & LF_ST_INSTANTIATED)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "%s has initial=\"approx\" (start computed from the "
               "parameters): it can only be set before fmi2EnterInitializationMode", name);
        return LF_ERROR;
    }
    if (kind == LF_KIND_INPUT && isfinite(value) &&
        (value < lf_model.real_min[vr] || value > lf_model.real_max[vr])) {
        lf_log(c, LF_WARNING, LF_LOG_WARNING,
               "t = %.17g: input %s = %g is outside its range [%g, %g]; the model may not be "
               "valid there", c->t, name, value, lf_model.real_min[vr], lf_model.real_max[vr]);
        lf_input_set(c, vr, value);
        return LF_WARNING;
    }
    if (!isfinite(value) || value < lf_model.real_min[vr] || value > lf_model.real_max[vr]) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: %s = %g is outside its range [%g, %g]; value not set", c->t,
               name, value, lf_model.real_min[vr], lf_model.real_max[vr]);
        return LF_ERROR;
    }
    if (kind == LF_KIND_INPUT) {
        lf_input_set(c, vr, value);
        return LF_OK;
    }
    if (kind == LF_KIND_STATE) c->x_set[vr - LF_VR_X0] = 1;
    if (kind == LF_KIND_PARAMETER && c->r[vr] != value) c->k_stale = 1;
    c->r[vr] = value;
    c->outputs_valid = 0;
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
    if ((kind == LF_KIND_OUTPUT || kind == LF_KIND_LOCAL) && !c->outputs_valid &&
        lf_update_outputs(c) != LF_OK)
        return LF_ERROR;
    if (kind == LF_KIND_STATE && lf_prepare_initial(c) != LF_OK) return LF_ERROR;
    *value = kind == LF_KIND_INPUT ? lf_input_now(c, vr) : c->r[vr];
    return LF_OK;
}

LfStatus lf_get_integer(LfInstance *c, unsigned vr, int *value) {
    if (vr == LF_VR_SOLVER) {
        *value = c->solver_id;
        return LF_OK;
    }
    if (vr >= LF_VR_Q0 && vr < LF_VR_Q0 + LF_NQ) {
        *value = (int)c->q[vr - LF_VR_Q0];
        return LF_OK;
    }
    if (LF_ND > 0 && vr == LF_VR_DINTERP) {
        *value = c->delay_interp;
        return LF_OK;
    }
    if (vr == LF_VR_SOLVER_INDEX) {
        *value = c->solver_index;
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
        c->solver_index = value; /* set_solver set solver_id too: both say the same */
        return LF_OK;
    }
    if (LF_ND > 0 && vr == LF_VR_DINTERP) {
        if (value != LF_DELAY_HERMITE && value != LF_DELAY_LINEAR) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR,
                   "delay_interpolation = %d: allowed 1 (hermite) or 2 (linear)", value);
            return LF_ERROR;
        }
        if (!(c->state & (LF_ST_INSTANTIATED | LF_ST_INIT))) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR,
                   "delay_interpolation can only be set before fmi2ExitInitializationMode");
            return LF_ERROR;
        }
        c->delay_interp = value;
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
    if (!(c->state & (LF_ST_INSTANTIATED | LF_ST_INIT))) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "%s can only be set before fmi2ExitInitializationMode", name);
        return LF_ERROR;
    }
    if (id == 0) return LF_OK;
    c->solver_id = id;
    return LF_OK;
}
