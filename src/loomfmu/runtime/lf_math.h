/* loomfmu runtime: the elementary functions of the generated code and the
 * solvers, the same bits on every platform.
 *
 * The C library's sin, exp, log, ... differ between platforms in the last
 * bit (glibc against msvcrt and wine's msvcrt), and an adaptive solver can
 * turn one differing bit into a different step sequence: a result differing
 * by the solver's tolerance.  These functions use only the operations IEEE
 * 754 rounds exactly (+ - * / and sqrt, in the order written; the runtime is
 * compiled with -ffp-contract=off), so every platform computes the same bits.
 * Defined in lf_math.c (exp, log, pow, hyperbolic, hypot) and lf_trig.c (sin,
 * cos, tan and their inverses), with the helpers of lf_math_bits.h.
 * codegen.py rewrites the generated model code to call them
 * (codegen.MATH_FUNCTIONS; sin and cos of one value become one lf_sincos,
 * codegen.pair_sin_cos); functions outside this list stay the C library's.
 *
 * Accuracy against the exact value, in units in the last place (measured by
 * benchmarks/math_functions.py and checked by tests/test_lf_math.py): sin,
 * cos, exp, log, atan, hypot below 1 ulp, pow below 1.2 ulp; the others
 * within about 2 ulp.  Special values
 * (NaN, +-Inf, +-0, subnormal arguments) follow C99 Annex F; a NaN result
 * of a non-NaN argument is always the same quiet NaN, and a NaN argument is
 * returned as it is (the hardware's own NaNs differ in sign between x86-64
 * and aarch64).  sin, cos and tan reduce every finite argument accurately.
 *
 * No state; only libc's sqrt (exactly rounded everywhere). */
#ifndef LF_MATH_H
#define LF_MATH_H

#include "lf_prefix.h"

double lf_sin(double x);
double lf_cos(double x);
/* lf_sin(x) and lf_cos(x), the same bits, with one argument reduction */
void lf_sincos(double x, double *s, double *c);
double lf_tan(double x);
double lf_asin(double x);
double lf_acos(double x);
double lf_atan(double x);
double lf_atan2(double y, double x);
double lf_sinh(double x);
double lf_cosh(double x);
double lf_tanh(double x);
double lf_exp(double x);
double lf_expm1(double x);
/* natural logarithm (lf_log is the runtime's logger) */
double lf_ln(double x);
double lf_log1p(double x);
double lf_log10(double x);
double lf_pow(double x, double y);
double lf_hypot(double x, double y);
double lf_asinh(double x);
double lf_acosh(double x);
double lf_atanh(double x);

#endif
