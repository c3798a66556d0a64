/* The C library's math functions on 100000 arguments each (a fixed xorshift
 * generator, the same on every platform): one line per result, its bits in
 * hex.  benchmarks/platforms.py --libm compiles it for each platform, runs it
 * natively, under wine and under qemu-aarch64, and counts the results whose
 * bits differ from the native run's. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#define N 100000

static unsigned long long s;

static double rnd(void) {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return (double)(s >> 11) / 9007199254740992.0;
}

int main(void) {
    static const char *names[] = {"sin", "cos", "tan", "exp", "log", "pow", "sqrt", "atan2",
                                  "atan", "tanh", "asin", "acos", "sinh", "cosh", "log10",
                                  "fmod"};
    int f, i;
    for (f = 0; f < 16; f++) {
        s = 88172645463325252ULL;
        for (i = 0; i < N; i++) {
            double a = (rnd() - 0.5) * 20, b = rnd() * 4, r = 0;
            unsigned long long u;
            switch (f) {
            case 0: r = sin(a); break;
            case 1: r = cos(a); break;
            case 2: r = tan(a); break;
            case 3: r = exp(a); break;
            case 4: r = log(b + 1e-3); break;
            case 5: r = pow(b, a / 4); break;
            case 6: r = sqrt(b); break;
            case 7: r = atan2(a, b - 2); break;
            case 8: r = atan(a); break;
            case 9: r = tanh(a / 4); break;
            case 10: r = asin(b / 4 - 0.5); break;
            case 11: r = acos(b / 4 - 0.5); break;
            case 12: r = sinh(a / 2); break;
            case 13: r = cosh(a / 2); break;
            case 14: r = log10(b + 1e-3); break;
            default: r = fmod(a, b + 0.1); break;
            }
            memcpy(&u, &r, 8);
            printf("%s %08lx%08lx\n", names[f], (unsigned long)(u >> 32),
                   (unsigned long)(u & 0xffffffffUL));
        }
    }
    return 0;
}
