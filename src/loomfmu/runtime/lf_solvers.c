/* loomfmu runtime: embedded ODE solvers behind the contract of lf_solver.h.
 *
 *   dopri5  explicit Dormand-Prince 5(4), FSAL, Hairer's 4th-order dense output
 *   rodas4  Hairer-Wanner RODAS (4(3), 6 stages, stiffly accurate Rosenbrock)
 *           with its 3rd-order dense output
 *   rk4     classical fixed-step Runge-Kutta with cubic Hermite dense output
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
#include "lf_solver.h"
#include "lf_linalg.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define LF_UROUND DBL_EPSILON
/* Give up a single step after this many failed attempts (guards against
 * endless halving when t == 0 makes the relative underflow test vacuous). */
#define LF_MAX_ATTEMPTS 200

extern const LfMethod lf_dopri5;
extern const LfMethod lf_rodas4;
extern const LfMethod lf_rk4;

/* ------------------------------------------------------------------------ */
/* helpers                                                                   */

static void set_msg(LfSolver *s, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(s->message, sizeof s->message, fmt, ap);
    va_end(ap);
}

static double *priv(LfSolver *s) { return s->work + 2 * s->ode.n; }
static const double *cpriv(const LfSolver *s) { return s->work + 2 * s->ode.n; }

