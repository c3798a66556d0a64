/* loomfmu shared runtime: model instance, values and the co-simulation step
 * loop with event location on the solver's dense output.
 *
 * Inputs are held constant over a communication step (zero-order hold); a
 * change of an input restarts the solver at the communication point. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_linalg.h"
#include "lf_runtime.h"

const char *const lf_log_category_names[LF_N_LOG] = LF_LOG_CATEGORY_NAMES;

#define LF_EVENT_MAX_ITER 200
/* least step over an event (relative to max(1, |t|)); its Euler error is O(gap^2) */
#define LF_EVENT_GAP 1e-12

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

/* Size the CasADi work arrays for the largest of the generated functions. */
static int alloc_casadi_work(LfInstance *c) {
    long long n_arg = 0, n_res = 0, n_iw = 0, n_w = 0;
    int k;
    for (k = 0; k < LF_N_FN; k++) {
        long long a = 0, r = 0, i = 0, w = 0;
        if (lf_model.fn[k].work(&a, &r, &i, &w)) return 0;
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
    c->t = c->t_start = c->last_successful_time = 0.0;
    c->t_stop = INFINITY;
    c->rtol_importer = 0.0;
    for (k = 0; k < LF_N_LOG; k++) c->log_on[k] = c->log_on_start;
    c->outputs_valid = 0;
    c->inputs_changed = 0;
    c->n_events = 0;
    c->max_steps = 10000000L;
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

static LfStatus delayed_values(LfInstance *c, double t, const double *x);

/* Call generated function `fn` at (t, x, w) with the instance's u, p, q and
 * the delayed values at t. */
static LfStatus eval_fn(LfInstance *c, int fn, double t, const double *x, const double *w,
                        double *out0, double *out1, double *out2) {
    if (LF_ND > 0 && fn != LF_FN_HIST && fn != LF_FN_TAU && delayed_values(c, t, x) != LF_OK)
        return LF_ERROR;
    c->arg[6] = c->dval;
    c->arg[0] = &t;
    c->arg[1] = x;
    c->arg[2] = w;
    c->arg[3] = &c->r[LF_VR_U0];
    c->arg[4] = &c->r[LF_VR_P0];
    c->arg[5] = c->q;
    c->res[0] = out0; /* functions with fewer outputs do not read the rest */
    c->res[1] = out1;
    c->res[2] = out2;
    return lf_model.fn[fn].eval(c->arg, c->res, c->iw, c->w, 0) ? LF_ERROR : LF_OK;
}

static int first_nonfinite(const double *v, size_t n) {
    size_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) return (int)i;
    return -1;
}

#define LF_NEWTON_MAX_ITER 30
#define LF_NEWTON_RTOL 1e-10
#define LF_NEWTON_ATOL 1e-12

/* Factor dF/dw at (t, x, w) into c->jac_ww (implicit models). */
static LfStatus factor_dFdw(LfInstance *c, double t, const double *x, const double *w) {
    if (eval_fn(c, LF_FN_RJAC, t, x, w, c->jac_ww, c->jac_wx, c->jac_wt) != LF_OK)
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
        if (eval_fn(c, LF_FN_RES, t, x, w, c->res_F, NULL, NULL) != LF_OK) return LF_ERROR;
        if (first_nonfinite(c->res_F, LF_NW) >= 0) {
            lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: algebraic loop: residual of "
                   "equation %d is not finite at Newton iteration %d", t,
                   first_nonfinite(c->res_F, LF_NW), it);
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
        if (first_nonfinite(w, LF_NW) >= 0) break;
        if (done || (size < 1e-8 && size >= 0.5 * prev)) return LF_OK;
        prev = size;
    }
    c->n_newton_fail++;
    lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
           "t = %.17g: algebraic loop: Newton did not converge in %d iterations", t,
           LF_NEWTON_MAX_ITER);
    return LF_DISCARD;
}

/* The unknowns w = [der(x); z] at (t, x). */
static LfStatus solve_w(LfInstance *c, double t, const double *x, double *w) {
    LfStatus st;
    int bad;
    if (LF_IMPLICIT) {
        st = newton(c, t, x, w);
        if (st != LF_OK) return st;
    } else if (eval_fn(c, LF_FN_WSOL, t, x, w, w, NULL, NULL) != LF_OK) {
        return LF_ERROR;
    }
    bad = first_nonfinite(w, LF_NW);
    if (bad >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: unknown %d of the model equations "
               "(derivative or algebraic variable) is %g", t, bad, w[bad]);
        return LF_DISCARD;
    }
    memcpy(c->w_cur, w, sizeof(double) * LF_NW);
    return LF_OK;
}

/* ---- delays: history of the delayed expressions ----------------------- */

#define HT(c, k, i) (c)->hist[(((size_t)(k) * LF_HIST_CAP + (size_t)(((c)->hist_start[k] + (i)) % LF_HIST_CAP)) * 3)]
#define HG(c, k, i) (&HT(c, k, i))[1]
#define HD(c, k, i) (&HT(c, k, i))[2]

