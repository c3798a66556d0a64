/* loomfmu runtime: dopri5, explicit Dormand-Prince 5(4) with FSAL and
 * Hairer's 4th-order dense output (contract: lf_solver.h). */
#include "lf_solver_impl.h"
#include "lf_math.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

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

/* private vectors: stages k1..k7, stage argument, new state, the accepted
 * step's k1 (k1 holds the next step's, FSAL); then the scalars: log of the
 * last accepted step's error (step-size control) and the accepted step's h
 * (dense output) */
enum { DP_K1, DP_K2, DP_K3, DP_K4, DP_K5, DP_K6, DP_K7, DP_Y, DP_YNEW, DP_K1OLD, DP_NVEC };
enum { DP_S_LERR, DP_S_H, DP_NSCAL };

/* step-size control (lf_dopri5_step.h): Hairer's DOPRI5 defaults, beta =
 * 0.04 (his code's choice for dopri5) and err_old = 1e-4 at a start; build
 * with -DLF_DP_BETA=0 -DLF_DP_SWITCH=0 for the classical controller */
#ifndef LF_DP_BETA
#define LF_DP_BETA 0.04
/* DP_ERR_TINY (below) for beta = 0.04, rounded down: a literal, where a
 * compiler that does not fold exp and log of constants would call them at
 * every step (tests/test_solvers.py checks it against the formula) */
#define DP_ERR_TINY 4.0e-8
#endif
#define DP_BETA ((double)(LF_DP_BETA))
#define DP_EXPO1 (0.2 - DP_BETA * 0.75)
#define DP_LERR_OLD0 (-9.210340371976182) /* log(1e-4) */
/* Below this error 1/fac = err^EXPO1 err_old^-BETA / 0.9 is under 0.1 (the
 * step grows tenfold, its cap) for every err_old >= 1e-4 (the slot's
 * floor), so the step needs neither log nor exp: the models whose steps the
 * communication grid bounds (a two-mass oscillator at 1e-4 s, a shaft) have
 * errors far below it.  Half the bound (8.1e-8 with beta = 0.04: 4.04e-8,
 * the literal 4.0e-8 above); the same result bit for bit (fac = 0.1 either way,
 * and log(err) < log(1e-4) would leave the slot at its floor). */
#ifndef DP_ERR_TINY
#define DP_ERR_TINY (0.5 * lf_exp((lf_ln(0.09) + DP_BETA * DP_LERR_OLD0) / DP_EXPO1))
#endif
/* Where the step is bound by stability rather than accuracy, Hairer's
 * estimate of the stiffness (his DOPRI5's detection: h |lambda| ~ h
 * |k7 - k6| / |y1 - y6|, two points at t + h) is of the order of the
 * stability boundary (3.3 on the negative axis) and the step size
 * oscillates about the boundary: errors grow over a few steps and one is
 * rejected (the spindle: one attempt in five).  Where the estimate exceeds
 * DP_STIFF_HL the step takes Gustafsson's PI gains, beta = 0.08 (1/fac =
 * err^0.14 err_old^-0.08 / 0.9), which damp that oscillation, and Hairer's
 * beta = 0.04 elsewhere, where the stronger gains cost steps (beta = 0.08
 * everywhere: spindle_modal +24 % steps, heald_frame +10 %).  Threshold
 * from a scan of 0.5-3 on the shipped models at rtol 1e-6 (right-hand
 * sides at 1.0 against none: spindle -14 %, heald_frame -2.3 %,
 * heald_frame_planar -2.7 %, backrest_regularized +1.3 %, the rest the
 * same).  -DLF_DP_SWITCH=0 builds Hairer's controller alone. */
#ifndef LF_DP_SWITCH
#define LF_DP_SWITCH 1
#endif
#define DP_STIFF_HL 1.0
#define DP_BETA_S 0.08
#define DP_EXPO1_S (0.2 - DP_BETA_S * 0.75)
/* DP_ERR_TINY for beta = 0.08: half the bound 1.76e-10, rounded down */
#define DP_ERR_TINY_S 8.0e-11