static int all_finite(const double *v, size_t n) {
    size_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

static void copy_vec(double *dst, const double *src, size_t n) {
    if (n) memmove(dst, src, n * sizeof(double));
}

/* Evaluate f; LF_OK only if f succeeded with finite values.  LF_DISCARD for
 * a non-finite argument/result or an f that reports LF_DISCARD; LF_ERROR or
 * LF_FATAL are passed through. */
static LfStatus eval_rhs(LfSolver *s, double t, const double *x, double *dx) {
    LfStatus st;
    size_t n = s->ode.n;
    if (!all_finite(x, n)) return LF_DISCARD;
    s->n_rhs++;
    st = s->ode.rhs(s->ode.ctx, t, x, dx);
    if (st == LF_OK || st == LF_WARNING) return all_finite(dx, n) ? LF_OK : LF_DISCARD;
    if (st == LF_DISCARD) return LF_DISCARD;
    return st == LF_FATAL ? LF_FATAL : LF_ERROR;
}

/* Hairer's weighted RMS norm of err with scale atol + rtol*max(|y0|,|y1|). */
static double err_norm(const LfSolver *s, const double *err, const double *y0,
                       const double *y1) {
    size_t i, n = s->ode.n;
    double sum = 0.0;
    if (n == 0) return 0.0;
    for (i = 0; i < n; i++) {
        double sk = s->opt.atol + s->opt.rtol * fmax(fabs(y0[i]), fabs(y1[i]));
        double q = err[i] / sk;
        sum += q * q;
    }
    return sqrt(sum / (double)n);
}

/* Automatic initial step (Hairer's HINIT, with RMS norms as in scipy).
 * f0 = f(t, x); y1, f1 are scratch vectors.  order: order of the method. */
static double initial_step(LfSolver *s, const double *f0, double *y1, double *f1,
                           double order, double hmax) {
    size_t i, n = s->ode.n;
    const double *x = s->x;
    double d0 = 0.0, d1 = 0.0, d2 = 0.0, h0, h1, dmax;
    if (n == 0) return hmax;
    for (i = 0; i < n; i++) {
        double sk = s->opt.atol + s->opt.rtol * fabs(x[i]);
        d0 += (x[i] / sk) * (x[i] / sk);
        d1 += (f0[i] / sk) * (f0[i] / sk);
    }
    d0 = sqrt(d0 / (double)n);
    d1 = sqrt(d1 / (double)n);
    h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    if (h0 > hmax) h0 = hmax;
    for (i = 0; i < n; i++) y1[i] = x[i] + h0 * f0[i];
    if (eval_rhs(s, s->t + h0, y1, f1) != LF_OK) return h0;
    for (i = 0; i < n; i++) {
        double sk = s->opt.atol + s->opt.rtol * fabs(x[i]);
        double q = (f1[i] - f0[i]) / sk;
        d2 += q * q;
    }
    d2 = sqrt(d2 / (double)n) / h0;
    dmax = fmax(d1, d2);
    if (dmax <= 1e-15)
        h1 = fmax(1e-6, h0 * 1e-3);
    else
        h1 = pow(0.01 / dmax, 1.0 / order);
    return fmin(fmin(100.0 * h0, h1), hmax);
}

static LfStatus bad_bound(LfSolver *s, double t_bound) {
    set_msg(s, "%s: invalid use: t_bound = %.17g is not after t = %.17g", s->method->name,
            t_bound, s->t);
    return LF_ERROR;
}

/* f failed at the accepted point itself: no step size can help. */
static LfStatus start_failure(LfSolver *s, LfStatus st) {
    if (st == LF_DISCARD)
        set_msg(s, "%s: right-hand side not finite (or not evaluable) at the current point t=%.17g",
                s->method->name, s->t);
    else
        set_msg(s, "%s: right-hand side returned an error at t=%.17g", s->method->name, s->t);
    return st;
}

static LfStatus callback_error(LfSolver *s, LfStatus st, double t_at) {
    set_msg(s, "%s: right-hand side returned an error at t=%.17g (step from t=%.17g)",
            s->method->name, t_at, s->t);
    return st;
}

enum { CAUSE_NONE, CAUSE_ERRTEST, CAUSE_NONFINITE, CAUSE_SINGULAR };

static const char *cause_text(int cause) {
    switch (cause) {
    case CAUSE_NONFINITE:
        return "non-finite values (Inf/NaN) in the right-hand side or the states";
    case CAUSE_SINGULAR:
        return "singular iteration matrix";
    case CAUSE_ERRTEST:
        return "local error test failed repeatedly (singularity, blow-up or discontinuity?)";
    default:
        return "the step size control asks for ever smaller steps (blow-up or singularity?)";
    }
}

/* Step-size underflow or too many failed attempts: give up the step. */
static LfStatus give_up(LfSolver *s, double h, double hmin, int cause, int too_many) {
    if (too_many)
        set_msg(s, "%s: step failed at t=%.17g after %d attempts (h=%.3g): %s", s->method->name,
                s->t, LF_MAX_ATTEMPTS, h, cause_text(cause));
    else
        set_msg(s, "%s: step size underflow at t=%.17g (h=%.3g < %.3g): %s", s->method->name,
                s->t, h, hmin, cause_text(cause));
    return LF_DISCARD;
}

/* Common preamble of an adaptive step attempt: limit h to the remaining
 * interval (stepping exactly to t_bound when close) and check underflow.
 * Returns 0 to go on, 1 to give up. */
static int plan_step(const LfSolver *s, double t_bound, double *h, double *t_new, int *last,
                     double *hmin) {
    double t = s->t;
    *hmin = 16.0 * LF_UROUND * fabs(t);
    if (t + 1.01 * *h >= t_bound) {
        *h = t_bound - t;
        *t_new = t_bound;
        *last = 1;
        return 0;
    }
    *last = 0;
    *t_new = t + *h;
    return !(*h >= *hmin) || !(*t_new > t);
}

/* ------------------------------------------------------------------------ */
/* dopri5                                                                    */

/* Dormand & Prince (1980) 5(4) tableau, Hairer-Norsett-Wanner DOPRI5 */
#define DP_C2 (1.0 / 5.0)
#define DP_C3 (3.0 / 10.0)
#define DP_C4 (4.0 / 5.0)
#define DP_C5 (8.0 / 9.0)
#define DP_A21 (1.0 / 5.0)
#define DP_A31 (3.0 / 40.0)
#define DP_A32 (9.0 / 40.0)
#define DP_A41 (44.0 / 45.0)
#define DP_A42 (-56.0 / 15.0)
#define DP_A43 (32.0 / 9.0)
#define DP_A51 (19372.0 / 6561.0)
#define DP_A52 (-25360.0 / 2187.0)
#define DP_A53 (64448.0 / 6561.0)
#define DP_A54 (-212.0 / 729.0)
#define DP_A61 (9017.0 / 3168.0)
#define DP_A62 (-355.0 / 33.0)
#define DP_A63 (46732.0 / 5247.0)
#define DP_A64 (49.0 / 176.0)
#define DP_A65 (-5103.0 / 18656.0)
#define DP_A71 (35.0 / 384.0)
#define DP_A73 (500.0 / 1113.0)
#define DP_A74 (125.0 / 192.0)
#define DP_A75 (-2187.0 / 6784.0)
#define DP_A76 (11.0 / 84.0)
/* error coefficients: 5th-order minus 4th-order weights */
#define DP_E1 (71.0 / 57600.0)
#define DP_E3 (-71.0 / 16695.0)
#define DP_E4 (71.0 / 1920.0)
#define DP_E5 (-17253.0 / 339200.0)
#define DP_E6 (22.0 / 525.0)
#define DP_E7 (-1.0 / 40.0)
/* dense output (Hairer's CONTD5) */
#define DP_D1 (-12715105075.0 / 11282082432.0)
#define DP_D3 (87487479700.0 / 32700410799.0)
#define DP_D4 (-10690763975.0 / 1880347072.0)
#define DP_D5 (701980252875.0 / 199316789632.0)
#define DP_D6 (-1453857185.0 / 822651844.0)
#define DP_D7 (69997945.0 / 29380423.0)

/* private vectors: stages k1..k7, stage argument, new state, dense r3..r5 */
enum { DP_K1, DP_K2, DP_K3, DP_K4, DP_K5, DP_K6, DP_K7, DP_Y, DP_YNEW, DP_R3, DP_R4, DP_R5, DP_NVEC };

static size_t dp_work_size(size_t n) { return DP_NVEC * n; }

static LfStatus dp_step(LfSolver *s, double t_bound) {
    const size_t n = s->ode.n;
    double *w = priv(s);
    double *k1 = w + DP_K1 * n, *k2 = w + DP_K2 * n, *k3 = w + DP_K3 * n, *k4 = w + DP_K4 * n;
    double *k5 = w + DP_K5 * n, *k6 = w + DP_K6 * n, *k7 = w + DP_K7 * n;
    double *y = w + DP_Y * n, *ynew = w + DP_YNEW * n;
    double *x = s->x;
    const double t = s->t, hmax = s->opt.h_max;
    double h;
    int rejected = 0, cause = CAUSE_NONE, attempts = 0;
    size_t i;
    LfStatus st;

    if (!(t_bound > t)) return bad_bound(s, t_bound);
    if (!s->fsal_valid) {
        st = eval_rhs(s, t, x, k1);
        if (st != LF_OK) return start_failure(s, st);
        s->fsal_valid = 1;
    }
    h = s->h;
    if (!(h > 0.0)) h = initial_step(s, k1, k2, k3, 5.0, fmin(hmax, t_bound - t));
    if (h > hmax) h = hmax;

    for (;;) {
        double h_prop = h, t_new, hmin, err, fac;
        int last;
        if (++attempts > LF_MAX_ATTEMPTS) return give_up(s, h, 0.0, cause, 1);
        if (plan_step(s, t_bound, &h, &t_new, &last, &hmin)) return give_up(s, h, hmin, cause, 0);

        for (i = 0; i < n; i++) y[i] = x[i] + h * DP_A21 * k1[i];
        st = eval_rhs(s, t + DP_C2 * h, y, k2);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++) y[i] = x[i] + h * (DP_A31 * k1[i] + DP_A32 * k2[i]);
        st = eval_rhs(s, t + DP_C3 * h, y, k3);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++)
            y[i] = x[i] + h * (DP_A41 * k1[i] + DP_A42 * k2[i] + DP_A43 * k3[i]);
        st = eval_rhs(s, t + DP_C4 * h, y, k4);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++)
            y[i] = x[i] + h * (DP_A51 * k1[i] + DP_A52 * k2[i] + DP_A53 * k3[i] + DP_A54 * k4[i]);
        st = eval_rhs(s, t + DP_C5 * h, y, k5);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++)
            y[i] = x[i] + h * (DP_A61 * k1[i] + DP_A62 * k2[i] + DP_A63 * k3[i] +
                               DP_A64 * k4[i] + DP_A65 * k5[i]);
        st = eval_rhs(s, t_new, y, k6);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++)
            ynew[i] = x[i] + h * (DP_A71 * k1[i] + DP_A73 * k3[i] + DP_A74 * k4[i] +
                                  DP_A75 * k5[i] + DP_A76 * k6[i]);
        st = eval_rhs(s, t_new, ynew, k7);
        if (st != LF_OK) goto failed;

        for (i = 0; i < n; i++)
            y[i] = h * (DP_E1 * k1[i] + DP_E3 * k3[i] + DP_E4 * k4[i] + DP_E5 * k5[i] +
                        DP_E6 * k6[i] + DP_E7 * k7[i]);
        err = err_norm(s, y, x, ynew);
        if (!isfinite(err)) {
            st = LF_DISCARD;
            goto failed;
        }
        if (err <= 1.0) {
            double hnew, *r3 = w + DP_R3 * n, *r4 = w + DP_R4 * n, *r5 = w + DP_R5 * n;
            fac = err > 0.0 ? 0.9 * pow(err, -0.2) : 10.0;
            if (fac > 10.0) fac = 10.0;
            if (fac < 0.2) fac = 0.2;
            if (rejected && fac > 1.0) fac = 1.0;
            hnew = h * fac;
            for (i = 0; i < n; i++) {
                double dy = ynew[i] - x[i];
                r3[i] = h * k1[i] - dy;
                r4[i] = dy - h * k7[i] - r3[i];
                r5[i] = h * (DP_D1 * k1[i] + DP_D3 * k3[i] + DP_D4 * k4[i] + DP_D5 * k5[i] +
                             DP_D6 * k6[i] + DP_D7 * k7[i]);
            }
            copy_vec(s->x_old, x, n);
            copy_vec(x, ynew, n);
            copy_vec(k1, k7, n); /* FSAL */
            s->t_old = t;
            s->t = t_new;
            /* a step shortened to hit t_bound says little about the next one */
            if (last && !rejected && h_prop > hnew) hnew = h_prop;
            s->h = fmin(hnew, hmax);
            s->n_steps++;
            return LF_OK;
        }
        fac = 0.9 * pow(err, -0.2);
        if (fac < 0.2) fac = 0.2;
        h *= fac;
        rejected = 1;
        cause = CAUSE_ERRTEST;
        s->n_rejected++;
        continue;
    failed:
        if (st != LF_DISCARD) return callback_error(s, st, t + h);
        h *= 0.25;
        rejected = 1;
        cause = CAUSE_NONFINITE;
        s->n_rejected++;
    }
}