/* g_k at time s from the history: constant before the first sample, the
 * last sample's Taylor line after it (not reached with steps <= tau), else
 * cubic Hermite (or linear) between the samples around s.  At a jump (two
 * samples at one time) `left` selects the value before it (the earlier
 * sample), otherwise the value after it.  s = t - tau is known to rounding
 * only (t_jump + tau - tau need not be t_jump): samples within `eps` of s
 * count as at s.  (Elsewhere the choice is immaterial: the interpolant is
 * continuous at a sample.) */
static double hist_interp(const LfInstance *c, int k, double s, int left, double eps) {
    long lo = -1, hi = c->hist_count[k], n = c->hist_count[k];
    double t0, t1, h, th, g0, g1;
    /* lo: the last sample with t_lo < s (left) or t_lo <= s (right) */
    while (hi - lo > 1) {
        long mid = (lo + hi) / 2;
        if (left ? HT(c, k, mid) < s - eps : HT(c, k, mid) <= s + eps) lo = mid;
        else hi = mid;
    }
    if (lo < 0) return HG(c, k, 0);
    if (lo == n - 1) return HG(c, k, n - 1) + HD(c, k, n - 1) * (s - HT(c, k, n - 1));
    hi = lo + 1;
    t0 = HT(c, k, lo);
    t1 = HT(c, k, hi);
    g0 = HG(c, k, lo);
    g1 = HG(c, k, hi);
    h = t1 - t0;
    th = (s - t0) / h;
    if (c->delay_interp == LF_DELAY_LINEAR) return g0 + (g1 - g0) * th;
    return (2 * th * th * th - 3 * th * th + 1) * g0 + (th * th * th - 2 * th * th + th) * h * HD(c, k, lo) +
           (3 * th * th - 2 * th * th * th) * g1 + (th * th * th - th * th) * h * HD(c, k, hi);
}

/* The delayed values at t.  Steps end at every breakpoint t_jump + tau
 * and the solver restarts there.  The stages of the step ending at a
 * breakpoint that run at its end take the value before the jump; the
 * restarted solver (t = its last accepted point) takes the value after it.
 * Only there is s = t - tau taken as equal to a sample within rounding. */
static LfStatus delayed_values(LfInstance *c, double t, const double *x) {
    double g[LF_DIM(2 * LF_ND)];
    int k, need_now = 0, left = c->solver_ready && t > c->solver.t && t >= c->t_bp_step;
    double eps = (left || (c->solver_ready && t == c->solver.t))
                     ? 8 * 2.220446049250313e-16 * fmax(1.0, fabs(t))
                     : 0.0;
    for (k = 0; k < LF_ND; k++)
        if (c->tau[k] == 0 || c->hist_count[k] == 0) need_now = 1;
    if (need_now) { /* zero delay, or no history yet: the value now */
        c->arg[6] = c->dval;
        if (eval_fn(c, LF_FN_HIST, t, x, c->w_cur, g, &g[LF_ND], NULL) != LF_OK) return LF_ERROR;
    }
    for (k = 0; k < LF_ND; k++)
        c->dval[k] = (c->tau[k] == 0 || c->hist_count[k] == 0) ? g[k]
                                                                : hist_interp(c, k, t - c->tau[k], left, eps);
    return LF_OK;
}

static void add_breakpoint(LfInstance *c, double t) {
    if (c->n_bp < LF_MAX_BP) c->bp[c->n_bp++] = t;
}

/* The next pending breakpoint after t, or t_end if none comes first (and
 * forget those passed); *is_bp: a breakpoint falls on the returned time. */
static double next_breakpoint(LfInstance *c, double t, double t_end, int *is_bp) {
    double next = t_end;
    int i, j = 0;
    *is_bp = 0;
    for (i = 0; i < c->n_bp; i++) {
        if (c->bp[i] <= t) continue;
        c->bp[j++] = c->bp[i];
        if (c->bp[i] <= next) {
            next = c->bp[i];
            *is_bp = 1;
        }
    }
    c->n_bp = j;
    return next;
}

static LfStatus solve_w(LfInstance *c, double t, const double *x, double *w);

/* Append (t, g, dg/dt) at an accepted point; `jump`: the history is
 * discontinuous here (input change, reinit), so its values reach the
 * equations tau later: a breakpoint. */
static LfStatus hist_append(LfInstance *c, double t, const double *g, int jump) {
    int k;
    for (k = 0; k < LF_ND; k++) {
        double oldest_needed = t - c->tau[k] - c->solver.opt.h_max;
        if (c->tau[k] == 0) continue; /* read at the current time, never from here */
        /* drop samples no query can reach any more */
        while (c->hist_count[k] >= 2 && HT(c, k, 1) <= oldest_needed) {
            c->hist_start[k] = (c->hist_start[k] + 1) % LF_HIST_CAP;
            c->hist_count[k]--;
        }
        if (c->hist_count[k] == LF_HIST_CAP) {
            lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
                   "t = %.17g: history of delay %s is full: %d samples cover only %g s of "
                   "the %g s needed (the steps are too small for this delay)", t,
                   lf_model.delay_names[k], LF_HIST_CAP, t - HT(c, k, 0), c->tau[k]);
            return LF_DISCARD;
        }
        HT(c, k, c->hist_count[k]) = t;
        HG(c, k, c->hist_count[k]) = g[k];
        HD(c, k, c->hist_count[k]) = g[LF_ND + k];
        c->hist_count[k]++;
        if (jump && c->tau[k] > 0) add_breakpoint(c, t + c->tau[k]);
    }
    return LF_OK;
}

