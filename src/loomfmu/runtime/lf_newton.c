/* loomfmu shared runtime: the unknowns w = [der(x); z] of the model
 * equations (closed form, or Newton with the exact dF/dw for algebraic
 * loops), and the right-hand side and Jacobian the solvers integrate. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_newton.h"
#include "lf_base.h"
#include "lf_eval.h"
#include "lf_instance.h"
#include "lf_internal.h"
#include "lf_linalg.h"
#include "lf_wcache.h"

#define LF_NEWTON_MAX_ITER 30
#define LF_NEWTON_RTOL 1e-10
#define LF_NEWTON_ATOL 1e-12

/* Factor dF/dw at (t, x, w) into c->unsaved.jac_ww (implicit models). */
static LfStatus factor_dFdw(LfInstance *c, double t, const double *x, const double *w) {
    if (lf_eval_fn(c, LF_FN_RJAC, t, x, w, c->unsaved.jac_ww, c->unsaved.jac_wx, c->unsaved.jac_wt) != LF_OK)
        return LF_ERROR;
    if (lf_lu_factor(c->unsaved.jac_ww, LF_NW, c->unsaved.piv) != 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
               "t = %.17g: algebraic loop has no unique solution (dF/dw singular)", t);
        return LF_DISCARD;
    }
    return LF_OK;
}

/* -DLF_NEWTON_STATS: counts of the solves in steps (c->unsaved.wc_on), printed to
 * stderr at exit (tests/test_newton_predictor.py; one instance at a time) */
#ifdef LF_NEWTON_STATS
#include <stdio.h>
static long st_solves, st_hits, st_full, st_full_it, st_simp, st_simp_it, st_fallback;
static void __attribute__((destructor)) st_print(void) {
    fprintf(stderr, "newton_stats: solves %ld hits %ld full %ld full_it %ld simplified %ld "
            "simplified_it %ld fallbacks %ld\n", st_solves, st_hits, st_full, st_full_it,
            st_simp, st_simp_it, st_fallback);
}
#define STAT(x) (c->unsaved.wc_on ? (void)(x) : (void)0)
#else
#define STAT(x) ((void)0)
#endif

/* -DLF_NEWTON_MEMORY=0: Newton from the last solve at every solve, as
 * before the memory (tests compare the two) */
#ifndef LF_NEWTON_MEMORY
#define LF_NEWTON_MEMORY 1
#endif

/* -DLF_TEAR=0: a torn model solved by Newton on every unknown, as an
 * untorn one (tests compare the two).  The torn form is taken inside the
 * co-simulation steps only (c->unsaved.wc_on): model exchange, whose
 * importer evaluates the derivatives at its own points (after an event in
 * the new mode from the old mode's solution), keeps Newton on every
 * unknown.  There the torn iteration reached other solutions of the
 * backrest's equations than the full Newton (each satisfying them: its
 * friction law has more than one root), and through FMPy's CVode the
 * backrest's model-exchange run left its reference by 4.8 of a friction
 * moment's range (tests/test_ls_ref.py). */
#ifndef LF_TEAR
#define LF_TEAR 1
#endif
#define LF_USE_TEAR (LF_TORN && LF_TEAR)

/* Newton's memory (lf_newton_mem.h) is kept and used while a step runs
 * (not by a torn model's Newton, whose loop is a few unknowns) */
static inline int nm_on(const LfInstance *c) { return LF_NEWTON_MEMORY && LF_IMPLICIT && !LF_USE_TEAR && c->unsaved.wc_on; }

/* keep the factorization in c->unsaved.jac_ww, c->unsaved.piv and dF/dx, dF/dt in
 * c->unsaved.jac_wx, c->unsaved.jac_wt (just evaluated together) for this generation */
static void nm_keep_lu(LfInstance *c) {
    LfNewtonMem *m = &c->unsaved.nm;
    memcpy(m->lu, c->unsaved.jac_ww, sizeof(double) * LF_NW * LF_NW);
    memcpy(m->piv, c->unsaved.piv, sizeof(size_t) * LF_NW);
    memcpy(m->fx, c->unsaved.jac_wx, sizeof(double) * LF_NW * LF_NX);
    memcpy(m->ft, c->unsaved.jac_wt, sizeof(double) * LF_NW);
    m->lu_gen = c->unsaved.wc_gen;
    m->stale = 0;
    m->tan_ok = 0;
}