static void dp_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = cpriv(s);
    const double *r3 = w + DP_R3 * n, *r4 = w + DP_R4 * n, *r5 = w + DP_R5 * n;
    const double *x0 = s->x_old, *x1 = s->x;
    double h = s->t - s->t_old, th, th1;
    size_t i;
    if (!(h > 0.0)) {
        copy_vec(out, x1, n);
        return;
    }
    th = (tq - s->t_old) / h;
    th1 = 1.0 - th;
    for (i = 0; i < n; i++) {
        double dy = x1[i] - x0[i];
        out[i] = x0[i] + th * (dy + th1 * (r3[i] + th * (r4[i] + th1 * r5[i])));
    }
}

const LfMethod lf_dopri5 = {"dopri5", 1, 0, dp_work_size, dp_step, dp_dense};

/* ------------------------------------------------------------------------ */
/* rodas4                                                                    */

/* Hairer & Wanner, Solving ODEs II, Sec. IV.7; coefficients of RODAS
 * (METH=1) in the W-transformed form used by rodas.f:
 *   (I/(h*gamma) - J) k_i = f(t + c_i h, x + sum_j a_ij k_j)
 *                           + sum_j (c_ij/h) k_j + h d_i df/dt
 * x_new = x + sum_j a_5j k_j + k5 + k6 (stiffly accurate), error = k6. */