static LfStatus hist_sample(LfInstance *c, double t, const double *x, double *g);

static LfStatus hist_push(LfInstance *c, double t, const double *x, int jump) {
    double g[LF_DIM(2 * LF_ND)];
    LfStatus st;
    if (LF_ND == 0) return LF_OK;
    st = hist_sample(c, t, x, g);
    if (st != LF_OK) return st;
    return hist_append(c, t, g, jump);
}

/* After an accepted step: the history up to its end, sampled on the dense
 * output (hermite) or only at the step's end (linear, the naive way). */
static LfStatus hist_step(LfInstance *c);

#define LF_HIST_MAX_DEPTH 12

/* g and dg/dt at (t, x), for the history. */
static LfStatus hist_sample(LfInstance *c, double t, const double *x, double *g) {
    LfStatus st = solve_w(c, t, x, c->w_tmp);
    if (st != LF_OK) return st;
    return eval_fn(c, LF_FN_HIST, t, x, c->w_tmp, g, &g[LF_ND], NULL);
}

/* Sample the history inside the accepted step (ta, tb] on the solver's dense
 * output: bisect while the cubic Hermite through the end samples misses g
 * at the midpoint by more than the solver's tolerance, then push the
 * samples in time order (tb last).  ga, gb: samples at ta, tb. */
static LfStatus hist_refine(LfInstance *c, double ta, const double *ga, double tb,
                            const double *gb, int depth) {
    double gm[LF_DIM(2 * LF_ND)], xm[LF_DIM(LF_NX)], tm = 0.5 * (ta + tb), h = tb - ta;
    int k, fine = 1;
    LfStatus st;
    if (depth < LF_HIST_MAX_DEPTH) {
        c->solver.method->dense(&c->solver, tm, xm);
        st = hist_sample(c, tm, xm, gm);
        if (st != LF_OK) return st;
        for (k = 0; k < LF_ND; k++) {
            double herm;
            if (c->tau[k] == 0) continue;
            herm = 0.5 * (ga[k] + gb[k]) + 0.125 * h * (ga[LF_ND + k] - gb[LF_ND + k]);
            if (fabs(herm - gm[k]) > c->solver.opt.atol + c->solver.opt.rtol * fabs(gm[k]))
                fine = 0;
        }
        if (!fine) {
            st = hist_refine(c, ta, ga, tm, gm, depth + 1);
            if (st != LF_OK) return st;
            return hist_refine(c, tm, gm, tb, gb, depth + 1);
        }
    }
    return hist_append(c, tb, gb, 0);
}

static LfStatus hist_step(LfInstance *c) {
    double ga[LF_DIM(2 * LF_ND)], gb[LF_DIM(2 * LF_ND)];
    LfSolver *s = &c->solver;
    long n;
    int k = 0;
    LfStatus st;
    while (k < LF_ND && c->tau[k] == 0) k++;
    if (k == LF_ND) return LF_OK; /* only zero delays: no history is kept */
    n = c->hist_count[k];
    if (c->delay_interp == LF_DELAY_LINEAR || !(s->t > s->t_old) || n == 0 ||
        HT(c, k, n - 1) != s->t_old)
        return hist_push(c, s->t, s->x, 0);
    st = hist_sample(c, s->t_old, s->x_old, ga);
    if (st == LF_OK) st = hist_sample(c, s->t, s->x, gb);
    if (st != LF_OK) return st;
    return hist_refine(c, s->t_old, ga, s->t, gb, 0);
}

/* Delays from the parameters; each must fit the history the FMU holds. */
static LfStatus init_delays(LfInstance *c, LfSolverOptions *opt) {
    int k;
    if (LF_ND == 0) return LF_OK;
    if (eval_fn(c, LF_FN_TAU, c->t, &c->r[LF_VR_X0], c->w_cur, c->tau, NULL, NULL) != LF_OK)
        return LF_ERROR;
    for (k = 0; k < LF_ND; k++) {
        if (!(c->tau[k] >= 0) || c->tau[k] > lf_model.delay_max[k]) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR,
                   "delay %s = %g s: allowed 0 ... %g s, the longest delay this FMU's "
                   "history was built to hold (rebuild with a larger max_delay)",
                   lf_model.delay_names[k], c->tau[k], lf_model.delay_max[k]);
            return LF_ERROR;
        }
        /* a step longer than the delay would need history not yet computed */
        if (c->tau[k] > 0 && opt->h_max > c->tau[k]) opt->h_max = c->tau[k];
        if (c->tau[k] > 0 && opt->h_fixed > c->tau[k]) {
            lf_log(c, LF_WARNING, LF_LOG_WARNING,
                   "solver_h_fixed = %g s is longer than delay %s = %g s: rk4 steps are "
                   "limited to the delay", opt->h_fixed, lf_model.delay_names[k], c->tau[k]);
            opt->h_fixed = c->tau[k];
        }
    }
    return LF_OK;
}

