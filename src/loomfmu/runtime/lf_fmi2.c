/* loomfmu shared runtime: FMI 2.0 Co-Simulation interface.
 *
 * Every function checks the instance pointer and the call order against a
 * mask of allowed states, and logs expected vs actual on failure.  Features
 * the model description declares as absent (directional derivatives, input
 * derivatives) return fmi2Error with a log line. */
#include <math.h>
#include <string.h>

#include "fmi2Functions.h"
#include "lf_runtime.h"
#include "lf_state.h"

#define ANY_STATE                                                                    \
    (LF_ST_INSTANTIATED | LF_ST_INIT | LF_ST_STEP_COMPLETE | LF_ST_STEP_FAILED |     \
     LF_ST_TERMINATED | LF_ST_ERROR)
#define RUNNING (LF_ST_STEP_COMPLETE | LF_ST_STEP_FAILED)

typedef struct {
    fmi2CallbackFunctions cb;
} Fmi2Env;

/* The message is the logger's format string (FMI 2.0, 2.1.5): '%' and the
 * variable-reference marker '#' are escaped, so that it prints as written. */
static void fmi2_log_bridge(void *env, const char *instance, LfStatus status,
                            const char *category, const char *message) {
    const fmi2CallbackFunctions *cb = (const fmi2CallbackFunctions *)env;
    char buf[1100];
    size_t i = 0;
    for (; *message && i + 2 < sizeof buf; message++) {
        if (*message == '%' || *message == '#') buf[i++] = *message;
        buf[i++] = *message;
    }
    buf[i] = '\0';
    cb->logger(cb->componentEnvironment, instance, (fmi2Status)status, category, buf);
}

static int allowed(LfInstance *c, const char *fn, int mask) {
    if (!c) return 0;
    if (c->state & mask) return 1;
    lf_log(c, LF_ERROR, LF_LOG_ERROR,
           "%s must not be called in the current state (state mask %d, allowed %d)", fn,
           (int)c->state, mask);
    return 0;
}

#define CHECK(fn, mask)                                                              \
    do {                                                                             \
        if (!allowed((LfInstance *)c, fn, mask)) return fmi2Error;                   \
    } while (0)

/* ---- inquiry, logging, life cycle ------------------------------------ */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n,
                               const fmi2String categories[]) {
    LfInstance *inst = (LfInstance *)c;
    size_t i;
    int k;
    CHECK("fmi2SetDebugLogging", ANY_STATE);
    if (n == 0) {
        for (k = 0; k < LF_N_LOG; k++) inst->log_on[k] = loggingOn;
        return fmi2OK;
    }
    for (i = 0; i < n; i++) { /* all known, or nothing changes */
        int found = 0;
        for (k = 0; k < LF_N_LOG; k++)
            if (categories[i] && strcmp(categories[i], lf_log_category_names[k]) == 0) found = 1;
        if (!found) {
            lf_log(inst, LF_ERROR, LF_LOG_ERROR, "fmi2SetDebugLogging: unknown category %s",
                   categories[i] ? categories[i] : "(null)");
            return fmi2Error;
        }
    }
    for (i = 0; i < n; i++)
        for (k = 0; k < LF_N_LOG; k++)
            if (strcmp(categories[i], lf_log_category_names[k]) == 0) inst->log_on[k] = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                              fmi2String fmuGUID, fmi2String resourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    LfAllocator alloc;
    LfInstance *c;
    fmi2CallbackFunctions *cb;
    const char *name = instanceName ? instanceName : "";
    int k;
    (void)resourceLocation;
    (void)visible;
    if (!functions || !functions->logger || !functions->allocateMemory ||
        !functions->freeMemory)
        return NULL;
    if (fmuType != fmi2CoSimulation) {
        functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                          "fmi2Instantiate: only fmi2CoSimulation is supported");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, lf_model.guid) != 0) {
        functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                          "fmi2Instantiate: the GUID does not match this binary's");
        return NULL;
    }
    alloc.calloc = functions->allocateMemory;
    alloc.free = functions->freeMemory;
    /* the instance keeps its own copy of the callbacks */
    cb = (fmi2CallbackFunctions *)alloc.calloc(1, sizeof *cb);
    c = cb ? lf_instantiate(name, fmi2_log_bridge, cb, alloc) : NULL;
    if (!c) {
        if (cb) alloc.free(cb);
        functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                          "fmi2Instantiate: out of memory or solver registry mismatch");
        return NULL;
    }
    *cb = *functions;
    c->log_on_start = loggingOn;
    for (k = 0; k < LF_N_LOG; k++) c->log_on[k] = loggingOn;
    return c;
}

