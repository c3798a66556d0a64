/* loomfmu runtime: the bit-level helpers and constants lf_math.c and
 * lf_trig.c share (static, inline: each file has its own copy).  Only exact
 * operations: bits in and out, Dekker's and Knuth's error-free products and
 * sums (no fused multiply-add: the runtime is compiled with
 * -ffp-contract=off). */
#ifndef LF_MATH_BITS_H
#define LF_MATH_BITS_H

#include <string.h>

/* the kernels of lf_sin and lf_cos inlined into them (their arguments stay
 * in registers): the compilers' own spelling of "always inline" */
#if defined(__GNUC__)
#define LF_M_INLINE static inline __attribute__((always_inline))
#elif defined(_MSC_VER)
#define LF_M_INLINE static __forceinline
#else
#define LF_M_INLINE static inline
#endif

typedef unsigned long long u64;

static inline u64 bits_of(double x) {
    u64 u;
    memcpy(&u, &x, sizeof u);
    return u;
}

static inline double of_bits(u64 u) {
    double x;
    memcpy(&x, &u, sizeof x);
    return x;
}

#define TWO_M1022 2.2250738585072014e-308 /* 2^-1022 */
#define TWO_M60 8.673617379884035e-19 /* 2^-60 */
#define TWO_M55 2.7755575615628914e-17 /* 2^-55 */
#define TWO_M54 5.551115123125783e-17 /* 2^-54 */
#define TWO_M29 1.862645149230957e-09 /* 2^-29 */
#define TWO_M28 3.725290298461914e-09 /* 2^-28 */
#define TWO_M27 7.450580596923828e-09 /* 2^-27 */
#define TWO_P28 268435456.0 /* 2^28 */
#define TWO_P500 3.273390607896142e+150 /* 2^500 */
#define TWO_M500 3.054936363499605e-151 /* 2^-500 */
#define TWO_P600 4.149515568880993e+180 /* 2^600 */
#define TWO_M600 2.409919865102884e-181 /* 2^-600 */
#define TWO_P53 9007199254740992.0 /* 2^53 */
#define TWO_M53 1.1102230246251565e-16 /* 2^-53 */
#define TWO_P54 1.8014398509481984e+16 /* 2^54 */
#define TWO_P60 1.152921504606847e+18 /* 2^60 */
#define TWO_P66 7.378697629483821e+19 /* 2^66 */
#define SIGN_BIT 0x8000000000000000ULL
#define ABS_MASK 0x7fffffffffffffffULL

static inline double nan_value(void) { return of_bits(0x7ff8000000000000ULL); }
static inline double fabs_(double x) { return of_bits(bits_of(x) & ABS_MASK); }
static inline int negative(double x) { return (bits_of(x) & SIGN_BIT) != 0; }
static inline int is_nan(double x) { return x != x; }
static inline int exponent_of(double x) { return (int)((bits_of(x) >> 52) & 0x7ff); }

/* 2^k for -1022 <= k <= 1023 */
static inline double pow2(int k) { return of_bits((u64)(k + 1023) << 52); }

/* x 2^k, rounded once (x normal, |k| < 2100) */
static inline double scale2(double x, int k) {
    if (k > 1023) {
        x *= pow2(1023);
        k -= 1023;
        if (k > 1023) return x * pow2(1023) * pow2(k - 1023);
        return x * pow2(k);
    }
    if (k < -1021) return (x * pow2(k + 54)) * pow2(-54);
    return x * pow2(k);
}

/* nearest integer to x (|x| < 2^62), ties away from zero */
static inline long long nearest(double x) { return (long long)(x < 0 ? x - 0.5 : x + 0.5); }

/* a * b = *p + *e exactly (Dekker; no fused multiply-add) */
static inline void two_prod(double a, double b, double *p, double *e) {
    double ca = 134217729.0 * a, cb = 134217729.0 * b;
    double ah = ca - (ca - a), al = a - ah, bh = cb - (cb - b), bl = b - bh;
    *p = a * b;
    *e = ((ah * bh - *p) + ah * bl + al * bh) + al * bl;
}

/* a + b = *s + *e exactly (Knuth) */
static inline void two_sum(double a, double b, double *s, double *e) {
    double bb;
    *s = a + b;
    bb = *s - a;
    *e = (a - (*s - bb)) + (b - bb);
}

#endif
