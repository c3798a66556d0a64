/* loomfmu runtime: sin, cos, tan, atan, atan2, asin and acos, the same bits
 * on every platform (see lf_math.h, which declares them).  sin and cos reduce
 * x = n pi/2 + (y0 + y1) with pi/2 in three 33-bit parts (each n * part
 * exact) below |x| = 2^20 pi/2, with Payne and Hanek's method above (2/pi to
 * 1 216 bits), then odd and even polynomials with y1 as a first-order
 * correction.  atan uses five intervals (breakpoints 7/16, 11/16, 19/16,
 * 39/16) around atan(0), atan(1/2), atan(1), atan(3/2), atan(inf).
 * Coefficients: lf_math_coeffs.h. */
#include "lf_math.h"

#include <math.h> /* HUGE_VAL, sqrt */

#include "lf_math_bits.h"
#include "lf_math_coeffs.h"

/* ---------------------------------------------------------- sin and cos */

/* sin(x + y), |x| <= pi/4 (about), |y| below half an ulp of x */
LF_M_INLINE double sin_kernel(double x, double y) {
    double z = x * x, v = z * x, z2 = z * z; /* Estrin's scheme: a shorter chain */
    double r = (LF_M_SIN1 + z * LF_M_SIN2) + z2 * ((LF_M_SIN3 + z * LF_M_SIN4)
               + z2 * (LF_M_SIN5 + z * LF_M_SIN6));
    return x - ((z * (0.5 * y - v * r) - y) - v * LF_M_SIN0);
}

/* cos(x + y) */
LF_M_INLINE double cos_kernel(double x, double y) {
    double z = x * x, hz = 0.5 * z, w = 1.0 - hz, z2 = z * z;
    double r = z * ((LF_M_COS0 + z * LF_M_COS1) + z2 * ((LF_M_COS2 + z * LF_M_COS3)
               + z2 * ((LF_M_COS4 + z * LF_M_COS5) + z2 * LF_M_COS6)));
    return w + (((1.0 - w) - hz) + (z * r - x * y));
}

static const unsigned long two_over_pi[LF_M_TWO_OVER_PI_WORDS] = {LF_M_TWO_OVER_PI_BITS};

/* bits p .. p+31 of 2/pi (bit 1 is the first after the binary point) */
static u64 two_over_pi_bits(int p) {
    int w = (p - 1) / 32, off = (p - 1) % 32;
    u64 hi = two_over_pi[w], lo = w + 1 < LF_M_TWO_OVER_PI_WORDS ? two_over_pi[w + 1] : 0;
    return (((hi << 32) | lo) >> (32 - off)) & 0xffffffffULL;
}

/* bits pos .. pos+count-1 (count <= 53) of a number in 32-bit limbs, least
 * significant limb first */
static u64 limb_bits(const u64 *limbs, int pos, int count) {
    u64 r = 0;
    int k;
    for (k = count - 1; k >= 0; k--)
        r = (r << 1) | ((limbs[(pos + k) / 32] >> ((pos + k) % 32)) & 1);
    return r;
}

/* Payne and Hanek's reduction for |x| >= 2^20 pi/2: |x| = m 2^t with m an
 * integer of 53 bits; x 2/pi mod 4 needs only the bits of 2/pi from t - 1 on,
 * since m 2^t times earlier bits is a multiple of 4.  W, 192 bits of 2/pi
 * from there, times m in 32-bit limbs gives n (two bits) and the fraction to
 * 159 bits (the truncated bits of 2/pi weigh under 2^-139). */
