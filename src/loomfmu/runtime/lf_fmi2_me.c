/* loomfmu shared runtime: FMI 2.0 model exchange (the state machine of
 * FMI 2.0, section 3.2.3, over the version-independent core lf_me.c).
 *
 * After fmi2ExitInitializationMode the instance is in event mode; the
 * importer iterates fmi2NewDiscreteStates (our modes settle in one call),
 * enters continuous-time mode, integrates with fmi2SetTime,
 * fmi2SetContinuousStates, fmi2GetDerivatives and fmi2GetEventIndicators,
 * calls fmi2CompletedIntegratorStep after every accepted step (needed for
 * the delays' history and the validity conditions) and fmi2EnterEventMode
 * at events.  A call in another state, or on a co-simulation instance, is
 * refused with fmi2Error and a log naming the function and the state. */
#include "lf_fmi2.h"

/* getters: from initialization mode on (FMI 2.0, 3.2.3) */
#define ME_GET (LF_ST_INIT | ME_RUNNING | LF_ST_TERMINATED | LF_ST_ERROR)

/* `fn` is a model-exchange function: the instance must be one */
static int is_me(fmi2Component c, const char *fn) {
    LfInstance *inst = (LfInstance *)c;
    if (ENV(inst)->me) return 1;
    lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s is a model-exchange function; this "
           "instance was instantiated as fmi2CoSimulation", inst->run.t, fn);
    return 0;
}

#define ME_CHECK(fn, mask)                                                           \
    do {                                                                             \
        CHECK(fn, mask);                                                             \
        if (!is_me(c, fn)) return fmi2Error;                                         \
    } while (0)

/* a failure of the model (not of the call's arguments) ends in state Error */
static fmi2Status model_status(LfInstance *inst, LfStatus st) {
    if (st == LF_ERROR || st == LF_FATAL) inst->run.state = LF_ST_ERROR;
    return (fmi2Status)st;
}

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    ME_CHECK("fmi2EnterEventMode", M2_CONT);
    ENV((LfInstance *)c)->me_cont = 0;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    LfInstance *inst = (LfInstance *)c;
    LfMeEventInfo ev;
    LfStatus st;
    ME_CHECK("fmi2NewDiscreteStates", M2_EVENT);
    if (!info) return lf_fmi2_null_arg(inst, "fmi2NewDiscreteStates", "fmi2eventInfo");
    if (lf_me_check_time(inst, "fmi2NewDiscreteStates") != LF_OK) return fmi2Error;
    st = lf_me_event_update(inst, "fmi2NewDiscreteStates", &ev);
    if (st != LF_OK) return model_status(inst, st);
    info->newDiscreteStatesNeeded = ev.discrete_states_need_update ? fmi2True : fmi2False;
    info->terminateSimulation = ev.terminate ? fmi2True : fmi2False;
    info->nominalsOfContinuousStatesChanged = ev.nominals_changed ? fmi2True : fmi2False;
    info->valuesOfContinuousStatesChanged = ev.states_changed ? fmi2True : fmi2False;
    info->nextEventTimeDefined = ev.next_time_defined ? fmi2True : fmi2False;
    info->nextEventTime = ev.next_time_defined ? ev.next_time : 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    LfInstance *inst = (LfInstance *)c;
    LfStatus st;
    ME_CHECK("fmi2EnterContinuousTimeMode", M2_EVENT);
    st = lf_me_enter_continuous(inst, "fmi2EnterContinuousTimeMode");
    if (st != LF_OK) return model_status(inst, st);
    ENV(inst)->me_cont = 1;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation) {
    LfInstance *inst = (LfInstance *)c;
    int event = 0, terminate = 0;
    LfStatus st;
    (void)noSetFMUStatePriorToCurrentPoint;
    ME_CHECK("fmi2CompletedIntegratorStep", M2_CONT);
    if (!enterEventMode)
        return lf_fmi2_null_arg(inst, "fmi2CompletedIntegratorStep", "enterEventMode");
    if (!terminateSimulation)
        return lf_fmi2_null_arg(inst, "fmi2CompletedIntegratorStep", "terminateSimulation");
    if (lf_me_check_time(inst, "fmi2CompletedIntegratorStep") != LF_OK) return fmi2Error;
    st = lf_me_completed_step(inst, "fmi2CompletedIntegratorStep", &event, &terminate);
    *enterEventMode = event ? fmi2True : fmi2False;
    *terminateSimulation = terminate ? fmi2True : fmi2False;
    return model_status(inst, st);
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    ME_CHECK("fmi2SetTime", ME_RUNNING);
    return (fmi2Status)lf_me_set_time((LfInstance *)c, "fmi2SetTime", time);
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    ME_CHECK("fmi2SetContinuousStates", M2_CONT);
    return (fmi2Status)lf_me_set_states((LfInstance *)c, "fmi2SetContinuousStates", x, nx);
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    ME_CHECK("fmi2GetDerivatives", ME_GET);
    return (fmi2Status)lf_me_derivatives((LfInstance *)c, "fmi2GetDerivatives", derivatives,
                                         nx);
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    ME_CHECK("fmi2GetEventIndicators", ME_GET);
    return (fmi2Status)lf_me_event_indicators((LfInstance *)c, "fmi2GetEventIndicators",
                                              eventIndicators, ni);
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    ME_CHECK("fmi2GetContinuousStates", ME_GET);
    return (fmi2Status)lf_me_get_states((LfInstance *)c, "fmi2GetContinuousStates", x, nx);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[],
                                             size_t nx) {
    ME_CHECK("fmi2GetNominalsOfContinuousStates", LF_ST_INSTANTIATED | ME_GET);
    return (fmi2Status)lf_me_nominals((LfInstance *)c, "fmi2GetNominalsOfContinuousStates",
                                      x_nominal, nx);
}
