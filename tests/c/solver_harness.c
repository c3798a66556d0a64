/* Standalone driver for the loomfmu embedded ODE solvers (lf_solvers.c,
 * lf_dopri5.c, lf_rodas4.c).
 *
 * Usage:
 *   solver_harness run <method> <problem> <rtol> <atol> <t_end> <ncomm> <h_fixed> <h_max>
 *       integrate <problem> from 0 to t_end, in ncomm communication intervals
 *       (each solver call gets t_bound = end of the current interval), and
 *       compare with the exact solution
 *   solver_harness snapshot <same arguments as run>
 *       copy the solver (struct + work) halfway, continue, restore the copy in
 *       a different buffer, continue again: both results must be identical
 *   solver_harness side <same arguments as run>
 *       run the problem alone, then interleaved step by step with a second
 *       solver (other problem); both runs must give identical results
 *   solver_harness reset <method> <rtol> <atol> <h_fixed>
 *       decay problem, jump x -> 2x at t = 0.5 via lf_solver_reset
 *   solver_harness badopt
 *       invalid options must give LF_ERROR with a message
 *   solver_harness linalg
 *       LU factorization/solve checks
 *
 * Output: one "key value" pair per line (message last, rest of the line).
 */
#include "lf_linalg.h"
#include "lf_solver.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846
/* the most states of a problem (the arrays below hold that many) */
#define H_MAXN 17

/* ---------------------------------------------------------------- problems */

typedef struct {
    const char *name;
    size_t n;
    double x0[H_MAXN];
    LfStatus (*rhs)(void *ctx, double t, const double *x, double *dx);
    LfStatus (*jac)(void *ctx, double t, const double *x, double *J, double *dfdt);
    /* exact solution; returns 0 if unknown */
    int (*exact)(double t, double *x);
} Problem;

static LfStatus decay_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    (void)t;
    dx[0] = -x[0];
    return LF_OK;
}
static LfStatus decay_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)t;
    (void)x;
    J[0] = -1.0;
    ft[0] = 0.0;
    return LF_OK;
}
static int decay_x(double t, double *x) {
    x[0] = exp(-t);
    return 1;
}

static LfStatus osc_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    (void)t;
    dx[0] = x[1];
    dx[1] = -x[0];
    return LF_OK;
}
static LfStatus osc_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)t;
    (void)x;
    J[0] = 0.0;  /* d f0 / d x0 */
    J[1] = -1.0; /* d f1 / d x0 */
    J[2] = 1.0;  /* d f0 / d x1 */
    J[3] = 0.0;
    ft[0] = ft[1] = 0.0;
    return LF_OK;
}
static int osc_x(double t, double *x) {
    x[0] = cos(t);
    x[1] = -sin(t);
    return 1;
}

/* linear stiff system with eigenvalues -1 (eigenvector (1,1)) and -1e4
 * (eigenvector (1,-1)), x(0) = (2, 0) */
#define ST_A (-5000.5)
#define ST_B 4999.5
static LfStatus stiff_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    (void)t;
    dx[0] = ST_A * x[0] + ST_B * x[1];
    dx[1] = ST_B * x[0] + ST_A * x[1];
    return LF_OK;
}
static LfStatus stiff_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)t;
    (void)x;
    J[0] = ST_A;
    J[1] = ST_B;
    J[2] = ST_B;
    J[3] = ST_A;
    ft[0] = ft[1] = 0.0;
    return LF_OK;
}
static int stiff_x(double t, double *x) {
    double e1 = exp(-t), e2 = exp(-1e4 * t);
    x[0] = e1 + e2;
    x[1] = e1 - e2;
    return 1;
}

/* x' = cos(t): non-autonomous, J = 0, df/dt = -sin(t) */
static LfStatus cos_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    (void)x;
    dx[0] = cos(t);
    return LF_OK;
}
static LfStatus cos_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)x;
    J[0] = 0.0;
    ft[0] = -sin(t);
    return LF_OK;
}
/* same, but the Jacobian callback wrongly claims df/dt = 0 */
static LfStatus cos_j_nodfdt(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)t;
    (void)x;
    J[0] = 0.0;
    ft[0] = 0.0;
    return LF_OK;
}
static int cos_x(double t, double *x) {
    x[0] = sin(t);
    return 1;
}

