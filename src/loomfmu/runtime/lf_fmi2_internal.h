/* loomfmu shared runtime: what the FMI 2.0 facade's files share
 * (lf_fmi2.c: inquiry, life cycle, values, co-simulation; lf_fmi2_state.c:
 * FMU states). */
#ifndef LF_FMI2_INTERNAL_H
#define LF_FMI2_INTERNAL_H

#include "fmi2Functions.h"
#include "lf_runtime.h"

#define ANY_STATE                                                                    \
    (LF_ST_INSTANTIATED | LF_ST_INIT | LF_ST_STEP_COMPLETE | LF_ST_STEP_FAILED |     \
     LF_ST_TERMINATED | LF_ST_ERROR)
#define RUNNING (LF_ST_STEP_COMPLETE | LF_ST_STEP_FAILED)

/* an FMU state: the bytes of lf_state_write, in the instance's list */
typedef struct StateBlob {
    struct StateBlob *next;
    size_t n;
    unsigned char data[1];
} StateBlob;

/* What the facade keeps per instance (the instance's log_env). */
typedef struct {
    fmi2CallbackFunctions cb; /* first: the logger bridge reads it as its env */
    StateBlob *states;        /* FMU states made by this instance, freed with it */
    int rtol_set;             /* solver_rtol set by the importer (since reset) */
} Fmi2Env;

#define ENV(inst) ((Fmi2Env *)(inst)->log_env)

/* The instance if `c` is a live instance of this FMU, else NULL (never
 * dereferences a pointer it did not hand out). */
LfInstance *lf_fmi2_live(fmi2Component c);
/* 1 if `c` is live and in one of the states of `mask`; else logs and gives 0. */
int lf_fmi2_allowed(fmi2Component c, const char *fn, int mask);
/* Logs that argument `arg` of `fn` is NULL; fmi2Error. */
fmi2Status lf_fmi2_null_arg(LfInstance *c, const char *fn, const char *arg);
/* The arrays of a get/set call: present if nvr > 0, nvr plausible, every
 * value reference below n_vars (else logs and gives 0). */
int lf_fmi2_check_vrs(LfInstance *c, const char *fn, const fmi2ValueReference vr[], size_t nvr,
                      const void *value, unsigned n_vars);
/* Frees every FMU state the instance made. */
void lf_fmi2_free_states(LfInstance *inst);

#define CHECK(fn, mask)                                                              \
    do {                                                                             \
        if (!lf_fmi2_allowed(c, fn, mask)) return fmi2Error;                         \
    } while (0)

#endif
