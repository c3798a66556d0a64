/* loomfmu shared runtime: FMI 3.0 co-simulation (fmi3DoStep with the
 * runtime's embedded solvers), event mode, output derivatives.
 *
 * Without eventModeUsed, events located inside a step are handled inside it
 * (the mode switch and the states' reinitialization at the located time),
 * as in FMI 2.0.
 *
 * With eventModeUsed and earlyReturnAllowed (mightReturnEarlyFromDoStep is
 * true), fmi3DoStep returns at the first event located inside the step
 * (lf_step.h: stop_at_events): earlyReturn, eventHandlingNeeded,
 * lastSuccessfulTime = the event time, outputs there with the modes before
 * the event.  The importer enters event mode (fmi3EnterEventMode), where
 * fmi3UpdateDiscreteStates performs the event (modes chosen again, states
 * reinitialized: valuesOfContinuousStatesChanged) and may set inputs, and
 * returns with fmi3EnterStepMode; the next fmi3DoStep starts at the event
 * time.  The trajectory is the same as without early return.
 *
 * With eventModeUsed but no early return, events are handled inside the
 * step and fmi3DoStep sets eventHandlingNeeded when one happened, so that
 * the importer learns of it (fmi3UpdateDiscreteStates then has nothing
 * left to update). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_build.h"
#include "lf_facade.h"
#include "lf_fmi3.h"
#include "lf_modes.h"
#include "lf_step.h"

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    LfInstance *c;
    (void)resourcePath;
    (void)visible;
    if (!LF_HAS_CS) {
        lf_fmi3_refuse_interface("fmi3InstantiateCoSimulation", instanceEnvironment, logMessage,
                                 "co-simulation");
        return NULL;
    }
    /* providesIntermediateUpdate is false: the callback is never called and
     * intermediate variables are not provided (FMI 3.0 lets the FMU ignore
     * them) */
    if (!requiredIntermediateVariables && nRequiredIntermediateVariables > 0) {
        char why[256];
        snprintf(why, sizeof why, "requiredIntermediateVariables is NULL but "
                 "nRequiredIntermediateVariables = %zu; allowed: an array of that many value "
                 "references, or 0; not instantiated", nRequiredIntermediateVariables);
        lf_fmi3_refuse_instantiation("fmi3InstantiateCoSimulation", instanceEnvironment,
                                     logMessage, why);
        return NULL;
    }
    (void)intermediateUpdate;
    c = lf_fmi3_new("fmi3InstantiateCoSimulation", F3_CS, instanceName, instantiationToken,
                    loggingOn, instanceEnvironment, logMessage);
    if (!c) return NULL;
    ENV3(c)->event_mode_used = eventModeUsed ? 1 : 0;
    ENV3(c)->early_return_allowed = earlyReturnAllowed ? 1 : 0;
    /* return early at events only to an importer that handles them in event mode */
    c->unsaved.stop_at_events = eventModeUsed && earlyReturnAllowed;
    return c;
}

/* ---- event mode (co-simulation with eventModeUsed, model exchange) -------- */

fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    LfInstance *inst = (LfInstance *)c;
    Fmi3Env *e;
    CHECK3("fmi3EnterEventMode", F3_STEP | F3_CONT);
    e = ENV3(inst);
    if (e->kind == F3_CS && !e->event_mode_used) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi3EnterEventMode: the instance was "
               "made with eventModeUsed = false (fmi3InstantiateCoSimulation); event mode "
               "cannot be entered", inst->run.t);
        return fmi3Error;
    }
    e->in_event_mode = 1;
    e->in_cont_mode = 0;
    return fmi3OK;
}

/* Inputs set in event mode: the modes are chosen again for them here, at
 * the instance's time and states (as model exchange does), so that the
 * importer reads the settled modes and outputs in event mode; the next
 * fmi3DoStep restarts the solver here as after any input change (it finds
 * the modes consistent).  *changed: a mode or a state changed. */
