/* loomfmu shared runtime: FMI 2.0 co-simulation: the step (the runtime's
 * step loop, lf_step.c) and the status inquiries. */
#include "lf_fmi2.h"

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    LfInstance *inst = (LfInstance *)c;
    LfStatus st;
    (void)noSetPrior;
    CHECK("fmi2DoStep", LF_ST_STEP_COMPLETE);
    /* an invalid call (bad step, past stopTime) is refused and changes nothing */
    if (!lf_step_args_ok(inst, t, h) &&
        (!lf_step_integrable(inst, "fmi2DoStep", t, h) || lf_check_step(inst, t, h) != LF_OK))
        return fmi2Error;
    st = lf_do_checked_step(inst, t, h);
    if (st == LF_DISCARD) inst->run.state = LF_ST_STEP_FAILED;
    else if (st != LF_OK && st != LF_WARNING) inst->run.state = LF_ST_ERROR;
    return (fmi2Status)st;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    CHECK("fmi2CancelStep", RUNNING);
    return lf_fmi2_unsupported(c, "fmi2CancelStep (fmi2DoStep never returns fmi2Pending)");
}

/* FMI 2.0, 4.2.3: a status kind the FMU does not provide gives fmi2Discard */
static fmi2Status status_kind_unknown(fmi2Component c, const char *fn, fmi2StatusKind s) {
    lf_log((LfInstance *)c, LF_DISCARD, LF_LOG_DISCARD, "%s: status kind %d is not provided",
           fn, (int)s);
    return fmi2Discard;
}

#define STATUS_CHECK(fn)                                                             \
    do {                                                                             \
        CHECK(fn, RUNNING | LF_ST_TERMINATED);                                       \
        if (!value) return lf_fmi2_null_arg((LfInstance *)c, fn, "value");                   \
    } while (0)

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    STATUS_CHECK("fmi2GetStatus");
    if (s != fmi2DoStepStatus) return status_kind_unknown(c, "fmi2GetStatus", s);
    *value = ((LfInstance *)c)->run.state == LF_ST_STEP_FAILED ? fmi2Discard : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    STATUS_CHECK("fmi2GetRealStatus");
    if (s != fmi2LastSuccessfulTime) return status_kind_unknown(c, "fmi2GetRealStatus", s);
    *value = ((LfInstance *)c)->run.last_successful_time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    STATUS_CHECK("fmi2GetIntegerStatus");
    return status_kind_unknown(c, "fmi2GetIntegerStatus", s);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    STATUS_CHECK("fmi2GetBooleanStatus");
    if (s != fmi2Terminated) return status_kind_unknown(c, "fmi2GetBooleanStatus", s);
    /* true after a validity condition failed: the model cannot go on */
    *value = ((LfInstance *)c)->run.wants_terminate ? fmi2True : fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    STATUS_CHECK("fmi2GetStringStatus");
    return status_kind_unknown(c, "fmi2GetStringStatus", s);
}