#define RO_GAMMA 0.25
#define RO_C2 0.386
#define RO_C3 0.21
#define RO_C4 0.63
#define RO_D1 0.25
#define RO_D2 (-0.1043)
#define RO_D3 0.1035
#define RO_D4 (-0.3620000000000023e-01)
#define RO_A21 1.544
#define RO_A31 0.9466785280815826
#define RO_A32 0.2557011698983284
#define RO_A41 3.314825187068521
#define RO_A42 2.896124015972201
#define RO_A43 0.9986419139977817
#define RO_A51 1.221224509226641
#define RO_A52 6.019134481288629
#define RO_A53 12.53708332932087
#define RO_A54 (-0.6878860361058950)
#define RO_C21 (-5.6688)
#define RO_C31 (-2.430093356833875)
#define RO_C32 (-0.2063599157091915)
#define RO_C41 (-0.1073529058151375)
#define RO_C42 (-9.594562251023355)
#define RO_C43 (-20.47028614809616)
#define RO_C51 7.496443313967647
#define RO_C52 (-10.24680431464352)
#define RO_C53 (-33.99990352819905)
#define RO_C54 11.70890893206160
#define RO_C61 8.083246795921522
#define RO_C62 (-7.981132988064893)
#define RO_C63 (-31.52159432874371)
#define RO_C64 16.31930543123136
#define RO_C65 (-6.058818238834054)
/* dense output */
#define RO_D21 10.12623508344586
#define RO_D22 (-7.487995877610167)
#define RO_D23 (-34.80091861555747)
#define RO_D24 (-7.992771707568823)
#define RO_D25 1.025137723295662
#define RO_D31 (-0.6762803392801253)
#define RO_D32 6.087714651680015
#define RO_D33 16.43084320892478
#define RO_D34 24.76722511418386
#define RO_D35 (-6.594389125716872)

