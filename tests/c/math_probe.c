/* The runtime's elementary functions (lf_math.c) on fixed arguments: special
 * values, then N arguments per function from a fixed xorshift generator (the
 * same on every platform).  One line per call: the function, the bits of its
 * arguments and of its result, in hex.  Built with -DPROBE_LIBM it calls the
 * C library's functions instead.  tests/test_lf_math.py runs it natively,
 * under wine and under qemu-aarch64; benchmarks/platforms.py --libm counts
 * the results of both builds that differ between platforms. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lf_math.h"

#ifdef PROBE_LIBM
#define F(ours, libm) libm
#else
#define F(ours, libm) ours
#endif

static unsigned long long s;

static double rnd(void) {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return (double)(s >> 11) / 9007199254740992.0;
}

static unsigned long long bits(double x) {
    unsigned long long u;
    memcpy(&u, &x, sizeof u);
    return u;
}

/* x's bits in hex (two halves: msvcrt's printf has no %llx) */
static void put(double x) {
    unsigned long long u = bits(x);
    printf(" %08lx%08lx", (unsigned long)(u >> 32), (unsigned long)(u & 0xffffffffUL));
}

static void line(int f, double a, double b, double r);

static double of_bits(unsigned long long u) {
    double x;
    memcpy(&x, &u, sizeof x);
    return x;
}

static const char *names[] = {"sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh",
                              "cosh", "tanh", "exp", "expm1", "log", "log1p", "log10", "pow",
                              "hypot", "asinh", "acosh", "atanh"};
#define NF 20
#define BINARY(f) ((f) == 6 || (f) == 15 || (f) == 16)

static double call(int f, double a, double b) {
    switch (f) {
    case 0: return F(lf_sin, sin)(a);
    case 1: return F(lf_cos, cos)(a);
    case 2: return F(lf_tan, tan)(a);
    case 3: return F(lf_asin, asin)(a);
    case 4: return F(lf_acos, acos)(a);
    case 5: return F(lf_atan, atan)(a);
    case 6: return F(lf_atan2, atan2)(a, b);
    case 7: return F(lf_sinh, sinh)(a);
    case 8: return F(lf_cosh, cosh)(a);
    case 9: return F(lf_tanh, tanh)(a);
    case 10: return F(lf_exp, exp)(a);
    case 11: return F(lf_expm1, expm1)(a);
    case 12: return F(lf_ln, log)(a);
    case 13: return F(lf_log1p, log1p)(a);
    case 14: return F(lf_log10, log10)(a);
    case 15: return F(lf_pow, pow)(a, b);
    case 16: return F(lf_hypot, hypot)(a, b);
    case 17: return F(lf_asinh, asinh)(a);
    case 18: return F(lf_acosh, acosh)(a);
    default: return F(lf_atanh, atanh)(a);
    }
}

/* a random argument of function f: u, v uniform in [0, 1) */
static void draw(int f, double u, double v, double *a, double *b) {
    double w = rnd();
    *b = 0.0;
    switch (f) {
    case 0: case 1: *a = (u - 0.5) * (w < 0.8 ? 40.0 : 3e6); break;
    case 2: *a = (u - 0.5) * 8.0; break;
    case 3: case 4: *a = 2.0 * u - 1.0; break;
    case 5: *a = (u - 0.5) * (w < 0.8 ? 10.0 : 1e6); break;
    case 6: *a = (u - 0.5) * 4.0; *b = (v - 0.5) * 4.0; break;
    case 7: case 8: case 9: *a = (u - 0.5) * (w < 0.8 ? 6.0 : 1400.0); break;
    case 10: *a = (u - 0.5) * (w < 0.5 ? 4.0 : 1500.0); break;
    case 11: *a = (u - 0.5) * (w < 0.5 ? 2.0 : 100.0); break;
    case 12: case 14: *a = w < 0.5 ? 0.5 + u : lf_exp((u - 0.5) * 1400.0); break;
    case 13: *a = w < 0.5 ? (u - 0.5) * 1e-3 : u * 10.0 - 0.999; break;
    case 16: *a = (u - 0.5) * 1e3; *b = (v - 0.5) * (w < 0.5 ? 1e3 : 1e-3); break;
    case 17: *a = (u - 0.5) * (w < 0.5 ? 4.0 : 1e6); break;
    case 18: *a = 1.0 + u * (w < 0.5 ? 2.0 : 1e6); break;
    case 19: *a = 2.0 * u - 1.0; break;
    default:
        *a = w < 0.5 ? 4.0 * u : lf_exp((u - 0.5) * 40.0);
        *b = (v - 0.5) * (w < 0.5 ? 20.0 : 30.0);
        if (w > 0.8) { /* |y log x| up to 700: the result near overflow or underflow */
            *a = 0.5 + 1.5 * u;
            *b = (v - 0.5) * 1400.0 / (lf_ln(*a) == 0.0 ? 1.0 : lf_ln(*a));
        }
        if (rnd() < 0.1) { /* negative bases with integer exponents */
            *a = -*a;
            *b = (double)(long long)*b;
        }
        break;
    }
}

static void line(int f, double a, double b, double r) {
    printf("%s", names[f]);
    put(a);
    put(b);
    put(r);
    printf("\n");
}

int main(int argc, char **argv) {
    /* special arguments, as bits: +-0, +-min subnormal, +-min normal, +-1,
     * +-0.5, +-max, +-Inf, NaN, 710, -746, 1e300, -1e-300, 3e8 */
    static const unsigned long long special[] = {
        0x0000000000000000ULL, 0x8000000000000000ULL, 0x0000000000000001ULL,
        0x8000000000000001ULL, 0x0010000000000000ULL, 0x8010000000000000ULL,
        0x3ff0000000000000ULL, 0xbff0000000000000ULL, 0x3fe0000000000000ULL,
        0xbfe0000000000000ULL, 0x7fefffffffffffffULL, 0xffefffffffffffffULL,
        0x7ff0000000000000ULL, 0xfff0000000000000ULL, 0x7ff8000000000000ULL,
        0x4086300000000000ULL, 0xc087500000000000ULL, 0x7e37e43c8800759cULL,
        0x81a56e1fc2f8f359ULL, 0x41b1e1a300000000ULL};
    int n = argc > 1 ? atoi(argv[1]) : 1000, f, i, j, ns = sizeof special / sizeof *special;
    for (f = 0; f < NF; f++) {
        int binary = BINARY(f);
        for (i = 0; i < ns; i++)
            for (j = 0; j < (binary ? ns : 1); j++) {
                double a = of_bits(special[i]), b = binary ? of_bits(special[j]) : 0.0;
                line(f, a, b, call(f, a, b));
            }
        s = 88172645463325252ULL + (unsigned long long)f;
        for (i = 0; i < n; i++) {
            double a, b, u = rnd(), v = rnd();
            draw(f, u, v, &a, &b);
            line(f, a, b, call(f, a, b));
        }
    }
    return 0;
}
