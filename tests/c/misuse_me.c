/* Model-exchange driver for a loomfmu FMU built "both": compiled with the
 * FMU's own sources under -fsanitize=address,undefined (LeakSanitizer on),
 * so that a crash, an out-of-bounds access, undefined behaviour or a leak
 * ends the process with a non-zero code (tests/test_misuse.py).
 *
 * It integrates 1 s by explicit Euler (0.25 ms steps) the way an importer
 * does (time, states, derivatives, indicators, a completed step after each,
 * event mode when the FMU asks), takes an FMU state halfway, then misuses
 * the model-exchange functions: calls in the wrong state, NULL arrays,
 * sizes other than the FMU's (SIZE_MAX too), NaN states and time, a
 * co-simulation call, calls after fmi2Terminate and after fmi2FreeInstance.
 * Each misuse must return fmi2Error with exactly one error log line (none
 * after fmi2FreeInstance: nothing to log through); each legal call fmi2OK.
 * Prints "events E unexpected U"; exit code 0 iff U = 0. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi2Functions.h"
#include "lf_model.h"

#define NX LF_NX
#define NE (LF_NE > 0 ? LF_NE : 1)

static int n_err;     /* lines logged with fmi2Error or worse */
static int unexpected;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    (void)name;
    (void)category;
    (void)message;
    if (status >= fmi2Error) n_err++;
}

static void expect(int line, const char *call, fmi2Status got, fmi2Status want, int logs,
                   int before) {
    if (got == want && n_err == before + logs) return;
    unexpected++;
    fprintf(stderr, "line %d: %s returned %d (expected %d), %d error lines (expected %d)\n",
            line, call, (int)got, (int)want, n_err - before, logs);
}

#define OK(call)                                                                     \
    do {                                                                             \
        int before_ = n_err;                                                         \
        expect(__LINE__, #call, (call), fmi2OK, 0, before_);                         \
    } while (0)
#define REFUSED(call)                                                                \
    do {                                                                             \
        int before_ = n_err;                                                         \
        expect(__LINE__, #call, (call), fmi2Error, 1, before_);                      \
    } while (0)

int main(void) {
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("me", fmi2ModelExchange, lf_model.guid, "", &cb, 0, 0);
    double x[NX + 4], dx[NX + 4], z[NE + 4], h = 2.5e-4, t = 0.0;
    fmi2EventInfo info;
    fmi2Boolean ev = fmi2False, term = fmi2False;
    fmi2FMUstate state = NULL;
    size_t size = 0;
    unsigned char *bytes;
    int i, k, n_events = 0;
    if (!c) return 2;
    REFUSED(fmi2SetTime(c, 0.1)); /* instantiated */
    OK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    OK(fmi2EnterInitializationMode(c));
    OK(fmi2GetDerivatives(c, dx, NX));
    OK(fmi2ExitInitializationMode(c));
    REFUSED(fmi2SetContinuousStates(c, x, NX)); /* event mode */
    REFUSED(fmi2NewDiscreteStates(c, NULL));
    OK(fmi2NewDiscreteStates(c, &info));
    OK(fmi2EnterContinuousTimeMode(c));
    OK(fmi2GetContinuousStates(c, x, NX));
    for (i = 1; i <= 4000; i++) { /* explicit Euler to 1 s */
        OK(fmi2GetDerivatives(c, dx, NX));
        for (k = 0; k < NX; k++) x[k] += h * dx[k];
        t = i * h;
        OK(fmi2SetTime(c, t));
        OK(fmi2SetContinuousStates(c, x, NX));
        OK(fmi2GetEventIndicators(c, z, LF_NE));
        OK(fmi2CompletedIntegratorStep(c, fmi2True, &ev, &term));
        if (i == 2000) OK(fmi2GetFMUstate(c, &state));
        if (!ev) continue;
        n_events++;
        OK(fmi2EnterEventMode(c));
        OK(fmi2NewDiscreteStates(c, &info));
        OK(fmi2EnterContinuousTimeMode(c));
        OK(fmi2GetContinuousStates(c, x, NX));
    }
    REFUSED(fmi2SetContinuousStates(c, NULL, NX));
    REFUSED(fmi2SetContinuousStates(c, x, NX + 1));
    REFUSED(fmi2SetContinuousStates(c, x, SIZE_MAX));
    REFUSED(fmi2GetDerivatives(c, dx, SIZE_MAX));
    REFUSED(fmi2GetEventIndicators(c, z, SIZE_MAX));
    REFUSED(fmi2GetNominalsOfContinuousStates(c, NULL, NX));
    x[0] = NAN;
    REFUSED(fmi2SetContinuousStates(c, x, NX));
    REFUSED(fmi2SetTime(c, NAN));
    REFUSED(fmi2CompletedIntegratorStep(c, fmi2True, NULL, &term));
    REFUSED(fmi2DoStep(c, t, 0.1, fmi2True)); /* a co-simulation call */
    REFUSED(fmi2NewDiscreteStates(c, &info)); /* continuous-time mode */
    OK(fmi2SetFMUstate(c, state));
    OK(fmi2SerializedFMUstateSize(c, state, &size));
    bytes = (unsigned char *)malloc(size);
    if (bytes) OK(fmi2SerializeFMUstate(c, state, (fmi2Byte *)bytes, size));
    free(bytes);
    OK(fmi2FreeFMUstate(c, &state));
    OK(fmi2Terminate(c));
    REFUSED(fmi2SetTime(c, 1.0)); /* terminated */
    fmi2FreeInstance(c);
    fmi2FreeInstance(c); /* twice: ignored */
    {
        int before = n_err;
        expect(__LINE__, "fmi2GetDerivatives(freed)", fmi2GetDerivatives(c, dx, NX), fmi2Error,
               0, before);
    }
    printf("events %d unexpected %d\n", n_events, unexpected);
    return unexpected != 0;
}