/* Prothero-Robinson: x' = L (x - sin t) + cos t, x(0) = 0, exact sin t,
 * stiff (L = -1e4) and non-autonomous */
#define PR_L (-1e4)
static LfStatus pr_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    dx[0] = PR_L * (x[0] - sin(t)) + cos(t);
    return LF_OK;
}
static LfStatus pr_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)x;
    J[0] = PR_L;
    ft[0] = -PR_L * cos(t) - sin(t);
    return LF_OK;
}

/* x' = -x, but f is NaN for t > 0.5 */
static LfStatus nan_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    dx[0] = t > 0.5 ? NAN : -x[0];
    return LF_OK;
}
/* x' = -x, but f reports LF_ERROR for t > 0.5 */
static LfStatus err_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    dx[0] = -x[0];
    return t > 0.5 ? LF_ERROR : LF_OK;
}
/* x' = x^2, x(0) = 1: blows up at t = 1 */
static LfStatus blow_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    (void)t;
    dx[0] = x[0] * x[0];
    return LF_OK;
}
static LfStatus blow_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)t;
    J[0] = 2.0 * x[0];
    ft[0] = 0.0;
    return LF_OK;
}
static int blow_x(double t, double *x) {
    x[0] = 1.0 / (1.0 - t);
    return t < 1.0;
}
/* a lightly damped stiff oscillator driven slowly (a rotor mode on an oil
 * film): x0' = x1 + cos t, x1' = -w^2 (x0 - sin t) - 2 z w x1, eigenvalues
 * -z w +- i w sqrt(1 - z^2), w = 2000, z = 0.02: x -> (sin t, 0) after a
 * fast transient from x(0) = (1, 0).  dopri5's step is bound by its
 * stability region near the imaginary axis.  No exact solution (exact
 * returns 0): the tests compare runs. */
#define SO_W 2000.0
#define SO_Z 0.02
static LfStatus stiffosc_f(void *c, double t, const double *x, double *dx) {
    double y0 = x[0] - sin(t);
    (void)c;
    dx[0] = x[1] + cos(t);
    dx[1] = -SO_W * SO_W * y0 - 2.0 * SO_Z * SO_W * x[1];
    return LF_OK;
}
static LfStatus stiffosc_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)x;
    J[0] = 0.0;
    J[1] = -SO_W * SO_W;
    J[2] = 1.0;
    J[3] = -2.0 * SO_Z * SO_W;
    ft[0] = -sin(t);
    ft[1] = SO_W * SO_W * cos(t);
    return LF_OK;
}
static int stiffosc_x(double t, double *x) {
    (void)t;
    (void)x;
    return 0;
}
/* JUMP_N states (the vectorized dopri5 steps, with tail elements: 5 for the
 * SSE2 build, 17 for the AVX2 one): x' = -x, until at t = 30 x_0' jumps to
 * 1.7e308 (finite), where the steps have grown long (x is below atol): the
 * next stage arguments overflow to Inf.  f answers a non-finite argument
 * with LF_ERROR, so the run ends in Discard only if every stage's argument
 * was checked before the call */
#define JUMP(N)                                                                    \
    static LfStatus jump##N##_f(void *c, double t, const double *x, double *dx) { \
        int i;                                                                     \
        (void)c;                                                                   \
        for (i = 0; i < N; i++) {                                                  \
            if (!isfinite(x[i])) return LF_ERROR;                                  \
            dx[i] = -x[i];                                                         \
        }                                                                          \
        if (t >= 30.0) dx[0] = 1.7e308;                                            \
        return LF_OK;                                                              \
    }                                                                              \
    static LfStatus jump##N##_j(void *c, double t, const double *x, double *J,    \
                                double *ft) {                                      \
        int i, j;                                                                  \
        (void)c;                                                                   \
        (void)t;                                                                   \
        (void)x;                                                                   \
        for (i = 0; i < N; i++) {                                                  \
            for (j = 0; j < N; j++) J[i + N * j] = i == j ? -1.0 : 0.0;            \
            ft[i] = 0.0;                                                           \
        }                                                                          \
        return LF_OK;                                                              \
    }                                                                              \
    static int jump##N##_x(double t, double *x) {                                 \
        int i;                                                                     \
        for (i = 0; i < N; i++) x[i] = exp(-t) / (i + 1.0);                        \
        return t < 30.0;                                                           \
    }