void fmi2FreeInstance(fmi2Component c) {
    LfInstance *inst = (LfInstance *)c;
    void (*release)(void *) = inst ? inst->alloc.free : NULL;
    void *cb = inst ? inst->log_env : NULL;
    lf_free(inst);
    if (cb) release(cb);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    LfInstance *inst = (LfInstance *)c;
    fmi2Status status = fmi2OK;
    CHECK("fmi2SetupExperiment", LF_ST_INSTANTIATED);
    if (!isfinite(startTime) || (stopTimeDefined && !(stopTime >= startTime))) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR,
               "fmi2SetupExperiment: startTime = %g, stopTime = %g (expected finite, start <= "
               "stop)", startTime, stopTimeDefined ? stopTime : INFINITY);
        return fmi2Error;
    }
    inst->t_start = inst->t = startTime;
    inst->t_stop = stopTimeDefined ? stopTime : INFINITY;
    /* the importer's tolerance is the solvers' relative tolerance (it wins over
     * solver_rtol, which keeps its value); it is limited to solver_rtol's range */
    inst->rtol_importer = 0.0;
    if (toleranceDefined) {
        double lo = lf_model.real_min[LF_SET_RTOL], hi = lf_model.real_max[LF_SET_RTOL];
        double tol = tolerance;
        if (!(tol >= lo && tol <= hi)) {
            tol = isfinite(tol) && tol > hi ? hi : lo;
            lf_log(inst, LF_WARNING, LF_LOG_WARNING,
                   "fmi2SetupExperiment: tolerance = %g is outside [%g, %g]; using %g", tolerance,
                   lo, hi, tol);
            status = fmi2Warning;
        }
        inst->rtol_importer = tol;
    }
    return status;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    CHECK("fmi2EnterInitializationMode", LF_ST_INSTANTIATED);
    ((LfInstance *)c)->state = LF_ST_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    LfInstance *inst = (LfInstance *)c;
    CHECK("fmi2ExitInitializationMode", LF_ST_INIT);
    if (lf_initialize(inst) != LF_OK) {
        inst->state = LF_ST_ERROR;
        return fmi2Error;
    }
    inst->state = LF_ST_STEP_COMPLETE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK("fmi2Terminate", RUNNING);
    ((LfInstance *)c)->state = LF_ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    CHECK("fmi2Reset", ANY_STATE);
    lf_reset_values((LfInstance *)c);
    return fmi2OK;
}

/* ---- values ------------------------------------------------------------ */

/* FMI 2.0, 4.2.4: values can be read from initialization mode on, and set
 * before initialization, in it and after a completed step */
#define GET_STATES (LF_ST_INIT | RUNNING | LF_ST_TERMINATED | LF_ST_ERROR)
#define SET_STATES (LF_ST_INSTANTIATED | LF_ST_INIT | LF_ST_STEP_COMPLETE)

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    size_t i;
    CHECK("fmi2GetReal", GET_STATES);
    for (i = 0; i < nvr; i++)
        if (lf_get_real((LfInstance *)c, vr[i], &value[i]) != LF_OK) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    size_t i;
    fmi2Status worst = fmi2OK;
    CHECK("fmi2SetReal", SET_STATES);
    for (i = 0; i < nvr; i++) {
        LfStatus st = lf_set_real((LfInstance *)c, vr[i], value[i]);
        if (st > LF_WARNING) return fmi2Error;
        if (st == LF_WARNING) worst = fmi2Warning;
    }
    return worst;
}

