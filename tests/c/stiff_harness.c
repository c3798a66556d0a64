/* Standalone driver for the stiff linear algebra of the loomfmu runtime
 * (lf_schur.c) and the stiff solvers (lf_rodas4.c, lf_wmethod.c).
 *
 * Usage:
 *   stiff_harness schur <n_pairs> <n_rest> <seed>
 *       random Newton matrix alpha*I - J whose J has n_pairs kinematic rows
 *       q' = c v (states interleaved), n_rest other states; solves through
 *       lf_shifted_factor/solve against a plain dense LU of the same matrix
 *   stiff_harness run <method> <problem> <rtol> <atol> <t_end> <h_max> <ncomm>
 *       integrate <problem> from 0 to t_end in ncomm communication intervals
 *       (lf_solver_reset at each, as the FMU step loop after an input change)
 *       and compare with the exact solution where known
 * Problems: kaps (Kaps' nonlinear stiff problem, exact e^-2t, e^-t), lin2
 * (linear stiff, eigenvalues -2 and -1000, exact), kaps_w / lin2_w (the same
 * with a wrong Jacobian: W != J, for the W-method property), chain (12
 * masses with a cubic and a stiff spring and a first-order drive lag, 25
 * states interleaved q, v; no exact solution: the solution is printed).
 *
 * Output: one "key value" pair per line.
 */
#include "lf_linalg.h"
#include "lf_solver_impl.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define NMAX 64
#define NCHAIN 12

/* ---------------------------------------------------------------- problems */

typedef struct {
    const char *name;
    size_t n;
    LfStatus (*rhs)(void *ctx, double t, const double *x, double *dx);
    LfStatus (*jac)(void *ctx, double t, const double *x, double *J, double *dfdt);
    int (*exact)(double t, double *x); /* 0: unknown */
    void (*start)(double *x);
} Problem;

#define KAPS_K 1000.0

static LfStatus kaps_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    (void)t;
    dx[0] = -(KAPS_K + 2.0) * x[0] + KAPS_K * x[1] * x[1];
    dx[1] = x[0] - x[1] - x[1] * x[1];
    return LF_OK;
}
static LfStatus kaps_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)t;
    J[0] = -(KAPS_K + 2.0);
    J[1] = 1.0;
    J[2] = 2.0 * KAPS_K * x[1];
    J[3] = -1.0 - 2.0 * x[1];
    ft[0] = ft[1] = 0.0;
    return LF_OK;
}
/* W != J, off by O(1) entries (rodas4 falls to order 1 with it) */
static LfStatus kaps_wrong(void *c, double t, const double *x, double *J, double *ft) {
    kaps_j(c, t, x, J, ft);
    J[1] += 0.5;
    J[2] += 2.0;
    J[3] -= 0.5;
    return LF_OK;
}
static int kaps_x(double t, double *x) {
    x[0] = exp(-2.0 * t);
    x[1] = exp(-t);
    return 1;
}
static void kaps_0(double *x) { kaps_x(0.0, x); }

/* x' = A x + g(t), A = [[-a, b], [b, -a]] (eigenvalues -(a-b) = -2 and
 * -(a+b) = -1000), g = s' - A s with s = (sin t, cos t), so that
 * x = s(t) + e^-2t (1, 1) + e^-1000t (1, -1) exactly.  lin2_w: W = J + I/2
 * and a wrong df/dt.  (A W off J in the stiff coupling would keep order 3
 * only once h*1000 << 1: W-methods need W close to J in stiff directions
 * for their order to show at practical steps.) */