JUMP(5)
JUMP(17)
/* seventeen states, nonlinear and coupled, with a slow and a fast part (the
 * vectorized steps on every element, tails included): a chain of eight
 * pendulums x_2i' = x_2i+1, x_2i+1' = -w_i^2 sin x_2i - 0.1 x_2i+1 +
 * 0.5 (x_2i+2 - x_2i) (w_i = 1 + i/2), and x_16' = -x_16 + x_0 x_1.
 * No exact solution (exact returns 0): the tests compare runs. */
#define CH_P 8
#define CH_N (2 * CH_P + 1)
static LfStatus chain_f(void *c, double t, const double *x, double *dx) {
    int i;
    (void)c;
    (void)t;
    for (i = 0; i < CH_P; i++) {
        double w = 1.0 + 0.5 * i, right = i < CH_P - 1 ? x[2 * i + 2] : 0.0;
        dx[2 * i] = x[2 * i + 1];
        dx[2 * i + 1] = -w * w * sin(x[2 * i]) - 0.1 * x[2 * i + 1] + 0.5 * (right - x[2 * i]);
    }
    dx[CH_N - 1] = -x[CH_N - 1] + x[0] * x[1];
    return LF_OK;
}
static LfStatus chain_j(void *c, double t, const double *x, double *J, double *ft) {
    int i;
    (void)c;
    (void)t;
    memset(J, 0, sizeof(double) * CH_N * CH_N);
    for (i = 0; i < CH_P; i++) {
        double w = 1.0 + 0.5 * i;
        J[2 * i + CH_N * (2 * i + 1)] = 1.0;
        J[2 * i + 1 + CH_N * (2 * i)] = -w * w * cos(x[2 * i]) - 0.5;
        J[2 * i + 1 + CH_N * (2 * i + 1)] = -0.1;
        if (i < CH_P - 1) J[2 * i + 1 + CH_N * (2 * i + 2)] = 0.5;
        ft[2 * i] = ft[2 * i + 1] = 0.0;
    }
    J[CH_N - 1 + CH_N * (CH_N - 1)] = -1.0;
    J[CH_N - 1] = x[1];
    J[CH_N - 1 + CH_N] = x[0];
    ft[CH_N - 1] = 0.0;
    return LF_OK;
}
static int chain_x(double t, double *x) {
    (void)t;
    (void)x;
    return 0;
}
/* a chirp, x' = cos(t^2): the frequency grows with t, so the step sizes
 * shrink all the way and the controller's trend lags the error (no exact
 * solution: exact returns 0, the tests compare runs) */
static LfStatus chirp_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    (void)x;
    dx[0] = cos(t * t);
    return LF_OK;
}
static LfStatus chirp_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)x;
    J[0] = 0.0;
    ft[0] = -2.0 * t * sin(t * t);
    return LF_OK;
}
static int chirp_x(double t, double *x) {
    (void)t;
    (void)x;
    return 0;
}
/* Jacobian with NaN */
static LfStatus nanjac_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)t;
    (void)x;
    J[0] = NAN;
    ft[0] = 0.0;
    return LF_OK;
}
/* no states at all */
static LfStatus empty_f(void *c, double t, const double *x, double *dx) {
    (void)c;
    (void)t;
    (void)x;
    (void)dx;
    return LF_OK;
}
static LfStatus empty_j(void *c, double t, const double *x, double *J, double *ft) {
    (void)c;
    (void)t;
    (void)x;
    (void)J;
    (void)ft;
    return LF_OK;
}
static int empty_x(double t, double *x) {
    (void)t;
    (void)x;
    return 1;
}