static LfStatus settle_inputs(LfInstance *inst, int *changed) {
    double x[LF_DIM(LF_NX)];
    int ch = 0;
    LfStatus st;
    if (LF_NQ == 0 || !inst->run.inputs_changed) return LF_OK;
    memcpy(x, &inst->val.r[LF_VR_X0], sizeof(double) * LF_NX);
    st = lf_event_update(inst, -1, inst->run.t, x, &ch);
    if (st != LF_OK || !ch) return st;
    memcpy(&inst->val.r[LF_VR_X0], x, sizeof(double) * LF_NX);
    lf_solver_reset(&inst->solver, inst->run.t, x);
    inst->run.outputs_valid = 0;
    *changed = 1;
    return LF_OK;
}

/* Co-simulation: the pending event of an early return is performed here,
 * then the modes are chosen again for inputs set in event mode; events of
 * steps without early return were handled inside them.  The modes settle
 * in one call: nothing is left to iterate. */
static fmi3Status cs_update_discrete_states(LfInstance *inst, fmi3Boolean *need_update,
                                            fmi3Boolean *terminate,
                                            fmi3Boolean *nominals_changed,
                                            fmi3Boolean *values_changed,
                                            fmi3Boolean *next_defined, fmi3Float64 *next) {
    Fmi3Env *e = ENV3(inst);
    int changed = 0;
    LfStatus st = lf_handle_pending_event(inst, &changed);
    if (st == LF_OK) st = settle_inputs(inst, &changed);
    *need_update = fmi3False;
    *terminate = inst->run.wants_terminate ? fmi3True : fmi3False;
    *nominals_changed = fmi3False;
    *values_changed = changed || inst->stats.n_events > e->events_seen ? fmi3True : fmi3False;
    *next_defined = fmi3False;
    *next = 0.0;
    e->events_seen = inst->stats.n_events;
    if (st == LF_DISCARD) return fmi3Discard; /* validity failed: terminateSimulation */
    return st == LF_OK ? fmi3OK : lf_fmi3_fail(inst, st);
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    LfInstance *inst = (LfInstance *)c;
    const char *fn = "fmi3UpdateDiscreteStates";
    CHECK3(fn, F3_EVENT);
    if (!discreteStatesNeedUpdate) return lf_fmi3_null_arg(inst, fn, "discreteStatesNeedUpdate");
    if (!terminateSimulation) return lf_fmi3_null_arg(inst, fn, "terminateSimulation");
    if (!nominalsOfContinuousStatesChanged)
        return lf_fmi3_null_arg(inst, fn, "nominalsOfContinuousStatesChanged");
    if (!valuesOfContinuousStatesChanged)
        return lf_fmi3_null_arg(inst, fn, "valuesOfContinuousStatesChanged");
    if (!nextEventTimeDefined) return lf_fmi3_null_arg(inst, fn, "nextEventTimeDefined");
    if (!nextEventTime) return lf_fmi3_null_arg(inst, fn, "nextEventTime");
    if (ENV3(inst)->kind == F3_ME)
        return lf_fmi3_me_update_discrete_states(
            inst, discreteStatesNeedUpdate, terminateSimulation,
            nominalsOfContinuousStatesChanged, valuesOfContinuousStatesChanged,
            nextEventTimeDefined, nextEventTime);
    return cs_update_discrete_states(inst, discreteStatesNeedUpdate, terminateSimulation,
                                     nominalsOfContinuousStatesChanged,
                                     valuesOfContinuousStatesChanged, nextEventTimeDefined,
                                     nextEventTime);
}

fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    LfInstance *inst = (LfInstance *)c;
    if (!lf_fmi3_cs_instance(c, "fmi3EnterStepMode", F3_EVENT)) return fmi3Error;
    ENV3(inst)->in_event_mode = 0;
    return fmi3OK;
}