#define LIN_A 501.0
#define LIN_B 499.0
static LfStatus lin2_f(void *c, double t, const double *x, double *dx) {
    double s0 = sin(t), s1 = cos(t);
    (void)c;
    dx[0] = -LIN_A * x[0] + LIN_B * x[1] + (s1 - (-LIN_A * s0 + LIN_B * s1));
    dx[1] = LIN_B * x[0] - LIN_A * x[1] + (-s0 - (LIN_B * s0 - LIN_A * s1));
    return LF_OK;
}
static LfStatus lin2_j(void *c, double t, const double *x, double *J, double *ft) {
    double d0 = cos(t), d1 = -sin(t);
    (void)c;
    (void)x;
    J[0] = -LIN_A;
    J[1] = LIN_B;
    J[2] = LIN_B;
    J[3] = -LIN_A;
    /* dg/dt = s'' - A s' */
    ft[0] = -sin(t) - (-LIN_A * d0 + LIN_B * d1);
    ft[1] = -cos(t) - (LIN_B * d0 - LIN_A * d1);
    return LF_OK;
}
static LfStatus lin2_wrong(void *c, double t, const double *x, double *J, double *ft) {
    lin2_j(c, t, x, J, ft);
    J[0] += 0.5;
    J[3] += 0.5;
    ft[0] += 1.0;
    return LF_OK;
}
static int lin2_x(double t, double *x) {
    double e1 = exp(-2.0 * t), e2 = exp(-1000.0 * t);
    x[0] = sin(t) + e1 + e2;
    x[1] = cos(t) + e1 - e2;
    return 1;
}
static void lin2_0(double *x) { lin2_x(0.0, x); }

/* chain: masses k = 0..NCHAIN-1 at x[2k] (position) and x[2k+1] (velocity),
 * springs between neighbours (one stiff, all with a cubic term and damping),
 * the first mass driven through a first-order lag z = x[2*NCHAIN] of the
 * force u(t) = sin(20 t). */
#define CH_K 4.0e3
#define CH_KSTIFF 4.0e6
#define CH_K3 1.0e9
#define CH_C 0.5
#define CH_TAU 1e-3
static double ch_k(size_t k) { return k == 5 ? CH_KSTIFF : CH_K; }
static LfStatus chain_f(void *c, double t, const double *x, double *dx) {
    size_t k;
    (void)c;
    for (k = 0; k < NCHAIN; k++) {
        double f = k == 0 ? x[2 * NCHAIN] : 0.0;
        if (k > 0) {
            double d = x[2 * k] - x[2 * k - 2], dv = x[2 * k + 1] - x[2 * k - 1];
            f -= ch_k(k) * d + CH_K3 * d * d * d + CH_C * dv;
        }
        if (k + 1 < NCHAIN) {
            double d = x[2 * k] - x[2 * k + 2], dv = x[2 * k + 1] - x[2 * k + 3];
            f -= ch_k(k + 1) * d + CH_K3 * d * d * d + CH_C * dv;
        }
        dx[2 * k] = x[2 * k + 1];
        dx[2 * k + 1] = f;
    }
    dx[2 * NCHAIN] = (sin(20.0 * t) - x[2 * NCHAIN]) / CH_TAU;
    return LF_OK;
}
/* spring between masses k-1 and k: its contribution to J */
static void ch_spring(double *J, size_t n, const double *x, size_t k) {
    size_t a = 2 * k - 2, b = 2 * k;
    double d = x[b] - x[a];
    double ks = ch_k(k) + 3.0 * CH_K3 * d * d;
    /* force on b: -ks d - c dv; on a: +ks d + c dv */
    J[(b + 1) + b * n] -= ks;
    J[(b + 1) + a * n] += ks;
    J[(a + 1) + b * n] += ks;
    J[(a + 1) + a * n] -= ks;
    J[(b + 1) + (b + 1) * n] -= CH_C;
    J[(b + 1) + (a + 1) * n] += CH_C;
    J[(a + 1) + (b + 1) * n] += CH_C;
    J[(a + 1) + (a + 1) * n] -= CH_C;
}
static LfStatus chain_j(void *c, double t, const double *x, double *J, double *ft) {
    const size_t n = 2 * NCHAIN + 1;
    size_t k;
    (void)c;
    memset(J, 0, sizeof(double) * n * n);
    memset(ft, 0, sizeof(double) * n);
    for (k = 0; k < NCHAIN; k++) J[2 * k + (2 * k + 1) * n] = 1.0;
    for (k = 1; k < NCHAIN; k++) ch_spring(J, n, x, k);
    J[1 + (2 * NCHAIN) * n] = 1.0;
    J[2 * NCHAIN + (2 * NCHAIN) * n] = -1.0 / CH_TAU;
    ft[2 * NCHAIN] = 20.0 * cos(20.0 * t) / CH_TAU;
    return LF_OK;
}
static int chain_x(double t, double *x) {
    (void)t;
    (void)x;
    return 0;
}
static void chain_0(double *x) {
    size_t k;
    for (k = 0; k < 2 * NCHAIN + 1; k++) x[k] = 0.0;
    x[2 * NCHAIN - 2] = 1e-4; /* last mass displaced */
}