static fmi2Status no_such(LfInstance *c, const char *fn, const char *type, fmi2ValueReference vr) {
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "%s: there is no %s variable with value reference %u",
           fn, type, (unsigned)vr);
    return fmi2Error;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    size_t i;
    CHECK("fmi2GetInteger", GET_STATES);
    for (i = 0; i < nvr; i++) {
        int v;
        if (lf_get_integer((LfInstance *)c, vr[i], &v) != LF_OK) return fmi2Error;
        value[i] = v;
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    size_t i;
    CHECK("fmi2SetInteger", SET_STATES);
    for (i = 0; i < nvr; i++)
        if (lf_set_integer((LfInstance *)c, vr[i], value[i]) != LF_OK) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    (void)value;
    CHECK("fmi2GetBoolean", GET_STATES);
    return nvr ? no_such((LfInstance *)c, "fmi2GetBoolean", "Boolean", vr[0]) : fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    (void)value;
    CHECK("fmi2SetBoolean", SET_STATES);
    return nvr ? no_such((LfInstance *)c, "fmi2SetBoolean", "Boolean", vr[0]) : fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    (void)value;
    CHECK("fmi2GetString", GET_STATES);
    return nvr ? no_such((LfInstance *)c, "fmi2GetString", "String", vr[0]) : fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    (void)value;
    CHECK("fmi2SetString", SET_STATES);
    return nvr ? no_such((LfInstance *)c, "fmi2SetString", "String", vr[0]) : fmi2OK;
}

/* ---- not provided (declared absent in the model description) ---------- */

static fmi2Status unsupported(fmi2Component c, const char *fn) {
    if (c) lf_log((LfInstance *)c, LF_ERROR, LF_LOG_ERROR,
                  "%s is not supported by this FMU (see modelDescription.xml)", fn);
    return fmi2Error;
}

/* ---- FMU state (lf_state.c): a blob of its size and the bytes ----------- */

typedef struct {
    size_t n;
    unsigned char data[1];
} StateBlob;

#define STATE_STATES (LF_ST_INSTANTIATED | LF_ST_INIT | RUNNING | LF_ST_TERMINATED)