static int trig_reduce_huge(double x, double *y0, double *y1) {
    u64 u = bits_of(x), m = (u & 0x000fffffffffffffULL) | 0x0010000000000000ULL;
    u64 w[6], prod[8] = {0}, mj, carry, a;
    int t = (int)((u >> 52) & 0x7ff) - 1075, p0 = t - 1 > 1 ? t - 1 : 1, sh, i, j, n;
    double fh, fl, f2, sum, err, ph, pe;
    for (i = 0; i < 6; i++) w[i] = two_over_pi_bits(p0 + 32 * (5 - i));
    for (j = 0; j < 2; j++) {
        mj = j ? m >> 32 : m & 0xffffffffULL;
        carry = 0;
        for (i = 0; i < 6; i++) {
            a = prod[i + j] + w[i] * mj + carry; /* < 2^64 */
            prod[i + j] = a & 0xffffffffULL;
            carry = a >> 32;
        }
        prod[6 + j] += carry;
    }
    sh = p0 + 191 - t; /* x 2/pi = prod 2^-sh (mod 4) */
    n = (int)limb_bits(prod, sh, 2);
    fh = (double)limb_bits(prod, sh - 53, 53) * TWO_M53;
    fl = (double)limb_bits(prod, sh - 106, 53) * TWO_M53 * TWO_M53;
    f2 = (double)limb_bits(prod, sh - 159, 53) * TWO_M53 * TWO_M53 * TWO_M53;
    if (fh >= 0.5) { /* the nearest multiple of pi/2 is the next one */
        fh -= 1.0;
        n += 1;
    }
    sum = fh + fl;
    err = (fl - (sum - fh)) + f2;
    two_prod(sum, LF_M_PIO2_HI, &ph, &pe);
    pe += sum * LF_M_PIO2_LO + err * LF_M_PIO2_HI;
    *y0 = ph + pe;
    *y1 = pe - (*y0 - ph);
    if (negative(x)) {
        *y0 = -*y0;
        *y1 = -*y1;
        n = -n;
    }
    return n & 3;
}

/* x = n pi/2 + y0 + y1 for finite x; returns n mod 4 */
LF_M_INLINE int trig_reduce(double x, double *y0, double *y1) {
    double fn, r, w, t;
    int ex;
    long long n;
    if (fabs_(x) <= 0.7853981633974483) {
        *y0 = x;
        *y1 = 0.0;
        return 0;
    }
    if (fabs_(x) >= 1647099.0) return trig_reduce_huge(x, y0, y1); /* 2^20 pi/2 */
    n = nearest(x * LF_M_TWO_OVER_PI);
    fn = (double)n;
    ex = exponent_of(x);
    r = x - fn * LF_M_PIO2_1; /* exact while |n| < 2^20 */
    w = fn * LF_M_PIO2_1T;
    *y0 = r - w;
    if (ex - exponent_of(*y0) > 16) { /* cancellation: the next 33 bits */
        t = r;
        w = fn * LF_M_PIO2_2;
        r = t - w;
        w = fn * LF_M_PIO2_2T - ((t - r) - w);
        *y0 = r - w;
        if (ex - exponent_of(*y0) > 49) {
            t = r;
            w = fn * LF_M_PIO2_3;
            r = t - w;
            w = fn * LF_M_PIO2_3T - ((t - r) - w);
            *y0 = r - w;
        }
    }
    *y1 = (r - *y0) - w;
    return (int)(n & 3);
}

double lf_sin(double x) {
    double ax = fabs_(x), y0, y1;
    if (ax <= 0.7853981633974483) return ax < TWO_M27 ? x : sin_kernel(x, 0.0);
    if (!(ax < HUGE_VAL)) return is_nan(x) ? x : nan_value();
    switch (trig_reduce(x, &y0, &y1)) {
    case 0: return sin_kernel(y0, y1);
    case 1: return cos_kernel(y0, y1);
    case 2: return -sin_kernel(y0, y1);
    default: return -cos_kernel(y0, y1);
    }
}

double lf_cos(double x) {
    double ax = fabs_(x), y0, y1;
    if (ax <= 0.7853981633974483) return ax < TWO_M27 ? 1.0 : cos_kernel(x, 0.0);
    if (!(ax < HUGE_VAL)) return is_nan(x) ? x : nan_value();
    switch (trig_reduce(x, &y0, &y1)) {
    case 0: return cos_kernel(y0, y1);
    case 1: return -sin_kernel(y0, y1);
    case 2: return -cos_kernel(y0, y1);
    default: return sin_kernel(y0, y1);
    }
}

void lf_sincos(double x, double *s, double *c) {
    double ax = fabs_(x), y0, y1, ks, kc;
    int n;
    if (ax <= 0.7853981633974483) {
        *s = ax < TWO_M27 ? x : sin_kernel(x, 0.0);
        *c = ax < TWO_M27 ? 1.0 : cos_kernel(x, 0.0);
        return;
    }
    if (!(ax < HUGE_VAL)) {
        *s = *c = is_nan(x) ? x : nan_value();
        return;
    }
    n = trig_reduce(x, &y0, &y1); /* once for both */
    ks = sin_kernel(y0, y1);
    kc = cos_kernel(y0, y1);
    switch (n) {
    case 0: *s = ks; *c = kc; break;
    case 1: *s = kc; *c = -ks; break;
    case 2: *s = -ks; *c = -kc; break;
    default: *s = -kc; *c = ks; break;
    }
}

