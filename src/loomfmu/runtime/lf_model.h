/* loomfmu shared runtime: the contract a generated model fulfils.
 *
 * A model contributes CasADi-generated functions with the fixed argument
 * list (t, x, w, u, p, q, d, u_rate, d_rate, k) and one `const LfModel lf_model` (model_decl.c),
 * both written by loomfmu.export.codegen from the Python declaration.  Nothing here
 * is written by hand per model.
 *
 * w = [der(x); z] are the unknowns of the model's equations F = 0: given in
 * closed form by `wsol` (LF_IMPLICIT == 0) or found by Newton on `res` with
 * the exact dF/dw from `rjac` (LF_IMPLICIT == 1); a torn implicit model
 * (LF_TORN == 1) also has `tpre`, `tres`, `tpost`: Newton on a few of the
 * unknowns, the others in closed form.  q are the discrete modes.
 */
#ifndef LF_MODEL_H
#define LF_MODEL_H

#include "lf_prefix.h"

#include "model_decl.h"

typedef enum {
    LF_KIND_SETTING = 0,   /* runtime setting (tolerances, steps) */
    LF_KIND_PARAMETER = 1,
    LF_KIND_STATE = 2,
    LF_KIND_INPUT = 3,
    LF_KIND_OUTPUT = 4,
    LF_KIND_LOCAL = 5      /* algebraic variable, computed with the outputs */
} LfKind;

/* CasADi's generated entry points (casadi_int = long long int). */
typedef int (*LfCasadiEval)(const double **arg, double **res, long long *iw,
                            double *w, int mem);
typedef int (*LfCasadiWork)(long long *sz_arg, long long *sz_res,
                            long long *sz_iw, long long *sz_w);
typedef struct {
    LfCasadiEval eval;
    LfCasadiWork work;
} LfFunction;

/* in the order of loomfmu.export.codegen.FUNCTIONS */
enum {
    LF_FN_WSOL = 0,   /* -> w                        (explicit models) */
    LF_FN_WJAC = 1,   /* -> dw/dx, dw/dt             (explicit models) */
    LF_FN_RES = 2,    /* -> F                        (implicit models) */
    LF_FN_RJAC = 3,   /* -> dF/dw, dF/dx, dF/dt      (implicit models) */
    LF_FN_OUT = 4,    /* -> outputs, algebraic locals */
    LF_FN_EVT = 5,    /* -> event indicators */
    LF_FN_VALID = 6,  /* -> >= 0 where the current mode is consistent */
    LF_FN_REINIT = 7, /* -> states after a mode change */
    LF_FN_INIT = 8,   /* -> start of the states from the parameters */
    LF_FN_HIST = 9,   /* -> delayed expressions g and their time derivative */
    LF_FN_TAU = 10,   /* -> the delays (from the parameters) */
    LF_FN_CONS = 11,  /* -> constraints on the parameters, each >= 0 */
    LF_FN_DJAC = 12,  /* -> dw/dd (explicit) or dF/dd (implicit), dg/dx, dg/dt */
    LF_FN_YDER = 13,  /* -> output rates (explicit: complete; implicit: parts) */
    LF_FN_VLD = 14,   /* -> validity conditions (Model.require), each >= 0 */
    LF_FN_PRE = 15,   /* -> k, the parameter-only subexpressions (from p) */
    LF_FN_DIRW = 16,  /* -> dw/du (explicit) or dF/du (implicit), dg/du, dy/dd */
    LF_FN_DIRY = 17,  /* -> dy/dx, dy/dw, dy/du (y: outputs and algebraic locals) */
    LF_FN_TPRE = 18,  /* -> w[tear_pre] in closed form        (torn models) */
    LF_FN_TRES = 19,  /* -> residual of w[tear_torn], its Jacobian in them */
    LF_FN_TPOST = 20, /* -> w[tear_post] from w[tear_pre], w[tear_torn] */
    LF_N_FN = 21
};

/* Models with delays: one more function, LF_HISTOUT_FN (model_decl.c), of
 * the same arguments -> g, dg/dt (as hist) and the outputs and algebraic
 * locals (as out), their shared subexpressions computed once; lf_eval_fn's
 * id LF_FN_HISTOUT.  The history sample at a step's end takes it and keeps
 * the outputs for lf_update_outputs (lf_delay.c). */
#define LF_FN_HISTOUT LF_N_FN
#ifdef LF_HISTOUT_FN
extern const LfFunction LF_HISTOUT_FN;
#endif

/* Real value references are laid out as
 *   settings | parameters | states | inputs | outputs | algebraic locals */
#define LF_VR_P0 (LF_NSET)
#define LF_VR_X0 (LF_VR_P0 + LF_NP)
#define LF_VR_U0 (LF_VR_X0 + LF_NX)
#define LF_VR_Y0 (LF_VR_U0 + LF_NU)
#define LF_VR_Z0 (LF_VR_Y0 + LF_NY)
#define LF_NREAL (LF_VR_Z0 + LF_NZ)
/* Integer value references: the `solver` enumeration, the modes, then (with
 * delays) the `delay_interpolation` enumeration, then `solver_index` (the
 * solver as a plain Integer, for importers that cannot set Enumerations) */
#define LF_VR_SOLVER 0
#define LF_VR_Q0 1
#define LF_VR_DINTERP (LF_VR_Q0 + LF_NQ)
#define LF_VR_SOLVER_INDEX (LF_VR_DINTERP + (LF_ND > 0))
#define LF_N_INTEGER (LF_VR_SOLVER_INDEX + 1)

typedef struct {
    const char *identifier;
    const char *guid;
    unsigned n_real;
    const char *const *real_names; /* by value reference */
    const double *real_start;      /* NAN where calculated */
    const double *real_min;
    const double *real_max;
    const LfKind *real_kind;
    const char *const *event_names;
    const int *event_mode;           /* mode re-chosen at each event, -1: none */
    /* known breaks (codegen.clock_states, codegen.event_time_only):
     * clock_state[j] (LF_NX): 1 where der(x_j) depends on the parameters only,
     *   2 on parameters and inputs only (x_j is linear in t while the inputs
     *   are held), 0 otherwise;
     * event_time_only[k] (LF_NE): 1 where indicator k depends on t, p and
     *   level-1 clock states only (its zeros known at any time), 2 also on
     *   inputs or level-2 clock states (known while the inputs are held),
     *   0 on other states, w, q or d */
    const int *event_time_only;
    const int *clock_state;
    const char *const *mode_names;
    const int *mode_start;
    const int *mode_value_offset;    /* values of mode k: [offset[k], offset[k+1]) */
    const double *mode_values;       /* in priority order */
    const char *const *delay_names;
    const double *delay_max;         /* longest delay the history is built for */
    const char *const *constraint_messages;
    const int *x_computed;           /* state's start computed (initial="approx") */
    const double *x_nominal;         /* state's nominal (the model description's; 1 if none) */
    const char *const *solver_names; /* must match lf_methods[] */
    const char *const *validity_names;    /* Model.require: name, message */
    const char *const *validity_messages;
    /* torn models (LF_TORN, loomfmu.export.tearing): indices into w of the
     * unknowns before Newton (LF_NT_PRE), Newton's (LF_NT_TORN) and after
     * it (LF_NT_POST) */
    const int *tear_pre;
    const int *tear_torn;
    const int *tear_post;
    LfFunction fn[LF_N_FN];
} LfModel;

extern const LfModel lf_model;

#endif
