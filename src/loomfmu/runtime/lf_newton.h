/* loomfmu shared runtime: the unknowns w (closed form or Newton) and the
 * ODE the solvers integrate (lf_newton.c). */
#ifndef LF_NEWTON_H
#define LF_NEWTON_H

#include "lf_instance.h"

/* the ODE the solvers integrate (right-hand side and Jacobian of c) */
LfOde lf_ode_of(LfInstance *c);
/* The unknowns w = [der(x); z] at (t, x) (closed form or
 * Newton), and the right-hand side the solvers integrate. */
LfStatus lf_solve_w(LfInstance *c, double t, const double *x, double *w);
LfStatus lf_rhs(void *ctx, double t, const double *x, double *dx);

/* Solve dF/dw v = b at (t, x, w) in place (implicit models). */
LfStatus lf_solve_dFdw(LfInstance *c, double t, const double *x, const double *w, double *b);

#endif
