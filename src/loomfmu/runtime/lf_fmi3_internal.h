/* loomfmu shared runtime: what the FMI 3.0 facade's files share
 * (lf_fmi3.c: inquiry, life cycle, state machine; lf_fmi3_values.c: getters
 * and setters by type; lf_fmi3_cs.c: co-simulation and event mode;
 * lf_fmi3_me.c: model exchange; lf_fmi3_state.c: FMU states;
 * lf_fmi3_dirder.c: directional derivatives).
 *
 * Value references (the model description's convention): Float64 vr = the
 * runtime's Real vr (lf_model.h), der(x_k) = LF_NREAL + k, the Integers
 * (Int32 for the modes and solver_index, Int64 for the Enumerations
 * `solver` and `delay_interpolation`) = LF_NREAL + LF_NX + the runtime's
 * Integer vr; then the independent variable `time` and the event
 * indicators (model exchange's `event_indicator.<event>`), Float64, read
 * only. */
#ifndef LF_FMI3_INTERNAL_H
#define LF_FMI3_INTERNAL_H

#include <stddef.h>

#include "fmi3Functions.h"
#include "lf_base.h"
#include "lf_inputs.h"
#include "lf_outputs.h"
#include "lf_runtime.h"
#include "lf_step.h"
#include "lf_facade.h"

/* Float64 value references of the state derivatives, then the Integers */
#define F3_VR_DER0 ((unsigned)LF_NREAL)
#define F3_VR_INT0 ((unsigned)(LF_NREAL + LF_NX))
#define F3_VR_TIME ((unsigned)(LF_NREAL + LF_NX + LF_N_INTEGER))
#define F3_VR_EVT0 (F3_VR_TIME + 1u)

/* The FMI 3.0 interface states, as bits so that each call checks a mask.
 * The runtime's LfState says where the instance is in its life cycle; the
 * facade adds event mode (co-simulation with eventModeUsed, model exchange)
 * and continuous-time mode (model exchange). */
enum {
    F3_INSTANTIATED = 1 << 0,
    F3_INIT = 1 << 1,
    F3_EVENT = 1 << 2,
    F3_STEP = 1 << 3,           /* co-simulation: step mode */
    F3_STEP_DISCARDED = 1 << 4, /* co-simulation: the last fmi3DoStep was discarded */
    F3_CONT = 1 << 5,           /* model exchange: continuous-time mode */
    F3_TERMINATED = 1 << 6,
    F3_ERROR = 1 << 7
};
#define F3_ANY                                                                       \
    (F3_INSTANTIATED | F3_INIT | F3_EVENT | F3_STEP | F3_STEP_DISCARDED | F3_CONT |  \
     F3_TERMINATED | F3_ERROR)
/* after initialization, not terminated */
#define F3_RUNNING (F3_EVENT | F3_STEP | F3_STEP_DISCARDED | F3_CONT)

typedef enum { F3_CS = 1, F3_ME = 2 } F3Interface;

/* What the facade keeps per instance (the instance's log_env). */
typedef struct {
    fmi3LogMessageCallback log_message; /* may be NULL: nothing is logged */
    fmi3InstanceEnvironment env;
    F3Interface kind;
    int event_mode_used;     /* co-simulation: fmi3InstantiateCoSimulation's flag */
    int early_return_allowed;
    int in_event_mode;       /* event mode (the runtime's state: stepping) */
    int in_cont_mode;        /* model exchange: continuous-time mode */
    long events_seen;        /* the runtime's event count the importer was told of */
    int rtol_set;            /* solver_rtol set by the importer (since reset) */
    LfBlob *states;          /* FMU states made by this instance, freed with it */
} Fmi3Env;

#define ENV3(inst) ((Fmi3Env *)(inst)->unsaved.log_env)

/* lf_fmi3.c */
/* The instance if `c` is a live FMI 3 instance of this FMU, else NULL
 * (never dereferences a pointer it did not hand out). */
LfInstance *lf_fmi3_live(fmi3Instance c);
/* The instance's FMI 3 interface state (one F3_ bit). */
int lf_fmi3_state(LfInstance *inst);
/* 1 if `c` is live and in one of the states of `mask`; else logs and gives 0. */
int lf_fmi3_allowed(fmi3Instance c, const char *fn, int mask);
/* 1 if `c` is a live co-simulation instance in one of `mask`'s states; else
 * logs (the interface first, then the state) and gives 0. */
int lf_fmi3_cs_instance(fmi3Instance c, const char *fn, int mask);
/* 1 if the instance is of `kind` (co-simulation, model exchange); else logs. */
int lf_fmi3_interface(LfInstance *inst, const char *fn, F3Interface kind);
/* Logs that argument `arg` of `fn` is NULL; fmi3Error. */
fmi3Status lf_fmi3_null_arg(LfInstance *c, const char *fn, const char *arg);
/* Logs that `fn` is not provided by this FMU (see the model description). */
fmi3Status lf_fmi3_unsupported(fmi3Instance c, const char *fn, const char *why);
/* A new instance of `kind`: NULL (logged through logMessage) on a bad
 * token, a missing name or no memory. */
LfInstance *lf_fmi3_new(const char *fn, F3Interface kind, fmi3String name, fmi3String token,
                        fmi3Boolean logging_on, fmi3InstanceEnvironment env,
                        fmi3LogMessageCallback log_message);
/* Logs that the FMU does not declare `interface` (instantiation refused). */
/* An fmi3Instantiate* refused for an illegal argument: ``why`` logged (no instance) */
void lf_fmi3_refuse_instantiation(const char *fn, fmi3InstanceEnvironment env,
                                  fmi3LogMessageCallback log, const char *why);
void lf_fmi3_refuse_interface(const char *fn, fmi3InstanceEnvironment env,
                              fmi3LogMessageCallback log, const char *interface);
/* Sets the runtime's and the facade's state after an error (fmi3Error). */
fmi3Status lf_fmi3_fail(LfInstance *inst, LfStatus st);

/* lf_fmi3_values.c: the arrays of a get/set call (present if nvr > 0,
 * nValues == nvr, every value reference of the type). */
int lf_fmi3_check_vrs(LfInstance *c, const char *fn, const fmi3ValueReference vr[],
                      size_t nvr, const void *value, size_t n_values, unsigned vr0,
                      unsigned n_vars);

/* lf_fmi3_me.c: fmi3UpdateDiscreteStates of a model-exchange instance (the
 * arguments checked by the caller) */
fmi3Status lf_fmi3_me_update_discrete_states(LfInstance *inst, fmi3Boolean *need_update,
                                             fmi3Boolean *terminate,
                                             fmi3Boolean *nominals_changed,
                                             fmi3Boolean *values_changed,
                                             fmi3Boolean *next_defined, fmi3Float64 *next);

/* lf_fmi3_me.c: LF_OK unless `inst` is a running model-exchange instance
 * whose delayed values at the importer's (t, x) lie beyond the history its
 * completed steps made (LF_DISCARD, logged by lf_me_delays_known): the
 * getters of values computed at that point check it first. */
LfStatus lf_fmi3_me_delays_known(LfInstance *inst, const char *fn);

/* lf_fmi3.c: frees the FMU states the instance made */
void lf_fmi3_free_states(LfInstance *inst);

#endif