/* Say that Newton failed at t: the loop's unknowns (the algebraic
 * variables, e.g. the coupled inputs of a composed scene) and the largest
 * residual left at the last iterate w. */
static void newton_failed(LfInstance *c, double t, const double *x, const double *w) {
    char names[200] = "";
    size_t used = 0;
    int i, worst = -1;
    for (i = 0; i < LF_NZ && used + 1 < sizeof names; i++) {
        int n = snprintf(names + used, sizeof names - used, "%s%s", i ? ", " : "",
                         lf_model.real_names[LF_VR_Z0 + i]);
        if (n < 0) break;
        used += (size_t)n;
    }
    if (used >= sizeof names) strcpy(names + sizeof names - 5, " ...");
    if (lf_first_nonfinite(w, LF_NW) < 0 &&
        lf_eval_fn1(c, LF_FN_RES, t, x, w, c->unsaved.res_F) == LF_OK)
        for (i = 0; i < LF_NW; i++)
            if (worst < 0 || fabs(c->unsaved.res_F[i]) > fabs(c->unsaved.res_F[worst])) worst = i;
    if (worst >= 0 && isfinite(c->unsaved.res_F[worst]))
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
               "t = %.17g: algebraic loop (unknowns: der(x)%s%s): Newton did not converge in "
               "%d iterations; largest residual %.3g in equation %d", t, LF_NZ ? ", " : "",
               names, LF_NEWTON_MAX_ITER, c->unsaved.res_F[worst], worst);
    else
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
               "t = %.17g: algebraic loop (unknowns: der(x)%s%s): Newton did not converge in "
               "%d iterations (the iterate is not finite)", t, LF_NZ ? ", " : "", names,
               LF_NEWTON_MAX_ITER);
}

/* Newton on F(t, x, w) = 0 from w, with the exact dF/dw.  Converged
 * when every |dw_i| <= LF_NEWTON_ATOL + LF_NEWTON_RTOL max(|w_i|, |w0_i|)
 * (w0: the start), or when the scaled step stops shrinking at rounding
 * level (a component near 0 coupled to large terms cannot get below its
 * terms' rounding). */
static LfStatus newton(LfInstance *c, double t, const double *x, double *w) {
    double w0[LF_DIM(LF_NW)];
    int it, i;
    double prev = INFINITY;
    LfStatus st;
    STAT(st_full++);
    memcpy(w0, w, sizeof w0);
    for (it = 0; it < LF_NEWTON_MAX_ITER; it++) {
        int done = 1;
        double size = 0.0;
        STAT(st_full_it++);
        if (lf_eval_fn1(c, LF_FN_RES, t, x, w, c->unsaved.res_F) != LF_OK) return LF_ERROR;
        if (lf_first_nonfinite(c->unsaved.res_F, LF_NW) >= 0) {
            lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: algebraic loop: residual of "
                   "equation %d is not finite at Newton iteration %d", t,
                   lf_first_nonfinite(c->unsaved.res_F, LF_NW), it);
            return LF_DISCARD;
        }
        st = factor_dFdw(c, t, x, w);
        if (st != LF_OK) return st;
        if (nm_on(c)) nm_keep_lu(c);
        lf_lu_solve(c->unsaved.jac_ww, LF_NW, c->unsaved.piv, c->unsaved.res_F);
        for (i = 0; i < LF_NW; i++) {
            double scale = fmax(fabs(w[i]), fabs(w0[i]));
            w[i] -= c->unsaved.res_F[i];
            if (fabs(c->unsaved.res_F[i]) > LF_NEWTON_ATOL + LF_NEWTON_RTOL * scale) done = 0;
            size = fmax(size, fabs(c->unsaved.res_F[i]) / (LF_NEWTON_ATOL + scale));
        }
        if (lf_first_nonfinite(w, LF_NW) >= 0) break;
        if (done || (size < 1e-8 && size >= 0.5 * prev)) return LF_OK;
        prev = size;
    }
    c->stats.n_newton_fail++;
    newton_failed(c, t, x, w);
    return LF_DISCARD;
}

