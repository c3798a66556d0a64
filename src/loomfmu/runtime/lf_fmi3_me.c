/* loomfmu shared runtime: FMI 3.0 model exchange, through the
 * version-independent core lf_me.h (the importer integrates; the FMU gives
 * derivatives, event indicators, and settles its modes in event mode).
 *
 * State machine (FMI 3.0, 3.2): after fmi3ExitInitializationMode the
 * instance is in event mode; fmi3UpdateDiscreteStates there, then
 * fmi3EnterContinuousTimeMode; fmi3EnterEventMode returns to event mode.
 * Time and inputs are set in both modes, the states in continuous-time mode;
 * fmi3CompletedIntegratorStep after every accepted step (the delays'
 * history needs it: needsCompletedIntegratorStep="true").  The runtime's
 * interface state stays "stepping" while the facade keeps the mode. */
#include <stdio.h>

#include "lf_build.h"
#include "lf_facade.h"
#include "lf_fmi3_internal.h"

/* FMI 3.0's masks of the model-exchange functions */
#define MASK_SET_TIME (F3_EVENT | F3_CONT)
#define MASK_SET_STATES (F3_CONT)
#define MASK_GET (F3_INIT | F3_EVENT | F3_CONT | F3_TERMINATED)
#define MASK_NUMBERS (F3_ANY)

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName,
                                          fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)resourcePath;
    (void)visible;
    if (!LF_HAS_ME) {
        lf_fmi3_refuse_interface("fmi3InstantiateModelExchange", instanceEnvironment,
                                 logMessage, "model exchange");
        return NULL;
    }
    return lf_fmi3_new("fmi3InstantiateModelExchange", F3_ME, instanceName,
                       instantiationToken, loggingOn, instanceEnvironment, logMessage);
}

/* The instance if `c` is a live model-exchange instance in one of `mask`'s
 * states; else NULL (logged: the interface first, then the state). */
static LfInstance *me_instance(fmi3Instance c, const char *fn, int mask) {
    LfInstance *inst = lf_fmi3_live(c);
    if (!inst || !lf_fmi3_interface(inst, fn, F3_ME) || !lf_fmi3_allowed(c, fn, mask))
        return NULL;
    return inst;
}

LfStatus lf_fmi3_me_delays_known(LfInstance *inst, const char *fn) {
    if (ENV3(inst)->kind != F3_ME || inst->run.state != LF_ST_STEP_COMPLETE) return LF_OK;
    return lf_me_delays_known(inst, fn);
}

/* LF_DISCARD keeps the mode (the importer may retry with a smaller step);
 * errors of bad arguments change nothing either (the core checks them
 * before anything is changed). */
static fmi3Status me_status(LfStatus st) {
    return st == LF_OK ? fmi3OK : st == LF_WARNING ? fmi3Warning
           : st == LF_DISCARD ? fmi3Discard : fmi3Error;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) {
    const char *fn = "fmi3EnterContinuousTimeMode";
    LfInstance *inst = me_instance(c, fn, F3_EVENT);
    LfStatus st;
    if (!inst) return fmi3Error;
    st = lf_me_enter_continuous(inst, fn);
    if (st > LF_WARNING) return me_status(st);
    ENV3(inst)->in_event_mode = 0;
    ENV3(inst)->in_cont_mode = 1;
    return me_status(st);
}

fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 time) {
    const char *fn = "fmi3SetTime";
    LfInstance *inst = me_instance(c, fn, MASK_SET_TIME);
    return inst ? me_status(lf_me_set_time(inst, fn, time)) : fmi3Error;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t nx) {
    const char *fn = "fmi3SetContinuousStates";
    LfInstance *inst = me_instance(c, fn, MASK_SET_STATES);
    return inst ? me_status(lf_me_set_states(inst, fn, x, nx)) : fmi3Error;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t nx) {
    const char *fn = "fmi3GetContinuousStates";
    LfInstance *inst = me_instance(c, fn, MASK_GET);
    return inst ? me_status(lf_me_get_states(inst, fn, x, nx)) : fmi3Error;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 dx[], size_t nx) {
    const char *fn = "fmi3GetContinuousStateDerivatives";
    LfInstance *inst = me_instance(c, fn, MASK_GET);
    return inst ? me_status(lf_me_derivatives(inst, fn, dx, nx)) : fmi3Error;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 e[], size_t ne) {
    const char *fn = "fmi3GetEventIndicators";
    LfInstance *inst = me_instance(c, fn, MASK_GET);
    return inst ? me_status(lf_me_event_indicators(inst, fn, e, ne)) : fmi3Error;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominals[],
                                             size_t nx) {
    const char *fn = "fmi3GetNominalsOfContinuousStates";
    LfInstance *inst = me_instance(c, fn, MASK_GET);
    return inst ? me_status(lf_me_nominals(inst, fn, nominals, nx)) : fmi3Error;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) {
    const char *fn = "fmi3GetNumberOfEventIndicators";
    LfInstance *inst = me_instance(c, fn, MASK_NUMBERS);
    if (!inst) return fmi3Error;
    if (!n) return lf_fmi3_null_arg(inst, fn, "nEventIndicators");
    *n = LF_NE;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) {
    const char *fn = "fmi3GetNumberOfContinuousStates";
    LfInstance *inst = me_instance(c, fn, MASK_NUMBERS);
    if (!inst) return fmi3Error;
    if (!n) return lf_fmi3_null_arg(inst, fn, "nContinuousStates");
    *n = LF_NX;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation) {
    const char *fn = "fmi3CompletedIntegratorStep";
    LfInstance *inst = me_instance(c, fn, F3_CONT);
    int enter = 0, terminate = 0;
    LfStatus st;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!inst) return fmi3Error;
    if (!enterEventMode) return lf_fmi3_null_arg(inst, fn, "enterEventMode");
    if (!terminateSimulation) return lf_fmi3_null_arg(inst, fn, "terminateSimulation");
    st = lf_me_completed_step(inst, fn, &enter, &terminate);
    *enterEventMode = enter ? fmi3True : fmi3False;
    *terminateSimulation = terminate ? fmi3True : fmi3False;
    return me_status(st);
}

/* fmi3UpdateDiscreteStates of a model-exchange instance (lf_fmi3_cs.c
 * checks the state and the arguments). */
fmi3Status lf_fmi3_me_update_discrete_states(LfInstance *inst, fmi3Boolean *need_update,
                                             fmi3Boolean *terminate,
                                             fmi3Boolean *nominals_changed,
                                             fmi3Boolean *values_changed,
                                             fmi3Boolean *next_defined, fmi3Float64 *next) {
    LfMeEventInfo info = {0, 0, 0, 0, 0, 0.0};
    LfStatus st = lf_me_event_update(inst, "fmi3UpdateDiscreteStates", &info);
    if (st > LF_DISCARD) return fmi3Error;
    *need_update = info.discrete_states_need_update ? fmi3True : fmi3False;
    *terminate = info.terminate ? fmi3True : fmi3False;
    *nominals_changed = info.nominals_changed ? fmi3True : fmi3False;
    *values_changed = info.states_changed ? fmi3True : fmi3False;
    *next_defined = info.next_time_defined ? fmi3True : fmi3False;
    *next = info.next_time_defined ? info.next_time : 0.0;
    return me_status(st);
}
