/* loomfmu shared runtime: the solve cache of models solved by Newton.
 * While a step runs (lf_step.c sets c->unsaved.wc_on), the last two solves of the
 * unknowns w at (t, x) are kept, so that a second solve at the same point
 * takes the first one's w instead of Newton's iterations (each a residual,
 * dF/dw, its LU and a solve): the step loop evaluates the event
 * indicators, the validity conditions and the outputs at points the solver
 * has just evaluated (the end of an accepted step, its last stage: dopri5
 * and rk4 evaluate f there) and the event and validity scans sample the
 * same midpoints.  (A closed-form w costs about what keeping it would, on
 * every call: explicit models keep nothing.)
 *
 * A point matches bit for bit in t and x, and in the generation wc_gen,
 * which the step loop advances when a step starts and wherever a mode is
 * set (the rest that w depends on, the inputs' polynomials, parameters and
 * folded terms, cannot change inside a step).  A point gets the w of its
 * first solve, where a new solve would start Newton at it and move it by
 * rounding.  Without delays only: the delayed values come from a history
 * that grows inside the step.  A cache, not part of the FMU state: each step starts
 * empty, so a restored state continues bit for bit. */
#ifndef LF_WCACHE_H
#define LF_WCACHE_H

#include <string.h>

#include "lf_instance.h"

#define LF_WC_USED (LF_IMPLICIT && LF_ND == 0)
/* Explicit models remember only where c->val.w_cur was solved (wk_t, wk_x of
 * generation wk_g): w_cur holds that w already, so a hit costs a copy and
 * keeping costs the key.  Whoever writes w_cur otherwise clears wk_g. */
#define LF_WK_USED (!LF_IMPLICIT && LF_ND == 0)

/* w of (t, x) if kept (copied to w and w_cur, as a solve does): 1, else 0 */
static inline int lf_wc_take(LfInstance *c, double t, const double *x, double *w) {
    int j;
    for (j = 0; j < 2; j++) {
        if (c->unsaved.wc_t[j] != t || c->unsaved.wc_g[j] != c->unsaved.wc_gen || memcmp(&c->unsaved.wc_t[j], &t, sizeof t) ||
            memcmp(c->unsaved.wc_x[j], x, sizeof(double) * LF_NX) != 0)
            continue;
        memcpy(w, c->unsaved.wc_w[j], sizeof(double) * LF_NW);
        memcpy(c->val.w_cur, c->unsaved.wc_w[j], sizeof(double) * LF_NW);
        c->unsaved.wc_last = j;
        return 1;
    }
    return 0;
}

/* keep w of (t, x) in place of the one used longer ago */
static inline void lf_wc_keep(LfInstance *c, double t, const double *x, const double *w) {
    int j = 1 - c->unsaved.wc_last;
    c->unsaved.wc_last = j;
    c->unsaved.wc_g[j] = c->unsaved.wc_gen;
    c->unsaved.wc_t[j] = t;
    memcpy(c->unsaved.wc_x[j], x, sizeof(double) * LF_NX);
    memcpy(c->unsaved.wc_w[j], w, sizeof(double) * LF_NW);
}

/* w_cur if it is w of (t, x) (copied to w): 1, else 0 */
static inline int lf_wk_take(LfInstance *c, double t, const double *x, double *w) {
    if (c->unsaved.wk_t != t || c->unsaved.wk_g != c->unsaved.wc_gen || memcmp(&c->unsaved.wk_t, &t, sizeof t) ||
        memcmp(c->unsaved.wk_x, x, sizeof(double) * LF_NX) != 0)
        return 0;
    if (w != c->val.w_cur) memcpy(w, c->val.w_cur, sizeof(double) * LF_NW);
    return 1;
}

/* w_cur was just solved at (t, x) */
static inline void lf_wk_keep(LfInstance *c, double t, const double *x) {
    c->unsaved.wk_t = t;
    c->unsaved.wk_g = c->unsaved.wc_gen;
    memcpy(c->unsaved.wk_x, x, sizeof(double) * LF_NX);
}

#endif
