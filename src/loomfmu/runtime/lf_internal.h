/* loomfmu shared runtime: pure helpers and constants the runtime's files
 * share (generated functions by id, the delays' history ring, the event
 * scans' constants, finiteness, min and max).  Near the bottom: on
 * lf_instance.h only; declares no function of a .c file and calls none.
 * The files are layered, each calling only files below it, each with its
 * header of the same name (docs/guides/runtime.md):
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

#include "lf_instance.h"

#define LF_EPS 2.220446049250313e-16

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

/* index of the first non-finite value of v[0..n-1], -1 if none */
static inline int lf_first_nonfinite(const double *v, size_t n) {
    size_t i;
    /* the common case without a branch per element (a few elements: the
     * loop below is as cheap, and keeps its callers small enough to inline) */
    if (n >= 8 && lf_all_finite(v, n)) return -1;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) return (int)i;
    return -1;
}

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

#endif
