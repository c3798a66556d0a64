/* loomfmu shared runtime: the model instance, LfInstance, grouped by
 * concern (the fields not saved with the FMU state in its member
 * `unsaved`), and the constants that size it.  The bottom of the runtime:
 * types, constants and macros only, no function of any .c file declared or
 * called here, so every runtime file can take the instance's layout from
 * this header without depending on a file above it (lf_runtime.h declares
 * the instance's life cycle, lf_runtime.c). */
#ifndef LF_INSTANCE_H
#define LF_INSTANCE_H

#include "lf_model.h"
#include "lf_newton_mem.h"
#include "lf_solver.h"

#define LF_DIM(n) ((n) > 0 ? (n) : 1)
/* samples of history kept per delayed expression */
#define LF_HIST_CAP 65536
/* pending discontinuities of delayed values (history jumps + tau): an input
 * changed at every communication point keeps tau / h of them pending; past
 * the capacity the step is discarded (lf_delay.c), never dropped silently */
#define LF_MAX_BP 8192
/* the capacity of this FMU: none without delays */
#define LF_BP_CAP (LF_ND > 0 ? LF_MAX_BP : 0)

enum { LF_DELAY_HERMITE = 1, LF_DELAY_LINEAR = 2 };

/* Only event location, validity conditions and the delays' history read
 * the solver's dense output: without them the solver need not prepare it
 * (LfSolver.dense_unused, set wherever the runtime makes its solver). */
#define LF_DENSE_UNUSED (LF_NE == 0 && LF_NV == 0 && LF_ND == 0)
/* lf_rhs returns LF_OK with finite values only (lf_solve_w checks w):
 * LfSolver.rhs_finite, set with dense_unused */

/* FMI interface states, as bits so that each call can check a mask. */
typedef enum {
    LF_ST_INSTANTIATED = 1 << 0,
    LF_ST_INIT = 1 << 1,
    LF_ST_STEP_COMPLETE = 1 << 2,
    LF_ST_STEP_FAILED = 1 << 3,
    LF_ST_TERMINATED = 1 << 4,
    LF_ST_ERROR = 1 << 5
} LfState;

typedef enum {
    LF_LOG_EVENTS = 0,
    LF_LOG_WARNING = 1,
    LF_LOG_DISCARD = 2,
    LF_LOG_ERROR = 3,
    LF_LOG_SOLVER = 4,
    LF_N_LOG = 5
} LfLogCategory;

typedef void (*LfLogFn)(void *env, const char *instance, LfStatus status,
                        const char *category, const char *message);

/* The instance, grouped by concern.  Every member but `unsaved` is saved
 * with the FMU state (lf_state.c writes it field by field into its own
 * layout, LfStateValues: the grouping here is the memory's, not the
 * state's); `unsaved` holds everything that is not: the importer's
 * environment, work arrays, scratch and caches, each rebuilt or reset when
 * a state is set. */

/* the interface: FMI state, times, solver choice (saved) */
typedef struct {
    LfState state;
    double t;                /* current communication time */
    double t_start;
    double t_stop;           /* stopTime of fmi2SetupExperiment (INFINITY: none) */
    double rtol_importer;    /* tolerance of fmi2SetupExperiment (0: none) */
    double last_successful_time;
    int outputs_valid;       /* r[] outputs/locals match t, x, u, p */
    int inputs_changed;      /* an input was set since the last step */
    int wants_terminate;     /* fmi2Terminated: a validity condition failed */
    int solver_id;           /* 1-based index into lf_methods[] */
    int solver_index;        /* `solver_index`: 0, or the solver that wins over `solver` */
    int solver_ready;        /* the solver is made (after initialization) */
    long max_steps;          /* internal steps per communication step */
} LfRun;

/* the model's values (saved) */
typedef struct {
    double r[LF_NREAL];           /* every Real by value reference */
    double q[LF_DIM(LF_NQ)];      /* discrete modes */
    int x_set[LF_DIM(LF_NX)];     /* state set by the importer before initialization */
    double w_cur[LF_DIM(LF_NW)];  /* unknowns at the last solve: Newton's start */
} LfValues;