static const Problem problems[] = {
    {"decay", 1, {1.0, 0.0}, decay_f, decay_j, decay_x},
    {"osc", 2, {1.0, 0.0}, osc_f, osc_j, osc_x},
    {"stiff", 2, {2.0, 0.0}, stiff_f, stiff_j, stiff_x},
    {"cos", 1, {0.0, 0.0}, cos_f, cos_j, cos_x},
    {"cos_nodfdt", 1, {0.0, 0.0}, cos_f, cos_j_nodfdt, cos_x},
    {"pr", 1, {0.0, 0.0}, pr_f, pr_j, cos_x},
    {"nan_after", 1, {1.0, 0.0}, nan_f, decay_j, decay_x},
    {"error_after", 1, {1.0, 0.0}, err_f, decay_j, decay_x},
    {"blowup", 1, {1.0, 0.0}, blow_f, blow_j, blow_x},
    {"stiffosc", 2, {1.0, 0.0}, stiffosc_f, stiffosc_j, stiffosc_x},
    {"jump5", 5, {1.0, 0.5, 1.0 / 3.0, 0.25, 0.2}, jump5_f, jump5_j, jump5_x},
    {"jump17", 17, {1.0, 0.5, 1.0 / 3.0, 0.25, 0.2, 1.0 / 6.0, 1.0 / 7.0, 0.125, 1.0 / 9.0, 0.1,
                    1.0 / 11.0, 1.0 / 12.0, 1.0 / 13.0, 1.0 / 14.0, 1.0 / 15.0, 1.0 / 16.0,
                    1.0 / 17.0},
     jump17_f, jump17_j, jump17_x},
    {"chain17", CH_N,
     {1.0, 0.0, -0.5, 0.0, 0.25, 0.0, 0.0, 0.3, 0.5, 0.0, -0.2, 0.1, 0.0, 0.0, 0.4, -0.1, 1.0},
     chain_f, chain_j, chain_x},
    {"chirp", 1, {0.0, 0.0}, chirp_f, chirp_j, chirp_x},
    {"nanjac", 1, {1.0, 0.0}, decay_f, nanjac_j, decay_x},
    {"empty", 0, {0.0, 0.0}, empty_f, empty_j, empty_x},
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
    return NULL;
}

/* allocator that counts live blocks (checks lf_solver_free) */
static long live_blocks = 0;
static void *count_calloc(size_t nobj, size_t size) {
    void *p = calloc(nobj, size);
    if (p) live_blocks++;
    return p;
}
static void count_free(void *p) {
    if (p) live_blocks--;
    free(p);
}
static const LfAllocator alloc = {count_calloc, count_free};

static double max_abs_diff(const double *a, const double *b, size_t n) {
    double m = 0.0;
    size_t i;
    for (i = 0; i < n; i++) {
        double d = fabs(a[i] - b[i]);
        if (!(d <= m)) m = d; /* NaN propagates */
    }
    return m;
}

/* ---------------------------------------------------------------- run */

typedef struct {
    const LfMethod *m;
    const Problem *p;
    LfSolverOptions opt;
    double t_end;
    long ncomm;
} Setup;

typedef struct {
    LfStatus status;
    double err_final, err_max, dense_err, dense_end_err;
    int landed; /* every communication point hit exactly */
    double x[H_MAXN];
} Result;

static int parse_setup(int argc, char **argv, Setup *su) {
    if (argc < 10) return 0;
    su->m = find_method(argv[2]);
    su->p = find_problem(argv[3]);
    if (!su->m || !su->p) return 0;
    su->opt.rtol = atof(argv[4]);
    su->opt.atol = atof(argv[5]);
    su->t_end = atof(argv[6]);
    su->ncomm = atol(argv[7]);
    su->opt.h_fixed = atof(argv[8]);
    su->opt.h_max = atof(argv[9]);
    su->opt.max_steps = 1000000;
    if (su->ncomm < 1) su->ncomm = 1;
    return 1;
}

static double comm_point(const Setup *su, long k) {
    return k == su->ncomm ? su->t_end : su->t_end * (double)k / (double)su->ncomm;
}

/* Advance until t == tb; checks dense output after every accepted step. */
static LfStatus advance(LfSolver *s, const Problem *p, double tb, Result *r) {
    static const double thetas[] = {0.1, 0.25, 0.5, 0.75, 0.9};
    double xe[H_MAXN], xd[H_MAXN];
    long guard = 0;
    size_t k;
    while (s->t < tb) {
        LfStatus st = s->method->step(s, tb);
        if (st != LF_OK) return st;
        if (++guard > 10000000L) return LF_FATAL;
        if (p->exact(s->t, xe)) {
            double e = max_abs_diff(s->x, xe, p->n);
            if (!(e <= r->err_max)) r->err_max = e;
        }
        for (k = 0; k < sizeof thetas / sizeof thetas[0]; k++) {
            double tq = s->t_old + thetas[k] * (s->t - s->t_old);
            s->method->dense(s, tq, xd);
            if (p->exact(tq, xe)) {
                double e = max_abs_diff(xd, xe, p->n);
                if (!(e <= r->dense_err)) r->dense_err = e;
            }
        }
        s->method->dense(s, s->t_old, xd);
        {
            double e = max_abs_diff(xd, s->x_old, p->n);
            if (!(e <= r->dense_end_err)) r->dense_end_err = e;
        }
        s->method->dense(s, s->t, xd);
        {
            double e = max_abs_diff(xd, s->x, p->n);
            if (!(e <= r->dense_end_err)) r->dense_end_err = e;
        }
    }
    if (s->t != tb) r->landed = 0;
    return LF_OK;
}