/* ---- stepping --------------------------------------------------------------- */

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    LfInstance *inst = (LfInstance *)c;
    const char *fn = "fmi3DoStep";
    Fmi3Env *e;
    LfStatus st;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!lf_fmi3_cs_instance(c, fn, F3_STEP)) return fmi3Error;
    if (!eventHandlingNeeded) return lf_fmi3_null_arg(inst, fn, "eventHandlingNeeded");
    if (!terminateSimulation) return lf_fmi3_null_arg(inst, fn, "terminateSimulation");
    if (!earlyReturn) return lf_fmi3_null_arg(inst, fn, "earlyReturn");
    if (!lastSuccessfulTime) return lf_fmi3_null_arg(inst, fn, "lastSuccessfulTime");
    e = ENV3(inst);
    /* an invalid call (bad step, past stopTime) is refused and changes nothing */
    if (!lf_step_integrable(inst, fn, t, h) || lf_check_step(inst, t, h) != LF_OK)
        return fmi3Error;
    if (inst->ev.pending && e->event_mode_used) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: the event at t = %.17g is not "
               "handled yet: call fmi3EnterEventMode and fmi3UpdateDiscreteStates first; step "
               "refused, nothing changed", inst->run.t, fn, inst->ev.t_event);
        return fmi3Error;
    }
    st = lf_do_step(inst, t, h);
    *lastSuccessfulTime = inst->run.last_successful_time;
    *terminateSimulation = inst->run.wants_terminate ? fmi3True : fmi3False;
    /* an early return: at a pending event (a step that ends early because it
     * failed, e.g. a validity condition, is a Discard, not an early return:
     * fmi-standard #1845) */
    *earlyReturn = st == LF_OK && inst->unsaved.stop_at_events && inst->ev.pending &&
                   inst->run.last_successful_time < t + h ? fmi3True : fmi3False;
    *eventHandlingNeeded = e->event_mode_used && (inst->ev.pending ||
                                                  inst->stats.n_events > e->events_seen)
                               ? fmi3True : fmi3False;
    if (!e->event_mode_used) e->events_seen = inst->stats.n_events;
    if (st == LF_DISCARD) inst->run.state = LF_ST_STEP_FAILED;
    else if (st != LF_OK && st != LF_WARNING) return lf_fmi3_fail(inst, st);
    return (fmi3Status)st;
}

/* ---- output derivatives (maxOutputDerivativeOrder = 1) ---------------------- */

#define OUT_DER_STATES (F3_EVENT | F3_STEP | F3_STEP_DISCARDED | F3_TERMINATED)

fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    LfInstance *inst = (LfInstance *)c;
    const char *fn = "fmi3GetOutputDerivatives";
    size_t i;
    if (!lf_fmi3_cs_instance(c, fn, OUT_DER_STATES)) return fmi3Error;
    if (nvr > 0 && !orders) return lf_fmi3_null_arg(inst, fn, "orders (with nValueReferences > 0)");
    if (!lf_fmi3_check_vrs(inst, fn, vr, nvr, values, nValues, 0, LF_NREAL)) return fmi3Error;
    for (i = 0; i < nvr; i++) {
        LfKind kind = lf_model.real_kind[vr[i]];
        if (kind != LF_KIND_OUTPUT && kind != LF_KIND_LOCAL) {
            lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: valueReferences[%lu] = %u "
                   "(%s) is not an output (outputs: %u ... %u)", inst->run.t, fn, (unsigned long)i,
                   (unsigned)vr[i], lf_model.real_names[vr[i]], (unsigned)LF_VR_Y0,
                   (unsigned)(LF_NREAL - 1));
            return fmi3Error;
        }
        if (orders[i] != 1) {
            lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: orders[%lu] = %d for %s; "
                   "allowed 1 (maxOutputDerivativeOrder = 1)", inst->run.t, fn, (unsigned long)i,
                   (int)orders[i], lf_model.real_names[vr[i]]);
            return fmi3Error;
        }
    }
    for (i = 0; i < nvr; i++)
        if (lf_output_derivative(inst, vr[i], &values[i]) != LF_OK) return fmi3Error;
    return fmi3OK;
}
