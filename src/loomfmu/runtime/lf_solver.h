/* loomfmu shared runtime: the contract between the co-simulation step loop
 * and the embedded ODE solvers.
 *
 * A solver integrates x' = f(t, x) one accepted step at a time, keeping
 * t_old, t and an interpolant (dense output) over [t_old, t].  Events are not
 * the solvers' business: the step loop looks for sign changes of the event
 * indicators over each accepted step, locates the root on `dense`, and calls
 * lf_solver_reset() at the event.
 *
 * All solver state lives in LfSolver and its single `work` buffer, so that
 * getting/setting the FMU state is a copy of the struct plus the buffer.
 */
#ifndef LF_SOLVER_H
#define LF_SOLVER_H

#include "lf_prefix.h"

#include <stddef.h>

/* Values equal fmi2Status / fmi3Status so they can be passed through. */
typedef enum {
    LF_OK = 0,
    LF_WARNING = 1,
    LF_DISCARD = 2,
    LF_ERROR = 3,
    LF_FATAL = 4
} LfStatus;

typedef struct {
    size_t n;   /* number of states */
    void *ctx;  /* passed back unchanged to rhs and jac */
    /* dx = f(t, x).  Returns LF_OK, or LF_DISCARD/LF_ERROR when f cannot be
     * evaluated (e.g. a non-finite result). */
    LfStatus (*rhs)(void *ctx, double t, const double *x, double *dx);
    /* J = df/dx (n*n, column-major: J[i + j*n] = dfi/dxj), dfdt = df/dt (n).
     * May be NULL for methods that do not need it. */
    LfStatus (*jac)(void *ctx, double t, const double *x, double *J, double *dfdt);
} LfOde;

typedef struct {
    double rtol;    /* relative tolerance (adaptive methods), > 0 */
    double atol;    /* absolute tolerance (adaptive methods), > 0 */
    double h_max;   /* largest internal step, > 0 */
    double h_fixed; /* step of fixed-step methods, > 0 */
    long max_steps; /* per call of lf_solver_advance-like loops; informational */
} LfSolverOptions;

typedef struct {
    void *(*calloc)(size_t nobj, size_t size);
    void (*free)(void *obj);
} LfAllocator;

struct LfMethod;

typedef struct {
    const struct LfMethod *method;
    LfOde ode;
    LfSolverOptions opt;
    double t;        /* time of the current (last accepted) point */
    double t_old;    /* time of the previous accepted point */
    double h;        /* step size proposed for the next step (0: choose) */
    double *x;       /* state at t (n) -- points into work */
    double *x_old;   /* state at t_old (n) -- points into work */
    double *work;    /* method workspace: method->work_size(n) doubles */
    size_t work_len; /* total doubles in work (incl. x, x_old) */
    int fsal_valid;  /* method-private flag: cached f(t, x) in work is valid */
    long n_steps, n_rejected, n_rhs, n_jac, n_lu;
    char message[256]; /* why the last call failed (empty on success) */
    /* Set by the caller after lf_solver_init (0 there): 1 promises that
     * `dense` is never called, and a method may skip preparing its
     * interpolant (dopri5 does).  A setting of the caller, not solver state. */
    int dense_unused;
    /* Set by the caller after lf_solver_init (0 there): 1 promises that
     * ode.rhs returns LF_OK only with finite values (the runtime's does:
     * it checks the unknowns it solves), so the results need no check
     * here.  A setting of the caller, not solver state. */
    int rhs_finite;
} LfSolver;

typedef struct LfMethod {
    const char *name;   /* "dopri5", "rodas4", "rk4" */
    int adaptive;       /* 1: error-controlled, uses rtol/atol */
    int needs_jac;      /* 1: uses ode.jac */
    /* doubles of private workspace for n states (x and x_old excluded) */
    size_t (*work_size)(size_t n);
    /* Take one accepted step from s->t towards t_bound (never past it):
     * on LF_OK, x_old/t_old hold the previous point and x/t the new one.
     * On failure (step size underflow, non-finite values, singular matrix)
     * leaves t and x at the last accepted point, writes s->message and
     * returns LF_DISCARD (or LF_ERROR for invalid use). */
    LfStatus (*step)(LfSolver *s, double t_bound);
    /* x_out = interpolant at t, t_old <= t <= t (after a successful step). */
    void (*dense)(const LfSolver *s, double t, double *x_out);
} LfMethod;

/* Methods are registered in this order; the index is the FMU's `solver`
 * enumeration value minus one. */
extern const LfMethod *const lf_methods[];
extern const size_t lf_n_methods;

/* Allocate and start a solver at (t0, x0).  Returns LF_ERROR with a message
 * in s->message for invalid options (non-positive tolerances etc.). */
LfStatus lf_solver_init(LfSolver *s, const LfMethod *m, LfOde ode,
                        LfSolverOptions opt, double t0, const double *x0,
                        const LfAllocator *alloc);
/* Restart at (t, x) after a discontinuity (event, input change, set state):
 * cached derivatives are invalidated, the step size guess is kept. */
void lf_solver_reset(LfSolver *s, double t, const double *x);
void lf_solver_free(LfSolver *s, const LfAllocator *alloc);

/* 1 if every v[i] is finite (the solvers' and the runtime's check of every
 * stage argument and every result).  v * 0 is +-0 for a finite v and NaN
 * for an infinite or NaN one, and a NaN stays in the sums: two loads,
 * multiplications and additions per two elements and no branch, where
 * isfinite with an exit per element costs about three times as much (at
 * -O2 without -ffast-math, which no build of ours uses: x * 0 is not 0
 * under IEEE 754).  Inf * 0 raises the invalid-operation flag, where
 * isfinite raises none: an importer that traps FE_INVALID but neither
 * FE_OVERFLOW nor FE_DIVBYZERO (one of which made the Inf) would stop here
 * rather than get the FMU's Discard; the comparison this replaced,
 * fabs(v) <= DBL_MAX, raised it for every NaN. */
static inline int lf_all_finite(const double *v, size_t n) {
    double a = 0.0, b = 0.0;
    size_t i;
    for (i = 0; i + 1 < n; i += 2) {
        a += v[i] * 0.0;
        b += v[i + 1] * 0.0;
    }
    if (i < n) a += v[i] * 0.0;
    return a + b == 0.0;
}

#endif