static LfStatus init_solver(LfSolver *s, const Setup *su) {
    LfOde ode;
    ode.n = su->p->n;
    ode.ctx = NULL;
    ode.rhs = su->p->rhs;
    ode.jac = su->p->jac;
    return lf_solver_init(s, su->m, ode, su->opt, 0.0, su->p->x0, &alloc);
}

static void print_result(const LfSolver *s, const Result *r) {
    printf("status %d\n", (int)r->status);
    printf("t %.17g\n", s->t);
    printf("x0 %.17g\n", s->ode.n > 0 ? s->x[0] : 0.0);
    {
        size_t i; /* every state, as x_<i> (x0 above is the first) */
        for (i = 0; i < s->ode.n; i++) printf("x_%lu %.17g\n", (unsigned long)i, s->x[i]);
    }
    printf("err_final %.6e\n", r->err_final);
    printf("err_max %.6e\n", r->err_max);
    printf("dense_err %.6e\n", r->dense_err);
    printf("dense_end_err %.6e\n", r->dense_end_err);
    printf("landed %d\n", r->landed);
    printf("steps %ld\nrejected %ld\nrhs %ld\njac %ld\nlu %ld\n", s->n_steps, s->n_rejected,
           s->n_rhs, s->n_jac, s->n_lu);
    printf("work_len %lu\n", (unsigned long)s->work_len);
}

static void finish(LfSolver *s, const Problem *p, Result *r) {
    double xe[H_MAXN];
    size_t i;
    for (i = 0; i < p->n; i++) r->x[i] = s->x[i];
    if (p->exact(s->t, xe))
        r->err_final = max_abs_diff(s->x, xe, p->n);
    else
        r->err_final = NAN;
}

static int cmd_run(int argc, char **argv) {
    Setup su;
    LfSolver s;
    Result r;
    long k;
    LfStatus st;
    if (!parse_setup(argc, argv, &su)) return 2;
    memset(&r, 0, sizeof r);
    r.landed = 1;
    st = init_solver(&s, &su);
    if (st != LF_OK) {
        printf("status %d\nmessage %s\n", (int)st, s.message);
        return 0;
    }
    for (k = 1; k <= su.ncomm; k++) {
        st = advance(&s, su.p, comm_point(&su, k), &r);
        if (st != LF_OK) break;
    }
    r.status = st;
    finish(&s, su.p, &r);
    print_result(&s, &r);
    {
        /* after a failure: the state must still be the last accepted one */
        double xe[H_MAXN];
        int finite = 1;
        size_t i;
        for (i = 0; i < su.p->n; i++) finite &= isfinite(s.x[i]) ? 1 : 0;
        printf("x_finite %d\n", finite);
        if (su.p->exact(s.t, xe)) printf("err_at_t %.6e\n", max_abs_diff(s.x, xe, su.p->n));
        /* the dense output inside the last interval (an interpolant of
         * the last accepted step, or x's value if there is none), never
         * made of a failed attempt's stages: its error at the midpoint */
        {
            double xm[H_MAXN], tm = 0.5 * (s.t_old + s.t);
            s.method->dense(&s, tm, xm);
            if (su.p->n > 0 && su.p->exact(tm, xe))
                printf("dense_mid_err %.6e\n", max_abs_diff(xm, xe, su.p->n));
            printf("last_interval %.17g\n", s.t - s.t_old);
        }
    }
    lf_solver_free(&s, &alloc);
    printf("live_blocks %ld\n", live_blocks);
    printf("message %s\n", s.message);
    return 0;
}

