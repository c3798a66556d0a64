/* loomfmu runtime: the one step routine of the Rosenbrock methods (rodas4 in
 * lf_rodas4.c, ros34pw2 in lf_wmethod.c), each method a coefficient table
 * and, for a W-method, a policy for its iteration matrix.
 *
 * Hairer's transformed form (Solving ODEs II, Sec. IV.7):
 *   (I/(h*gamma) - J) k_i = f(t + alpha_i h, x + sum_j a_ij k_j)
 *                           + sum_j (c_ij/h) k_j + h d_i df/dt,
 * stage 1 at (t, x) with f0 = f(t, x); every method is stiffly accurate:
 * x_new = (argument of the last stage) + k_s.  The error vector is
 * sum_j e_j k_j, or k_s alone.  Step sizes: Hairer's controller with
 * Gustafsson's predictive variant, 1/5 <= hnew/h <= 6.
 *
 * Method-private data (after x and x_old, LF_PRIV): the controller scalars
 * LF_RB_HACC, LF_RB_ERRACC, LF_RB_HISTOK, the method's own scalars, then
 * the vectors k_1..k_s, LF_RB_Y (stage argument / new state), LF_RB_DY (f
 * at a stage), LF_RB_F0 = f(t, x), LF_RB_FT = df/dt, the method's own
 * vectors, then J (n*n) and the factored iteration matrix (lf_shifted_*). */
#ifndef LF_ROSENBROCK_H
#define LF_ROSENBROCK_H

#include "lf_solver_impl.h"

#define LF_RB_MAX_STAGES 6

enum { LF_RB_HACC, LF_RB_ERRACC, LF_RB_HISTOK, LF_RB_NSCAL };
/* vector index of Y, DY, F0, FT, of the method's first own vector */
#define LF_RB_Y(m) ((m)->stages)
#define LF_RB_DY(m) ((m)->stages + 1)
#define LF_RB_F0(m) ((m)->stages + 2)
#define LF_RB_FT(m) ((m)->stages + 3)
#define LF_RB_OWN(m) ((m)->stages + 4)

typedef struct LfRosenbrock LfRosenbrock;

struct LfRosenbrock {
    const char *name;   /* in messages */
    int stages;         /* s <= LF_RB_MAX_STAGES */
    int nscal, nvec;    /* private scalars and vectors in all (>= LF_RB_NSCAL, s + 4) */
    double gamma;
    /* a_ij and c_ij, j < i: the lower triangles row by row (row i,
     * 0-based, starts at i(i-1)/2; row 0 is empty); stage
     * times alpha_i (1.0: exactly the step's end t_new); d_i (0: no df/dt
     * term); e_j error weights (NULL: the error is k_s) */
    const double *a, *c, *alpha, *d, *e;
    double order;       /* of the initial step guess (lf_sv_initial_step) */
    double expo;        /* controller: err^expo */
    /* 1: J and df/dt at every accepted point (f0 recomputed too); 0: a
     * W-method that keeps f(t_new) as the next f0 and J as long as `matrix`
     * likes */
    int fresh_jacobian;
    /* optional (NULL for rodas4): renew the matrix before the first attempt
     * (rejected = 0) or after a rejection (rejected = 1)? */
    int (*renew)(const LfSolver *s, int rejected);
    /* optional: the step size to try instead of h */
    double (*propose)(LfSolver *s, double h, double t_bound, int rejected, int renew);
    /* optional: make the factors usable for h; LF_OK, a Jacobian failure or
     * -1 (singular).  NULL: factor I/(h*gamma) - J at every attempt */
    int (*matrix)(LfSolver *s, double h, int renew);
    /* accepted step, before the state moves to t_new (y = new state, k =
     * stages); LF_OK, or a failure of f that rejects the step */
    LfStatus (*accept)(LfSolver *s, double *const *k, const double *y, double t_new);
};

size_t lf_rb_work_size(const LfRosenbrock *m, size_t n);
double *lf_rb_vec(LfSolver *s, const LfRosenbrock *m, int k);
double *lf_rb_jac(LfSolver *s, const LfRosenbrock *m);
double *lf_rb_lu(LfSolver *s, const LfRosenbrock *m);
/* J and df/dt at the current point (s->t, s->x); messages name the method */
LfStatus lf_rb_jacobian(LfSolver *s, const LfRosenbrock *m);
LfStatus lf_rb_step(LfSolver *s, const LfRosenbrock *m, double t_bound);

#endif
