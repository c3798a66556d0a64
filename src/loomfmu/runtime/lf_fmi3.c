/* loomfmu shared runtime: FMI 3.0 facade, common part (inquiry, logging,
 * instances, the state machine, life cycle) and the features this FMU
 * declares absent (clocks, intervals, configuration mode, adjoint
 * derivatives, scheduled execution): those return fmi3Error with a log line.
 *
 * Every function checks the instance pointer (the registry of live
 * instances, lf_facade.c, shared with the FMI 2.0 facade) and the call
 * order against a mask of FMI 3 interface states, and logs the function,
 * the state it was called in and the states it is allowed in.  Misuse is
 * refused, never a crash. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lf_facade_ops.h"
#include "lf_fmi3.h"

/* FMI 3.0's names of the interface states, in the order of the F3_ bits */
static const char *const state_names[] = {"Instantiated", "InitializationMode", "EventMode",
                                          "StepMode", "StepMode (step discarded)",
                                          "ContinuousTimeMode", "Terminated", "Error"};
#define N_STATE_NAMES ((int)(sizeof state_names / sizeof state_names[0]))

/* The message goes through unchanged (FMI 3.0 logMessage is no format). */
static void fmi3_log_bridge(void *env, const char *instance, LfStatus status,
                            const char *category, const char *message) {
    const Fmi3Env *e = (const Fmi3Env *)env;
    (void)instance;
    if (e->log_message) e->log_message(e->env, (fmi3Status)status, category, message);
}

LfInstance *lf_fmi3_live(fmi3Instance c) {
    LfInstance *inst = lf_live(c);
    /* an instance of the FMI 2 facade cannot be here (other binary) */
    return inst;
}

int lf_fmi3_state(LfInstance *inst) {
    const Fmi3Env *e = ENV3(inst);
    switch (inst->run.state) {
    case LF_ST_INSTANTIATED: return F3_INSTANTIATED;
    case LF_ST_INIT: return F3_INIT;
    case LF_ST_STEP_COMPLETE:
        if (e->in_event_mode) return F3_EVENT;
        return e->kind == F3_ME ? F3_CONT : F3_STEP;
    case LF_ST_STEP_FAILED: return F3_STEP_DISCARDED;
    case LF_ST_TERMINATED: return F3_TERMINATED;
    default: return F3_ERROR;
    }
}

int lf_fmi3_allowed(fmi3Instance c, const char *fn, int mask) {
    LfInstance *inst = lf_fmi3_live(c);
    int now;
    if (!inst) return 0; /* NULL, freed or not an instance: nothing to log through */
    now = lf_fmi3_state(inst);
    if (now == F3_STEP_DISCARDED && (mask & F3_STEP) && !(mask & F3_STEP_DISCARDED)) {
        /* said plainly: both states are FMI 3.0's StepMode */
        lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s must not be called after "
               "fmi3DoStep returned fmi3Discard (the step was not completed): read the values "
               "of the last completed step, restore an FMU state (fmi3SetFMUState), or "
               "fmi3Terminate or fmi3Reset",
               inst->run.t, fn);
        return 0;
    }
    return lf_check_state(inst, fn, now, mask, state_names, N_STATE_NAMES);
}

int lf_fmi3_cs_instance(fmi3Instance c, const char *fn, int mask) {
    LfInstance *inst = lf_fmi3_live(c);
    return inst && lf_fmi3_interface(inst, fn, F3_CS) && lf_fmi3_allowed(c, fn, mask);
}

int lf_fmi3_interface(LfInstance *inst, const char *fn, F3Interface kind) {
    if (ENV3(inst)->kind == kind) return 1;
    lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s is a %s function, but the instance "
           "was made by %s", inst->run.t, fn, kind == F3_CS ? "co-simulation" : "model exchange",
           kind == F3_CS ? "fmi3InstantiateModelExchange" : "fmi3InstantiateCoSimulation");
    return 0;
}

fmi3Status lf_fmi3_null_arg(LfInstance *c, const char *fn, const char *arg) {
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: %s is NULL; nothing done", c->run.t, fn, arg);
    return fmi3Error;
}

fmi3Status lf_fmi3_unsupported(fmi3Instance c, const char *fn, const char *why) {
    LfInstance *inst = lf_fmi3_live(c);
    if (inst)
        lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s is not supported by this FMU: %s "
               "(see modelDescription.xml)", inst->run.t, fn, why);
    return fmi3Error;
}

fmi3Status lf_fmi3_fail(LfInstance *inst, LfStatus st) {
    if (st == LF_DISCARD) return fmi3Discard;
    if (st == LF_OK || st == LF_WARNING) return (fmi3Status)st;
    inst->run.state = LF_ST_ERROR;
    ENV3(inst)->in_event_mode = ENV3(inst)->in_cont_mode = 0;
    return st == LF_FATAL ? fmi3Fatal : fmi3Error;
}