/* lo[j], hi[j]: the rows [lo, hi) of column j of the LF_NW x ncol matrix a
 * outside which it is zero (lo = hi = 0 for a zero column). */
static void nonzero_rows(const double *a, int ncol, int *lo, int *hi) {
    int i, j;
    for (j = 0; j < ncol; j++) {
        const double *col = a + (size_t)j * LF_NW;
        int first = LF_NW, last = -1;
        for (i = 0; i < LF_NW; i++)
            if (col[i] != 0.0) {
                if (i < first) first = i;
                last = i;
            }
        lo[j] = last < 0 ? 0 : first;
        hi[j] = last + 1;
    }
}

/* The kept dF/dw's inverse and the tangent [dw/dx, dw/dt] = -(dF/dw)^-1
 * [dF/dx, dF/dt], formed at their first use after the LU was kept: a
 * product with the inverse costs about half an LU solve at the sizes of
 * our models' loops, and a stage's solve takes two or more. */
static void nm_tangent(LfNewtonMem *m) {
    int i, j, k;
    memset(m->inv, 0, sizeof(double) * LF_NW * LF_NW);
    for (j = 0; j < LF_NW; j++) {
        m->inv[j + j * LF_NW] = 1.0;
        lf_lu_solve(m->lu, LF_NW, m->piv, &m->inv[j * LF_NW]);
    }
    nonzero_rows(m->inv, LF_NW, m->inv_lo, m->inv_hi);
    for (i = 0; i < LF_NW; i++) m->wt[i] = 0.0;
    for (i = 0; i < LF_NW * LF_NX; i++) m->wx[i] = 0.0;
    for (k = 0; k < LF_NW; k++) { /* zeros skipped: a composed model's blocks */
        const double *col = &m->inv[k * LF_NW];
        int lo = m->inv_lo[k], hi = m->inv_hi[k];
        if (m->ft[k] != 0.0)
            for (i = lo; i < hi; i++) m->wt[i] -= col[i] * m->ft[k];
        for (j = 0; j < LF_NX; j++) {
            double f = m->fx[k + j * LF_NW];
            if (f != 0.0)
                for (i = lo; i < hi; i++) m->wx[i + j * LF_NW] -= col[i] * f;
        }
    }
    nonzero_rows(m->wx, LF_NX, m->wx_lo, m->wx_hi);
    m->tan_ok = 1;
}

/* dw := (dF/dw)^-1 f with the kept inverse */
static inline void nm_apply(const LfNewtonMem *m, const double *f, double *dw) {
    double v[LF_DIM(LF_NW)];
    int i, k;
    for (i = 0; i < LF_NW; i++) v[i] = 0.0;
    for (k = 0; k < LF_NW; k++) {
        const double *col = &m->inv[k * LF_NW];
        double fk = f[k];
        if (fk != 0.0)
            for (i = m->inv_lo[k]; i < m->inv_hi[k]; i++) v[i] += col[i] * fk;
    }
    memcpy(dw, v, sizeof v);
}

/* The predictor: w at (t, x) to first order from the generation's last
 * solution (tb, xb, wb): w ~ wb + dw/dx (x - xb) + dw/dt (t - tb) with the
 * tangent where the kept LU was factored. */
static void nm_predict(LfInstance *c, double t, const double *x, double *w) {
    LfNewtonMem *m = &c->unsaved.nm;
    double p[LF_DIM(LF_NW)], dt = t - m->tb;
    int i, j;
    if (!m->tan_ok) nm_tangent(m);
    for (i = 0; i < LF_NW; i++) p[i] = m->wb[i] + m->wt[i] * dt;
    for (j = 0; j < LF_NX; j++) {
        double dx = x[j] - m->xb[j];
        if (dx != 0.0)
            for (i = m->wx_lo[j]; i < m->wx_hi[j]; i++) p[i] += m->wx[i + j * LF_NW] * dx;
    }
    memcpy(w, p, sizeof p);
}