static const Problem problems[] = {
    {"kaps", 2, kaps_f, kaps_j, kaps_x, kaps_0},
    {"kaps_w", 2, kaps_f, kaps_wrong, kaps_x, kaps_0},
    {"lin2", 2, lin2_f, lin2_j, lin2_x, lin2_0},
    {"lin2_w", 2, lin2_f, lin2_wrong, lin2_x, lin2_0},
    {"chain", 2 * NCHAIN + 1, chain_f, chain_j, chain_x, chain_0},
};

static const Problem *find_problem(const char *name) {
    size_t k;
    for (k = 0; k < sizeof problems / sizeof problems[0]; k++)
        if (strcmp(problems[k].name, name) == 0) return &problems[k];
    return NULL;
}

static const LfMethod *find_method(const char *name) {
    size_t k;
    for (k = 0; k < lf_n_methods; k++)
        if (strcmp(lf_methods[k]->name, name) == 0) return lf_methods[k];
    /* not (yet) in the registry of the FMUs */
    if (strcmp(name, lf_ros34pw2.name) == 0) return &lf_ros34pw2;
    return NULL;
}

/* ---------------------------------------------------------------- commands */

static unsigned long rng_state = 1;
static double rnd(void) { /* uniform in [-1, 1) */
    rng_state = rng_state * 6364136223846793005UL + 1442695040888963407UL;
    return (double)((rng_state >> 11) & 0xFFFFFFFFUL) / 2147483648.0 - 1.0;
}

static int cmd_schur(int argc, char **argv) {
    static double J[NMAX * NMAX], E[NMAX * NMAX], ws[NMAX * NMAX + 16 * NMAX], b[NMAX],
        x1[NMAX], x2[NMAX], r[NMAX];
    static size_t piv[NMAX];
    size_t np, nr, n, i, j, k;
    double alpha = 1e4, dmax = 0.0, xmax = 0.0, rmax = 0.0, bmax = 0.0;
    int rc1, rc2;
    if (argc < 5) return 2;
    np = (size_t)atoi(argv[2]);
    nr = (size_t)atoi(argv[3]);
    rng_state = (unsigned long)atol(argv[4]);
    n = 2 * np + nr;
    if (n > NMAX || n == 0) return 2;
    /* states: pairs (q_k, v_k) first interleaved, then the rest; row q_k
     * is c_k e_{v_k}, every other row dense */
    for (j = 0; j < n; j++)
        for (i = 0; i < n; i++) J[i + j * n] = 1e3 * rnd();
    for (k = 0; k < np; k++) {
        for (j = 0; j < n; j++) J[2 * k + j * n] = 0.0;
        J[2 * k + (2 * k + 1) * n] = k % 2 ? 1.0 : 0.5 + rnd();
    }
    for (i = 0; i < n; i++) b[i] = x1[i] = x2[i] = rnd();
    for (i = 0; i < n * n; i++) E[i] = -J[i];
    for (i = 0; i < n; i++) E[i + i * n] += alpha;
    rc1 = lf_lu_factor(E, n, piv);
    lf_lu_solve(E, n, piv, x1);
    rc2 = lf_shifted_factor(ws, J, n, alpha);
    lf_shifted_solve(ws, J, n, x2);
    for (i = 0; i < n; i++) {
        double s = alpha * x2[i];
        for (j = 0; j < n; j++) s -= J[i + j * n] * x2[j];
        r[i] = s - b[i];
        dmax = fmax(dmax, fabs(x1[i] - x2[i]));
        xmax = fmax(xmax, fabs(x1[i]));
        rmax = fmax(rmax, fabs(r[i]));
        bmax = fmax(bmax, fabs(b[i]));
    }
    printf("n %lu\n", (unsigned long)n);
    printf("rc_dense %d\nrc_schur %d\n", rc1, rc2);
    printf("eliminated %lu\n", (unsigned long)lf_shifted_eliminated(ws));
    printf("max_rel_diff %.3e\n", dmax / xmax);
    printf("rel_residual %.3e\n", rmax / bmax);
    return 0;
}