/* ---- inquiry, logging ---------------------------------------------------- */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t n,
                               const fmi3String categories[]) {
    CHECK3("fmi3SetDebugLogging", F3_ANY);
    return lf_set_debug_logging((LfInstance *)c, "fmi3SetDebugLogging", loggingOn, n,
                                categories) == LF_OK ? fmi3OK : fmi3Error;
}

/* ---- instances ------------------------------------------------------------ */

static void instantiate_error(fmi3LogMessageCallback log, fmi3InstanceEnvironment env,
                              const char *fn, const char *message) {
    char buf[300];
    if (!log) return;
    snprintf(buf, sizeof buf, "%s: %s", fn, message);
    log(env, fmi3Error, "logStatusError", buf);
}

void lf_fmi3_refuse_instantiation(const char *fn, fmi3InstanceEnvironment env,
                                  fmi3LogMessageCallback log, const char *why) {
    instantiate_error(log, env, fn, why);
}

void lf_fmi3_refuse_interface(const char *fn, fmi3InstanceEnvironment env,
                              fmi3LogMessageCallback log, const char *interface) {
    char buf[200];
    snprintf(buf, sizeof buf, "this FMU does not declare %s (modelDescription.xml); not "
             "instantiated", interface);
    instantiate_error(log, env, fn, buf);
}

static void *f3_calloc(size_t n, size_t size) { return calloc(n, size); }
static void f3_free(void *p) { free(p); }

LfInstance *lf_fmi3_new(const char *fn, F3Interface kind, fmi3String name, fmi3String token,
                        fmi3Boolean logging_on, fmi3InstanceEnvironment env,
                        fmi3LogMessageCallback log_message) {
    LfAllocator alloc;
    LfInstance *c;
    Fmi3Env *e;
    int k;
    if (!name || !name[strspn(name, " \t\n\r\f\v")]) {
        instantiate_error(log_message, env, fn, "instanceName is NULL, empty or only white "
                          "space (FMI 3.0 requires a name with a character that is not white "
                          "space)");
        return NULL;
    }
    if (!token || strcmp(token, lf_model.guid) != 0) {
        instantiate_error(log_message, env, fn, "instantiationToken does not match this "
                          "binary's (modelDescription.xml)");
        return NULL;
    }
    alloc.calloc = f3_calloc;
    alloc.free = f3_free;
    e = (Fmi3Env *)calloc(1, sizeof *e);
    if (e) {
        e->log_message = log_message;
        e->env = env;
        e->kind = kind;
    }
    c = e ? lf_instantiate(name, fmi3_log_bridge, e, alloc) : NULL;
    if (!c || !lf_live_add(c)) {
        if (c) lf_free(c);
        free(e);
        instantiate_error(log_message, env, fn, c ? "too many live instances of this FMU"
                          : "out of memory or solver registry mismatch");
        return NULL;
    }
    c->unsaved.log_on_start = logging_on;
    for (k = 0; k < LF_N_LOG; k++) c->unsaved.log_on[k] = logging_on;
    return c;
}

void lf_fmi3_free_states(LfInstance *inst) { lf_blobs_free(inst, &ENV3(inst)->states); }

/* Frees the instance and every FMU state it made.  A pointer that is not a
 * live instance (NULL, freed already) is ignored. */
void fmi3FreeInstance(fmi3Instance c) {
    LfInstance *inst = lf_fmi3_live(c);
    Fmi3Env *e;
    if (!inst || !lf_live_remove(inst)) return;
    e = ENV3(inst);
    lf_fmi3_free_states(inst);
    lf_free(inst);
    free(e);
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible;
    (void)loggingOn; (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    instantiate_error(logMessage, instanceEnvironment, "fmi3InstantiateScheduledExecution",
                      "scheduled execution is not supported (the model description declares "
                      "co-simulation and model exchange only)");
    return NULL;
}

/* ---- life cycle ------------------------------------------------------------ */

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    LfInstance *inst = (LfInstance *)c;
    LfStatus st;
    CHECK3("fmi3EnterInitializationMode", F3_INSTANTIATED);
    st = lf_setup_experiment(inst, "fmi3EnterInitializationMode", toleranceDefined, tolerance,
                             startTime, stopTimeDefined, stopTime);
    if (st > LF_WARNING) return fmi3Error; /* nothing set, still instantiated */
    inst->run.state = LF_ST_INIT;
    return (fmi3Status)st;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    LfInstance *inst = (LfInstance *)c;
    Fmi3Env *e;
    int warned;
    CHECK3("fmi3ExitInitializationMode", F3_INIT);
    e = ENV3(inst);
    warned = lf_log_rtol_override(inst, e->rtol_set, "fmi3EnterInitializationMode");
    if ((e->kind == F3_ME ? lf_me_initialize(inst) : lf_initialize(inst)) != LF_OK)
        return lf_fmi3_fail(inst, LF_ERROR);
    inst->run.state = LF_ST_STEP_COMPLETE;
    e->events_seen = inst->stats.n_events;
    /* FMI 3.0: model exchange and co-simulation with eventModeUsed go to
     * event mode, co-simulation without it to step mode */
    e->in_event_mode = e->kind == F3_ME || e->event_mode_used;
    e->in_cont_mode = 0;
    return warned ? fmi3Warning : fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance c) {
    LfInstance *inst = (LfInstance *)c;
    CHECK3("fmi3Terminate", F3_RUNNING);
    inst->run.state = LF_ST_TERMINATED;
    ENV3(inst)->in_event_mode = ENV3(inst)->in_cont_mode = 0;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance c) {
    LfInstance *inst = (LfInstance *)c;
    Fmi3Env *e;
    CHECK3("fmi3Reset", F3_ANY);
    e = ENV3(inst);
    lf_reset_values(inst);
    inst->unsaved.stop_at_events = e->event_mode_used && e->early_return_allowed; /* configuration */
    e->rtol_set = 0;
    e->in_event_mode = e->in_cont_mode = 0;
    e->events_seen = 0;
    return fmi3OK;
}

