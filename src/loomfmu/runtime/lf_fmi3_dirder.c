/* loomfmu shared runtime: FMI 3.0 directional derivatives (co-simulation and
 * model exchange), exact, from CasADi's symbolic Jacobians through
 * lf_directional_derivative (lf_dirder.h).  Float64 value references pass
 * through unchanged (the runtime's Real vrs, der(x_k) = LF_NREAL + k).
 * Unknowns: state derivatives, outputs, algebraic locals; knowns: states,
 * inputs.  Every variable is a scalar: nSeed = nKnowns, nSensitivity =
 * nUnknowns. */
#include <stddef.h>

#include "lf_dirder.h"
#include "lf_fmi3.h"

#define DIRDER_STATES (F3_INIT | F3_EVENT | F3_STEP | F3_CONT | F3_TERMINATED)

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[],
                                        size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity) {
    LfInstance *inst = (LfInstance *)c;
    const char *fn = "fmi3GetDirectionalDerivative";
    LfStatus st;
    CHECK3(fn, DIRDER_STATES);
    if (nSeed != nKnowns || nSensitivity != nUnknowns) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: nSeed = %lu, nSensitivity = %lu; "
               "expected nKnowns = %lu and nUnknowns = %lu (every variable is a scalar); "
               "nothing computed", inst->run.t, fn, (unsigned long)nSeed,
               (unsigned long)nSensitivity, (unsigned long)nKnowns, (unsigned long)nUnknowns);
        return fmi3Error;
    }
    if (nUnknowns == 0) return fmi3OK;
    if (!unknowns || !knowns || !seed || !sensitivity)
        return lf_fmi3_null_arg(inst, fn, !unknowns ? "unknowns" : !knowns ? "knowns"
                                          : !seed ? "seed" : "sensitivity");
    /* model exchange: at the importer's (t, x), delayed values from the history */
    st = lf_fmi3_me_delays_known(inst, fn);
    if (st != LF_OK) return st == LF_DISCARD ? fmi3Discard : fmi3Error;
    st = lf_directional_derivative(inst, unknowns, nUnknowns, knowns, nKnowns, seed,
                                   sensitivity);
    return st == LF_OK ? fmi3OK : st == LF_DISCARD ? fmi3Discard : fmi3Error;
}