static LfStatus rhs_cb(void *ctx, double t, const double *x, double *dx) {
    LfInstance *c = (LfInstance *)ctx;
    LfStatus st = solve_w(c, t, x, c->w_tmp);
    if (st != LF_OK) return st;
    memcpy(dx, c->w_tmp, sizeof(double) * LF_NX);
    return LF_OK;
}

/* A zero delay reads d = g(t, x) now: add dw/dd (dg/dx, dg/dt) to c->jac_wx
 * and c->jac_wt (for implicit models dw/dd = -(dF/dw)^-1 dF/dd, with dF/dw
 * factored in c->jac_ww).  Without it Rosenbrock methods lose their order. */
static LfStatus zero_delay_jacobian(LfInstance *c, double t, const double *x) {
    double wd[LF_DIM(LF_NW * LF_ND)], gx[LF_DIM(LF_ND * LF_NX)], gt[LF_DIM(LF_ND)];
    int i, j, k, any = 0;
    for (k = 0; k < LF_ND; k++)
        if (c->tau[k] == 0) any = 1;
    if (!any) return LF_OK;
    if (eval_fn(c, LF_FN_DJAC, t, x, c->w_cur, wd, gx, gt) != LF_OK) return LF_ERROR;
    for (k = 0; k < LF_ND; k++) {
        double *col = &wd[k * LF_NW];
        if (c->tau[k] != 0) continue;
        if (LF_IMPLICIT) {
            lf_lu_solve(c->jac_ww, LF_NW, c->piv, col);
            for (i = 0; i < LF_NW; i++) col[i] = -col[i];
        }
        for (j = 0; j < LF_NX; j++)
            for (i = 0; i < LF_NW; i++) c->jac_wx[i + j * LF_NW] += col[i] * gx[k + j * LF_ND];
        for (i = 0; i < LF_NW; i++) c->jac_wt[i] += col[i] * gt[k];
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
        st = solve_w(c, t, x, c->w_tmp);
        if (st == LF_OK) st = factor_dFdw(c, t, x, c->w_tmp);
        if (st != LF_OK) return st;
        for (j = 0; j < LF_NX; j++) lf_lu_solve(c->jac_ww, LF_NW, c->piv, &c->jac_wx[j * LF_NW]);
        lf_lu_solve(c->jac_ww, LF_NW, c->piv, c->jac_wt);
        for (i = 0; i < LF_NW * LF_NX; i++) c->jac_wx[i] = -c->jac_wx[i];
        for (i = 0; i < LF_NW; i++) c->jac_wt[i] = -c->jac_wt[i];
    } else if (eval_fn(c, LF_FN_WJAC, t, x, c->w_cur, c->jac_wx, c->jac_wt, NULL) != LF_OK) {
        return LF_ERROR;
    }
    if (LF_ND > 0) {
        st = zero_delay_jacobian(c, t, x);
        if (st != LF_OK) return st;
    }
    for (j = 0; j < LF_NX; j++)
        for (i = 0; i < LF_NX; i++) J[i + j * LF_NX] = c->jac_wx[i + j * LF_NW];
    memcpy(dfdt, c->jac_wt, sizeof(double) * LF_NX);
    if (first_nonfinite(J, (size_t)LF_NX * LF_NX) >= 0 || first_nonfinite(dfdt, LF_NX) >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: Jacobian is not finite", t);
        return LF_DISCARD;
    }
    return LF_OK;
}

static LfStatus initial_states(LfInstance *c);
static LfStatus initial_modes(LfInstance *c);

/* Before the solver starts, the states and modes read (and the outputs
 * computed from them) are those initialization will start from. */
static LfStatus prepare_initial(LfInstance *c) {
    if (!(c->state & (LF_ST_INSTANTIATED | LF_ST_INIT)) || c->solver_ready) return LF_OK;
    if (initial_states(c) != LF_OK) return LF_ERROR;
    return LF_NQ > 0 ? initial_modes(c) : LF_OK;
}