/* private data: 3 controller scalars (h_acc, err_acc, valid), then vectors
 * k1..k6, stage argument / new state, f at stage, f0 = f(t,x), df/dt,
 * dense cont3, cont4; then J and the LU of the iteration matrix (n*n each),
 * then the pivot indices. */
enum { RO_HACC, RO_ERRACC, RO_HISTOK, RO_NSCAL };
enum { RO_K1, RO_K2, RO_K3, RO_K4, RO_K5, RO_K6, RO_Y, RO_DY, RO_F0, RO_FT, RO_CONT3, RO_CONT4, RO_NVEC };

static size_t ro_work_size(size_t n) {
    return RO_NSCAL + RO_NVEC * n + 2 * n * n + lf_lu_piv_doubles(n);
}

static double *ro_vec(LfSolver *s, int k) { return priv(s) + RO_NSCAL + (size_t)k * s->ode.n; }
static double *ro_jac(LfSolver *s) { return priv(s) + RO_NSCAL + RO_NVEC * s->ode.n; }
static double *ro_lu(LfSolver *s) { return ro_jac(s) + s->ode.n * s->ode.n; }
static size_t *ro_piv(LfSolver *s) { return (size_t *)(void *)(ro_lu(s) + s->ode.n * s->ode.n); }

static void ro_clear_history(LfSolver *s) { priv(s)[RO_HISTOK] = 0.0; }

/* f0 = f(t,x), J, df/dt at the accepted point */
static LfStatus ro_prepare(LfSolver *s) {
    const size_t n = s->ode.n;
    double *f0 = ro_vec(s, RO_F0), *ft = ro_vec(s, RO_FT), *J = ro_jac(s);
    LfStatus st = eval_rhs(s, s->t, s->x, f0);
    if (st != LF_OK) return start_failure(s, st);
    s->n_jac++;
    st = s->ode.jac(s->ode.ctx, s->t, s->x, J, ft);
    if (st == LF_OK || st == LF_WARNING) {
        if (all_finite(J, n * n) && all_finite(ft, n)) return LF_OK;
        set_msg(s, "rodas4: Jacobian or df/dt not finite at t=%.17g", s->t);
        return LF_DISCARD;
    }
    if (st == LF_DISCARD) {
        set_msg(s, "rodas4: Jacobian could not be evaluated at t=%.17g", s->t);
        return LF_DISCARD;
    }
    set_msg(s, "rodas4: Jacobian callback returned an error at t=%.17g", s->t);
    return st == LF_FATAL ? LF_FATAL : LF_ERROR;
}

