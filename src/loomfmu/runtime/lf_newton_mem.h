/* loomfmu shared runtime: Newton's memory for models solved by Newton
 * (lf_newton.c), a field of LfInstance (lf_instance.h).
 *
 * While a step runs (c->unsaved.wc_on), the solves of the unknowns w at the
 * solver's stages, the event and validity scans' points and the outputs
 * are close to each other.  Newton's memory keeps, from the solves of the
 * current generation (the solve cache's c->unsaved.wc_gen: advanced when a step
 * starts and wherever a mode is set, so parameters, inputs and modes are
 * the same for every solve that uses it):
 *  - dF/dw where it was last factored (its LU and inverse) and the
 *    tangent there, for (a) the first-order predictor of w at a new point
 *    (t, x) from the last solution (tb, xb, wb): w ~ wb + dw/dx (x - xb) +
 *    dw/dt (t - tb), and (b) simplified Newton iterations from it (the
 *    residual and a product with the kept inverse, no new dF/dw), accepted
 *    by Newton's tolerance while they contract fast; otherwise Newton with
 *    the exact dF/dw takes over (and its factorization is kept).
 *  - the last solution (tb, xb, wb) of the generation.
 * Not part of the FMU state: each step starts without it (a new
 * generation), so a restored state continues bit for bit. */
#ifndef LF_NEWTON_MEM_H
#define LF_NEWTON_MEM_H

#include <stddef.h>

#include "lf_model.h"

/* n doubles where the model is solved by Newton and n > 0, else 1 (a
 * model without Newton keeps none) */
#define LF_NM_DIM(n) (LF_IMPLICIT && (n) > 0 ? (n) : 1)

typedef struct {
    unsigned long lu_gen;   /* generation of the kept LU (0: none) */
    unsigned long b_gen;    /* generation of the kept solution (0: none) */
    /* dF/dw factored (LU, pivots) and dF/dx, dF/dt at the same point */
    double lu[LF_NM_DIM(LF_NW * LF_NW)];
    size_t piv[LF_NM_DIM(LF_NW)];
    double fx[LF_NM_DIM(LF_NW * LF_NX)];
    double ft[LF_NM_DIM(LF_NW)];
    /* formed from them at first use (tan_ok): (dF/dw)^-1 and the
     * tangent dw/dx = -(dF/dw)^-1 dF/dx, dw/dt = -(dF/dw)^-1 dF/dt */
    int tan_ok;
    double inv[LF_NM_DIM(LF_NW * LF_NW)];
    double wx[LF_NM_DIM(LF_NW * LF_NX)];
    double wt[LF_NM_DIM(LF_NW)];
    /* rows [lo, hi) holding the nonzeros of each column of inv and of wx
     * (a composed model's blocks: most of each column is zero) */
    int inv_lo[LF_NM_DIM(LF_NW)], inv_hi[LF_NM_DIM(LF_NW)];
    int wx_lo[LF_NM_DIM(LF_NX)], wx_hi[LF_NM_DIM(LF_NX)];
    double tb;              /* the last solution (tb, xb, wb) */
    double xb[LF_NM_DIM(LF_NX)];
    double wb[LF_NM_DIM(LF_NW)];
    int stale;              /* the last simplified solve contracted slowly */
} LfNewtonMem;

#endif