/* Simplified Newton from w (the kept LU of dF/dw for every iteration).  q: the
 * largest |dw_i| / (LF_NEWTON_ATOL + LF_NEWTON_RTOL max(|w_i|, |w0_i|)),
 * Newton's stopping test is q <= 1; the rate theta = q / q_before.  While
 * theta <= LF_SIMPLE_RATE the iterate's error is at most about
 * theta / (1 - theta) times its last step: converged when that is within
 * Newton's tolerance, or when the step itself is (Newton's test).
 * 1: converged (w the solution), 0: not (w unchanged), < 0: the residual
 * failed. */
#define LF_SIMPLE_MAX_ITER 6
#define LF_SIMPLE_RATE 0.25
static int simplified(LfInstance *c, double t, const double *x, double *w) {
    double w1[LF_DIM(LF_NW)], dw[LF_DIM(LF_NW)], prev = INFINITY;
    int it, i;
    STAT(st_simp++);
    memcpy(w1, w, sizeof w1);
    for (it = 0; it < LF_SIMPLE_MAX_ITER; it++) {
        double q = 0.0, theta;
        STAT(st_simp_it++);
        if (lf_eval_fn1(c, LF_FN_RES, t, x, w1, c->unsaved.res_F) != LF_OK) return -1;
        if (lf_first_nonfinite(c->unsaved.res_F, LF_NW) >= 0) break;
        nm_apply(&c->unsaved.nm, c->unsaved.res_F, dw);
        for (i = 0; i < LF_NW; i++) {
            double a = fabs(w1[i]), b = fabs(w[i]), d = fabs(dw[i]);
            w1[i] -= dw[i];
            d /= LF_NEWTON_ATOL + LF_NEWTON_RTOL * (a > b ? a : b);
            if (d > q) q = d;
        }
        theta = q / prev;
        if (!(theta <= LF_SIMPLE_RATE) || lf_first_nonfinite(w1, LF_NW) >= 0) break;
        if (q <= 1.0 || (it > 0 && theta * q <= 1.0 - theta)) {
            memcpy(w, w1, sizeof w1);
            if (it >= 3) c->unsaved.nm.stale = 1;
            return 1;
        }
        prev = q;
    }
    STAT(st_fallback++);
    c->unsaved.nm.stale = 1;
    return 0;
}

/* b := a^-1 b for the torn unknowns' Jacobian a (LF_NT_TORN square,
 * column-major, overwritten): Gaussian elimination with partial pivoting,
 * its size a constant the compiler unrolls (a loop is a few unknowns, and
 * lf_lu_factor's general loops cost more than the arithmetic here).
 * Nonzero where a pivot is zero or not finite. */
static inline int torn_linear_solve(double *a, double *b) {
    enum { N = LF_DIM(LF_NT_TORN) };
    int i, j, k;
    for (k = 0; k < LF_NT_TORN; k++) {
        int p = k;
        double piv, tmp;
        for (i = k + 1; i < LF_NT_TORN; i++)
            if (fabs(a[i + k * N]) > fabs(a[p + k * N])) p = i;
        piv = a[p + k * N];
        if (!(fabs(piv) > 0.0) || !isfinite(piv)) return 1;
        if (p != k) {
            for (j = k; j < LF_NT_TORN; j++) {
                tmp = a[k + j * N];
                a[k + j * N] = a[p + j * N];
                a[p + j * N] = tmp;
            }
            tmp = b[k];
            b[k] = b[p];
            b[p] = tmp;
        }
        for (i = k + 1; i < LF_NT_TORN; i++) {
            double l = a[i + k * N] / piv;
            for (j = k + 1; j < LF_NT_TORN; j++) a[i + j * N] -= l * a[k + j * N];
            b[i] -= l * b[k];
        }
    }
    for (k = LF_NT_TORN - 1; k >= 0; k--) {
        for (j = k + 1; j < LF_NT_TORN; j++) b[k] -= a[k + j * N] * b[j];
        b[k] /= a[k + k * N];
    }
    return 0;
}

