/* loomfmu runtime: what the solver files (lf_solver_common.c: helpers; lf_solvers.c: rk4,
 * registry and life cycle; lf_dopri5.c; lf_rodas4.c; lf_wmethod.c) share.  Not part of
 * the solver contract, which is lf_solver.h. */
#ifndef LF_SOLVER_IMPL_H
#define LF_SOLVER_IMPL_H

#include "lf_solver.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define LF_UROUND DBL_EPSILON
/* Give up a single step after this many failed attempts (guards against
 * endless halving when t == 0 makes the relative underflow test vacuous). */
#define LF_MAX_ATTEMPTS 200

/* method-private data: after x and x_old in the work buffer */
#define LF_PRIV(s) ((s)->work + 2 * (s)->ode.n)
#define LF_CPRIV(s) ((const double *)((s)->work + 2 * (s)->ode.n))

enum { CAUSE_NONE, CAUSE_ERRTEST, CAUSE_NONFINITE, CAUSE_SINGULAR };

extern const LfMethod lf_dopri5;
extern const LfMethod lf_rodas4;
extern const LfMethod lf_rk4;
extern const LfMethod lf_ros34pw2;

void lf_sv_set_msg(LfSolver *s, const char *fmt, ...);
void lf_sv_copy_vec(double *dst, const double *src, size_t n);
/* f at (t, x): LF_OK only with finite values; LF_DISCARD for non-finite
 * arguments/results or an f that reports LF_DISCARD; errors passed through.
 * Inline: every stage of every method calls it. */
static inline LfStatus lf_sv_eval_rhs_checked(LfSolver *s, double t, const double *x,
                                              double *dx, int x_bad);
static inline LfStatus lf_sv_eval_rhs(LfSolver *s, double t, const double *x, double *dx) {
    return lf_sv_eval_rhs_checked(s, t, x, dx, !lf_all_finite(x, s->ode.n));
}
/* 1 if v is not finite (isfinite's answer as an expression that vectorizes:
 * a method that forms x in a loop checks it there, LF_SV_NOT_FINITE ORed
 * over the elements, and passes the result as x_bad) */
#define LF_SV_NOT_FINITE(v) (!(fabs(v) <= DBL_MAX))
/* The bits of v * 0: +-0 (no exponent bits) for a finite v, a NaN (every
 * exponent bit) otherwise.  ORed over a loop's elements, an integer OR that
 * the vectorizer keeps in vector registers where a branch or a comparison
 * would keep the loop scalar; LF_SV_BITS_BAD(acc) is 1 if one element was
 * not finite (the same FE_INVALID caveat as lf_all_finite). */
static inline uint64_t lf_sv_nan_bits(double v) {
    double z = v * 0.0;
    uint64_t b;
    memcpy(&b, &z, sizeof b);
    return b;
}
#define LF_SV_BITS_BAD(acc) (((acc) & UINT64_C(0x7ff0000000000000)) != 0)
/* lf_sv_eval_rhs where the caller checked x: x_bad != 0 gives LF_DISCARD */
static inline LfStatus lf_sv_eval_rhs_checked(LfSolver *s, double t, const double *x,
                                              double *dx, int x_bad) {
    LfStatus st;
    if (x_bad) return LF_DISCARD;
    s->n_rhs++;
    st = s->ode.rhs(s->ode.ctx, t, x, dx);
    if (st == LF_OK || st == LF_WARNING)
        return s->rhs_finite || lf_all_finite(dx, s->ode.n) ? LF_OK : LF_DISCARD;
    if (st == LF_DISCARD) return LF_DISCARD;
    return st == LF_FATAL ? LF_FATAL : LF_ERROR;
}
/* Hairer's weighted RMS norm of err, scale atol + rtol max(|y0|, |y1|) */
double lf_sv_err_norm(const LfSolver *s, const double *err, const double *y0, const double *y1);
/* automatic initial step (Hairer's HINIT); f0 = f(t, x), y1, f1 scratch */
double lf_sv_initial_step(LfSolver *s, const double *f0, double *y1, double *f1, double order,
                          double hmax);
LfStatus lf_sv_bad_bound(LfSolver *s, double t_bound);
LfStatus lf_sv_start_failure(LfSolver *s, LfStatus st);
LfStatus lf_sv_callback_error(LfSolver *s, LfStatus st, double t_at);
LfStatus lf_sv_give_up(LfSolver *s, double h, double hmin, int cause, int too_many);
/* limit h to the remaining interval; 1: step size underflow, give up */
int lf_sv_plan_step(const LfSolver *s, double t_bound, double *h, double *t_new, int *last,
                    double *hmin);
/* forget rodas4's step-size controller history (after a restart) */
void lf_rodas4_clear_history(LfSolver *s);
/* ros34pw2 after a restart: forget the controller history, keep J and the
 * factorization (a W-method keeps its order with any matrix) */
void lf_ros34pw2_restart(LfSolver *s);

#endif