LfStatus lf_update_outputs(LfInstance *c) {
    double y[LF_DIM(LF_NY + LF_NZ)];
    int bad;
    if (c->outputs_valid || LF_NY + LF_NZ == 0) return LF_OK;
    if (prepare_initial(c) != LF_OK) return LF_ERROR;
    if (solve_w(c, c->t, &c->r[LF_VR_X0], c->w_tmp) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: model equations cannot be solved", c->t);
        return LF_ERROR;
    }
    if (eval_fn(c, LF_FN_OUT, c->t, &c->r[LF_VR_X0], c->w_tmp, y, NULL, NULL) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: output function failed", c->t);
        return LF_ERROR;
    }
    bad = first_nonfinite(y, LF_NY + LF_NZ);
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
        if (value != c->r[vr]) c->inputs_changed = 1;
        c->r[vr] = value;
        c->outputs_valid = 0;
        return LF_WARNING;
    }
    if (!isfinite(value) || value < lf_model.real_min[vr] || value > lf_model.real_max[vr]) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: %s = %g is outside its range [%g, %g]; value not set", c->t,
               name, value, lf_model.real_min[vr], lf_model.real_max[vr]);
        return LF_ERROR;
    }
    if (kind == LF_KIND_INPUT && value != c->r[vr]) c->inputs_changed = 1;
    if (kind == LF_KIND_STATE) c->x_set[vr - LF_VR_X0] = 1;
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
    if ((kind == LF_KIND_OUTPUT || kind == LF_KIND_LOCAL) && lf_update_outputs(c) != LF_OK)
        return LF_ERROR;
    if (kind == LF_KIND_STATE && prepare_initial(c) != LF_OK) return LF_ERROR;
    *value = c->r[vr];
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
    lf_log(c, LF_ERROR, LF_LOG_ERROR,
           "fmi2GetInteger: value reference %u is not an Integer (expected < %d)", vr,
           LF_VR_Q0 + LF_NQ + (LF_ND > 0));
    return LF_ERROR;
}

LfStatus lf_set_integer(LfInstance *c, unsigned vr, int value) {
    if (vr == LF_VR_SOLVER) return lf_set_solver(c, value);
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
           "fmi2SetInteger: value reference %u cannot be set (solver: %d%s)", vr, LF_VR_SOLVER,
           LF_ND > 0 ? ", delay_interpolation" : "");
    return LF_ERROR;
}

LfStatus lf_set_solver(LfInstance *c, int id) {
    if (id < 1 || id > (int)lf_n_methods) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "solver = %d is not a solver (expected 1..%d)", id,
               (int)lf_n_methods);
        return LF_ERROR;
    }
    if (!(c->state & (LF_ST_INSTANTIATED | LF_ST_INIT))) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "solver can only be set before fmi2ExitInitializationMode");
        return LF_ERROR;
    }
    c->solver_id = id;
    return LF_OK;
}

/* ---- stepping ------------------------------------------------------------ */

static LfStatus eval_events(LfInstance *c, double t, const double *x, double *e) {
    LfStatus st;
    if (LF_NE == 0) return LF_OK;
    st = solve_w(c, t, x, c->w_tmp);
    if (st != LF_OK) return st;
    if (eval_fn(c, LF_FN_EVT, t, x, c->w_tmp, e, NULL, NULL) != LF_OK ||
        first_nonfinite(e, LF_NE) >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: event indicators not finite", t);
        return LF_DISCARD;
    }
    return LF_OK;
}

/* Choose the value of mode k at (t, x): the first value, in the declared
 * priority order, that is consistent (validity >= 0) once the states are
 * reinitialized for it.  x is updated with the reinitialized states. */
static LfStatus choose_mode(LfInstance *c, int k, double t, double *x) {
    double old = c->q[k], x_try[LF_DIM(LF_NX)], valid[LF_DIM(LF_NQ)];
    int j;
    for (j = lf_model.mode_value_offset[k]; j < lf_model.mode_value_offset[k + 1]; j++) {
        LfStatus st;
        c->q[k] = lf_model.mode_values[j];
        if (eval_fn(c, LF_FN_REINIT, t, x, c->w_cur, x_try, NULL, NULL) != LF_OK)
            return LF_ERROR;
        c->quiet++;
        st = solve_w(c, t, x_try, c->w_tmp);
        c->quiet--;
        if (st != LF_OK) continue; /* cannot be solved in this mode */
        if (eval_fn(c, LF_FN_VALID, t, x_try, c->w_tmp, valid, NULL, NULL) != LF_OK)
            return LF_ERROR;
        if (valid[k] >= 0) {
            memcpy(x, x_try, sizeof(double) * LF_NX);
            if (c->q[k] != old)
                lf_log(c, LF_OK, LF_LOG_EVENTS, "t = %.17g: mode %s: %g -> %g", t,
                       lf_model.mode_names[k], old, c->q[k]);
            return LF_OK;
        }
    }
    c->q[k] = old;
    lf_log(c, LF_ERROR, LF_LOG_ERROR,
           "t = %.17g: no value of mode %s is consistent here (the model has no "
           "solution with any of its declared values)", t, lf_model.mode_names[k]);
    return LF_ERROR;
}

/* Constraints across parameters (each >= 0), which ranges cannot express. */
static LfStatus check_constraints(LfInstance *c) {
    double v[LF_DIM(LF_NC)];
    int k, ok = 1;
    if (LF_NC == 0) return LF_OK;
    if (eval_fn(c, LF_FN_CONS, c->t, &c->r[LF_VR_X0], c->w_cur, v, NULL, NULL) != LF_OK)
        return LF_ERROR;
    for (k = 0; k < LF_NC; k++)
        if (!(v[k] >= 0)) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "parameters violate %s (value %g, must be >= 0)",
                   lf_model.constraint_messages[k], v[k]);
            ok = 0;
        }
    return ok ? LF_OK : LF_ERROR;
}

