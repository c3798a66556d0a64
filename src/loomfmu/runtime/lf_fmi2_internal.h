/* loomfmu shared runtime: what the FMI 2.0 facade's files share
 * (lf_fmi2.c: inquiry, life cycle, state machine; lf_fmi2_values.c: get and
 * set by type; lf_fmi2_cs.c: co-simulation; lf_fmi2_me.c: model exchange;
 * lf_fmi2_state.c: FMU states; lf_fmi2_deriv.c: input, output and
 * directional derivatives). */
#ifndef LF_FMI2_INTERNAL_H
#define LF_FMI2_INTERNAL_H

#include "fmi2Functions.h"
#include "lf_base.h"
#include "lf_inputs.h"
#include "lf_outputs.h"
#include "lf_runtime.h"
#include "lf_step.h"
#include "lf_facade.h"
#include "lf_facade_ops.h"

/* The interfaces this FMU declares (lf_build.h, written by the builder);
 * without it: co-simulation only. */
#if defined(__has_include)
#if __has_include("lf_build.h")
#include "lf_build.h"
#endif
#endif
#ifndef LF_HAS_CS
#define LF_HAS_CS 1
#endif
#ifndef LF_HAS_ME
#define LF_HAS_ME 0
#endif

/* FMI 2.0 interface states: the runtime's LfState bits, and model
 * exchange's event and continuous-time modes (the runtime's state is then
 * LF_ST_STEP_COMPLETE; lf_fmi2_state_bits maps it). */
#define M2_EVENT (1 << 6)
#define M2_CONT (1 << 7)
#define ME_RUNNING (M2_EVENT | M2_CONT)
#define ANY_STATE                                                                    \
    (LF_ST_INSTANTIATED | LF_ST_INIT | LF_ST_STEP_COMPLETE | LF_ST_STEP_FAILED |     \
     LF_ST_TERMINATED | LF_ST_ERROR | ME_RUNNING)
#define RUNNING (LF_ST_STEP_COMPLETE | LF_ST_STEP_FAILED)

/* der(x_k) is Real vr LF_NREAL + k (read only) */
/* der(x_k) has value reference LF_NREAL + k only where the model description
 * declares it: in builds with model exchange */
#define F2_N_REAL ((unsigned)(LF_NREAL + (LF_HAS_ME ? LF_NX : 0)))

/* What the facade keeps per instance (the instance's log_env). */
typedef struct {
    fmi2CallbackFunctions cb; /* first: the logger bridge reads it as its env */
    LfBlob *states;           /* FMU states made by this instance, freed with it */
    int rtol_set;             /* solver_rtol set by the importer (since reset) */
    int me;                   /* instantiated as fmi2ModelExchange */
    int me_cont;              /* model exchange: continuous-time mode (else event mode) */
} Fmi2Env;

#define ENV(inst) ((Fmi2Env *)(inst)->unsaved.log_env)

/* The instance if `c` is a live instance of this FMU, else NULL (never
 * dereferences a pointer it did not hand out). */
LfInstance *lf_fmi2_live(fmi2Component c);
/* The instance's interface state as one bit of the masks above. */
int lf_fmi2_state_bits(const LfInstance *inst);
/* 1 if `c` is live and in one of the states of `mask`; else logs and gives 0. */
int lf_fmi2_allowed(fmi2Component c, const char *fn, int mask);
/* Logs that argument `arg` of `fn` is NULL; fmi2Error. */
fmi2Status lf_fmi2_null_arg(LfInstance *c, const char *fn, const char *arg);
/* Logs that `fn` is not provided; fmi2Error. */
fmi2Status lf_fmi2_unsupported(fmi2Component c, const char *fn);
/* The arrays of a get/set call: present if nvr > 0, nvr plausible, every
 * value reference below n_vars (else logs and gives 0). */
int lf_fmi2_check_vrs(LfInstance *c, const char *fn, const fmi2ValueReference vr[], size_t nvr,
                      const void *value, unsigned n_vars);
/* Longest value-reference array accepted (lf_fmi2_check_vrs, lf_fmi2_values.c) */
#define LF_FMI2_NVR_LIMIT(n_vars) (16 * (size_t)(n_vars) + 16)
/* The hot path of lf_fmi2_check_vrs (every get/set call): 1 if the arrays
 * pass its checks, without the call that prepares a log line; 0 leaves the
 * answer (and the log) to lf_fmi2_check_vrs. */
static inline int lf_fmi2_vrs_ok(const fmi2ValueReference vr[], size_t nvr, const void *value,
                                 unsigned n_vars) {
    size_t i;
    if (nvr == 0) return 1;
    if (!vr || !value || nvr > LF_FMI2_NVR_LIMIT(n_vars)) return 0;
    for (i = 0; i < nvr; i++)
        if (vr[i] >= n_vars) return 0;
    return 1;
}
/* Frees every FMU state the instance made. */
void lf_fmi2_free_states(LfInstance *inst);

#endif