static LfStatus ro_step(LfSolver *s, double t_bound) {
    const size_t n = s->ode.n;
    double *k1 = ro_vec(s, RO_K1), *k2 = ro_vec(s, RO_K2), *k3 = ro_vec(s, RO_K3);
    double *k4 = ro_vec(s, RO_K4), *k5 = ro_vec(s, RO_K5), *k6 = ro_vec(s, RO_K6);
    double *y = ro_vec(s, RO_Y), *dy = ro_vec(s, RO_DY), *f0 = ro_vec(s, RO_F0);
    double *ft = ro_vec(s, RO_FT), *J = ro_jac(s), *E = ro_lu(s), *hist = priv(s);
    size_t *piv = ro_piv(s);
    double *x = s->x;
    const double t = s->t, hmax = s->opt.h_max;
    double h;
    int rejected = 0, cause = CAUSE_NONE, attempts = 0, nsing = 0;
    size_t i;
    LfStatus st;

    if (!(t_bound > t)) return bad_bound(s, t_bound);
    if (!s->fsal_valid) {
        st = ro_prepare(s);
        if (st != LF_OK) return st;
        s->fsal_valid = 1;
    }
    h = s->h;
    if (!(h > 0.0)) h = initial_step(s, f0, y, dy, 4.0, fmin(hmax, t_bound - t));
    if (h > hmax) h = hmax;

    for (;;) {
        double h_prop = h, t_new, hmin, err, fac, hnew, fac_lu, hd, c1, c2, c3, c4, c5;
        int last;
        if (++attempts > LF_MAX_ATTEMPTS) return give_up(s, h, 0.0, cause, 1);
        if (plan_step(s, t_bound, &h, &t_new, &last, &hmin)) return give_up(s, h, hmin, cause, 0);

        /* iteration matrix I/(h*gamma) - J, factorized */
        fac_lu = 1.0 / (h * RO_GAMMA);
        for (i = 0; i < n * n; i++) E[i] = -J[i];
        for (i = 0; i < n; i++) E[i + i * n] += fac_lu;
        s->n_lu++;
        if (lf_lu_factor(E, n, piv) != 0) {
            if (++nsing >= 5) {
                set_msg(s, "rodas4: singular iteration matrix I/(h*gamma) - J at t=%.17g "
                           "(h=%.3g, 5 step reductions)", t, h);
                return LF_DISCARD;
            }
            h *= 0.5;
            rejected = 1;
            cause = CAUSE_SINGULAR;
            s->n_rejected++;
            continue;
        }

        /* stage 1 */
        hd = h * RO_D1;
        for (i = 0; i < n; i++) k1[i] = f0[i] + hd * ft[i];
        lf_lu_solve(E, n, piv, k1);
        /* stage 2 */
        for (i = 0; i < n; i++) y[i] = x[i] + RO_A21 * k1[i];
        st = eval_rhs(s, t + RO_C2 * h, y, dy);
        if (st != LF_OK) goto failed;
        hd = h * RO_D2;
        c1 = RO_C21 / h;
        for (i = 0; i < n; i++) k2[i] = dy[i] + c1 * k1[i] + hd * ft[i];
        lf_lu_solve(E, n, piv, k2);
        /* stage 3 */
        for (i = 0; i < n; i++) y[i] = x[i] + RO_A31 * k1[i] + RO_A32 * k2[i];
        st = eval_rhs(s, t + RO_C3 * h, y, dy);
        if (st != LF_OK) goto failed;
        hd = h * RO_D3;
        c1 = RO_C31 / h;
        c2 = RO_C32 / h;
        for (i = 0; i < n; i++) k3[i] = dy[i] + c1 * k1[i] + c2 * k2[i] + hd * ft[i];
        lf_lu_solve(E, n, piv, k3);
        /* stage 4 */
        for (i = 0; i < n; i++) y[i] = x[i] + RO_A41 * k1[i] + RO_A42 * k2[i] + RO_A43 * k3[i];
        st = eval_rhs(s, t + RO_C4 * h, y, dy);
        if (st != LF_OK) goto failed;
        hd = h * RO_D4;
        c1 = RO_C41 / h;
        c2 = RO_C42 / h;
        c3 = RO_C43 / h;
        for (i = 0; i < n; i++) k4[i] = dy[i] + c1 * k1[i] + c2 * k2[i] + c3 * k3[i] + hd * ft[i];
        lf_lu_solve(E, n, piv, k4);
        /* stage 5 (c5 = 1, d5 = 0) */
        for (i = 0; i < n; i++)
            y[i] = x[i] + RO_A51 * k1[i] + RO_A52 * k2[i] + RO_A53 * k3[i] + RO_A54 * k4[i];
        st = eval_rhs(s, t_new, y, dy);
        if (st != LF_OK) goto failed;
        c1 = RO_C51 / h;
        c2 = RO_C52 / h;
        c3 = RO_C53 / h;
        c4 = RO_C54 / h;
        for (i = 0; i < n; i++) k5[i] = dy[i] + c1 * k1[i] + c2 * k2[i] + c3 * k3[i] + c4 * k4[i];
        lf_lu_solve(E, n, piv, k5);
        /* embedded 3rd-order solution, stage 6 */
        for (i = 0; i < n; i++) y[i] += k5[i];
        st = eval_rhs(s, t_new, y, dy);
        if (st != LF_OK) goto failed;
        c1 = RO_C61 / h;
        c2 = RO_C62 / h;
        c3 = RO_C63 / h;
        c4 = RO_C64 / h;
        c5 = RO_C65 / h;
        for (i = 0; i < n; i++)
            k6[i] = dy[i] + c1 * k1[i] + c2 * k2[i] + c3 * k3[i] + c4 * k4[i] + c5 * k5[i];
        lf_lu_solve(E, n, piv, k6);
        /* new solution (4th order) */
        for (i = 0; i < n; i++) y[i] += k6[i];

        err = err_norm(s, k6, x, y);
        if (!isfinite(err) || !all_finite(y, n)) {
            st = LF_DISCARD;
            goto failed;
        }
        /* Hairer's RODAS controller: 1/5 <= hnew/h <= 6 */
        fac = pow(err, 0.25) / 0.9;
        if (fac > 5.0) fac = 5.0;
        if (fac < 1.0 / 6.0) fac = 1.0 / 6.0;
        hnew = h / fac;
        if (err <= 1.0) {
            double *cont3 = ro_vec(s, RO_CONT3), *cont4 = ro_vec(s, RO_CONT4);
            if (hist[RO_HISTOK] != 0.0) {
                /* predictive controller of Gustafsson */
                double facgus = (hist[RO_HACC] / h) * pow(err * err / hist[RO_ERRACC], 0.25) / 0.9;
                if (facgus > 5.0) facgus = 5.0;
                if (facgus < 1.0 / 6.0) facgus = 1.0 / 6.0;
                fac = fmax(fac, facgus);
                hnew = h / fac;
            }
            hist[RO_HACC] = h;
            hist[RO_ERRACC] = fmax(1e-2, err);
            hist[RO_HISTOK] = 1.0;
            for (i = 0; i < n; i++) {
                cont3[i] = RO_D21 * k1[i] + RO_D22 * k2[i] + RO_D23 * k3[i] + RO_D24 * k4[i] +
                           RO_D25 * k5[i];
                cont4[i] = RO_D31 * k1[i] + RO_D32 * k2[i] + RO_D33 * k3[i] + RO_D34 * k4[i] +
                           RO_D35 * k5[i];
            }
            copy_vec(s->x_old, x, n);
            copy_vec(x, y, n);
            s->t_old = t;
            s->t = t_new;
            if (rejected && hnew > h) hnew = h;
            if (last && !rejected && h_prop > hnew) hnew = h_prop;
            s->h = fmin(hnew, hmax);
            s->fsal_valid = 0; /* f0, J, df/dt are recomputed at the new point */
            s->n_steps++;
            return LF_OK;
        }
        h = hnew;
        rejected = 1;
        cause = CAUSE_ERRTEST;
        s->n_rejected++;
        continue;
    failed:
        if (st != LF_DISCARD) return callback_error(s, st, t + h);
        h *= 0.25;
        rejected = 1;
        cause = CAUSE_NONFINITE;
        s->n_rejected++;
    }
}

