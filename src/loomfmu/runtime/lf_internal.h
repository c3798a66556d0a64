/* loomfmu shared runtime: functions shared between the runtime's own files.
 * Not part of the interface the FMI facade uses (that is lf_runtime.h).
 * The files are layered, each calling only files below it (docs/runtime.md):
 *   lf_base.c      logging, the generated functions' work arrays
 *   lf_inputs.c    inputs as polynomials of time
 *   lf_eval.c      calls of the generated functions (inputs, delayed values,
 *                  folded parameters passed)
 *   lf_newton.c    the unknowns w (closed form or Newton), right-hand side
 *   lf_delay.c     the delays' history: samples, refinement, breakpoints
 *   lf_modes.c     event indicators at a point, discrete modes
 *   lf_start.c     start values of states and modes
 *   lf_validity.c  validity conditions after a step
 *   lf_outputs.c   outputs and output derivatives
 *   lf_events.c    event location in a step, crossing, early return
 *   lf_breaks.c    known breaks predicted ahead
 *   lf_step.c      initialization and the step loop
 *   lf_runtime.c   the instance's life cycle, getting and setting values */
#ifndef LF_INTERNAL_H
#define LF_INTERNAL_H

#include <math.h>
#include <stddef.h>

#include "lf_runtime.h"
#include "lf_step.h"

#define LF_EPS 2.220446049250313e-16

/* lf_base.c: size and allocate the CasADi work arrays (c->unsaved.arg, res, iw, w)
 * for the largest generated function; 0 if out of memory */
int lf_alloc_casadi_work(LfInstance *c);

/* Generated function `fn` (an LfFunctionId, or LF_FN_HISTOUT). */
static inline const LfFunction *lf_function_of(int fn) {
#ifdef LF_HISTOUT_FN
    if (fn == LF_FN_HISTOUT) return &LF_HISTOUT_FN;
#endif
    return &lf_model.fn[fn];
}
#ifdef LF_HISTOUT_FN
#define LF_N_FN_ALL (LF_N_FN + 1)
#else
#define LF_N_FN_ALL LF_N_FN
#endif

/* The history of delay k: sample i (0: the oldest kept) in the ring, its
 * time, value and slope (lf_delay.c writes it, lf_eval.c reads it) */
#define LF_HT(c, k, i) (c)->dl.hist[(((size_t)(k) * LF_HIST_CAP + (size_t)(((c)->dl.hist_start[k] + (i)) % LF_HIST_CAP)) * 3)]
#define LF_HG(c, k, i) (&LF_HT(c, k, i))[1]
#define LF_HD(c, k, i) (&LF_HT(c, k, i))[2]

/* lf_eval.c: generated function `fn` at (t, x, w) with the instance's u,
 * p, q and the delayed values at t; index of the first non-finite value. */
LfStatus lf_eval_fn(LfInstance *c, int fn, double t, const double *x, const double *w,
                    double *out0, double *out1, double *out2);
/* lf_eval_fn of a generated function with one output (wsol, out, evt: an
 * LfFunctionId, not LF_FN_HISTOUT), inline where nothing is to be prepared
 * (no delays, the folded terms current, the fixed arguments set, the inputs
 * held): the same call with the same arguments, without lf_eval_fn's own
 * call (the hot path: every right-hand side and output evaluation).  The
 * outputs past res[0] are not set: a function with one output reads none. */
static inline LfStatus lf_eval_fn1(LfInstance *c, int fn, double t, const double *x,
                                   const double *w, double *out0) {
    if (LF_ND > 0 || (LF_NK > 0 && c->unsaved.k_stale) || !c->unsaved.args_set || c->unsaved.u_poly)
        return lf_eval_fn(c, fn, t, x, w, out0, NULL, NULL);
    c->unsaved.arg[0] = &t;
    c->unsaved.arg[1] = x;
    c->unsaved.arg[2] = w;
    c->unsaved.arg[3] = &c->val.r[LF_VR_U0];
    c->unsaved.arg[7] = c->unsaved.u_zero;
    c->unsaved.res[0] = out0;
    return lf_model.fn[fn].eval(c->unsaved.arg, c->unsaved.res, c->unsaved.iw, c->unsaved.w, 0) ? LF_ERROR : LF_OK;
}
static inline int lf_first_nonfinite(const double *v, size_t n) {
    size_t i;
    /* the common case without a branch per element (a few elements: the
     * loop below is as cheap, and keeps its callers small enough to inline) */
    if (n >= 8 && lf_all_finite(v, n)) return -1;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) return (int)i;
    return -1;
}
/* lf_start.c: before the solver starts: states and modes initialization
 * starts from */
LfStatus lf_prepare_initial(LfInstance *c);

/* lf_newton.c: the unknowns w = [der(x); z] at (t, x) (closed form or
 * Newton), and the right-hand side the solvers integrate. */
LfStatus lf_solve_w(LfInstance *c, double t, const double *x, double *w);
LfStatus lf_rhs(void *ctx, double t, const double *x, double *dx);

/* lf_eval.c: the delayed values at t, from the history (c->dl.dval) */
LfStatus lf_delayed_values(LfInstance *c, double t, const double *x);
/* the same, and d/dt of each delayed value with tau > 0 (0 for tau = 0) */
LfStatus lf_delayed_rates(LfInstance *c, double t, const double *x, double *rate);