/* A torn model (lf_model.h: LF_TORN): w[tear_pre] and the hoisted
 * subexpressions h in closed form, Newton with the exact Jacobian on the
 * LF_NT_TORN torn unknowns only (their residual reads [w; h] and gives the
 * other unknowns of the loop in closed form inside), then w[tear_post] in
 * closed form.  w holds the start of the torn unknowns.  The stopping test is Newton's
 * (newton()) on the torn unknowns.  1: solved; 0: not (a closed form or
 * the residual not finite, a singular Jacobian, no convergence: the
 * caller runs Newton on every unknown, which says what failed); < 0: a
 * generated function failed. */
static int torn_solve(LfInstance *c, double t, const double *x, double *w) {
    enum { NP = LF_NT_PRE + LF_NT_HOIST, NT = LF_DIM(LF_NT_TORN) };
    /* wh = [w; h]: the argument w of tres and tpost */
    double wh[LF_DIM(LF_NW + LF_NT_HOIST)], part[LF_DIM(NP > LF_NT_POST ? NP : LF_NT_POST)];
    double F[NT], J[NT * NT], w0[NT], prev = INFINITY, q_prev = INFINITY;
    int it, i;
    memcpy(wh, w, sizeof(double) * LF_NW);
    if (NP > 0) {
        if (lf_eval_fn1(c, LF_FN_TPRE, t, x, w, part) != LF_OK) return -1;
        if (lf_first_nonfinite(part, NP) >= 0) return 0;
        for (i = 0; i < LF_NT_PRE; i++) wh[lf_model.tear_pre[i]] = part[i];
        for (i = 0; i < LF_NT_HOIST; i++) wh[LF_NW + i] = part[LF_NT_PRE + i];
    }
    for (i = 0; i < LF_NT_TORN; i++) w0[i] = wh[lf_model.tear_torn[i]];
    for (it = 0; LF_NT_TORN > 0; it++) {
        double size = 0.0, q = 0.0, theta;
        if (it == LF_NEWTON_MAX_ITER) return 0;
        STAT(st_full_it++);
        if (lf_eval_fn(c, LF_FN_TRES, t, x, wh, F, J, NULL) != LF_OK) return -1;
        if (lf_first_nonfinite(F, LF_NT_TORN) >= 0 || torn_linear_solve(J, F) != 0) return 0;
        for (i = 0; i < LF_NT_TORN; i++) {
            double *wi = &wh[lf_model.tear_torn[i]], scale = fmax(fabs(*wi), fabs(w0[i]));
            double d = fabs(F[i]);
            *wi -= F[i];
            q = fmax(q, d / (LF_NEWTON_ATOL + LF_NEWTON_RTOL * scale));
            size = fmax(size, d / (LF_NEWTON_ATOL + scale));
        }
        /* converged: Newton's test (q <= 1), its stagnation at rounding, or
         * (contracting at the rate theta <= 1/4) the error after this step,
         * about theta / (1 - theta) times the step, within the tolerance */
        theta = q / q_prev;
        if (q <= 1.0 || (size < 1e-8 && size >= 0.5 * prev) ||
            (it > 0 && theta <= 0.25 && theta * q <= 1.0 - theta))
            break;
        prev = size;
        q_prev = q;
    }
    if (LF_NT_POST > 0) {
        if (lf_eval_fn1(c, LF_FN_TPOST, t, x, wh, part) != LF_OK) return -1;
        if (lf_first_nonfinite(part, LF_NT_POST) >= 0) return 0;
        for (i = 0; i < LF_NT_POST; i++) wh[lf_model.tear_post[i]] = part[i];
    }
    memcpy(w, wh, sizeof(double) * LF_NW);
    return lf_first_nonfinite(w, LF_NW) < 0;
}

/* The unknowns w = [der(x); z] at (t, x) (inline in lf_rhs, the solvers'
 * hot path: forced where the compiler can be told, since its size (Newton
 * for implicit models, two callers) made gcc keep it a call). */
