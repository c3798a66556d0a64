/* loomfmu shared runtime: the delays' history (lf_delay.c): samples at
 * accepted steps, refinement, breakpoints. */
#ifndef LF_DELAY_H
#define LF_DELAY_H

#include "lf_instance.h"

double lf_next_breakpoint(LfInstance *c, double t, double t_end, int *is_bp);
LfStatus lf_hist_push(LfInstance *c, double t, const double *x, int jump);
LfStatus lf_hist_step(LfInstance *c, int skippable);
/* g and dg/dt of the delayed expressions at (t, x): one history sample */
LfStatus lf_hist_sample(LfInstance *c, double t, const double *x, double *g);
LfStatus lf_hist_sample_end(LfInstance *c, double t, const double *x, double *g);
int lf_hist_outputs(LfInstance *c, const double *w, double *y);
LfStatus lf_init_delays(LfInstance *c, LfSolverOptions *opt);

#endif