static int cmd_snapshot(int argc, char **argv) {
    Setup su;
    LfSolver s, snap;
    Result r;
    long k, half;
    double xa[H_MAXN] = {0}, ta, *wcopy, *w2;
    long steps_a;
    LfStatus st = LF_OK;
    if (!parse_setup(argc, argv, &su)) return 2;
    if (su.ncomm < 2) su.ncomm = 2;
    half = su.ncomm / 2;
    memset(&r, 0, sizeof r);
    r.landed = 1;
    if (init_solver(&s, &su) != LF_OK) return 3;
    for (k = 1; k <= half && st == LF_OK; k++) st = advance(&s, su.p, comm_point(&su, k), &r);
    if (st != LF_OK) return 3;
    snap = s;
    wcopy = (double *)malloc((s.work_len ? s.work_len : 1) * sizeof(double));
    memcpy(wcopy, s.work, s.work_len * sizeof(double));
    for (k = half + 1; k <= su.ncomm && st == LF_OK; k++)
        st = advance(&s, su.p, comm_point(&su, k), &r);
    if (st != LF_OK) return 3;
    memcpy(xa, s.x, su.p->n * sizeof(double));
    ta = s.t;
    steps_a = s.n_steps;
    /* scribble over the original buffer, restore the copy elsewhere */
    memset(s.work, 0xff, s.work_len * sizeof(double));
    w2 = (double *)calloc(snap.work_len ? snap.work_len : 1, sizeof(double));
    memcpy(w2, wcopy, snap.work_len * sizeof(double));
    lf_solver_free(&s, &alloc);
    s = snap;
    s.x = w2 + (snap.x - snap.work);
    s.x_old = w2 + (snap.x_old - snap.work);
    s.work = w2;
    for (k = half + 1; k <= su.ncomm && st == LF_OK; k++)
        st = advance(&s, su.p, comm_point(&su, k), &r);
    printf("status %d\n", (int)st);
    printf("identical %d\n", st == LF_OK && ta == s.t && steps_a == s.n_steps &&
                                 memcmp(xa, s.x, su.p->n * sizeof(double)) == 0);
    printf("steps %ld\n", s.n_steps);
    free(w2);
    free(wcopy);
    return 0;
}

static int cmd_side(int argc, char **argv) {
    Setup su, su2;
    LfSolver a, b;
    Result ra, rb;
    double xa[H_MAXN] = {0};
    double ta;
    long na;
    LfStatus sa = LF_OK, sb = LF_OK;
    if (!parse_setup(argc, argv, &su)) return 2;
    su.ncomm = 1;
    su2 = su;
    su2.p = find_problem(strcmp(su.p->name, "osc") == 0 ? "decay" : "osc");
    su2.opt.rtol *= 10.0;
    memset(&ra, 0, sizeof ra);
    memset(&rb, 0, sizeof rb);
    /* alone */
    if (init_solver(&a, &su) != LF_OK) return 3;
    sa = advance(&a, su.p, su.t_end, &ra);
    memcpy(xa, a.x, su.p->n * sizeof(double));
    ta = a.t;
    na = a.n_steps;
    lf_solver_free(&a, &alloc);
    /* interleaved with another solver */
    if (init_solver(&a, &su) != LF_OK || init_solver(&b, &su2) != LF_OK) return 3;
    while ((a.t < su.t_end && sa == LF_OK) || (b.t < su.t_end && sb == LF_OK)) {
        if (a.t < su.t_end && sa == LF_OK) sa = a.method->step(&a, su.t_end);
        if (b.t < su.t_end && sb == LF_OK) sb = b.method->step(&b, su.t_end);
    }
    printf("status %d\n", (int)(sa != LF_OK ? sa : sb));
    printf("identical %d\n", ta == a.t && na == a.n_steps &&
                                 memcmp(xa, a.x, su.p->n * sizeof(double)) == 0);
    {
        double xe[H_MAXN];
        su2.p->exact(b.t, xe);
        printf("err_other %.6e\n", max_abs_diff(b.x, xe, su2.p->n));
    }
    lf_solver_free(&a, &alloc);
    lf_solver_free(&b, &alloc);
    printf("live_blocks %ld\n", live_blocks);
    return 0;
}

/* decay; at t = 0.5 the state jumps x -> 2x (restart via lf_solver_reset);
 * exact afterwards: 2 exp(-t) */