/* A step shortened to land on t_bound (h < h_prop, the size the controller
 * proposed) has an error that says little of the step size's trend: the
 * next step takes h_prop, as before the shortening, unless this step's
 * error predicts that a step of h_prop would fail.  The error estimate
 * scales as h^5, so a step of h_prop would have err (h_prop / h)^5: where
 * that exceeds 1 the next step is the one the controller takes from this
 * step's error, h / fac (within [h/5, h_prop]).  Kept without it, the
 * heald frames' steps after a landing were rejected one in ten (the
 * controller's trend lags where the error constant grows fast: 71 of
 * heald_frame's 1 464 attempts, 64 of heald_frame_planar's 1 523, nearly
 * all right after a landing); now 38 and 36, right-hand sides 8 797 -> 8 653
 * and 9 151 -> 9 109.  Only from landing steps of at least DP_LAND_MIN of
 * the proposal: the error of a much shorter one, scaled by (h_prop / h)^5
 * (1e15 for a thousandth), says nothing where it is rounding (a delayed
 * input at rtol 1e-12, landing on a breakpoint and a communication point
 * every millisecond: the steps shrank to underflow); from a quarter, the
 * next step is at least a tenth of the proposal whatever the error.
 * Where the prediction stays below 1 no log or exp is needed.  Where it
 * stays below DP_LAND_GROW_ERR, h_prop is far inside the tolerance and the
 * next step is the controller's own from this error if that is longer (up
 * to 10 h; dp_land_may_grow): without it a landing with a tiny error never
 * grew the step again (heald_frame_rigid in one communication step, its
 * clock's error near zero: 34 steps against 28; the drive with an input
 * jumping every 0.01 s at rtol 1e-12: 1 577 right-hand sides against
 * 1 217).  Between 0.01 and 1 the proposal is kept: the controller's
 * longer step there was what the heald frames rejected (0.1: heald_frame
 * 47 rejected against 38, the spindle 282 against 247). */
#ifndef LF_DP_LAND_PREDICT
#define LF_DP_LAND_PREDICT 1 /* 0: always h_prop (the tests compare) */
#endif
#define DP_LAND_MIN 0.25
#ifndef LF_DP_LAND_GROW
#define LF_DP_LAND_GROW 1 /* 0: h_prop also where the controller's is longer (tests) */
#endif
#define DP_LAND_GROW_ERR 0.01
static int dp_land_may_grow(double err, double h, double h_prop) { /* err (h_prop/h)^5 */
    double q = h / h_prop, q2 = q * q;
    return err <= DP_LAND_GROW_ERR * q2 * q2 * q;
}
static int dp_land_keeps(double err, double h, double h_prop) {
    double q = h / h_prop, q2 = q * q;
    return !LF_DP_LAND_PREDICT || q < DP_LAND_MIN || err <= q2 * q2 * q;
}

static size_t dp_work_size(size_t n) { return DP_NVEC * n + DP_NSCAL; }

/* The stage sums are loops over the states whose elements do not depend on
 * each other.  GCC's -O2 keeps them scalar (its cheap cost model wants trip
 * counts known at compile time); vectorized, every element's operations are
 * the same, in the same order, so the results are bit for bit the scalar
 * loops'.
 *
 * Each stage's argument must be finite before f is called
 * (lf_sv_eval_rhs_checked): each loop ORs the bits of v * 0 over the
 * elements it forms (lf_sv_nan_bits), an integer OR the vectorizer keeps
 * in the loop (a comparison or a floating-point sum would keep the loop
 * scalar or need a second pass; the second pass was 5 % of heald_frame's
 * run).  The error estimate is scaled in a loop of its own and summed in
 * order after it: lf_sv_err_norm's arithmetic, bit for bit.
 *
 * The models of one or two states (a rigid mechanism, a shaft, a two-mass
 * oscillator, the drive) take one step per communication step or so, on a
 * right-hand side of a few dozen instructions: there the loops' control and
 * the pointers into the work buffer are a fifth of the step.  Builds for
 * n = 1 and 2 as constants let the compiler unroll them (bit for bit the
 * same arithmetic: two_mass_force's run 23.5 M -> 22.6 M instructions).
 * From three states the vectorized build is used (instructions of the
 * limit driver's run, vectorized against scalar: heald_frame_planar, 7
 * states, -1.6 %; backrest, 4, -0.1 %). */
#define DP_BAD(bits) (LF_SV_BITS_BAD(bits) ? (bits = 0, 1) : 0)
/* The vectors the loops read and write are disjoint parts of the work
 * buffer (x, x_old and the private vectors above), which the compiler
 * cannot know: it vectorized each loop twice, with a run-time check of the
 * pointers' overlap choosing the copy.  GCC's ivdep says there is no
 * dependence between iterations: the checks and the scalar copies go (the
 * same arithmetic; instructions of the limit driver's runs: heald_frame
 * -3.6 %, heald_frame_planar -3.0 %, two_mass_force -5.5 %) */
