/* loomfmu shared runtime: FMI 2.0 Co-Simulation interface.
 *
 * Every function checks the instance pointer and the call order against a
 * mask of allowed states, and logs expected vs actual on failure.  Features
 * the model description declares as absent (directional derivatives) return
 * fmi2Error with a log line.  Input and output derivatives: lf_fmi2_deriv.c.
 *
 * Misuse is refused, never a crash: NULL arrays, sizes no array of this FMU
 * can have, non-finite or backward time, FMU states not made by this
 * instance.  An instance is known by the registry of live instances below,
 * so that a call with a freed instance (fmi2FreeInstance twice, fmi2DoStep
 * after fmi2FreeInstance) returns fmi2Error (nothing to log through) without
 * touching the freed memory.  Limit: if the allocator has given the freed
 * address to a new instance of this FMU, the call goes to that instance. */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "fmi2Functions.h"
#include "lf_runtime.h"
#include "lf_fmi2_internal.h"
#include "lf_state.h"


/* ---- registry of live instances (lock-free; instances may live in several
 * threads) ------------------------------------------------------------------ */

#define LF_MAX_LIVE 1024
static void *live_slots[LF_MAX_LIVE];
static int live_top; /* slots in use are below */

static int live_add(void *c) {
    int i, top;
    for (i = 0; i < LF_MAX_LIVE; i++) {
        void *expected = NULL;
        if (__atomic_compare_exchange_n(&live_slots[i], &expected, c, 0, __ATOMIC_SEQ_CST,
                                        __ATOMIC_SEQ_CST)) {
            top = __atomic_load_n(&live_top, __ATOMIC_SEQ_CST);
            while (top < i + 1 &&
                   !__atomic_compare_exchange_n(&live_top, &top, i + 1, 0, __ATOMIC_SEQ_CST,
                                                __ATOMIC_SEQ_CST)) {
            }
            return 1;
        }
    }
    return 0;
}

/* 1 if c was live (and is not any more): only one caller can free it */
static int live_remove(void *c) {
    int i, top = __atomic_load_n(&live_top, __ATOMIC_SEQ_CST);
    for (i = 0; i < top; i++) {
        void *expected = c;
        if (__atomic_compare_exchange_n(&live_slots[i], &expected, NULL, 0, __ATOMIC_SEQ_CST,
                                        __ATOMIC_SEQ_CST))
            return 1;
    }
    return 0;
}

LfInstance *lf_fmi2_live(fmi2Component c) {
    int i, top = __atomic_load_n(&live_top, __ATOMIC_SEQ_CST);
    if (!c) return NULL;
    for (i = 0; i < top; i++)
        if (__atomic_load_n(&live_slots[i], __ATOMIC_SEQ_CST) == c) return (LfInstance *)c;
    return NULL;
}

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

/* FMI 2.0's names of the interface states, in the order of LfState's bits */
static const char *const state_names[] = {"Instantiated", "InitializationMode",
                                          "StepComplete", "StepFailed", "Terminated",
                                          "Error"};
#define N_STATE_NAMES ((int)(sizeof state_names / sizeof state_names[0]))

/* the names of the states in `mask`, comma separated */
static void state_list(int mask, char *buf, size_t size) {
    int i;
    size_t used = 0;
    buf[0] = '\0';
    for (i = 0; i < N_STATE_NAMES; i++) {
        int n;
        if (!(mask & (1 << i))) continue;
        n = snprintf(buf + used, size - used, "%s%s", used ? ", " : "", state_names[i]);
        if (n < 0 || (size_t)n >= size - used) return;
        used += (size_t)n;
    }
}

int lf_fmi2_allowed(fmi2Component c, const char *fn, int mask) {
    LfInstance *inst = lf_fmi2_live(c);
    char now[64], allowed[160];
    if (!inst) return 0; /* NULL, freed or not an instance: nothing to log through */
    if (inst->state & mask) return 1;
    state_list((int)inst->state, now, sizeof now);
    state_list(mask, allowed, sizeof allowed);
    lf_log(inst, LF_ERROR, LF_LOG_ERROR,
           "t = %.17g: %s must not be called in state %s; allowed in: %s", inst->t, fn,
           now[0] ? now : "unknown", allowed);
    return 0;
}