/* events (saved): the indicators at the last accepted point and an early
 * return's pending event (lf_step.h): with stop_at_events set (by the
 * facade) lf_do_step ends at the first event located in the step, on the
 * root's new side with the modes before the event, and defers its
 * handling to lf_handle_pending_event */
typedef struct {
    double e_old[LF_DIM(LF_NE)];  /* indicators at the last accepted point */
    int pending;                  /* an event located, its handling deferred */
    int index;                    /* its indicator (-1: none pending) */
    double t_event;               /* its time (the solver's, on the new side) */
    /* the last point before the event, where the validity conditions held
     * (the step ends there if one fails across the event) */
    double t_ok;
    double x_ok[LF_DIM(LF_NX)];
    double q_ok[LF_DIM(LF_NQ)];
} LfEvents;

/* known breaks (lf_breaks.c; saved, so that a restored state steps as the
 * original did): ready: xdot holds der(x) of the clock states (0
 * elsewhere); index >= 0: the steps land at t_land, a margin before the
 * predicted root of that indicator, whose bracket ends at t_right; no
 * predicted root before clear, where the prediction is e; the next chunk
 * of the scan is dt long */
typedef struct {
    int ready;
    double xdot[LF_DIM(LF_NX)];
    int index;
    double t_land, t_right;
    double clear, dt;
    double e[LF_DIM(LF_NE)];
} LfKnownBreaks;

/* delays (saved): per delayed expression a ring of accepted samples (t, g,
 * dg/dt), interpolated by cubic Hermite (or linearly, for comparison), and
 * the pending breakpoints */
typedef struct {
    double dval[LF_DIM(LF_ND)];   /* delayed values passed to the functions */
    double tau[LF_DIM(LF_ND)];
    double *hist;                 /* LF_ND x LF_HIST_CAP x 3 (the samples in use are saved) */
    long hist_start[LF_DIM(LF_ND)];
    long hist_count[LF_DIM(LF_ND)];
    int delay_interp;
    double bp[LF_DIM(LF_BP_CAP)];
    int n_bp;
} LfDelays;

/* inputs as polynomials of time (fmi2SetRealInputDerivatives; saved):
 * input k is r[LF_VR_U0 + k] + u_d1[k] s + u_d2[k] s^2 / 2, s = t - u_t0[k]
 * (lf_inputs.c); held constant while both derivatives are 0.  seen_*: the
 * polynomials the solver last started a step with, at seen_t (value,
 * slope, second derivative): a change restarts the solver */
typedef struct {
    double u_d1[LF_DIM(LF_NU)], u_d2[LF_DIM(LF_NU)], u_t0[LF_DIM(LF_NU)];
    double seen_u[LF_DIM(LF_NU)], seen_d1[LF_DIM(LF_NU)], seen_d2[LF_DIM(LF_NU)];
    double seen_t;
} LfInputs;

/* statistics (saved) */
typedef struct {
    long n_events;
    long n_newton_fail;
} LfStats;

