/* loomfmu shared runtime: FMI 2.0 co-simulation input and output
 * derivatives (canInterpolateInputs="true", maxOutputDerivativeOrder="1"),
 * and directional derivatives (co-simulation and model exchange).
 *
 * fmi2SetRealInputDerivatives: orders 1 and 2 of Real inputs, set with
 * respect to the current communication point (lf_inputs.c); allowed where
 * fmi2SetReal is (instantiated, initialization mode, step complete).  The
 * call is checked whole before anything is set: every value reference an
 * input, every order 1 or 2, every value finite.
 *
 * fmi2GetRealOutputDerivatives: order 1 of outputs (and algebraic locals),
 * exact, at the current time (after fmi2DoStep: the end of the step), with
 * the inputs' current slopes; allowed after initialization (step complete or
 * failed, terminated).  Order 2 and higher: fmi2Error (maxOutputDerivativeOrder
 * is 1). */
#include <math.h>
#include <stddef.h>

#include "fmi2Functions.h"
#include "lf_dirder.h"
#include "lf_fmi2.h"

#define SET_STATES (LF_ST_INSTANTIATED | LF_ST_INIT | LF_ST_STEP_COMPLETE)
#define OUT_DER_STATES (RUNNING | LF_ST_TERMINATED)

/* input and output derivatives are co-simulation functions */
static int cs_only(LfInstance *inst, const char *fn) {
    if (!ENV(inst)->me) return 1;
    lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s is a co-simulation function; this "
           "instance was instantiated as fmi2ModelExchange", inst->run.t, fn);
    return 0;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    LfInstance *inst = (LfInstance *)c;
    size_t i;
    CHECK("fmi2SetRealInputDerivatives", SET_STATES);
    if (!cs_only(inst, "fmi2SetRealInputDerivatives")) return fmi2Error;
    if (nvr > 0 && !order)
        return lf_fmi2_null_arg(inst, "fmi2SetRealInputDerivatives", "order (with nvr > 0)");
    if (!lf_fmi2_check_vrs(inst, "fmi2SetRealInputDerivatives", vr, nvr, value, LF_NREAL))
        return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (lf_input_derivative_check(inst, vr[i], order[i], value[i]) != LF_OK)
            return fmi2Error;
    for (i = 0; i < nvr; i++) lf_input_derivative_set(inst, vr[i], order[i], value[i]);
    return fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[],
                                        fmi2Real value[]) {
    LfInstance *inst = (LfInstance *)c;
    size_t i;
    CHECK("fmi2GetRealOutputDerivatives", OUT_DER_STATES);
    if (!cs_only(inst, "fmi2GetRealOutputDerivatives")) return fmi2Error;
    if (nvr > 0 && !order)
        return lf_fmi2_null_arg(inst, "fmi2GetRealOutputDerivatives", "order (with nvr > 0)");
    if (!lf_fmi2_check_vrs(inst, "fmi2GetRealOutputDerivatives", vr, nvr, value, LF_NREAL))
        return fmi2Error;
    for (i = 0; i < nvr; i++) {
        LfKind kind = lf_model.real_kind[vr[i]];
        if (kind != LF_KIND_OUTPUT && kind != LF_KIND_LOCAL) {
            lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi2GetRealOutputDerivatives: "
                   "vr[%lu] = %u (%s) is not an output (outputs: %u ... %u)", inst->run.t,
                   (unsigned long)i, (unsigned)vr[i], lf_model.real_names[vr[i]],
                   (unsigned)LF_VR_Y0, (unsigned)(LF_NREAL - 1));
            return fmi2Error;
        }
        if (order[i] != 1) {
            lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi2GetRealOutputDerivatives: "
                   "order[%lu] = %d for %s; allowed 1 (maxOutputDerivativeOrder = 1; 0 is "
                   "not allowed by FMI 2.0)", inst->run.t, (unsigned long)i, (int)order[i],
                   lf_model.real_names[vr[i]]);
            return fmi2Error;
        }
    }
    for (i = 0; i < nvr; i++)
        if (lf_output_derivative(inst, vr[i], &value[i]) != LF_OK) return fmi2Error;
    return fmi2OK;
}

/* ---- directional derivatives ------------------------------------------------ */

/* Exact (CasADi's Jacobians, lf_dirder.c) at the current time and states:
 * unknowns der(x_k) (vr LF_NREAL + k), outputs and algebraic locals; knowns
 * states and inputs.  From initialization mode on, in co-simulation and
 * model exchange (where the delayed values must be known from the history,
 * as for fmi2GetDerivatives). */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    LfInstance *inst = (LfInstance *)c;
    const char *fn = "fmi2GetDirectionalDerivative";
    LfStatus st;
    CHECK(fn, LF_ST_INIT | RUNNING | ME_RUNNING | LF_ST_TERMINATED);
    if (ENV(inst)->me && (inst->run.state & LF_ST_STEP_COMPLETE) &&
        (st = lf_me_delays_known(inst, fn)) != LF_OK)
        return (fmi2Status)st;
    st = lf_directional_derivative(inst, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown,
                                   dvUnknown);
    return (fmi2Status)st;
}