double lf_tan(double x) {
    double y0, y1;
    int n;
    if (is_nan(x)) return x;
    if (fabs_(x) == HUGE_VAL) return nan_value();
    if (fabs_(x) < TWO_M27) return x;
    n = trig_reduce(x, &y0, &y1);
    if (n & 1) return -cos_kernel(y0, y1) / sin_kernel(y0, y1);
    return sin_kernel(y0, y1) / cos_kernel(y0, y1);
}

/* ---------------------------------------------------------- atan family */

double lf_atan(double x) {
    static const double hi[4] = {LF_M_ATAN_HALF_HI, LF_M_PIO4_HI, LF_M_ATAN_3HALF_HI,
                                 LF_M_PIO2_HI};
    static const double lo[4] = {LF_M_ATAN_HALF_LO, LF_M_PIO4_LO, LF_M_ATAN_3HALF_LO,
                                 LF_M_PIO2_LO};
    double ax = fabs_(x), t, z, a, res;
    int id;
    if (is_nan(x)) return x;
    if (ax >= TWO_P66) return negative(x) ? -LF_M_PIO2_HI : LF_M_PIO2_HI;
    if (ax < 0.4375) {
        if (ax < TWO_M29) return x;
        id = -1;
        t = x;
    } else if (ax < 0.6875) {
        id = 0;
        t = (2.0 * ax - 1.0) / (2.0 + ax);
    } else if (ax < 1.1875) {
        id = 1;
        t = (ax - 1.0) / (ax + 1.0);
    } else if (ax < 2.4375) {
        id = 2;
        t = (ax - 1.5) / (1.0 + 1.5 * ax);
    } else {
        id = 3;
        t = -1.0 / ax;
    }
    z = t * t;
    a = z * (LF_M_ATAN0 + z * (LF_M_ATAN1 + z * (LF_M_ATAN2 + z * (LF_M_ATAN3 + z * (LF_M_ATAN4
        + z * (LF_M_ATAN5 + z * (LF_M_ATAN6 + z * (LF_M_ATAN7 + z * (LF_M_ATAN8 + z * (LF_M_ATAN9
        + z * (LF_M_ATAN10 + z * LF_M_ATAN11)))))))))));
    if (id < 0) return t + t * a;
    res = hi[id] + ((t * a + lo[id]) + t);
    return negative(x) ? -res : res;
}

double lf_atan2(double y, double x) {
    double z, res;
    int ny = negative(y);
    if (is_nan(x)) return x;
    if (is_nan(y)) return y;
    if (y == 0) {
        if (!negative(x)) return y; /* +0 or x > 0 */
        return ny ? -LF_M_PI_HI : LF_M_PI_HI;
    }
    if (x == 0) return ny ? -LF_M_PIO2_HI : LF_M_PIO2_HI;
    if (fabs_(x) == HUGE_VAL) {
        if (fabs_(y) == HUGE_VAL)
            res = negative(x) ? 3.0 * LF_M_PIO4_HI : LF_M_PIO4_HI;
        else
            res = negative(x) ? LF_M_PI_HI : 0.0;
        return ny ? -res : res;
    }
    if (fabs_(y) == HUGE_VAL) return ny ? -LF_M_PIO2_HI : LF_M_PIO2_HI;
    z = fabs_(y / x);
    if (z > TWO_P60) z = LF_M_PIO2_HI; /* pi/2 - |x/y|, rounded */
    else if (negative(x) && z < TWO_M60) z = LF_M_PI_HI;
    else if (negative(x)) z = LF_M_PI_HI - (lf_atan(z) - LF_M_PI_LO);
    else z = lf_atan(z);
    return ny ? -z : z;
}

double lf_asin(double x) {
    if (is_nan(x)) return x;
    if (fabs_(x) > 1.0) return nan_value();
    return lf_atan2(x, sqrt((1.0 - x) * (1.0 + x)));
}

double lf_acos(double x) {
    if (is_nan(x)) return x;
    if (fabs_(x) > 1.0) return nan_value();
    return lf_atan2(sqrt((1.0 - x) * (1.0 + x)), x);
}
