/* loomfmu runtime: embedded ODE solvers behind the contract of lf_solver.h.
 *
 *   dopri5  explicit Dormand-Prince 5(4), FSAL, Hairer's 4th-order dense output
 *           (lf_dopri5.c)
 *   rodas4  Hairer-Wanner RODAS (4(3), 6 stages, stiffly accurate Rosenbrock)
 *           with its 3rd-order dense output (lf_rodas4.c)
 *   rk4     classical fixed-step Runge-Kutta with cubic Hermite dense output
 *           (here, with the registry and the life cycle; the helpers every
 *           method shares are in lf_solver_common.c)
 *   ros34pw2  Rang-Angermann Rosenbrock-W ROS34PW2 (3(2), 4 stages, stiffly
 *           accurate, L-stable) reusing the Jacobian and its factorization
 *           across steps (lf_wmethod.c)
 * The implicit methods factor I/(h*gamma) - J through lf_schur.c (dense, or
 * a Schur complement for the kinematic rows q' = v of mechanical models).
 *
 * Workspace layout (doubles, one buffer from the allocator):
 *   work[0 .. n)        x      (state at t)
 *   work[n .. 2n)       x_old  (state at t_old)
 *   work[2n .. )        method-private data, method->work_size(n) doubles
 * Nothing else holds state, so copying the struct plus `work` (and re-pointing
 * x = work, x_old = work + n) copies the solver.  No global mutable state.
 *
 * Failure policy of the adaptive methods: a right-hand side that fails
 * (returns LF_DISCARD or non-finite values) during a step attempt is treated
 * like a failed error test with a strong step reduction, since it is often
 * caused by a too large trial step (overflow).  If the step size then drops
 * below 16*eps*|t| (or too many attempts fail) the step is given up with
 * LF_DISCARD and a message naming the time and the cause.  A failure of f at
 * the current accepted point itself cannot be cured by a smaller step and
 * gives LF_DISCARD at once.  LF_ERROR/LF_FATAL from the callbacks are
 * passed through.
 */
#include "lf_solver_impl.h"
#include "lf_linalg.h"

#include <math.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* rk4                                                                       */

/* private vectors: k1 (= f(t, x) once valid), k2, k3, k4, stage argument /
 * new state, f(t_old, x_old) for the Hermite interpolant */
enum { RK_K1, RK_K2, RK_K3, RK_K4, RK_Y, RK_FOLD, RK_NVEC };

static size_t rk_work_size(size_t n) { return RK_NVEC * n; }

static LfStatus rk_step(LfSolver *s, double t_bound) {
    const size_t n = s->ode.n;
    double *w = LF_PRIV(s);
    double *k1 = w + RK_K1 * n, *k2 = w + RK_K2 * n, *k3 = w + RK_K3 * n, *k4 = w + RK_K4 * n;
    double *y = w + RK_Y * n, *fold = w + RK_FOLD * n;
    double *x = s->x;
    const double t = s->t;
    double h = s->opt.h_fixed, t_new, h2;
    size_t i;
    int bad;
    LfStatus st;

    if (!(t_bound > t)) return lf_sv_bad_bound(s, t_bound);
    if (!s->fsal_valid) {
        st = lf_sv_eval_rhs(s, t, x, k1);
        if (st != LF_OK) return lf_sv_start_failure(s, st);
        s->fsal_valid = 1;
    }
    /* shorten the last step to land exactly on t_bound (also absorbs a
     * remainder left over by rounding) */
    if (t + h * (1.0 + 1e-9) >= t_bound) {
        h = t_bound - t;
        t_new = t_bound;
    } else {
        t_new = t + h;
    }
    h2 = 0.5 * h;
    /* each stage's argument checked where it is formed (lf_sv_eval_rhs_checked) */
    for (i = 0, bad = 0; i < n; i++) {
        y[i] = x[i] + h2 * k1[i];
        bad |= LF_SV_NOT_FINITE(y[i]);
    }
    st = lf_sv_eval_rhs_checked(s, t + h2, y, k2, bad);
    if (st != LF_OK) goto failed;
    for (i = 0, bad = 0; i < n; i++) {
        y[i] = x[i] + h2 * k2[i];
        bad |= LF_SV_NOT_FINITE(y[i]);
    }
    st = lf_sv_eval_rhs_checked(s, t + h2, y, k3, bad);
    if (st != LF_OK) goto failed;
    for (i = 0, bad = 0; i < n; i++) {
        y[i] = x[i] + h * k3[i];
        bad |= LF_SV_NOT_FINITE(y[i]);
    }
    st = lf_sv_eval_rhs_checked(s, t_new, y, k4, bad);
    if (st != LF_OK) goto failed;
    for (i = 0, bad = 0; i < n; i++) {
        y[i] = x[i] + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
        bad |= LF_SV_NOT_FINITE(y[i]);
    }
    /* f at the new point: dense output + next k1 */
    st = lf_sv_eval_rhs_checked(s, t_new, y, k2, bad);
    if (st != LF_OK) goto failed;

    lf_sv_copy_vec(fold, k1, n);
    lf_sv_copy_vec(k1, k2, n);
    lf_sv_copy_vec(s->x_old, x, n);
    lf_sv_copy_vec(x, y, n);
    s->t_old = t;
    s->t = t_new;
    s->h = s->opt.h_fixed;
    s->n_steps++;
    return LF_OK;
failed:
    if (st != LF_DISCARD) return lf_sv_callback_error(s, st, t_new);
    lf_sv_set_msg(s, "rk4: non-finite values (Inf/NaN) in the right-hand side or the states in the "
               "step from t=%.17g to t=%.17g (h=%.3g)", t, t_new, h);
    return LF_DISCARD;
}