#if defined(__GNUC__)
#define LF_ALWAYS_INLINE __attribute__((always_inline))
#else
#define LF_ALWAYS_INLINE
#endif
static inline LF_ALWAYS_INLINE LfStatus solve_w(LfInstance *c, double t, const double *x, double *w) {
    LfStatus st;
    int bad;
    STAT(st_solves++);
    if (LF_WC_USED && c->unsaved.wc_on && lf_wc_take(c, t, x, w)) {
        STAT(st_hits++);
        return LF_OK;
    }
    if (LF_WK_USED && c->unsaved.wc_on && lf_wk_take(c, t, x, w)) return LF_OK;
    if (LF_USE_TEAR && c->unsaved.wc_on) {
        int done;
        STAT(st_full++);
        memcpy(w, c->val.w_cur, sizeof(double) * LF_NW);
        done = torn_solve(c, t, x, w);
        if (done < 0) return LF_ERROR;
        if (!done) {
            STAT(st_fallback++);
            memcpy(w, c->val.w_cur, sizeof(double) * LF_NW);
            st = newton(c, t, x, w);
            if (st != LF_OK) return st;
        }
    } else if (LF_IMPLICIT) {
        int done = 0;
        if (nm_on(c) && c->unsaved.nm.lu_gen == c->unsaved.wc_gen && c->unsaved.nm.b_gen == c->unsaved.wc_gen) {
            nm_predict(c, t, x, w);
            if (lf_first_nonfinite(w, LF_NW) >= 0) memcpy(w, c->val.w_cur, sizeof(double) * LF_NW);
            if (!c->unsaved.nm.stale) {
                done = simplified(c, t, x, w);
                if (done < 0) return LF_ERROR;
            }
        } else {
            memcpy(w, c->val.w_cur, sizeof(double) * LF_NW);
        }
        if (!done) {
            st = newton(c, t, x, w);
            if (st != LF_OK) return st;
        }
    } else if (lf_eval_fn1(c, LF_FN_WSOL, t, x, w, w) != LF_OK) {
        return LF_ERROR;
    }
    bad = lf_first_nonfinite(w, LF_NW);
    if (bad >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: unknown %d of the model equations "
               "(derivative or algebraic variable) is %g", t, bad, w[bad]);
        return LF_DISCARD;
    }
    memcpy(c->val.w_cur, w, sizeof(double) * LF_NW);
    if (nm_on(c)) {
        c->unsaved.nm.b_gen = c->unsaved.wc_gen;
        c->unsaved.nm.tb = t;
        memcpy(c->unsaved.nm.xb, x, sizeof(double) * LF_NX);
        memcpy(c->unsaved.nm.wb, w, sizeof(double) * LF_NW);
    }
    if (LF_WC_USED && c->unsaved.wc_on) lf_wc_keep(c, t, x, w);
    if (LF_WK_USED && c->unsaved.wc_on) lf_wk_keep(c, t, x);
    return LF_OK;
}

LfStatus lf_solve_w(LfInstance *c, double t, const double *x, double *w) {
    return solve_w(c, t, x, w);
}

LfStatus lf_rhs(void *ctx, double t, const double *x, double *dx) {
    LfInstance *c = (LfInstance *)ctx;
    LfStatus st = solve_w(c, t, x, c->unsaved.w_tmp);
    if (st != LF_OK) return st;
    memcpy(dx, c->unsaved.w_tmp, sizeof(double) * LF_NX);
    return LF_OK;
}

/* The delayed values' part of df/dx and df/dt, added to c->unsaved.jac_wx and
 * c->unsaved.jac_wt through dw/dd (for implicit models dw/dd = -(dF/dw)^-1 dF/dd,
 * with dF/dw factored in c->unsaved.jac_ww):
 *  - a zero delay reads d = g(t, x) now: dd/dx = dg/dx, dd/dt = dg/dt;
 *  - a delay tau > 0 reads d = g(t - tau) from the history: dd/dx = 0,
 *    dd/dt = the history's dg/dt at t - tau (its interpolant's slope).
 * Without them Rosenbrock methods lose their order (rodas4 fell to first
 * order on x' = -x(t - 1): error 3e-5 at rtol 1e-6, 3e-6 at 1e-8). */
