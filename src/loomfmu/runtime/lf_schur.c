/* loomfmu runtime: the Newton matrix E = alpha*I - J of the implicit solvers,
 * factored densely or through a Schur complement (see lf_linalg.h).
 *
 * Mechanical models have kinematic rows q_i' = v_j: row i of J holds a single
 * nonzero, off the diagonal.  Such a row of E reads alpha*x_i - c_i*x_j = b_i,
 * so x_i = (b_i + c_i*x_j)/alpha can be eliminated.  With Q the eliminated
 * rows (whose target j is not eliminated itself) and Y the others, the
 * remaining unknowns solve
 *   S y = b_Y + (1/alpha) J[Y,Q] b_Q,
 *   S   = (alpha*I - J)[Y,Y] - (1/alpha) J[Y,Q] C P,
 * where C = diag(c_i) and P maps each q to the position of its target in Y:
 * S is the Schur complement of the (diagonal) Q block, of size n - |Q|
 * (about n/2 for x = (q, v)), so its LU costs about 1/8 of the dense one.
 * The rows are found again in every matrix factored (an O(n^2) scan), so the
 * elimination is exact algebra for that J whatever the model.
 *
 * Workspace (doubles): [m, alpha, ny], then a block of n*n holding the LU of
 * S (ny*ny), B = J[Y,Q]/alpha (ny*m, column k for the k-th eliminated row)
 * and c_i/alpha (m), so that the solve reads contiguous memory and not J
 * (ny*ny + ny*m + m <= n*n since ny + m = n); then scratch (n), the pivots,
 * qmap, yidx and qidx (n size_t each).  qmap[i] = n for i not eliminated,
 * else the position in Y of its target; yidx[a] = index of the a-th kept
 * unknown; qidx[k] = index of the k-th eliminated one. */
#include "lf_linalg.h"

#ifndef LF_SCHUR_MIN_ROWS
/* eliminate only if at least this many rows qualify (compile with a huge
 * value to force the dense path, e.g. to compare both in the tests) */
#define LF_SCHUR_MIN_ROWS 1
#endif

enum { SH_M, SH_ALPHA, SH_NY, SH_HDR };

static double *sh_lu(double *ws) { return ws + SH_HDR; }
static double *sh_tmp(double *ws, size_t n) { return ws + SH_HDR + n * n; }
static size_t *sh_piv(double *ws, size_t n) { return (size_t *)(void *)(ws + SH_HDR + n * n + n); }
static size_t *sh_qmap(double *ws, size_t n) { return sh_piv(ws, n) + n; }
static size_t *sh_yidx(double *ws, size_t n) { return sh_piv(ws, n) + 2 * n; }
static size_t *sh_qidx(double *ws, size_t n) { return sh_piv(ws, n) + 3 * n; }

size_t lf_shifted_doubles(size_t n) { return SH_HDR + n * n + n + lf_lu_piv_doubles(4 * n); }

size_t lf_shifted_eliminated(const double *ws) { return (size_t)ws[SH_M]; }

/* Mark the rows to eliminate: qmap[i] = target column, or n. Returns |Q|. */
static size_t find_rows(const double *J, size_t n, size_t *qmap) {
    size_t i, j, m = 0;
    for (i = 0; i < n; i++) {
        size_t target = n, count = 0;
        for (j = 0; j < n && count < 2; j++) {
            if (J[i + j * n] != 0.0) {
                count++;
                target = j;
            }
        }
        qmap[i] = (count == 1 && target != i) ? target : n;
    }
    /* a row whose target is eliminated too (chains q' = p, p' = v) stays */
    for (i = 0; i < n; i++)
        if (qmap[i] < n && qmap[qmap[i]] < n) qmap[i] = n + 1;
    for (i = 0; i < n; i++) {
        if (qmap[i] == n + 1) qmap[i] = n;
        if (qmap[i] < n) m++;
    }
    return m;
}