static void rk_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = LF_CPRIV(s);
    const double *f1 = w + RK_K1 * n, *f0 = w + RK_FOLD * n;
    const double *x0 = s->x_old, *x1 = s->x;
    double h = s->t - s->t_old, th, th2, th3, h00, h10, h01, h11;
    size_t i;
    if (!(h > 0.0) || !s->fsal_valid) {
        lf_sv_copy_vec(out, x1, n);
        return;
    }
    th = (tq - s->t_old) / h;
    th2 = th * th;
    th3 = th2 * th;
    h00 = 2.0 * th3 - 3.0 * th2 + 1.0;
    h10 = (th3 - 2.0 * th2 + th) * h;
    h01 = 3.0 * th2 - 2.0 * th3;
    h11 = (th3 - th2) * h;
    for (i = 0; i < n; i++) out[i] = h00 * x0[i] + h10 * f0[i] + h01 * x1[i] + h11 * f1[i];
}

const LfMethod lf_rk4 = {"rk4", 0, 0, rk_work_size, rk_step, rk_dense};

/* ------------------------------------------------------------------------ */
/* registry and life cycle                                                   */

/* in the order of codegen's SOLVERS (the `solver` enumeration) */
const LfMethod *const lf_methods[] = {&lf_dopri5, &lf_rodas4, &lf_rk4, &lf_ros34pw2};
const size_t lf_n_methods = sizeof lf_methods / sizeof lf_methods[0];

LfStatus lf_solver_init(LfSolver *s, const LfMethod *m, LfOde ode, LfSolverOptions opt,
                        double t0, const double *x0, const LfAllocator *alloc) {
    size_t n = ode.n, len;
    const char *name;
    if (!s) return LF_ERROR;
    memset(s, 0, sizeof *s);
    s->method = m;
    s->ode = ode;
    s->opt = opt;
    s->t = s->t_old = t0;
    s->h = 0.0;
    s->work = s->x = s->x_old = NULL;
    s->work_len = 0;
    s->fsal_valid = 0;
    if (!m) {
        lf_sv_set_msg(s, "no solver method given");
        return LF_ERROR;
    }
    name = m->name;
    if (!alloc || !alloc->calloc || !alloc->free) {
        lf_sv_set_msg(s, "%s: no memory allocator given", name);
        return LF_ERROR;
    }
    if (!ode.rhs || (n > 0 && !x0)) {
        lf_sv_set_msg(s, "%s: right-hand side or initial state missing", name);
        return LF_ERROR;
    }
    if (m->needs_jac && !ode.jac) {
        lf_sv_set_msg(s, "%s needs the Jacobian, but none is available", name);
        return LF_ERROR;
    }
    if (m->adaptive) {
        if (!(opt.rtol > 0.0) || !isfinite(opt.rtol)) {
            lf_sv_set_msg(s, "%s: relative tolerance must be finite and > 0 (got %g)", name, opt.rtol);
            return LF_ERROR;
        }
        if (!(opt.atol > 0.0) || !isfinite(opt.atol)) {
            lf_sv_set_msg(s, "%s: absolute tolerance must be finite and > 0 (got %g)", name, opt.atol);
            return LF_ERROR;
        }
    } else if (!(opt.h_fixed > 0.0) || !isfinite(opt.h_fixed)) {
        lf_sv_set_msg(s, "%s: fixed step size must be finite and > 0 (got %g)", name, opt.h_fixed);
        return LF_ERROR;
    }
    if (!(opt.h_max > 0.0)) {
        lf_sv_set_msg(s, "%s: maximum step size must be > 0 (got %g)", name, opt.h_max);
        return LF_ERROR;
    }
    if (!isfinite(t0)) {
        lf_sv_set_msg(s, "%s: start time not finite", name);
        return LF_ERROR;
    }
    /* guard the n*n terms of the workspace size against overflow */
    if (n > ((size_t)1 << (sizeof(size_t) * 4 - 2))) {
        lf_sv_set_msg(s, "%s: too many states (%lu)", name, (unsigned long)n);
        return LF_ERROR;
    }
    len = 2 * n + m->work_size(n);
    s->work = (double *)alloc->calloc(len > 0 ? len : 1, sizeof(double));
    if (!s->work) {
        lf_sv_set_msg(s, "%s: out of memory (%lu doubles)", name, (unsigned long)len);
        return LF_ERROR;
    }
    s->work_len = len;
    s->x = s->work;
    s->x_old = s->work + n;
    lf_sv_copy_vec(s->x, x0, n);
    lf_sv_copy_vec(s->x_old, x0, n);
    return LF_OK;
}

void lf_solver_reset(LfSolver *s, double t, const double *x) {
    size_t n = s->ode.n;
    if (x != s->x) lf_sv_copy_vec(s->x, x, n);
    lf_sv_copy_vec(s->x_old, s->x, n);
    s->t = s->t_old = t;
    s->fsal_valid = 0;
    if (s->h > s->opt.h_max) s->h = s->opt.h_max;
    if (s->method == &lf_rodas4) lf_rodas4_clear_history(s);
    if (s->method == &lf_ros34pw2) lf_ros34pw2_restart(s);
    s->message[0] = '\0';
}

void lf_solver_free(LfSolver *s, const LfAllocator *alloc) {
    if (!s) return;
    if (s->work && alloc && alloc->free) alloc->free(s->work);
    s->work = s->x = s->x_old = NULL;
    s->work_len = 0;
    s->fsal_valid = 0;
}
