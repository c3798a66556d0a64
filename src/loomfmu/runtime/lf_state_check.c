/* loomfmu shared runtime: an FMU state's values checked against the model
 * before the state is accepted.
 *
 * lf_state.c checks the bytes (checksum, this FMU, its sizes) and the plain
 * fields (flags, counts, times, modes, the solver's fields); the checks here
 * need the model: the kinds of its Reals, its generated functions, the
 * names of its delays.  A checksum only says the bytes are as written: a
 * state crafted and sealed again, or written by a faulty program, reaches
 * these checks with any values, so
 * - every Real is checked by kind: a NaN output in a state that marks its
 *   outputs current would be returned by the next read, with OK;
 * - every delay is checked against the parameters the state carries: tau
 *   is computed from them at initialization and never again, so a tau that
 *   differs (0 instead of 0.5 s: the delayed value read now) would go on
 *   silently; the solver's step limits, bounded by the delays then, too;
 * - the history: samples finite and in time order, breakpoints finite.
 * Nothing of the instance is changed but the CasADi scratch, whose fixed
 * arguments the next call of a generated function sets again. */
#include <math.h>
#include <stdio.h>

#include "lf_state_check.h"
#include "lf_base.h"
#include "lf_instance.h"
#include "lf_internal.h"

int lf_state_refuse(LfInstance *c, const char *what, double value, const char *expected) {
    lf_log(c, LF_ERROR, LF_LOG_ERROR,
           "t = %.17g: FMU state refused: %s = %.17g, expected %s; the instance keeps its "
           "state", c->run.t, what, value, expected);
    return 0;
}

static const char *nonfinite_name(double x) {
    return isnan(x) ? "NaN" : x > 0 ? "+inf" : "-inf";
}

/* An output or algebraic local: current (outputs_valid) values are
 * returned as saved, so they must be finite; others are computed again
 * before a read, and are finite or not yet computed (NaN). */
static int check_output(LfInstance *c, unsigned vr, double x, int outputs_valid) {
    if (isfinite(x) || (isnan(x) && !outputs_valid)) return 1;
    lf_log(c, LF_ERROR, LF_LOG_ERROR,
           "t = %.17g: FMU state refused: %s %s is %s with outputs_valid = %d (%s); the "
           "instance keeps its state", c->run.t,
           lf_model.real_kind[vr] == LF_KIND_OUTPUT ? "output" : "algebraic variable",
           lf_model.real_names[vr], nonfinite_name(x), outputs_valid,
           outputs_valid ? "the state's outputs are returned as saved: they must be finite"
                         : "a value not yet computed is NaN, a computed one finite");
    return 0;
}

int lf_state_check_reals(LfInstance *c, const double *r, int solver_ready, int outputs_valid) {
    unsigned vr;
    for (vr = 0; vr < LF_NREAL; vr++) {
        double x = r[vr];
        LfKind kind = lf_model.real_kind[vr];
        int ok;
        if (kind == LF_KIND_OUTPUT || kind == LF_KIND_LOCAL) {
            if (!check_output(c, vr, x, outputs_valid)) return 0;
            continue;
        }
        if (kind == LF_KIND_SETTING || kind == LF_KIND_PARAMETER)
            ok = isfinite(x) && x >= lf_model.real_min[vr] && x <= lf_model.real_max[vr];
        else if (kind == LF_KIND_INPUT)
            ok = isfinite(x);
        else /* a state: not yet computed before initialization */
            ok = isfinite(x) || (isnan(x) && !solver_ready);
        if (!ok) return lf_state_refuse(c, lf_model.real_names[vr], x, "finite and within its range");
    }
    return 1;
}

/* The delays from the parameters p, as lf_init_delays computes them: the
 * folded parameter subexpressions k := pre(p) (lf_eval.c), then tau(p, k).
 * tau depends on the parameters only (Model.delay), so t, x, w, u, q, d
 * are not passed (the generated code reads a missing argument as 0). */