fmi2Status lf_fmi2_null_arg(LfInstance *c, const char *fn, const char *arg) {
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: %s is NULL; nothing done", c->t, fn, arg);
    return fmi2Error;
}

/* ---- inquiry, logging, life cycle ------------------------------------ */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

static int category_index(const char *name) {
    int k;
    for (k = 0; name && k < LF_N_LOG; k++)
        if (strcmp(name, lf_log_category_names[k]) == 0) return k;
    return -1;
}

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
    if (!categories) return lf_fmi2_null_arg(inst, "fmi2SetDebugLogging", "categories (with n > 0)");
    if (n > LF_N_LOG * 16) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR, "fmi2SetDebugLogging: nCategories = %lu, expected "
               "at most %d (the FMU has %d categories)", (unsigned long)n, LF_N_LOG * 16,
               LF_N_LOG);
        return fmi2Error;
    }
    for (i = 0; i < n; i++) /* all known, or nothing changes */
        if (category_index(categories[i]) < 0) {
            lf_log(inst, LF_ERROR, LF_LOG_ERROR, "fmi2SetDebugLogging: unknown category %s",
                   categories[i] ? categories[i] : "(null)");
            return fmi2Error;
        }
    for (i = 0; i < n; i++) inst->log_on[category_index(categories[i])] = loggingOn;
    return fmi2OK;
}

static void instantiate_error(const fmi2CallbackFunctions *f, const char *name,
                              const char *message) {
    f->logger(f->componentEnvironment, name, fmi2Error, "logStatusError", message);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                              fmi2String fmuGUID, fmi2String resourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
    LfAllocator alloc;
    LfInstance *c;
    Fmi2Env *env;
    const char *name = instanceName ? instanceName : "";
    int k;
    (void)resourceLocation;
    (void)visible;
    if (!functions || !functions->logger || !functions->allocateMemory ||
        !functions->freeMemory)
        return NULL;
    if (!instanceName || !instanceName[0]) {
        instantiate_error(functions, name, "fmi2Instantiate: instanceName is NULL or empty "
                          "(FMI 2.0 requires a non-empty name)");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        instantiate_error(functions, name, "fmi2Instantiate: only fmi2CoSimulation is supported");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, lf_model.guid) != 0) {
        instantiate_error(functions, name, "fmi2Instantiate: the GUID does not match this "
                          "binary's");
        return NULL;
    }
    alloc.calloc = functions->allocateMemory;
    alloc.free = functions->freeMemory;
    /* the instance keeps its own copy of the callbacks */
    env = (Fmi2Env *)alloc.calloc(1, sizeof *env);
    if (env) env->cb = *functions;
    c = env ? lf_instantiate(name, fmi2_log_bridge, env, alloc) : NULL;
    if (!c || !live_add(c)) {
        if (c) lf_free(c);
        if (env) alloc.free(env);
        instantiate_error(functions, name, c ? "fmi2Instantiate: too many live instances "
                          "(1024) of this FMU" : "fmi2Instantiate: out of memory or solver "
                          "registry mismatch");
        return NULL;
    }
    c->log_on_start = loggingOn;
    for (k = 0; k < LF_N_LOG; k++) c->log_on[k] = loggingOn;
    return c;
}

void lf_fmi2_free_states(LfInstance *inst) {
    StateBlob *b = ENV(inst)->states;
    while (b) {
        StateBlob *next = b->next;
        inst->alloc.free(b);
        b = next;
    }
    ENV(inst)->states = NULL;
}

/* Frees the instance and every FMU state it made (FMI 2.0, 2.1.5).  A
 * pointer that is not a live instance (NULL, freed already) is ignored. */
void fmi2FreeInstance(fmi2Component c) {
    LfInstance *inst = lf_fmi2_live(c);
    void (*release)(void *);
    Fmi2Env *env;
    if (!inst || !live_remove(inst)) return;
    release = inst->alloc.free;
    env = ENV(inst);
    lf_fmi2_free_states(inst);
    lf_free(inst);
    release(env);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    LfInstance *inst = (LfInstance *)c;
    fmi2Status status = fmi2OK;
    CHECK("fmi2SetupExperiment", LF_ST_INSTANTIATED);
    if (!isfinite(startTime) || (stopTimeDefined && !(isfinite(stopTime) &&
                                                      stopTime >= startTime))) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR,
               "fmi2SetupExperiment: startTime = %g, stopTime = %g (expected finite, start <= "
               "stop); nothing set", startTime, stopTimeDefined ? stopTime : INFINITY);
        return fmi2Error;
    }
    inst->t_start = inst->t = inst->last_successful_time = startTime;
    {   /* input derivatives set before refer to the start */
        int k;
        for (k = 0; k < LF_NU; k++) inst->u_t0[k] = startTime;
        inst->seen_t = startTime;
    }
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

