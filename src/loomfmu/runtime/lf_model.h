/* loomfmu shared runtime: the contract a generated model fulfils.
 *
 * A model contributes CasADi-generated functions with the fixed argument
 * list (t, x, u, p) and one `const LfModel lf_model` (model_decl.c), both
 * written by loomfmu.codegen from the Python declaration.  Nothing here is
 * written by hand per model.
 */
#ifndef LF_MODEL_H
#define LF_MODEL_H

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

enum { LF_FN_ODE = 0, LF_FN_JAC = 1, LF_FN_OUT = 2, LF_FN_EVT = 3, LF_N_FN = 4 };

/* Real value references are laid out as
 *   settings | parameters | states | inputs | outputs | algebraic locals */
#define LF_VR_P0 (LF_NSET)
#define LF_VR_X0 (LF_VR_P0 + LF_NP)
#define LF_VR_U0 (LF_VR_X0 + LF_NX)
#define LF_VR_Y0 (LF_VR_U0 + LF_NU)
#define LF_VR_Z0 (LF_VR_Y0 + LF_NY)
#define LF_NREAL (LF_VR_Z0 + LF_NZ)
/* Integer value reference of the `solver` enumeration */
#define LF_VR_SOLVER 0

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
    const char *const *solver_names; /* must match lf_methods[] */
    LfFunction fn[LF_N_FN];          /* ode, jac, out, evt */
} LfModel;

extern const LfModel lf_model;

#endif