static int cmd_reset(int argc, char **argv) {
    Setup su;
    LfSolver s;
    Result r;
    double xj, xd, e;
    LfStatus st;
    if (argc < 6) return 2;
    su.m = find_method(argv[2]);
    su.p = find_problem("decay");
    if (!su.m) return 2;
    su.opt.rtol = atof(argv[3]);
    su.opt.atol = atof(argv[4]);
    su.opt.h_fixed = atof(argv[5]);
    su.opt.h_max = 0.2;
    su.opt.max_steps = 100000;
    memset(&r, 0, sizeof r);
    if (init_solver(&s, &su) != LF_OK) return 3;
    st = advance(&s, su.p, 0.5, &r);
    if (st != LF_OK) return 3;
    xj = 2.0 * s.x[0];
    s.h = 1.0; /* must be clamped to h_max by the reset */
    lf_solver_reset(&s, 0.5, &xj);
    printf("h_after_reset %.17g\n", s.h);
    printf("reset_ok %d\n", s.t == 0.5 && s.t_old == 0.5 && s.x[0] == xj && s.x_old[0] == xj &&
                                s.fsal_valid == 0);
    s.method->dense(&s, 0.5, &xd);
    printf("dense_at_reset_err %.6e\n", fabs(xd - xj));
    /* reset aliasing s->x itself must be harmless */
    lf_solver_reset(&s, s.t, s.x);
    while (s.t < 2.0) {
        st = s.method->step(&s, 2.0);
        if (st != LF_OK) break;
        if (!(s.t_old >= 0.5)) {
            st = LF_FATAL;
            break;
        }
    }
    e = fabs(s.x[0] - 2.0 * exp(-s.t));
    printf("status %d\nt %.17g\nerr_final %.6e\n", (int)st, s.t, e);
    lf_solver_free(&s, &alloc);
    return 0;
}

static int cmd_badopt(void) {
    LfSolver s;
    LfOde ode;
    LfSolverOptions opt;
    double x0 = 1.0;
    LfStatus st;
    int ok = 1;
    size_t k;
    ode.n = 1;
    ode.ctx = NULL;
    ode.rhs = decay_f;
    ode.jac = NULL;
    for (k = 0; k < lf_n_methods; k++) {
        const LfMethod *m = lf_methods[k];
        opt.rtol = 1e-6;
        opt.atol = 1e-9;
        opt.h_max = 1.0;
        opt.h_fixed = 0.1;
        opt.max_steps = 100;
        ode.jac = decay_j;
        /* valid options work */
        st = lf_solver_init(&s, m, ode, opt, 0.0, &x0, &alloc);
        if (st != LF_OK) ok = 0;
        lf_solver_free(&s, &alloc);
        /* invalid options */
        if (m->adaptive) {
            opt.rtol = 0.0;
        } else {
            opt.h_fixed = -1.0;
        }
        st = lf_solver_init(&s, m, ode, opt, 0.0, &x0, &alloc);
        printf("%s_bad_tol %d %s\n", m->name, (int)st, s.message);
        if (st != LF_ERROR || s.message[0] == '\0') ok = 0;
        opt.rtol = 1e-6;
        opt.h_fixed = 0.1;
        opt.h_max = 0.0;
        st = lf_solver_init(&s, m, ode, opt, 0.0, &x0, &alloc);
        printf("%s_bad_hmax %d %s\n", m->name, (int)st, s.message);
        if (st != LF_ERROR || s.message[0] == '\0') ok = 0;
        opt.h_max = 1.0;
        if (m->needs_jac) {
            ode.jac = NULL;
            st = lf_solver_init(&s, m, ode, opt, 0.0, &x0, &alloc);
            printf("%s_no_jac %d %s\n", m->name, (int)st, s.message);
            if (st != LF_ERROR || s.message[0] == '\0') ok = 0;
        }
        /* stepping backwards / to the current time is invalid use */
        ode.jac = decay_j;
        st = lf_solver_init(&s, m, ode, opt, 1.0, &x0, &alloc);
        if (st == LF_OK) {
            st = m->step(&s, 0.5);
            printf("%s_backwards %d %s\n", m->name, (int)st, s.message);
            if (st != LF_ERROR || s.t != 1.0) ok = 0;
        }
        lf_solver_free(&s, &alloc);
    }
    printf("live_blocks %ld\n", live_blocks);
    printf("ok %d\n", ok && live_blocks == 0);
    return 0;
}