/* ---- not provided (declared absent in the model description) ------------- */

#define NO_CLOCKS "the FMU has no clocks"

fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed;
    (void)sensitivity; (void)nSensitivity;
    return lf_fmi3_unsupported(c, "fmi3GetAdjointDerivative", "providesAdjointDerivatives "
                               "is false");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference vr,
                                               size_t *n) {
    (void)vr; (void)n;
    return lf_fmi3_unsupported(c, "fmi3GetNumberOfVariableDependencies", "the dependencies "
                               "are in the model description's ModelStructure");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent; (void)elementIndicesOfDependent; (void)independents;
    (void)elementIndicesOfIndependents; (void)dependencyKinds; (void)nDependencies;
    return lf_fmi3_unsupported(c, "fmi3GetVariableDependencies", "the dependencies are in the "
                               "model description's ModelStructure");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) {
    return lf_fmi3_unsupported(c, "fmi3EnterConfigurationMode", "the FMU has no structural "
                               "parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) {
    return lf_fmi3_unsupported(c, "fmi3ExitConfigurationMode", "the FMU has no structural "
                               "parameters");
}

/* The clock and interval functions: the FMU has no clocks (fmi3Error, logged). */
#define NO_CLOCK_FUNCTION(name, params, ...)                                          \
    fmi3Status name params {                                                          \
        (void)vr, (void)nvr, __VA_ARGS__;                                             \
        return lf_fmi3_unsupported(c, #name, NO_CLOCKS);                              \
    }
#define VRS fmi3Instance c, const fmi3ValueReference vr[], size_t nvr

NO_CLOCK_FUNCTION(fmi3GetClock, (VRS, fmi3Clock values[]), (void)values)
NO_CLOCK_FUNCTION(fmi3SetClock, (VRS, const fmi3Clock values[]), (void)values)
NO_CLOCK_FUNCTION(fmi3GetIntervalDecimal, (VRS, fmi3Float64 intervals[],
                                           fmi3IntervalQualifier q[]), (void)intervals, (void)q)
NO_CLOCK_FUNCTION(fmi3GetIntervalFraction, (VRS, fmi3UInt64 counters[], fmi3UInt64 res[],
                                            fmi3IntervalQualifier q[]),
                  (void)counters, (void)res, (void)q)
NO_CLOCK_FUNCTION(fmi3GetShiftDecimal, (VRS, fmi3Float64 shifts[]), (void)shifts)
NO_CLOCK_FUNCTION(fmi3GetShiftFraction, (VRS, fmi3UInt64 counters[], fmi3UInt64 res[]),
                  (void)counters, (void)res)
NO_CLOCK_FUNCTION(fmi3SetIntervalDecimal, (VRS, const fmi3Float64 intervals[]), (void)intervals)
NO_CLOCK_FUNCTION(fmi3SetIntervalFraction, (VRS, const fmi3UInt64 counters[],
                                            const fmi3UInt64 res[]), (void)counters, (void)res)
NO_CLOCK_FUNCTION(fmi3SetShiftDecimal, (VRS, const fmi3Float64 shifts[]), (void)shifts)
NO_CLOCK_FUNCTION(fmi3SetShiftFraction, (VRS, const fmi3UInt64 counters[],
                                         const fmi3UInt64 res[]), (void)counters, (void)res)

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance c) {
    return lf_fmi3_unsupported(c, "fmi3EvaluateDiscreteStates", NO_CLOCKS);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference; (void)activationTime;
    return lf_fmi3_unsupported(c, "fmi3ActivateModelPartition", "scheduled execution is not "
                               "supported");
}
