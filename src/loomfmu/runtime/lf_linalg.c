/* loomfmu runtime: dense LU with partial pivoting (see lf_linalg.h). */
#include "lf_linalg.h"

#include <math.h>

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
        for (j = k + 1; j < n; j++) {
            double *colj = a + j * n;
            double akj = colj[k];
            if (akj == 0.0) continue;
            for (i = k + 1; i < n; i++) colj[i] -= colk[i] * akj;
        }
    }
    return 0;
}

void lf_lu_solve(const double *lu, size_t n, const size_t *piv, double *b) {
    size_t i, j, k;
    for (k = 0; k < n; k++) {
        size_t p = piv[k];
        if (p != k) {
            double tmp = b[k];
            b[k] = b[p];
            b[p] = tmp;
        }
    }
    /* forward substitution with unit lower triangle */
    for (j = 0; j < n; j++) {
        const double *colj = lu + j * n;
        double bj = b[j];
        if (bj == 0.0) continue;
        for (i = j + 1; i < n; i++) b[i] -= colj[i] * bj;
    }
    /* back substitution with U */
    for (j = n; j-- > 0;) {
        const double *colj = lu + j * n;
        double bj;
        b[j] /= colj[j];
        bj = b[j];
        if (bj == 0.0) continue;
        for (i = 0; i < j; i++) b[i] -= colj[i] * bj;
    }
}

size_t lf_lu_piv_doubles(size_t n) {
    return (n * sizeof(size_t) + sizeof(double) - 1) / sizeof(double);
}