#if defined(__GNUC__) && !defined(__clang__)
#define DP_IVDEP _Pragma("GCC ivdep")
#else
#define DP_IVDEP
#endif
#define DP_STEP_FN dp_step_scalar
#define DP_N s->ode.n
#include "lf_dopri5_step.h"
#undef DP_STEP_FN
#undef DP_N
#define DP_STEP_FN dp_step_1
#define DP_N 1
#include "lf_dopri5_step.h"
#undef DP_STEP_FN
#undef DP_N
#define DP_STEP_FN dp_step_2
#define DP_N 2
#include "lf_dopri5_step.h"
#undef DP_STEP_FN
#undef DP_N
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC push_options
#pragma GCC optimize("tree-vectorize", "vect-cost-model=dynamic")
#define DP_STEP_FN dp_step_vector
#define DP_N s->ode.n
#include "lf_dopri5_step.h"
#undef DP_STEP_FN
#undef DP_N
#pragma GCC pop_options
#define DP_HAVE_VECTOR 1
/* The same step for x86-64 processors with AVX2 (4 doubles a vector against
 * SSE2's 2; every x86-64 has SSE2, most since 2013 have AVX2), chosen at run
 * time (__builtin_cpu_supports), so the FMU still runs on any x86-64.  The
 * same operations in the same order, without FMA (-std=c99 contracts no
 * a * b + c): bit for bit the SSE2 build's results.  From DP_AVX2_MIN_N
 * states, where it pays in time, not only in instructions (the limit
 * driver's run, best of 21, AVX2 against SSE2: the spindle, 69 states,
 * -6 % time, -13 % instructions; spindle_modal, 17, -1.5 % time;
 * heald_frame, 13, +3 % time for -7 % instructions, its vectors of 13 with
 * their tails; heald_frame_planar, 7, +0.9 % instructions).
 * -DLF_DP_AVX2=0 leaves it out. */
#ifndef LF_DP_AVX2
#define LF_DP_AVX2 1
#endif
#if LF_DP_AVX2 && defined(__x86_64__)
#pragma GCC push_options
#pragma GCC target("avx2")
#pragma GCC optimize("tree-vectorize", "vect-cost-model=dynamic")
#define DP_STEP_FN dp_step_avx2
#define DP_N s->ode.n
#include "lf_dopri5_step.h"
#undef DP_STEP_FN
#undef DP_N
#pragma GCC pop_options
#define DP_HAVE_AVX2 1
#define DP_AVX2_MIN_N 16
#endif
#endif
/* states from which the vectorized step pays (above) */
#define DP_VECTOR_MIN_N 3

static LfStatus dp_step_any(LfSolver *s, double t_bound) {
    if (s->ode.n == 1) return dp_step_1(s, t_bound);
    if (s->ode.n == 2) return dp_step_2(s, t_bound);
#ifdef DP_HAVE_AVX2
    if (s->ode.n >= DP_AVX2_MIN_N && __builtin_cpu_supports("avx2"))
        return dp_step_avx2(s, t_bound);
#endif
#ifdef DP_HAVE_VECTOR
    if (s->ode.n >= DP_VECTOR_MIN_N) return dp_step_vector(s, t_bound);
#endif
    return dp_step_scalar(s, t_bound);
}

/* A step that failed leaves t and x at the last accepted point, but its
 * attempts overwrote the stages the dense output of the last step is made
 * of (dp_dense): the interval shrinks to that point (the dense output is
 * x there), never a mix of two steps. */
static LfStatus dp_step(LfSolver *s, double t_bound) {
    LfStatus st = dp_step_any(s, t_bound);
    if (st != LF_OK) {
        s->t_old = s->t;
        lf_sv_copy_vec(s->x_old, s->x, s->ode.n);
    }
    return st;
}

/* Hairer's CONTD5 from the accepted step's stages, which stay in the work
 * buffer until the next step starts (the step stores no coefficients: most
 * runs never read the dense output between two steps, the event scans read
 * it once in a while).  The same arithmetic as coefficients stored at the
 * step's end: bit for bit the same values.  (Not after steps taken with
 * s->dense_unused set.) */
static void dp_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = LF_CPRIV(s);
    const double *k1 = w + DP_K1OLD * n, *k3 = w + DP_K3 * n, *k4 = w + DP_K4 * n;
    const double *k5 = w + DP_K5 * n, *k6 = w + DP_K6 * n, *k7 = w + DP_K7 * n;
    const double *x0 = s->x_old, *x1 = s->x, hs = w[DP_NVEC * n + DP_S_H];
    double h = s->t - s->t_old, th, th1;
    size_t i;
    if (!(h > 0.0)) {
        lf_sv_copy_vec(out, x1, n);
        return;
    }
    th = (tq - s->t_old) / h;
    th1 = 1.0 - th;
    for (i = 0; i < n; i++) {
        double dy = x1[i] - x0[i];
        double r3 = hs * k1[i] - dy, r4 = dy - hs * k7[i] - r3;
        double r5 = hs * (DP_D1 * k1[i] + DP_D3 * k3[i] + DP_D4 * k4[i] + DP_D5 * k5[i] +
                          DP_D6 * k6[i] + DP_D7 * k7[i]);
        out[i] = x0[i] + th * (dy + th1 * (r3 + th * (r4 + th1 * r5)));
    }
}

const LfMethod lf_dopri5 = {"dopri5", 1, 0, dp_work_size, dp_step, dp_dense};