/* States declared with a start expression (e.g. a static equilibrium) start
 * there for the parameters actually set, unless the importer set them. */
static LfStatus initial_states(LfInstance *c) {
    double x0[LF_DIM(LF_NX)];
    int i;
    if (eval_fn(c, LF_FN_INIT, c->t, &c->r[LF_VR_X0], c->w_cur, x0, NULL, NULL) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "initial states cannot be evaluated");
        return LF_ERROR;
    }
    for (i = 0; i < LF_NX; i++) {
        if (c->x_set[i]) continue;
        if (!isfinite(x0[i])) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "initial value of %s is %g for these parameters",
                   lf_model.real_names[LF_VR_X0 + i], x0[i]);
            return LF_ERROR;
        }
        c->r[LF_VR_X0 + i] = x0[i];
    }
    return LF_OK;
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
static LfStatus consistent_modes(LfInstance *c, double t, double *x, int touched) {
    double valid[LF_DIM(LF_NQ)];
    unsigned char chosen[LF_DIM(LF_NQ)];
    int k, round;
    LfStatus st;
    for (k = 0; k < LF_NQ; k++) chosen[k] = (unsigned char)(k == touched);
    for (round = 0; LF_NQ > 0; round++) {
        int changed = 0;
        for (k = 0; k < LF_NQ; k++) {
            double old = c->q[k];
            if (!chosen[k]) {
                c->quiet++;
                st = solve_w(c, t, x, c->w_tmp);
                c->quiet--;
                if (st == LF_OK &&
                    eval_fn(c, LF_FN_VALID, t, x, c->w_tmp, valid, NULL, NULL) == LF_OK &&
                    valid[k] >= 0)
                    continue;
            }
            st = choose_mode(c, k, t, x);
            if (st != LF_OK) return st;
            chosen[k] = 1;
            if (c->q[k] != old) changed = 1;
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
static LfStatus initial_modes(LfInstance *c) {
    int k;
    for (k = 0; k < LF_NQ; k++) c->q[k] = lf_model.mode_start[k];
    return consistent_modes(c, c->t, &c->r[LF_VR_X0], -1);
}

LfOde lf_ode_of(LfInstance *c) {
    LfOde ode;
    ode.n = LF_NX;
    ode.ctx = c;
    ode.rhs = rhs_cb;
    ode.jac = jac_cb;
    return ode;
}

LfStatus lf_initialize(LfInstance *c) {
    LfOde ode = lf_ode_of(c);
    LfSolverOptions opt;
    LfStatus st;
    opt.rtol = c->rtol_importer > 0 ? c->rtol_importer : c->r[LF_SET_RTOL];
    opt.atol = c->r[LF_SET_ATOL];
    opt.h_max = c->r[LF_SET_H_MAX];
    opt.h_fixed = c->r[LF_SET_H_FIXED];
    opt.max_steps = c->max_steps;
    c->t = c->last_successful_time = c->t_start;
    if (check_constraints(c) != LF_OK) return LF_ERROR;
    if (initial_states(c) != LF_OK) return LF_ERROR;
    if (init_delays(c, &opt) != LF_OK) return LF_ERROR;
    if (LF_NQ > 0 && initial_modes(c) != LF_OK) return LF_ERROR;
    st = lf_solver_init(&c->solver, lf_methods[c->solver_id - 1], ode, opt, c->t_start,
                        &c->r[LF_VR_X0], &c->alloc);
    if (st != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "solver %s: %s", lf_methods[c->solver_id - 1]->name,
               c->solver.message);
        return LF_ERROR;
    }
    c->solver_ready = 1;
    c->inputs_changed = 0;
    c->outputs_valid = 0;
    if (hist_push(c, c->t, &c->r[LF_VR_X0], 1) != LF_OK) return LF_ERROR;
    st = eval_events(c, c->t, &c->r[LF_VR_X0], c->e_old);
    if (st != LF_OK) return LF_ERROR;
    return lf_update_outputs(c);
}

static int crossed(double a, double b) { return (a > 0 && b <= 0) || (a < 0 && b >= 0); }

/* Event indicator k on the dense output at time t. */
static LfStatus event_at(LfInstance *c, int k, double t, double *g) {
    LfStatus st;
    c->solver.method->dense(&c->solver, t, c->x_tmp);
    st = eval_events(c, t, c->x_tmp, c->e_new);
    *g = c->e_new[k];
    return st;
}

/* Illinois (modified regula falsi) on [ta, tb] where indicator k changes
 * sign; returns the final bracket [*t_left, *t_right]: t_left on the old
 * side, t_right on the new side of the root. */
static LfStatus locate_root(LfInstance *c, int k, double ta, double ga, double tb,
                            double gb, double *t_left, double *t_right) {
    int side = 0, it;
    double tol = 8.0 * 2.220446049250313e-16 * fmax(fabs(ta), fabs(tb)) + 1e-15;
    for (it = 0; it < LF_EVENT_MAX_ITER && tb - ta > tol; it++) {
        double tm = tb - gb * (tb - ta) / (gb - ga), gm;
        LfStatus st;
        if (!(tm > ta && tm < tb)) tm = 0.5 * (ta + tb);
        st = event_at(c, k, tm, &gm);
        if (st != LF_OK) return st;
        if (crossed(ga, gm)) {
            tb = tm;
            gb = gm;
            if (side == -1) ga *= 0.5;
            side = -1;
        } else {
            ta = tm;
            ga = gm;
            if (side == 1) gb *= 0.5;
            side = 1;
        }
    }
    *t_left = ta;
    *t_right = tb;
    return LF_OK;
}

/* the gap over an event grows (x4) up to this many times, and never beyond
 * LF_EVENT_GAP_MAX * max(1, |t|) nor the end of the step that saw the root */
#define LF_EVENT_GAP_TRIES 12
#define LF_EVENT_GAP_MAX 1e-6

/* Carry the state from the root's old side (t_left, x_left) across the
 * bracket to the new side by an Euler step over a gap that grows until
 * indicator k shows its new sign, and restart the solver there.  The caller
 * makes the gap reach LF_EVENT_GAP * max(1, |t|) past the root: the model's
 * own switch (an fmin, a floor) may sit a few ulps away from the
 * indicator's root, and a restart between the two would put the first stage
 * on the old branch.  The Euler error is O(gap^2).  The gap stays below
 * t_limit (the end of the step that saw the sign change) and
 * LF_EVENT_GAP_MAX * max(1, |t|).  If the indicator keeps its old sign
 * there (a root it only touches, e.g. (t - 1)^2, or one the redone
 * trajectory does not reach), *crossed_out = 0: no event; the solver
 * restarts at the last point tried, with that point's indicators. */
static LfStatus cross_gap(LfInstance *c, int k, double t_left, const double *x_left,
                          double gap, double t_limit, int *crossed_out) {
    double f[LF_DIM(LF_NX)], x[LF_DIM(LF_NX)], old = c->e_old[k];
    double gap_max = fmin(t_limit - t_left, LF_EVENT_GAP_MAX * fmax(1.0, fabs(t_left)));
    int i, j;
    LfStatus st = rhs_cb(c, t_left, x_left, f);
    if (st != LF_OK) return st;
    *crossed_out = 0;
    if (!(gap_max > 0)) gap_max = gap;
    for (i = 0; i < LF_EVENT_GAP_TRIES; i++, gap *= 4.0) {
        if (gap > gap_max) gap = gap_max;
        for (j = 0; j < LF_NX; j++) x[j] = x_left[j] + gap * f[j];
        st = eval_events(c, t_left + gap, x, c->e_new);
        if (st != LF_OK) return st;
        if (crossed(old, c->e_new[k])) {
            *crossed_out = 1;
            break;
        }
        if (gap >= gap_max) break;
    }
    lf_solver_reset(&c->solver, t_left + gap, x);
    memcpy(c->e_old, c->e_new, sizeof(double) * LF_NE);
    return LF_OK;
}

/* After an accepted step: find the earliest crossing.  The step is then
 * redone from t_old to the root's old side, so that no stage straddles the
 * discontinuity (the dense output of the straddling step is contaminated by
 * it), and the solver restarts on the new side. */
static LfStatus handle_events(LfInstance *c) {
    LfSolver *s = &c->solver;
    double t_left = s->t, t_right = s->t, margin, t_stop, t_end_step, e_end[LF_DIM(LF_NE)];
    int k, first = -1, crossed_gap;
    LfStatus st = eval_events(c, s->t, s->x, e_end);
    if (st != LF_OK) return st;
    for (k = 0; k < LF_NE; k++) {
        double tl, tr;
        if (!crossed(c->e_old[k], e_end[k])) continue;
        st = locate_root(c, k, s->t_old, c->e_old[k], s->t, e_end[k], &tl, &tr);
        if (st != LF_OK) return st;
        if (first < 0 || tr < t_right) {
            t_left = tl;
            t_right = tr;
            first = k;
        }
    }
    if (first < 0) {
        memcpy(c->e_old, e_end, sizeof(double) * LF_NE);
        return LF_OK;
    }
    t_end_step = s->t;
    /* stop a margin before the root: the stages of the redone step must
     * not reach the model's switch, which rounding can move by a few ulps */
    margin = LF_EVENT_GAP * fmax(1.0, fabs(t_left));
    t_stop = fmax(t_left - margin, s->t_old);
    memcpy(c->x_tmp, s->x_old, sizeof(double) * LF_NX);
    lf_solver_reset(s, s->t_old, c->x_tmp);
    while (s->t < t_stop) {
        st = s->method->step(s, t_stop);
        if (st != LF_OK) return st;
    }
    st = cross_gap(c, first, s->t, s->x, t_right - s->t + margin, t_end_step, &crossed_gap);
    if (st != LF_OK) return st;
    if (!crossed_gap) {
        lf_log(c, LF_OK, LF_LOG_EVENTS, "t = %.17g: indicator %s touched zero and kept its "
               "sign: no event, solver restarted", s->t, lf_model.event_names[first]);
        return hist_push(c, s->t, s->x, 0);
    }
    c->n_events++;
    if (LF_NQ > 0) {
        memcpy(c->x_tmp, s->x, sizeof(double) * LF_NX);
        if (lf_model.event_mode[first] >= 0) {
            st = choose_mode(c, lf_model.event_mode[first], s->t, c->x_tmp);
            if (st != LF_OK) return st;
        }
        st = consistent_modes(c, s->t, c->x_tmp, lf_model.event_mode[first]);
        if (st != LF_OK) return st;
        lf_solver_reset(s, s->t, c->x_tmp);
        st = eval_events(c, s->t, s->x, c->e_old);
        if (st != LF_OK) return st;
    }
    lf_log(c, LF_OK, LF_LOG_EVENTS, "t = %.17g: event %s, solver restarted", s->t,
           lf_model.event_names[first]);
    return hist_push(c, s->t, s->x, lf_model.event_mode[first] >= 0);
}

static LfStatus fail_step(LfInstance *c, LfStatus st, const char *what) {
    LfSolver *s = &c->solver;
    memcpy(&c->r[LF_VR_X0], s->x, sizeof(double) * LF_NX);
    c->t = c->last_successful_time = s->t;
    c->outputs_valid = 0;
    lf_log(c, st, st == LF_DISCARD ? LF_LOG_DISCARD : LF_LOG_ERROR,
           "t = %.17g: solver %s failed: %s; state kept at the last accepted time", s->t,
           s->method->name, what);
    return st;
}

LfStatus lf_check_step(LfInstance *c, double t0, double h) {
    if (!(h > 0) || !isfinite(h)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "fmi2DoStep: communicationStepSize = %g, expected a finite value > 0", h);
        return LF_ERROR;
    }
    if (t0 + h > c->t_stop * (1 + 1e-12) + 1e-12) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "fmi2DoStep: step to %.17g goes past stopTime = %.17g of fmi2SetupExperiment",
               t0 + h, c->t_stop);
        return LF_ERROR;
    }
    if (fabs(t0 - c->t) > 1e-9 * fmax(1.0, fabs(c->t))) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "fmi2DoStep: currentCommunicationPoint = %.17g, expected %.17g", t0, c->t);
        return LF_ERROR;
    }
    return LF_OK;
}