static void *h_calloc(size_t a, size_t b) { return calloc(a, b); }
static void h_free(void *p) { free(p); }

static int cmd_run(int argc, char **argv) {
    const LfMethod *m;
    const Problem *p;
    LfSolver s;
    LfOde ode;
    LfSolverOptions opt;
    LfAllocator alloc;
    double x0[NMAX], xe[NMAX], t_end, err = 0.0, scale = 0.0;
    long ncomm, c;
    size_t i;
    LfStatus st = LF_OK;
    if (argc < 9) return 2;
    m = find_method(argv[2]);
    p = find_problem(argv[3]);
    if (!m || !p) {
        fprintf(stderr, "unknown method or problem\n");
        return 2;
    }
    opt.rtol = atof(argv[4]);
    opt.atol = atof(argv[5]);
    t_end = atof(argv[6]);
    opt.h_max = atof(argv[7]);
    opt.h_fixed = opt.h_max;
    opt.max_steps = 0;
    ncomm = atol(argv[8]);
    ode.n = p->n;
    ode.ctx = NULL;
    ode.rhs = p->rhs;
    ode.jac = p->jac;
    alloc.calloc = h_calloc;
    alloc.free = h_free;
    p->start(x0);
    if (lf_solver_init(&s, m, ode, opt, 0.0, x0, &alloc) != LF_OK) {
        printf("status %d\nmessage %s\n", (int)LF_ERROR, s.message);
        return 0;
    }
    s.h = opt.h_max; /* first step: h_max (fixed steps when the tolerances are loose) */
    for (c = 1; c <= ncomm && st == LF_OK; c++) {
        double tb = c == ncomm ? t_end : t_end * (double)c / (double)ncomm;
        if (c > 1) lf_solver_reset(&s, s.t, s.x);
        while (st == LF_OK && s.t < tb) st = m->step(&s, tb);
    }
    printf("status %d\n", (int)st);
    printf("t %.17g\n", s.t);
    if (p->exact(s.t, xe)) {
        for (i = 0; i < p->n; i++) {
            err = fmax(err, fabs(s.x[i] - xe[i]));
            scale = fmax(scale, fabs(xe[i]));
        }
        printf("err_final %.6e\n", err / scale);
    }
    for (i = 0; i < p->n; i++) printf("x%lu %.17g\n", (unsigned long)i, s.x[i]);
    printf("steps %ld\nrejected %ld\nrhs %ld\njac %ld\nlu %ld\n", s.n_steps, s.n_rejected,
           s.n_rhs, s.n_jac, s.n_lu);
    printf("message %s\n", s.message);
    lf_solver_free(&s, &alloc);
    return 0;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: see source\n");
        return 2;
    }
    if (strcmp(argv[1], "schur") == 0) return cmd_schur(argc, argv);
    if (strcmp(argv[1], "run") == 0) return cmd_run(argc, argv);
    fprintf(stderr, "unknown command %s\n", argv[1]);
    return 2;
}