static int tau_of(LfInstance *c, const double *p, double *tau) {
    LfUnsaved *u = &c->unsaved;
    double *k = NULL;
    int i, failed;
    if (LF_NK > 0 && !(k = (double *)u->alloc.calloc(LF_DIM(LF_NK), sizeof(double)))) return 0;
    for (i = 0; i < 10; i++) u->arg[i] = NULL;
    u->args_set = 0; /* lf_eval_fn points the fixed arguments at the instance again */
    u->arg[4] = p;
    u->res[0] = k;
    failed = LF_NK > 0 && lf_model.fn[LF_FN_PRE].eval(u->arg, u->res, u->iw, u->w, 0) != 0;
    u->arg[9] = k;
    u->res[0] = tau;
    if (!failed) failed = lf_model.fn[LF_FN_TAU].eval(u->arg, u->res, u->iw, u->w, 0) != 0;
    for (i = 0; i < 10; i++) u->arg[i] = NULL; /* nothing left pointing at p or k */
    if (k) u->alloc.free(k);
    return !failed;
}

int lf_state_check_delays(LfInstance *c, const double *r, const double *tau,
                          const LfSolverOptions *opt, int solver_ready) {
    double want[LF_DIM(LF_ND)];
    int k;
    /* tau is computed at initialization: 0 before */
    if (LF_ND == 0 || !solver_ready) return 1;
    if (!tau_of(c, &r[LF_VR_P0], want)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: FMU state refused: its delays cannot be computed from its "
               "parameters (out of memory, or the delay function failed); the instance keeps "
               "its state", c->run.t);
        return 0;
    }
    for (k = 0; k < LF_ND; k++) {
        /* the same function of the same parameters: equal (a few ulps allowed) */
        if (!(fabs(tau[k] - want[k]) <= 4 * LF_EPS * fabs(want[k]))) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR,
                   "t = %.17g: FMU state refused: delay %s has tau = %.17g s, its parameters "
                   "give %.17g s; the instance keeps its state", c->run.t,
                   lf_model.delay_names[k], tau[k], want[k]);
            return 0;
        }
        /* lf_init_delays bounds the steps by each positive delay: a longer
         * step would read history not yet computed */
        if (tau[k] > 0 && (opt->h_max > tau[k] || opt->h_fixed > tau[k])) {
            int hmax = opt->h_max > tau[k];
            lf_log(c, LF_ERROR, LF_LOG_ERROR,
                   "t = %.17g: FMU state refused: solver step limit %s = %.17g s is longer "
                   "than delay %s = %.17g s (a step would read history not yet computed); "
                   "the instance keeps its state", c->run.t, hmax ? "h_max" : "h_fixed",
                   hmax ? opt->h_max : opt->h_fixed, lf_model.delay_names[k], tau[k]);
            return 0;
        }
    }
    return 1;
}

int lf_state_check_history(LfInstance *c, const long *hist_count, int n_bp, const double *hist) {
    char what[160];
    int k;
    long i;
    for (k = 0; k < LF_ND; k++) {
        for (i = 0; i < hist_count[k]; i++, hist += 3) {
            int bad = !isfinite(hist[0]) ? 0 : !isfinite(hist[1]) ? 1 : !isfinite(hist[2]) ? 2 : -1;
            if (bad < 0 && (i == 0 || hist[0] >= hist[-3])) continue;
            snprintf(what, sizeof what, "history sample %ld of delay %s (%s)", i,
                     lf_model.delay_names[k], bad == 1 ? "value" : bad == 2 ? "slope" : "time");
            return lf_state_refuse(c, what, hist[bad < 0 ? 0 : bad],
                                   bad < 0 ? "not before the previous sample" : "finite");
        }
    }
    for (i = 0; i < n_bp; i++)
        if (!isfinite(hist[i])) return lf_state_refuse(c, "delay breakpoint", hist[i], "finite");
    return 1;
}