/* The importer's tolerance wins over a solver_rtol the importer set: say so
 * when it takes effect, with both values. */
static int log_rtol_override(LfInstance *inst) {
    const char *name = lf_model.real_names[LF_SET_RTOL];
    if (!(inst->rtol_importer > 0) || !ENV(inst)->rtol_set ||
        inst->r[LF_SET_RTOL] == inst->rtol_importer)
        return 0;
    lf_log(inst, LF_WARNING, LF_LOG_WARNING,
           "t = %.17g: %s = %g is overridden by the importer's tolerance = %g of "
           "fmi2SetupExperiment; the solvers use %g", inst->t_start, name,
           inst->r[LF_SET_RTOL], inst->rtol_importer, inst->rtol_importer);
    return 1;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    LfInstance *inst = (LfInstance *)c;
    int warned;
    CHECK("fmi2ExitInitializationMode", LF_ST_INIT);
    warned = log_rtol_override(inst);
    if (lf_initialize(inst) != LF_OK) {
        inst->state = LF_ST_ERROR;
        return fmi2Error;
    }
    inst->state = LF_ST_STEP_COMPLETE;
    return warned ? fmi2Warning : fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK("fmi2Terminate", RUNNING);
    ((LfInstance *)c)->state = LF_ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    CHECK("fmi2Reset", ANY_STATE);
    lf_reset_values((LfInstance *)c);
    ENV((LfInstance *)c)->rtol_set = 0;
    return fmi2OK;
}

/* ---- values ------------------------------------------------------------ */

/* FMI 2.0, 4.2.4: values can be read from initialization mode on, and set
 * before initialization, in it and after a completed step */
#define GET_STATES (LF_ST_INIT | RUNNING | LF_ST_TERMINATED | LF_ST_ERROR)
#define SET_STATES (LF_ST_INSTANTIATED | LF_ST_INIT | LF_ST_STEP_COMPLETE)
#define N_INTEGER LF_N_INTEGER
/* Longest value-reference array accepted: FMI 2.0 allows a reference more
 * than once, but a request this long cannot be a real one and is refused
 * before either array is read.  (Arrays shorter than nvr below this limit
 * cannot be detected in C.) */
#define NVR_LIMIT(n_vars) (16 * (size_t)(n_vars) + 16)

/* The arrays of a get/set call: present if nvr > 0, nvr plausible, every
 * value reference of the type (checked before any value is read or written). */
int lf_fmi2_check_vrs(LfInstance *c, const char *fn, const fmi2ValueReference vr[], size_t nvr,
                     const void *value, unsigned n_vars) {
    size_t i;
    if (nvr == 0) return 1;
    if (!vr || !value) {
        lf_fmi2_null_arg(c, fn, !vr ? "vr (with nvr > 0)" : "value (with nvr > 0)");
        return 0;
    }
    if (nvr > NVR_LIMIT(n_vars)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: nvr = %lu, expected at most %lu (the "
               "FMU has %u variables of this type); no value read or written", c->t, fn,
               (unsigned long)nvr, (unsigned long)NVR_LIMIT(n_vars), n_vars);
        return 0;
    }
    if (n_vars == 0) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: vr[0] = %u, but the FMU has no "
               "variable of this type; no value read or written", c->t, fn, (unsigned)vr[0]);
        return 0;
    }
    for (i = 0; i < nvr; i++)
        if (vr[i] >= n_vars) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: vr[%lu] = %u is not a variable of "
                   "this type (expected < %u); no value read or written", c->t, fn,
                   (unsigned long)i, (unsigned)vr[i], n_vars);
            return 0;
        }
    return 1;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    size_t i;
    CHECK("fmi2GetReal", GET_STATES);
    if (!lf_fmi2_check_vrs((LfInstance *)c, "fmi2GetReal", vr, nvr, value, LF_NREAL)) return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (lf_get_real((LfInstance *)c, vr[i], &value[i]) != LF_OK) return fmi2Error;
    return fmi2OK;
}