static StateBlob *blob_alloc(LfInstance *c, size_t n) {
    StateBlob *b = (StateBlob *)c->alloc.calloc(1, sizeof(StateBlob) + n);
    if (b) b->n = n;
    else lf_log(c, LF_ERROR, LF_LOG_ERROR, "FMU state: out of memory (%lu bytes)",
                (unsigned long)n);
    return b;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    LfInstance *inst = (LfInstance *)c;
    size_t n;
    StateBlob *b;
    CHECK("fmi2GetFMUstate", STATE_STATES);
    n = lf_state_size(inst);
    b = (StateBlob *)*state;
    if (!b || b->n != n) {
        if (b) inst->alloc.free(b);
        *state = NULL;
        b = blob_alloc(inst, n);
        if (!b) return fmi2Error;
    }
    lf_state_write(inst, b->data);
    *state = b;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    const StateBlob *b = (const StateBlob *)state;
    CHECK("fmi2SetFMUstate", STATE_STATES);
    if (!b) {
        lf_log((LfInstance *)c, LF_ERROR, LF_LOG_ERROR, "fmi2SetFMUstate: state is NULL");
        return fmi2Error;
    }
    return (fmi2Status)lf_state_read((LfInstance *)c, b->data, b->n);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    CHECK("fmi2FreeFMUstate", STATE_STATES | LF_ST_ERROR);
    if (state && *state) ((LfInstance *)c)->alloc.free(*state);
    if (state) *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *n) {
    CHECK("fmi2SerializedFMUstateSize", STATE_STATES);
    if (!state) {
        lf_log((LfInstance *)c, LF_ERROR, LF_LOG_ERROR, "fmi2SerializedFMUstateSize: NULL state");
        return fmi2Error;
    }
    *n = ((const StateBlob *)state)->n;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[],
                                 size_t n) {
    const StateBlob *b = (const StateBlob *)state;
    CHECK("fmi2SerializeFMUstate", STATE_STATES);
    if (!b || n < b->n) {
        lf_log((LfInstance *)c, LF_ERROR, LF_LOG_ERROR,
               "fmi2SerializeFMUstate: expected a buffer of %lu bytes but was %lu",
               (unsigned long)(b ? b->n : 0), (unsigned long)n);
        return fmi2Error;
    }
    memcpy(bytes, b->data, b->n);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t n,
                                   fmi2FMUstate *state) {
    LfInstance *inst = (LfInstance *)c;
    StateBlob *b;
    CHECK("fmi2DeSerializeFMUstate", STATE_STATES);
    if (state && *state) {
        inst->alloc.free(*state);
        *state = NULL;
    }
    b = blob_alloc(inst, n);
    if (!b) return fmi2Error;
    memcpy(b->data, bytes, n);
    *state = b; /* checked against this FMU when set */
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[],
                                        size_t nu, const fmi2ValueReference z[], size_t nz,
                                        const fmi2Real dv[], fmi2Real dz[]) {
    (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz;
    return unsupported(c, "fmi2GetDirectionalDerivative");
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    return unsupported(c, "fmi2SetRealInputDerivatives");
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[],
                                        fmi2Real value[]) {
    (void)vr; (void)nvr; (void)order; (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives");
}

/* ---- co-simulation ------------------------------------------------------ */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    LfInstance *inst = (LfInstance *)c;
    LfStatus st;
    (void)noSetPrior;
    CHECK("fmi2DoStep", LF_ST_STEP_COMPLETE);
    /* an invalid call (bad step, past stopTime) is refused and changes nothing */
    if (lf_check_step(inst, t, h) != LF_OK) return fmi2Error;
    st = lf_do_step(inst, t, h);
    if (st == LF_DISCARD) inst->state = LF_ST_STEP_FAILED;
    else if (st != LF_OK && st != LF_WARNING) inst->state = LF_ST_ERROR;
    return (fmi2Status)st;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    CHECK("fmi2CancelStep", RUNNING);
    return unsupported(c, "fmi2CancelStep (fmi2DoStep never returns fmi2Pending)");
}

/* FMI 2.0, 4.2.3: a status kind the FMU does not provide gives fmi2Discard */
static fmi2Status status_kind_unknown(fmi2Component c, const char *fn, fmi2StatusKind s) {
    lf_log((LfInstance *)c, LF_DISCARD, LF_LOG_DISCARD, "%s: status kind %d is not provided",
           fn, (int)s);
    return fmi2Discard;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    CHECK("fmi2GetStatus", RUNNING | LF_ST_TERMINATED);
    if (s != fmi2DoStepStatus) return status_kind_unknown(c, "fmi2GetStatus", s);
    *value = ((LfInstance *)c)->state == LF_ST_STEP_FAILED ? fmi2Discard : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    CHECK("fmi2GetRealStatus", RUNNING | LF_ST_TERMINATED);
    if (s != fmi2LastSuccessfulTime) return status_kind_unknown(c, "fmi2GetRealStatus", s);
    *value = ((LfInstance *)c)->last_successful_time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s;
    (void)value;
    CHECK("fmi2GetIntegerStatus", RUNNING | LF_ST_TERMINATED);
    return status_kind_unknown(c, "fmi2GetIntegerStatus", s);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    CHECK("fmi2GetBooleanStatus", RUNNING | LF_ST_TERMINATED);
    if (s != fmi2Terminated) return status_kind_unknown(c, "fmi2GetBooleanStatus", s);
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s;
    (void)value;
    CHECK("fmi2GetStringStatus", RUNNING | LF_ST_TERMINATED);
    return status_kind_unknown(c, "fmi2GetStringStatus", s);
}
