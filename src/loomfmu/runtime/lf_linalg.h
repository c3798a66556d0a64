/* loomfmu runtime: small dense linear algebra for the implicit solvers.
 *
 * Matrices are n x n, column-major: A[i + j*n] is row i, column j.
 * Only libc/libm; no allocation, no global state.
 */
#ifndef LF_LINALG_H
#define LF_LINALG_H

#include "lf_prefix.h"

#include <stddef.h>

/* LU factorization with partial (row) pivoting, in place: on return the
 * strictly lower part of `a` holds L (unit diagonal implied) and the upper
 * part holds U, with P*A = L*U.  piv[k] is the row swapped with row k at
 * elimination step k (LAPACK getrf convention, 0-based).
 *
 * Returns 0 on success, or k+1 when the pivot of column k is zero or not
 * finite (matrix singular to working precision or containing Inf/NaN); the
 * factorization is then incomplete and must not be used for solving. */
int lf_lu_factor(double *a, size_t n, size_t *piv);

/* Solve A*x = b with the factors from lf_lu_factor; b is overwritten by x. */
void lf_lu_solve(const double *lu, size_t n, const size_t *piv, double *b);

/* Number of doubles needed to store n pivot indices (size_t) inside a
 * double workspace. */
size_t lf_lu_piv_doubles(size_t n);

/* The Newton (iteration) matrix E = alpha*I - J of the implicit solvers
 * (lf_schur.c).  Factored densely, or, when rows of J hold a single
 * off-diagonal entry (kinematic rows q' = v of mechanical models), by
 * eliminating those unknowns and factoring the Schur complement on the
 * others (about half the size).  The rows are detected anew in each J.
 * ws: lf_shifted_doubles(n) doubles owned by the caller; J must stay
 * unchanged between factor and solve (the solve reads its coupling rows). */
size_t lf_shifted_doubles(size_t n);
/* Returns 0, or nonzero when E is singular or not finite (see lf_lu_factor). */
int lf_shifted_factor(double *ws, const double *J, size_t n, double alpha);
/* x := E^-1 x with the factors in ws (ws's scratch part is overwritten). */
void lf_shifted_solve(double *ws, const double *J, size_t n, double *x);
/* Unknowns eliminated in the last factorization (0: dense LU). */
size_t lf_shifted_eliminated(const double *ws);

#endif