static void ro_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = cpriv(s) + RO_NSCAL;
    const double *cont3 = w + RO_CONT3 * n, *cont4 = w + RO_CONT4 * n;
    const double *x0 = s->x_old, *x1 = s->x;
    double h = s->t - s->t_old, th, th1;
    size_t i;
    if (!(h > 0.0)) {
        copy_vec(out, x1, n);
        return;
    }
    th = (tq - s->t_old) / h;
    th1 = 1.0 - th;
    for (i = 0; i < n; i++) out[i] = x0[i] * th1 + th * (x1[i] + th1 * (cont3[i] + th * cont4[i]));
}

const LfMethod lf_rodas4 = {"rodas4", 1, 1, ro_work_size, ro_step, ro_dense};

/* ------------------------------------------------------------------------ */
/* rk4                                                                       */

/* private vectors: k1 (= f(t, x) once valid), k2, k3, k4, stage argument /
 * new state, f(t_old, x_old) for the Hermite interpolant */
enum { RK_K1, RK_K2, RK_K3, RK_K4, RK_Y, RK_FOLD, RK_NVEC };

static size_t rk_work_size(size_t n) { return RK_NVEC * n; }

static LfStatus rk_step(LfSolver *s, double t_bound) {
    const size_t n = s->ode.n;
    double *w = priv(s);
    double *k1 = w + RK_K1 * n, *k2 = w + RK_K2 * n, *k3 = w + RK_K3 * n, *k4 = w + RK_K4 * n;
    double *y = w + RK_Y * n, *fold = w + RK_FOLD * n;
    double *x = s->x;
    const double t = s->t;
    double h = s->opt.h_fixed, t_new, h2;
    size_t i;
    LfStatus st;

    if (!(t_bound > t)) return bad_bound(s, t_bound);
    if (!s->fsal_valid) {
        st = eval_rhs(s, t, x, k1);
        if (st != LF_OK) return start_failure(s, st);
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
    for (i = 0; i < n; i++) y[i] = x[i] + h2 * k1[i];
    st = eval_rhs(s, t + h2, y, k2);
    if (st != LF_OK) goto failed;
    for (i = 0; i < n; i++) y[i] = x[i] + h2 * k2[i];
    st = eval_rhs(s, t + h2, y, k3);
    if (st != LF_OK) goto failed;
    for (i = 0; i < n; i++) y[i] = x[i] + h * k3[i];
    st = eval_rhs(s, t_new, y, k4);
    if (st != LF_OK) goto failed;
    for (i = 0; i < n; i++) y[i] = x[i] + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    st = eval_rhs(s, t_new, y, k2); /* f at the new point: dense output + next k1 */
    if (st != LF_OK) goto failed;

    copy_vec(fold, k1, n);
    copy_vec(k1, k2, n);
    copy_vec(s->x_old, x, n);
    copy_vec(x, y, n);
    s->t_old = t;
    s->t = t_new;
    s->h = s->opt.h_fixed;
    s->n_steps++;
    return LF_OK;
failed:
    if (st != LF_DISCARD) return callback_error(s, st, t_new);
    set_msg(s, "rk4: non-finite values (Inf/NaN) in the right-hand side or the states in the "
               "step from t=%.17g to t=%.17g (h=%.3g)", t, t_new, h);
    return LF_DISCARD;
}

static void rk_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = cpriv(s);
    const double *f1 = w + RK_K1 * n, *f0 = w + RK_FOLD * n;
    const double *x0 = s->x_old, *x1 = s->x;
    double h = s->t - s->t_old, th, th2, th3, h00, h10, h01, h11;
    size_t i;
    if (!(h > 0.0) || !s->fsal_valid) {
        copy_vec(out, x1, n);
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

const LfMethod *const lf_methods[] = {&lf_dopri5, &lf_rodas4, &lf_rk4};
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
        set_msg(s, "no solver method given");
        return LF_ERROR;
    }
    name = m->name;
    if (!alloc || !alloc->calloc || !alloc->free) {
        set_msg(s, "%s: no memory allocator given", name);
        return LF_ERROR;
    }
    if (!ode.rhs || (n > 0 && !x0)) {
        set_msg(s, "%s: right-hand side or initial state missing", name);
        return LF_ERROR;
    }
    if (m->needs_jac && !ode.jac) {
        set_msg(s, "%s needs the Jacobian, but none is available", name);
        return LF_ERROR;
    }
    if (m->adaptive) {
        if (!(opt.rtol > 0.0) || !isfinite(opt.rtol)) {
            set_msg(s, "%s: relative tolerance must be finite and > 0 (got %g)", name, opt.rtol);
            return LF_ERROR;
        }
        if (!(opt.atol > 0.0) || !isfinite(opt.atol)) {
            set_msg(s, "%s: absolute tolerance must be finite and > 0 (got %g)", name, opt.atol);
            return LF_ERROR;
        }
    } else if (!(opt.h_fixed > 0.0) || !isfinite(opt.h_fixed)) {
        set_msg(s, "%s: fixed step size must be finite and > 0 (got %g)", name, opt.h_fixed);
        return LF_ERROR;
    }
    if (!(opt.h_max > 0.0)) {
        set_msg(s, "%s: maximum step size must be > 0 (got %g)", name, opt.h_max);
        return LF_ERROR;
    }
    if (!isfinite(t0)) {
        set_msg(s, "%s: start time not finite", name);
        return LF_ERROR;
    }
    /* guard the n*n terms of the workspace size against overflow */
    if (n > ((size_t)1 << (sizeof(size_t) * 4 - 2))) {
        set_msg(s, "%s: too many states (%lu)", name, (unsigned long)n);
        return LF_ERROR;
    }
    len = 2 * n + m->work_size(n);
    s->work = (double *)alloc->calloc(len > 0 ? len : 1, sizeof(double));
    if (!s->work) {
        set_msg(s, "%s: out of memory (%lu doubles)", name, (unsigned long)len);
        return LF_ERROR;
    }
    s->work_len = len;
    s->x = s->work;
    s->x_old = s->work + n;
    copy_vec(s->x, x0, n);
    copy_vec(s->x_old, x0, n);
    return LF_OK;
}

void lf_solver_reset(LfSolver *s, double t, const double *x) {
    size_t n = s->ode.n;
    if (x != s->x) copy_vec(s->x, x, n);
    copy_vec(s->x_old, s->x, n);
    s->t = s->t_old = t;
    s->fsal_valid = 0;
    if (s->h > s->opt.h_max) s->h = s->opt.h_max;
    if (s->method == &lf_rodas4) ro_clear_history(s);
    s->message[0] = '\0';
}

void lf_solver_free(LfSolver *s, const LfAllocator *alloc) {
    if (!s) return;
    if (s->work && alloc && alloc->free) alloc->free(s->work);
    s->work = s->x = s->x_old = NULL;
    s->work_len = 0;
    s->fsal_valid = 0;
}