static LfStatus delay_jacobian(LfInstance *c, double t, const double *x) {
    double wd[LF_DIM(LF_NW * LF_ND)], gx[LF_DIM(LF_ND * LF_NX)], gt[LF_DIM(LF_ND)];
    double rate[LF_DIM(LF_ND)];
    int i, j, k;
    if (lf_delayed_rates(c, t, x, rate) != LF_OK) return LF_ERROR;
    if (lf_eval_fn(c, LF_FN_DJAC, t, x, c->val.w_cur, wd, gx, gt) != LF_OK) return LF_ERROR;
    for (k = 0; k < LF_ND; k++) {
        double *col = &wd[k * LF_NW], dd_dt = c->dl.tau[k] == 0 ? gt[k] : rate[k];
        if (LF_IMPLICIT) {
            lf_lu_solve(c->unsaved.jac_ww, LF_NW, c->unsaved.piv, col);
            for (i = 0; i < LF_NW; i++) col[i] = -col[i];
        }
        if (c->dl.tau[k] == 0)
            for (j = 0; j < LF_NX; j++)
                for (i = 0; i < LF_NW; i++) c->unsaved.jac_wx[i + j * LF_NW] += col[i] * gx[k + j * LF_ND];
        for (i = 0; i < LF_NW; i++) c->unsaved.jac_wt[i] += col[i] * dd_dt;
    }
    return LF_OK;
}

/* df/dx and df/dt: the first LF_NX rows of dw/dx, dw/dt, which implicit
 * models get from the implicit function theorem, dw = -(dF/dw)^-1 dF. */
static LfStatus jac_cb(void *ctx, double t, const double *x, double *J, double *dfdt) {
    LfInstance *c = (LfInstance *)ctx;
    int i, j;
    LfStatus st;
    if (LF_IMPLICIT) {
        st = lf_solve_w(c, t, x, c->unsaved.w_tmp);
        if (st == LF_OK) st = factor_dFdw(c, t, x, c->unsaved.w_tmp);
        if (st != LF_OK) return st;
        if (nm_on(c)) nm_keep_lu(c); /* at the solution: the stages' simplified Newton */
        for (j = 0; j < LF_NX; j++) lf_lu_solve(c->unsaved.jac_ww, LF_NW, c->unsaved.piv, &c->unsaved.jac_wx[j * LF_NW]);
        lf_lu_solve(c->unsaved.jac_ww, LF_NW, c->unsaved.piv, c->unsaved.jac_wt);
        for (i = 0; i < LF_NW * LF_NX; i++) c->unsaved.jac_wx[i] = -c->unsaved.jac_wx[i];
        for (i = 0; i < LF_NW; i++) c->unsaved.jac_wt[i] = -c->unsaved.jac_wt[i];
    } else if (lf_eval_fn(c, LF_FN_WJAC, t, x, c->val.w_cur, c->unsaved.jac_wx, c->unsaved.jac_wt, NULL) != LF_OK) {
        return LF_ERROR;
    }
    if (LF_ND > 0) {
        st = delay_jacobian(c, t, x);
        if (st != LF_OK) return st;
    }
    for (j = 0; j < LF_NX; j++)
        for (i = 0; i < LF_NX; i++) J[i + j * LF_NX] = c->unsaved.jac_wx[i + j * LF_NW];
    memcpy(dfdt, c->unsaved.jac_wt, sizeof(double) * LF_NX);
    if (lf_first_nonfinite(J, (size_t)LF_NX * LF_NX) >= 0 || lf_first_nonfinite(dfdt, LF_NX) >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: Jacobian is not finite", t);
        return LF_DISCARD;
    }
    return LF_OK;
}

LfOde lf_ode_of(LfInstance *c) {
    LfOde ode;
    ode.n = LF_NX;
    ode.ctx = c;
    ode.rhs = lf_rhs;
    ode.jac = jac_cb;
    return ode;
}

/* b := (dF/dw)^-1 b at (t, x, w) (implicit models; output derivatives). */
LfStatus lf_solve_dFdw(LfInstance *c, double t, const double *x, const double *w, double *b) {
    LfStatus st = factor_dFdw(c, t, x, w);
    if (st != LF_OK) return st;
    lf_lu_solve(c->unsaved.jac_ww, LF_NW, c->unsaved.piv, b);
    return LF_OK;
}