/* What fmi2SetReal/fmi2SetInteger can change, to undo a call that fails
 * part way: a refused call changes nothing. */
typedef struct {
    double r[LF_NREAL];
    double u_d1[LF_DIM(LF_NU)], u_d2[LF_DIM(LF_NU)], u_t0[LF_DIM(LF_NU)];
    int x_set[LF_DIM(LF_NX)];
    int inputs_changed, outputs_valid, solver_id, delay_interp, u_poly, solver_index;
} SetUndo;

static void undo_save(const LfInstance *c, SetUndo *u) {
    memcpy(u->r, c->r, sizeof u->r);
    memcpy(u->u_d1, c->u_d1, sizeof u->u_d1);
    memcpy(u->u_d2, c->u_d2, sizeof u->u_d2);
    memcpy(u->u_t0, c->u_t0, sizeof u->u_t0);
    u->u_poly = c->u_poly;
    memcpy(u->x_set, c->x_set, sizeof u->x_set);
    u->inputs_changed = c->inputs_changed;
    u->outputs_valid = c->outputs_valid;
    u->solver_id = c->solver_id;
    u->solver_index = c->solver_index;
    u->delay_interp = c->delay_interp;
}

static fmi2Status undo(LfInstance *c, const SetUndo *u) {
    memcpy(c->r, u->r, sizeof u->r);
    memcpy(c->u_d1, u->u_d1, sizeof u->u_d1);
    memcpy(c->u_d2, u->u_d2, sizeof u->u_d2);
    memcpy(c->u_t0, u->u_t0, sizeof u->u_t0);
    c->u_poly = u->u_poly;
    memcpy(c->x_set, u->x_set, sizeof u->x_set);
    c->inputs_changed = u->inputs_changed;
    c->outputs_valid = u->outputs_valid;
    c->solver_id = u->solver_id;
    c->solver_index = u->solver_index;
    c->delay_interp = u->delay_interp;
    return fmi2Error;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    LfInstance *inst = (LfInstance *)c;
    SetUndo u;
    size_t i;
    int rtol_set = 0;
    fmi2Status worst = fmi2OK;
    CHECK("fmi2SetReal", SET_STATES);
    if (!lf_fmi2_check_vrs(inst, "fmi2SetReal", vr, nvr, value, LF_NREAL)) return fmi2Error;
    undo_save(inst, &u);
    for (i = 0; i < nvr; i++) {
        LfStatus st = lf_set_real(inst, vr[i], value[i]);
        if (st > LF_WARNING) return undo(inst, &u);
        if (st == LF_WARNING) worst = fmi2Warning;
        if (vr[i] == LF_SET_RTOL) rtol_set = 1;
    }
    if (rtol_set) ENV(inst)->rtol_set = 1;
    return worst;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    size_t i;
    CHECK("fmi2GetInteger", GET_STATES);
    if (!lf_fmi2_check_vrs((LfInstance *)c, "fmi2GetInteger", vr, nvr, value, N_INTEGER))
        return fmi2Error;
    for (i = 0; i < nvr; i++) {
        int v;
        if (lf_get_integer((LfInstance *)c, vr[i], &v) != LF_OK) return fmi2Error;
        value[i] = v;
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    LfInstance *inst = (LfInstance *)c;
    SetUndo u;
    size_t i;
    CHECK("fmi2SetInteger", SET_STATES);
    if (!lf_fmi2_check_vrs(inst, "fmi2SetInteger", vr, nvr, value, N_INTEGER)) return fmi2Error;
    undo_save(inst, &u);
    for (i = 0; i < nvr; i++)
        if (lf_set_integer(inst, vr[i], value[i]) != LF_OK) return undo(inst, &u);
    return fmi2OK;
}

/* Boolean and String: this FMU has none, so any reference is refused */
static fmi2Status none_of_type(fmi2Component c, const char *fn, const fmi2ValueReference vr[],
                               size_t nvr, const void *value) {
    return lf_fmi2_check_vrs((LfInstance *)c, fn, vr, nvr, value, 0) ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    CHECK("fmi2GetBoolean", GET_STATES);
    return none_of_type(c, "fmi2GetBoolean", vr, nvr, value);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    CHECK("fmi2SetBoolean", SET_STATES);
    return none_of_type(c, "fmi2SetBoolean", vr, nvr, value);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    CHECK("fmi2GetString", GET_STATES);
    return none_of_type(c, "fmi2GetString", vr, nvr, value);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    CHECK("fmi2SetString", SET_STATES);
    return none_of_type(c, "fmi2SetString", vr, nvr, value);
}

/* ---- not provided (declared absent in the model description) ---------- */

static fmi2Status unsupported(fmi2Component c, const char *fn) {
    if (lf_fmi2_live(c)) lf_log((LfInstance *)c, LF_ERROR, LF_LOG_ERROR,
                        "%s is not supported by this FMU (see modelDescription.xml)", fn);
    return fmi2Error;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[],
                                        size_t nu, const fmi2ValueReference z[], size_t nz,
                                        const fmi2Real dv[], fmi2Real dz[]) {
    (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz;
    return unsupported(c, "fmi2GetDirectionalDerivative");
}

/* ---- co-simulation ------------------------------------------------------ */

/* A step the runtime can integrate: finite time and step, h > 0, starting at
 * the FMU's time, and an end that is a later time than the FMU's (t + h == t
 * below the resolution of time at t).  Otherwise refused, with nothing
 * changed. */
static int step_integrable(LfInstance *c, double t, double h) {
    const char *why = NULL;
    char buf[200];
    if (!isfinite(t)) why = "currentCommunicationPoint is not finite";
    else if (!isfinite(h) || !(h > 0)) why = "communicationStepSize is not finite and > 0";
    else if (!isfinite(t + h)) why = "the end of the step is not finite";
    else if (fabs(t - c->t) > 1e-9 * fmax(1.0, fabs(c->t))) { /* as lf_check_step */
        snprintf(buf, sizeof buf, "expected currentCommunicationPoint = t = %.17g (the end of "
                 "the last step, or the time of the FMU state set), got %.17g (%s the FMU's "
                 "time)", c->t, t, t < c->t ? "behind" : "ahead of");
        why = buf;
    } else if (!(t + h > c->t)) {
        snprintf(buf, sizeof buf, "the step does not advance time (below the resolution of "
                 "time here: %g s)", nextafter(c->t, INFINITY) - c->t);
        why = buf;
    }
    if (!why) return 1;
    lf_log(c, LF_ERROR, LF_LOG_ERROR,
           "t = %.17g: fmi2DoStep(currentCommunicationPoint = %.17g, communicationStepSize = "
           "%g): %s; step refused, nothing changed", c->t, t, h, why);
    return 0;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    LfInstance *inst = (LfInstance *)c;
    LfStatus st;
    (void)noSetPrior;
    CHECK("fmi2DoStep", LF_ST_STEP_COMPLETE);
    /* an invalid call (bad step, past stopTime) is refused and changes nothing */
    if (!step_integrable(inst, t, h) || lf_check_step(inst, t, h) != LF_OK) return fmi2Error;
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

#define STATUS_CHECK(fn)                                                             \
    do {                                                                             \
        CHECK(fn, RUNNING | LF_ST_TERMINATED);                                       \
        if (!value) return lf_fmi2_null_arg((LfInstance *)c, fn, "value");                   \
    } while (0)

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    STATUS_CHECK("fmi2GetStatus");
    if (s != fmi2DoStepStatus) return status_kind_unknown(c, "fmi2GetStatus", s);
    *value = ((LfInstance *)c)->state == LF_ST_STEP_FAILED ? fmi2Discard : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    STATUS_CHECK("fmi2GetRealStatus");
    if (s != fmi2LastSuccessfulTime) return status_kind_unknown(c, "fmi2GetRealStatus", s);
    *value = ((LfInstance *)c)->last_successful_time;
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
    *value = ((LfInstance *)c)->wants_terminate ? fmi2True : fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    STATUS_CHECK("fmi2GetStringStatus");
    return status_kind_unknown(c, "fmi2GetStringStatus", s);
}
