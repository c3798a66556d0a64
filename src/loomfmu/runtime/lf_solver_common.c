/* loomfmu runtime: the helpers every solver method shares (lf_solvers.c's
 * rk4, lf_dopri5.c, lf_rosenbrock.c and the methods on it): messages, error
 * norms, the initial step, step planning and failure reports.  Declared in
 * lf_solver_impl.h.  They call nothing of the methods: the registry
 * (lf_solvers.c) sits on top of the methods, and the methods on these. */
#include "lf_solver_impl.h"
#include "lf_math.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* helpers                                                                   */

void lf_sv_set_msg(LfSolver *s, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(s->message, sizeof s->message, fmt, ap);
    va_end(ap);
}

void lf_sv_copy_vec(double *dst, const double *src, size_t n) {
    if (n) memmove(dst, src, n * sizeof(double));
}

/* (lf_sv_eval_rhs: inline in lf_solver_impl.h, called at every stage) */

/* Hairer's weighted RMS norm of err with scale atol + rtol*max(|y0|,|y1|). */
double lf_sv_err_norm(const LfSolver *s, const double *err, const double *y0,
                       const double *y1) {
    size_t i, n = s->ode.n;
    double sum = 0.0;
    if (n == 0) return 0.0;
    for (i = 0; i < n; i++) {
        double a0 = fabs(y0[i]), a1 = fabs(y1[i]); /* fmax(a0, a1) (a library call) */
        double sk = s->opt.atol + s->opt.rtol * (a1 != a1 || a0 > a1 ? a0 : a1);
        double q = err[i] / sk;
        sum += q * q;
    }
    return sqrt(sum / (double)n);
}

/* Automatic initial step (Hairer's HINIT, with RMS norms as in scipy).
 * f0 = f(t, x); y1, f1 are scratch vectors.  order: order of the method. */
double lf_sv_initial_step(LfSolver *s, const double *f0, double *y1, double *f1,
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
    if (lf_sv_eval_rhs(s, s->t + h0, y1, f1) != LF_OK) return h0;
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
        h1 = lf_pow(0.01 / dmax, 1.0 / order);
    return fmin(fmin(100.0 * h0, h1), hmax);
}

LfStatus lf_sv_bad_bound(LfSolver *s, double t_bound) {
    lf_sv_set_msg(s, "%s: invalid use: t_bound = %.17g is not after t = %.17g", s->method->name,
            t_bound, s->t);
    return LF_ERROR;
}

/* f failed at the accepted point itself: no step size can help. */
LfStatus lf_sv_start_failure(LfSolver *s, LfStatus st) {
    if (st == LF_DISCARD)
        lf_sv_set_msg(s, "%s: right-hand side not finite (or not evaluable) at the current point t=%.17g",
                s->method->name, s->t);
    else
        lf_sv_set_msg(s, "%s: right-hand side returned an error at t=%.17g", s->method->name, s->t);
    return st;
}

LfStatus lf_sv_callback_error(LfSolver *s, LfStatus st, double t_at) {
    lf_sv_set_msg(s, "%s: right-hand side returned an error at t=%.17g (step from t=%.17g)",
            s->method->name, t_at, s->t);
    return st;
}

static const char *cause_text(int cause) {
    switch (cause) {
    case CAUSE_NONFINITE:
        return "non-finite values (Inf/NaN) in the right-hand side or the states";
    case CAUSE_SINGULAR:
        return "singular iteration matrix";
    case CAUSE_ERRTEST:
        return "local error test failed repeatedly (singularity, blow-up, discontinuity, or an "
               "input or parameter far outside its range?)";
    default:
        return "the step size control asks for ever smaller steps (blow-up, singularity, or an "
               "input or parameter far outside its range?)";
    }
}

/* Step-size underflow or too many failed attempts: give up the step. */
LfStatus lf_sv_give_up(LfSolver *s, double h, double hmin, int cause, int too_many) {
    if (too_many)
        lf_sv_set_msg(s, "%s: step failed at t=%.17g after %d attempts (h=%.3g): %s", s->method->name,
                s->t, LF_MAX_ATTEMPTS, h, cause_text(cause));
    else if (h < hmin)
        lf_sv_set_msg(s, "%s: step size underflow at t=%.17g (h=%.3g < %.3g): %s", s->method->name,
                s->t, h, hmin, cause_text(cause));
    else /* t + h == t: at t = 0 the relative bound hmin is 0 */
        lf_sv_set_msg(s, "%s: step size underflow at t=%.17g (h=%.3g no longer moves t): %s",
                s->method->name, s->t, h, cause_text(cause));
    return LF_DISCARD;
}

/* Common preamble of an adaptive step attempt: limit h to the remaining
 * interval (stepping exactly to t_bound when close) and check underflow.
 * Returns 0 to go on, 1 to give up. */
int lf_sv_plan_step(const LfSolver *s, double t_bound, double *h, double *t_new, int *last,
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
