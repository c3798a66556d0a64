/* loomfmu shared runtime: FMI 2.0 interface: inquiry, logging, life cycle
 * and the state machine (co-simulation: lf_fmi2_cs.c, model exchange:
 * lf_fmi2_me.c, values: lf_fmi2_values.c, FMU states: lf_fmi2_state.c,
 * derivatives: lf_fmi2_deriv.c).
 *
 * Every function checks the instance pointer and the call order against a
 * mask of allowed states, and logs expected vs actual on failure.  Features
 * the model description declares as absent return fmi2Error with a log
 * line; so does fmi2Instantiate of an interface the FMU does not declare
 * (LF_HAS_CS, LF_HAS_ME of lf_build.h).
 *
 * Misuse is refused, never a crash: NULL arrays, sizes no array of this FMU
 * can have, non-finite or backward time, FMU states not made by this
 * instance.  An instance is known by the registry of live instances
 * (lf_facade.c), so that a call with a freed instance (fmi2FreeInstance
 * twice, fmi2DoStep after fmi2FreeInstance) returns fmi2Error (nothing to
 * log through) without touching the freed memory.  Limit: if the allocator
 * has given the freed address to a new instance of this FMU, the call goes
 * to that instance. */
#include <ctype.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "lf_fmi2.h"

LfInstance *lf_fmi2_live(fmi2Component c) { return lf_live(c); }

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

/* FMI 2.0's names of the interface states, in the order of LfState's bits, then
 * model exchange's M2_EVENT, M2_CONT */
static const char *const state_names[] = {"Instantiated", "InitializationMode",
                                          "StepComplete", "StepFailed", "Terminated",
                                          "Error", "EventMode", "ContinuousTimeMode"};
#define N_STATE_NAMES ((int)(sizeof state_names / sizeof state_names[0]))

int lf_fmi2_state_bits(const LfInstance *inst) {
    if (ENV(inst)->me && inst->run.state == LF_ST_STEP_COMPLETE)
        return ENV(inst)->me_cont ? M2_CONT : M2_EVENT;
    return (int)inst->run.state;
}

int lf_fmi2_allowed(fmi2Component c, const char *fn, int mask) {
    LfInstance *inst = lf_fmi2_live(c);
    if (!inst) return 0; /* NULL, freed or not an instance: nothing to log through */
    return lf_check_state(inst, fn, lf_fmi2_state_bits(inst), mask, state_names,
                          N_STATE_NAMES);
}


fmi2Status lf_fmi2_null_arg(LfInstance *c, const char *fn, const char *arg) {
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: %s is NULL; nothing done", c->run.t, fn, arg);
    return fmi2Error;
}

/* ---- inquiry, logging, life cycle ------------------------------------ */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n,
                               const fmi2String categories[]) {
    CHECK("fmi2SetDebugLogging", ANY_STATE);
    return (fmi2Status)lf_set_debug_logging((LfInstance *)c, "fmi2SetDebugLogging", loggingOn,
                                            n, categories);
}

/* a character other than white space (FMI 2.0, 2.1.5: a non-empty name) */
static int has_visible_char(const char *s) {
    for (; *s; s++)
        if (!isspace((unsigned char)*s)) return 1;
    return 0;
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
    if (!instanceName || !has_visible_char(instanceName)) {
        instantiate_error(functions, name, "fmi2Instantiate: instanceName is NULL, empty or "
                          "white space only (FMI 2.0 requires a non-empty name)");
        return NULL;
    }
    if (!((fmuType == fmi2CoSimulation && LF_HAS_CS) ||
          (fmuType == fmi2ModelExchange && LF_HAS_ME))) {
        instantiate_error(functions, name, LF_HAS_ME ? (LF_HAS_CS ? "fmi2Instantiate: fmuType "
                          "must be fmi2ModelExchange or fmi2CoSimulation" : "fmi2Instantiate: "
                          "this FMU declares model exchange only (fmuType fmi2ModelExchange)")
                          : "fmi2Instantiate: this FMU declares co-simulation only (fmuType "
                          "fmi2CoSimulation)");
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
    if (env) {
        env->cb = *functions;
        env->me = fmuType == fmi2ModelExchange;
    }
    c = env ? lf_instantiate(name, fmi2_log_bridge, env, alloc) : NULL;
    if (!c || !lf_live_add(c)) {
        if (c) lf_free(c);
        if (env) alloc.free(env);
        instantiate_error(functions, name, c ? "fmi2Instantiate: too many live instances "
                          "(1024) of this FMU" : "fmi2Instantiate: out of memory or solver "
                          "registry mismatch");
        return NULL;
    }
    c->unsaved.log_on_start = loggingOn;
    for (k = 0; k < LF_N_LOG; k++) c->unsaved.log_on[k] = loggingOn;
    return c;
}

void lf_fmi2_free_states(LfInstance *inst) { lf_blobs_free(inst, &ENV(inst)->states); }

/* Frees the instance and every FMU state it made (FMI 2.0, 2.1.5).  A
 * pointer that is not a live instance (NULL, freed already) is ignored. */
void fmi2FreeInstance(fmi2Component c) {
    LfInstance *inst = lf_fmi2_live(c);
    void (*release)(void *);
    Fmi2Env *env;
    if (!inst || !lf_live_remove(inst)) return;
    release = inst->unsaved.alloc.free;
    env = ENV(inst);
    lf_fmi2_free_states(inst);
    lf_free(inst);
    release(env);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    CHECK("fmi2SetupExperiment", LF_ST_INSTANTIATED);
    return (fmi2Status)lf_setup_experiment((LfInstance *)c, "fmi2SetupExperiment",
                                           toleranceDefined, tolerance, startTime,
                                           stopTimeDefined, stopTime);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    CHECK("fmi2EnterInitializationMode", LF_ST_INSTANTIATED);
    ((LfInstance *)c)->run.state = LF_ST_INIT;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    LfInstance *inst = (LfInstance *)c;
    int warned;
    CHECK("fmi2ExitInitializationMode", LF_ST_INIT);
    warned = lf_log_rtol_override(inst, ENV(inst)->rtol_set, "fmi2SetupExperiment");
    if ((ENV(inst)->me ? lf_me_initialize(inst) : lf_initialize(inst)) != LF_OK) {
        inst->run.state = LF_ST_ERROR;
        return fmi2Error;
    }
    /* model exchange: to event mode (FMI 2.0, 3.2.3) */
    inst->run.state = LF_ST_STEP_COMPLETE;
    ENV(inst)->me_cont = 0;
    return warned ? fmi2Warning : fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK("fmi2Terminate", RUNNING | ME_RUNNING);
    ((LfInstance *)c)->run.state = LF_ST_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    CHECK("fmi2Reset", ANY_STATE);
    lf_reset_values((LfInstance *)c);
    ENV((LfInstance *)c)->rtol_set = 0;
    ENV((LfInstance *)c)->me_cont = 0;
    return fmi2OK;
}

/* ---- not provided (declared absent in the model description) ---------- */

fmi2Status lf_fmi2_unsupported(fmi2Component c, const char *fn) {
    if (lf_fmi2_live(c)) lf_log((LfInstance *)c, LF_ERROR, LF_LOG_ERROR,
                        "%s is not supported by this FMU (see modelDescription.xml)", fn);
    return fmi2Error;
}