LfStatus lf_do_step(LfInstance *c, double t0, double h) {
    LfSolver *s = &c->solver;
    double t_end = t0 + h;
    long steps = 0;
    LfStatus st = lf_check_step(c, t0, h);
    if (st != LF_OK) return st;
    if (c->inputs_changed) {
        /* the held inputs jump here: modes made invalid by the jump (a
         * stuck joint now loaded beyond its static limit) are chosen again */
        memcpy(c->x_tmp, s->x, sizeof(double) * LF_NX);
        if (LF_NQ > 0) {
            st = consistent_modes(c, s->t, c->x_tmp, -1);
            if (st != LF_OK) return fail_step(c, st, "no consistent mode after the input change");
        }
        lf_solver_reset(s, s->t, c->x_tmp);
        st = hist_push(c, s->t, s->x, 1);
        if (st != LF_OK) return fail_step(c, st, "history update failed");
        st = eval_events(c, s->t, s->x, c->e_old);
        if (st != LF_OK) return fail_step(c, st, "event indicators not finite");
        c->inputs_changed = 0;
    }
    while (s->t < t_end) {
        int is_bp = 0;
        double t_bound = LF_ND > 0 ? next_breakpoint(c, s->t, t_end, &is_bp) : t_end;
        s->message[0] = '\0';
        c->t_bp_step = is_bp ? t_bound : INFINITY;
        st = s->method->step(s, t_bound);
        c->t_bp_step = INFINITY;
        if (st != LF_OK) return fail_step(c, st, s->message);
        if (LF_NE > 0) {
            st = handle_events(c);
            if (st != LF_OK) return fail_step(c, st, "event handling failed");
        }
        if (LF_ND > 0) {
            int at_bp = is_bp && s->t == t_bound;
            st = hist_step(c);
            if (st != LF_OK) return fail_step(c, st, "history update failed");
            if (at_bp) lf_solver_reset(s, s->t, s->x); /* a delayed value jumps here */
        }
        if (++steps > c->max_steps)
            return fail_step(c, LF_DISCARD, "too many internal steps in one communication step");
    }
    memcpy(&c->r[LF_VR_X0], s->x, sizeof(double) * LF_NX);
    c->t = t_end;
    c->outputs_valid = 0;
    st = lf_update_outputs(c);
    if (st != LF_OK) return st;
    c->last_successful_time = t_end;
    return LF_OK;
}
