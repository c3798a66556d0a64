/* loomfmu shared runtime: an FMU state's values checked against the model
 * before the state is accepted (lf_state_check.c).  lf_state.c reads the
 * bytes and calls these with the state's own arrays, not the instance's:
 * each check logs the first problem it finds, naming the value, and
 * returns 0 (1 when the values pass). */
#ifndef LF_STATE_CHECK_H
#define LF_STATE_CHECK_H

#include "lf_instance.h"

/* Log that a state is refused because `what` = value, where `expected`
 * was expected, and that the instance keeps its state; returns 0. */
int lf_state_refuse(LfInstance *c, const char *what, double value, const char *expected);

/* The Reals r (LF_NREAL of them, by value reference) by kind: settings and
 * parameters finite and within their ranges, inputs finite, states finite
 * (or not yet computed, NaN, before initialization), outputs and algebraic
 * locals finite where outputs_valid says they are current, else finite or
 * not yet computed (NaN). */
int lf_state_check_reals(LfInstance *c, const double *r, int solver_ready, int outputs_valid);

/* The delays against the parameters in r: after initialization each tau
 * equals what the generated function gives from those parameters (as
 * lf_init_delays computed it), and the solver's step limits `opt` are
 * within every positive delay.  Uses the instance's CasADi scratch only. */
int lf_state_check_delays(LfInstance *c, const double *r, const double *tau,
                          const LfSolverOptions *opt, int solver_ready);

/* The history samples (t, g, dg/dt; hist_count[k] of delay k, delay by
 * delay) finite and in time order, then the n_bp pending breakpoints
 * finite. */
int lf_state_check_history(LfInstance *c, const long *hist_count, int n_bp, const double *hist);

#endif