/* lf_delay.c: history of the delayed expressions and its breakpoints. */
double lf_next_breakpoint(LfInstance *c, double t, double t_end, int *is_bp);
LfStatus lf_hist_push(LfInstance *c, double t, const double *x, int jump);
LfStatus lf_hist_step(LfInstance *c);
/* g and dg/dt of the delayed expressions at (t, x): one history sample */
LfStatus lf_hist_sample(LfInstance *c, double t, const double *x, double *g);
LfStatus lf_hist_sample_end(LfInstance *c, double t, const double *x, double *g);
int lf_hist_outputs(LfInstance *c, const double *w, double *y);
LfStatus lf_init_delays(LfInstance *c, LfSolverOptions *opt);

/* lf_modes.c: event indicators at a point, modes. */
LfStatus lf_eval_events(LfInstance *c, double t, const double *x, double *e);
LfStatus lf_consistent_modes(LfInstance *c, double t, double *x, int touched);
LfStatus lf_initial_modes(LfInstance *c);
/* lf_events.c: event location after a step. */
LfStatus lf_handle_events(LfInstance *c);
/* early return (lf_step.h): perform the event located and deferred by
 * lf_handle_events when c->unsaved.stop_at_events is set (nothing pending: LF_OK) */
LfStatus lf_apply_pending_event(LfInstance *c, int *changed);
/* lf_breaks.c: t_bound, or earlier: where the next step is to land, a
 * margin before the predicted zero of an indicator known ahead (sets
 * c->kb.index); lf_events.c: after a step that landed there, cross it as
 * an event (the gap may reach up to t_limit) */
double lf_known_break(LfInstance *c, double t_bound);
LfStatus lf_cross_known_break(LfInstance *c, double t_limit);
/* lf_events.c: rule 2's bound on the next step, left pending after a step
 * the known-break scan vouched for (c->unsaved.kb_sure == -INFINITY), taken from the
 * last step's samples (every indicator predicted; lf_known_break) */
LfStatus lf_event_bound_pending(LfInstance *c);
/* Scanning a function of time between samples (event indicators, validity
 * conditions; lf_events.c explains the rules): halves scanned again down to
 * LF_EVENT_SCAN_DEPTH levels where the quadratic through three samples
 * comes near zero; the next step bounded so that the function's second
 * difference over it stays below LF_EVENT_CURV of its size. */
#define LF_EVENT_SCAN_DEPTH 8
/* least step over an event (relative to max(1, |t|)); its Euler error is O(gap^2) */
#define LF_EVENT_GAP 1e-12
#define LF_EVENT_VERTEX_MARGIN 0.5
#define LF_EVENT_CURV 0.25
#define LF_EVENT_GROWTH 2.0
/* Does the quadratic through ga, gm, gb (start, middle, end) come closer to
 * zero at its extremum than LF_EVENT_VERTEX_MARGIN times the midpoint's
 * distance from the chord?  *th: where, in units of the interval. */
static inline int lf_near_zero_extremum(double ga, double gm, double gb, double *th) {
    double a = 2.0 * (ga - 2.0 * gm + gb), b = 4.0 * gm - 3.0 * ga - gb, v;
    double sgn = (ga > 0 || (ga == 0 && gb > 0)) ? 1.0 : -1.0;
    if (a == 0) return 0;
    *th = -b / (2.0 * a); /* extremum of ga + b th + a th^2 */
    v = ga + *th * (b + a * *th);
    return sgn * v < LF_EVENT_VERTEX_MARGIN * 0.25 * fabs(a);
}
/* fmax and fmin of numbers that are not NaN, without the library call (the
 * same result: the larger, the smaller; b where they compare equal) */
static inline double lf_max(double a, double b) { return a > b ? a : b; }
static inline double lf_min(double a, double b) { return a < b ? a : b; }

/* lf_inputs.c: the inputs (u, du/dt) at time t: the instance's values, or
 * their polynomials; did they change since the solver last started? */
void lf_inputs_at(LfInstance *c, double t, const double **u, const double **rate);
int lf_inputs_moved(LfInstance *c);
/* The common case of lf_inputs_moved, inline: 1 if every input is held now
 * and was held when the solver last started, at a value equal to the one it
 * had then: nothing moved.  0 leaves the answer to
 * lf_inputs_moved. */
static inline int lf_inputs_still(const LfInstance *c) {
    int k;
    if (c->unsaved.u_poly) return 0;
    for (k = 0; k < LF_NU; k++)
        if (c->val.r[LF_VR_U0 + k] != c->in.seen_u[k] || c->in.seen_d1[k] != 0 || c->in.seen_d2[k] != 0)
            return 0;
    return 1;
}
void lf_inputs_seen(LfInstance *c);

/* lf_validity.c: validity conditions (Model.require) after an accepted step;
 * LF_DISCARD with the state at the last valid time where one fails. */
LfStatus lf_check_validity(LfInstance *c);
LfStatus lf_validity_at_start(LfInstance *c);
/* after the solver restarted (an event): the conditions at the restart
 * point; where one fails, the step ends at (t_ok, x_ok) with the modes q_ok
 * (the last point checked before the restart) */
LfStatus lf_validity_restart(LfInstance *c, double t_ok, const double *x_ok,
                             const double *q_ok);

/* lf_newton.c: solve dF/dw v = b at (t, x, w) in place (implicit models). */
LfStatus lf_solve_dFdw(LfInstance *c, double t, const double *x, const double *w, double *b);

/* lf_start.c: start values of the states from the parameters. */
LfStatus lf_initial_states(LfInstance *c);

#endif