/* ---------------------------------------------------------------- linalg */

static double lcg(unsigned long *state) {
    *state = (*state * 6364136223846793005UL + 1442695040888963407UL) & 0xffffffffffffUL;
    return (double)(*state >> 8) / (double)(1UL << 40) - 0.5;
}

static int cmd_linalg(void) {
    enum { NMAX = 12 };
    double A[NMAX * NMAX], LU[NMAX * NMAX], b[NMAX], b0[NMAX], x[NMAX];
    size_t piv[NMAX];
    unsigned long seed = 12345;
    double worst = 0.0;
    size_t n, i, j;
    int rc, trial;
    for (n = 1; n <= NMAX; n++) {
        for (trial = 0; trial < 20; trial++) {
            double res = 0.0, scale = 0.0;
            for (i = 0; i < n * n; i++) A[i] = lcg(&seed);
            if (trial % 2) /* force pivoting: zero diagonal */
                for (i = 0; i < n; i++) A[i + i * n] = 0.0;
            for (i = 0; i < n; i++) x[i] = lcg(&seed);
            for (i = 0; i < n; i++) {
                b[i] = 0.0;
                for (j = 0; j < n; j++) b[i] += A[i + j * n] * x[j];
            }
            memcpy(LU, A, n * n * sizeof(double));
            memcpy(b0, b, n * sizeof(double));
            rc = lf_lu_factor(LU, n, piv);
            if (rc != 0) continue; /* (numerically) singular random matrix: skip */
            lf_lu_solve(LU, n, piv, b);
            /* relative residual |A x - b| / (|A| |x|) of the computed x */
            for (i = 0; i < n; i++) {
                double ri = -b0[i];
                for (j = 0; j < n; j++) {
                    ri += A[i + j * n] * b[j];
                    scale = fmax(scale, fabs(A[i + j * n]) * fabs(b[j]));
                }
                res = fmax(res, fabs(ri));
            }
            worst = fmax(worst, res / (scale > 0 ? scale : 1.0));
        }
    }
    printf("max_rel_residual %.3e\n", worst);
    /* a permutation matrix needs pivoting in every column */
    {
        double P[9] = {0, 0, 1, 1, 0, 0, 0, 1, 0}; /* columns */
        double bb[3] = {1, 2, 3};
        rc = lf_lu_factor(P, 3, piv);
        lf_lu_solve(P, 3, piv, bb);
        /* P x = b with P e0 = e2, P e1 = e0, P e2 = e1: x = (b2, b0, b1) */
        printf("perm_ok %d\n", rc == 0 && bb[0] == 3 && bb[1] == 1 && bb[2] == 2);
    }
    /* exactly singular: second column = 2 * first */
    {
        double S[9] = {1, 2, 3, 2, 4, 6, 0, 1, 5};
        rc = lf_lu_factor(S, 3, piv);
        printf("singular_rc %d\n", rc);
    }
    /* zero matrix */
    {
        double Z[4] = {0, 0, 0, 0};
        printf("zero_rc %d\n", lf_lu_factor(Z, 2, piv));
    }
    /* non-finite entry */
    {
        double N[4] = {1, 0, NAN, 1};
        double I[4] = {1, 0, INFINITY, 1};
        double N0[4] = {NAN, 0, 0, 1};
        printf("nan_rc %d\n", lf_lu_factor(N, 2, piv));
        printf("inf_rc %d\n", lf_lu_factor(I, 2, piv));
        printf("nan0_rc %d\n", lf_lu_factor(N0, 2, piv));
    }
    return 0;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: see source\n");
        return 2;
    }
    if (strcmp(argv[1], "run") == 0) return cmd_run(argc, argv);
    if (strcmp(argv[1], "snapshot") == 0) return cmd_snapshot(argc, argv);
    if (strcmp(argv[1], "side") == 0) return cmd_side(argc, argv);
    if (strcmp(argv[1], "reset") == 0) return cmd_reset(argc, argv);
    if (strcmp(argv[1], "badopt") == 0) return cmd_badopt();
    if (strcmp(argv[1], "linalg") == 0) return cmd_linalg();
    fprintf(stderr, "unknown command %s\n", argv[1]);
    return 2;
}