/* Not saved with the FMU state. */
typedef struct {
    /* -- the importer's environment and settings of the facade -- */
    char *name;
    void *log_env;
    LfLogFn log;
    LfAllocator alloc;
    int log_on[LF_N_LOG];
    int log_on_start;        /* loggingOn of fmi2Instantiate, restored by reset */
    int quiet;               /* > 0: trial solves, do not log their failures */
    int stop_at_events;      /* early return at events (lf_step.h) */
    /* -- calls of the generated functions (lf_eval.c) -- */
    /* CasADi work, sized for the largest generated function */
    const double **arg;
    double **res;
    long long *iw;
    double *w;
    int args_set;                 /* arg[4..6, 8, 9] point at p, q, d, d_rate, k */
    double k[LF_DIM(LF_NK)];      /* parameter-only subexpressions: `pre` of r[LF_VR_P0..] */
    int k_stale;                  /* k does not match the parameters: lf_eval_fn recomputes */
    /* -- inputs: derived from the saved polynomials, and scratch -- */
    int u_poly;                   /* some input derivative is nonzero */
    double u_now[LF_DIM(LF_NU)], u_rate[LF_DIM(LF_NU)], u_zero[LF_DIM(LF_NU)];
    double d_rate[LF_DIM(LF_ND)]; /* delayed values' rates (output derivatives) */
    /* -- the unknowns: scratch of the solves and the exact Jacobians:
     * dw/dx (explicit) or dF/dw, dF/dx (implicit) -- */
    double w_tmp[LF_DIM(LF_NW)];
    double jac_wx[LF_DIM(LF_NW * LF_NX)];
    double jac_ww[LF_IMPLICIT ? LF_DIM(LF_NW * LF_NW) : 1];
    double jac_wt[LF_DIM(LF_NW)];
    double res_F[LF_DIM(LF_NW)];
    size_t piv[LF_DIM(LF_NW)];
    /* -- the step loop's scratch -- */
    double e_new[LF_DIM(LF_NE)];
    double x_tmp[LF_DIM(LF_NX)];
    /* validity conditions at time vld_t (the start of the next step; set at
     * every step's start and end) */
    double vld_t, vld_v[LF_DIM(LF_NV)];
    /* -- delays -- */
    double t_bp_step;   /* end of the step being taken, if a breakpoint; else inf */
    /* where the last history lookup of each delay ended (a hint for the
     * next one, checked before use) */
    long hist_cursor[LF_DIM(LF_ND)];
    /* the outputs of the last history sample at a step's end (lf_delay.c,
     * models with LF_HISTOUT_FN): y at the point (t, x, u, u_rate, p, q, d,
     * w) they were computed at, taken by lf_update_outputs where every one
     * of these matches bit for bit */
    int ho_valid;
    double ho_t;
    double ho_x[LF_DIM(LF_NX)], ho_u[LF_DIM(LF_NU)], ho_ur[LF_DIM(LF_NU)];
    double ho_p[LF_DIM(LF_NP)], ho_q[LF_DIM(LF_NQ)], ho_d[LF_DIM(LF_ND)];
    double ho_w[LF_DIM(LF_NW)], ho_y[LF_DIM(LF_NY + LF_NZ)];
    /* -- known breaks: kb_cert: set by lf_known_break before each step,
     * read by lf_handle_events after it: every indicator is predicted and
     * the scan vouches for no root of the prediction in the step about to
     * be taken (lf_breaks.c; it vouches up to kb.clear while kb.ready).
     * kb_sure: -INFINITY while rule 2's bound on the step after the
     * solver's last one is pending (left so after a vouched step, and
     * unknown when an FMU state is set or at the start: taken if the next
     * step is not vouched, lf_event_bound_pending); otherwise the time it
     * was taken at -- */
    int kb_cert;
    double kb_sure;
    long n_known_breaks;            /* known breaks crossed (statistics) */
    /* -- the solve cache (lf_wcache.h): on while a step runs; entry j
     * holds w of (wc_t[j], wc_x[j]) of generation wc_g[j] -- */
    int wc_on, wc_last;
    unsigned long wc_gen, wc_g[2];
    double wc_t[2];
    double wc_x[2][LF_DIM(LF_NX)];
    double wc_w[2][LF_DIM(LF_NW)];
    unsigned long wk_g;             /* explicit models: w_cur is w of (wk_t, wk_x) */
    double wk_t;
    double wk_x[LF_DIM(LF_NX)];
    /* -- algebraic loops: Newton's memory (lf_newton_mem.h) -- */
    LfNewtonMem nm;
    /* model exchange: a delayed value was extrapolated (said once, lf_me.c) */
    int me_extrapolated;
} LfUnsaved;

typedef struct {
    LfRun run;               /* interface state, times, solver choice */
    LfValues val;            /* Reals, modes, unknowns */
    LfSolver solver;         /* the solver: its fields and work buffer */
    LfEvents ev;             /* indicators, pending event */
    LfKnownBreaks kb;        /* known breaks' prediction */
    LfDelays dl;             /* delays' history and breakpoints */
    LfInputs in;             /* input polynomials */
    LfStats stats;           /* counters */
    LfUnsaved unsaved;       /* everything not saved with the FMU state */
} LfInstance;

#endif
