/* loomfmu runtime: dense LU with partial pivoting (see lf_linalg.h).
 *
 * The inner loops update two columns at a time (factor: the rank-1 update of
 * columns j and j+1; solves: two columns of L or U against b), so that each
 * pass over the target vector does twice the arithmetic per load and store;
 * plain C, no intrinsics.  Results equal the textbook column loops to
 * rounding (the order of the two updates of an entry is kept).  A column
 * whose entries in row k are zero is not updated (x - l * 0 is x): the
 * Jacobian of a composed model is mostly zero blocks, and its factorization
 * then costs about what its diagonal blocks' would; the solves likewise skip
 * the columns a zero entry of the right-hand side multiplies. */
#include "lf_linalg.h"

#include <math.h>

/* y[i] -= a[i]*s + b[i]*t for i in [lo, hi) */
static void axpy2(double *y, const double *a, double s, const double *b, double t, size_t lo,
                  size_t hi) {
    size_t i;
    for (i = lo; i < hi; i++) y[i] = (y[i] - a[i] * s) - b[i] * t;
}

static void axpy1(double *y, const double *a, double s, size_t lo, size_t hi) {
    size_t i;
    for (i = lo; i < hi; i++) y[i] -= a[i] * s;
}

int lf_lu_factor(double *a, size_t n, size_t *piv) {
    size_t i, j, k;
    for (k = 0; k < n; k++) {
        double *colk = a + k * n;
        double amax = -1.0, pivot, inv;
        size_t p = k;
        int finite = 1;
        for (i = k; i < n; i++) {
            double v = fabs(colk[i]);
            if (!isfinite(v)) finite = 0;
            if (v > amax) {
                amax = v;
                p = i;
            }
        }
        piv[k] = p;
        if (!finite || !(amax > 0.0)) return (int)(k + 1);
        if (p != k) {
            for (j = 0; j < n; j++) {
                double tmp = a[k + j * n];
                a[k + j * n] = a[p + j * n];
                a[p + j * n] = tmp;
            }
        }
        pivot = colk[k];
        inv = 1.0 / pivot;
        for (i = k + 1; i < n; i++) colk[i] *= inv;
        for (j = k + 1; j + 1 < n; j += 2) {
            double *c0 = a + j * n, *c1 = c0 + n;
            double s0 = c0[k], s1 = c1[k];
            if (s0 == 0.0 && s1 == 0.0) continue; /* nothing to update (sparse rows) */
            /* columns j and j+1 against column k: two independent updates */
            for (i = k + 1; i < n; i++) {
                double l = colk[i];
                c0[i] -= l * s0;
                c1[i] -= l * s1;
            }
        }
        if (j < n && a[k + j * n] != 0.0) axpy1(a + j * n, colk, a[k + j * n], k + 1, n);
    }
    return 0;
}

void lf_lu_solve(const double *lu, size_t n, const size_t *piv, double *b) {
    size_t j, k;
    for (k = 0; k < n; k++) {
        size_t p = piv[k];
        if (p != k) {
            double tmp = b[k];
            b[k] = b[p];
            b[p] = tmp;
        }
    }
    /* forward substitution with the unit lower triangle, two columns a pass */
    for (j = 0; j + 1 < n; j += 2) {
        const double *c0 = lu + j * n, *c1 = c0 + n;
        double b0 = b[j], b1;
        if (b0 != 0.0) b[j + 1] -= c0[j + 1] * b0;
        b1 = b[j + 1];
        if (b0 != 0.0 || b1 != 0.0) axpy2(b, c0, b0, c1, b1, j + 2, n);
    }
    /* back substitution with U, two columns a pass */
    for (j = n; j >= 2; j -= 2) {
        const double *c1 = lu + (j - 1) * n, *c0 = c1 - n;
        double b1, b0;
        b[j - 1] /= c1[j - 1];
        b1 = b[j - 1];
        if (b1 != 0.0) b[j - 2] -= c1[j - 2] * b1;
        b[j - 2] /= c0[j - 2];
        b0 = b[j - 2];
        if (b0 != 0.0 || b1 != 0.0) axpy2(b, c1, b1, c0, b0, 0, j - 2);
    }
    if (j == 1) b[0] /= lu[0];
}

size_t lf_lu_piv_doubles(size_t n) {
    return (n * sizeof(size_t) + sizeof(double) - 1) / sizeof(double);
}