static int factor_dense(double *ws, const double *J, size_t n, double alpha) {
    double *lu = sh_lu(ws);
    size_t i;
    ws[SH_M] = 0.0;
    ws[SH_NY] = (double)n;
    for (i = 0; i < n * n; i++) lu[i] = -J[i];
    for (i = 0; i < n; i++) lu[i + i * n] += alpha;
    return lf_lu_factor(lu, n, sh_piv(ws, n));
}

int lf_shifted_factor(double *ws, const double *J, size_t n, double alpha) {
    size_t *qmap = sh_qmap(ws, n), *yidx = sh_yidx(ws, n), *qidx = sh_qidx(ws, n);
    double *S = sh_lu(ws), *B, *cq;
    size_t i, a, b, k, m, ny = 0;
    ws[SH_ALPHA] = alpha;
    m = find_rows(J, n, qmap);
    if (m < LF_SCHUR_MIN_ROWS || m == 0) return factor_dense(ws, J, n, alpha);
    /* positions in Y; targets are in Y, so qmap can then hold positions */
    for (i = 0, k = 0; i < n; i++) {
        if (qmap[i] >= n)
            yidx[ny++] = i;
        else
            qidx[k++] = i;
    }
    for (i = 0; i < n; i++) {
        if (qmap[i] >= n) continue;
        for (a = 0; a < ny && yidx[a] != qmap[i]; a++) continue;
        qmap[i] = a; /* a < ny: the target is kept */
    }
    B = S + ny * ny;
    cq = B + ny * m;
    for (b = 0; b < ny; b++) {
        const double *col = J + yidx[b] * n;
        for (a = 0; a < ny; a++) S[a + b * ny] = -col[yidx[a]];
    }
    for (a = 0; a < ny; a++) S[a + a * ny] += alpha;
    for (k = 0; k < m; k++) {
        const double *col = J + qidx[k] * n;
        double *Bk = B + k * ny, *Sb, c;
        i = qidx[k];
        b = qmap[i];
        Sb = S + b * ny;
        c = J[i + yidx[b] * n]; /* c_i */
        cq[k] = c / alpha;
        for (a = 0; a < ny; a++) {
            Bk[a] = col[yidx[a]] / alpha;
            Sb[a] -= c * Bk[a];
        }
    }
    ws[SH_M] = (double)m;
    ws[SH_NY] = (double)ny;
    return lf_lu_factor(S, ny, sh_piv(ws, n));
}

void lf_shifted_solve(double *ws, const double *J, size_t n, double *x) {
    size_t m = (size_t)ws[SH_M], ny = (size_t)ws[SH_NY], k, a;
    const size_t *qmap = sh_qmap(ws, n), *yidx = sh_yidx(ws, n), *qidx = sh_qidx(ws, n);
    const double *B = sh_lu(ws) + ny * ny, *cq = B + ny * m;
    double alpha = ws[SH_ALPHA], *y = sh_tmp(ws, n);
    (void)J; /* the factorization holds the coupling B and c */
    if (m == 0) {
        lf_lu_solve(sh_lu(ws), n, sh_piv(ws, n), x);
        return;
    }
    for (a = 0; a < ny; a++) y[a] = x[yidx[a]];
    for (k = 0; k + 1 < m; k += 2) { /* two columns of B a pass */
        const double *B0 = B + k * ny, *B1 = B0 + ny;
        double b0 = x[qidx[k]], b1 = x[qidx[k + 1]];
        for (a = 0; a < ny; a++) y[a] = (y[a] + B0[a] * b0) + B1[a] * b1;
    }
    if (k < m) {
        const double *Bk = B + k * ny;
        double bq = x[qidx[k]];
        for (a = 0; a < ny; a++) y[a] += Bk[a] * bq;
    }
    lf_lu_solve(sh_lu(ws), ny, sh_piv(ws, n), y);
    for (a = 0; a < ny; a++) x[yidx[a]] = y[a];
    for (k = 0; k < m; k++) {
        size_t i = qidx[k];
        x[i] = x[i] / alpha + cq[k] * y[qmap[i]];
    }
}
