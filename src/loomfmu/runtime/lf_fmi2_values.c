/* loomfmu shared runtime: FMI 2.0 get and set by type (Real, Integer;
 * this FMU has no Boolean or String).  Reals by the runtime's value
 * references (lf_model.h), and der(x_k) (read only) at LF_NREAL + k. */
#include <stddef.h>

#include "lf_fmi2.h"

/* FMI 2.0, 4.2.4: values can be read from initialization mode on, and set
 * before initialization, in it and after a completed step */
#define GET_STATES (LF_ST_INIT | RUNNING | ME_RUNNING | LF_ST_TERMINATED | LF_ST_ERROR)
#define SET_STATES (LF_ST_INSTANTIATED | LF_ST_INIT | LF_ST_STEP_COMPLETE | ME_RUNNING)
#define N_INTEGER LF_N_INTEGER
/* Longest value-reference array accepted: FMI 2.0 allows a reference more
 * than once, but a request this long cannot be a real one and is refused
 * before either array is read.  (Arrays shorter than nvr below this limit
 * cannot be detected in C.) */
#define NVR_LIMIT(n_vars) LF_FMI2_NVR_LIMIT(n_vars)

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
               "FMU has %u variables of this type); no value read or written", c->run.t, fn,
               (unsigned long)nvr, (unsigned long)NVR_LIMIT(n_vars), n_vars);
        return 0;
    }
    if (n_vars == 0) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: vr[0] = %u, but the FMU has no "
               "variable of this type; no value read or written", c->run.t, fn, (unsigned)vr[0]);
        return 0;
    }
    for (i = 0; i < nvr; i++)
        if (vr[i] >= n_vars) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: vr[%lu] = %u is not a variable of "
                   "this type (expected < %u); no value read or written", c->run.t, fn,
                   (unsigned long)i, (unsigned)vr[i], n_vars);
            return 0;
        }
    return 1;
}

/* A refused set call changes nothing: the values before it come back. */
static fmi2Status undo(LfInstance *c, const LfSetUndo *u) {
    lf_undo_restore(c, u);
    return fmi2Error;
}

/* Reals, and der(x_k) at vr LF_NREAL + k: at the current time and states
 * (model exchange: those the importer set, whose delayed values must be
 * known from the history) */
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    LfInstance *inst = (LfInstance *)c;
    double der[LF_DIM(LF_NX)];
    int have_der = 0, checked = 0;
    size_t i;
    CHECK("fmi2GetReal", GET_STATES);
    /* the hot path (co-simulation, outputs up to date, solver started, every
     * reference a Real but an input, so the arrays pass lf_fmi2_check_vrs):
     * what lf_get_real gives, read directly once all are checked */
    if (!ENV(inst)->me && inst->run.outputs_valid && inst->run.solver_ready && vr && value &&
        nvr <= LF_FMI2_NVR_LIMIT(F2_N_REAL)) {
        for (i = 0; i < nvr; i++) {
            fmi2ValueReference v = vr[i];
            /* (the inputs are the value references [LF_VR_U0, LF_VR_Y0): lf_model.h) */
            if (v >= LF_NREAL || (v >= LF_VR_U0 && v < LF_VR_Y0)) break;
        }
        if (i == nvr) {
            for (i = 0; i < nvr; i++) value[i] = inst->val.r[vr[i]];
            return fmi2OK;
        }
    }
    if (!lf_fmi2_vrs_ok(vr, nvr, value, F2_N_REAL) &&
        !lf_fmi2_check_vrs(inst, "fmi2GetReal", vr, nvr, value, F2_N_REAL))
        return fmi2Error;
    i = 0;
    if (!ENV(inst)->me && inst->run.outputs_valid && inst->run.solver_ready) {
        /* as above, up to the first other reference, which goes on by the
         * loop below */
        for (; i < nvr; i++) {
            fmi2ValueReference v = vr[i];
            if (v >= LF_NREAL || (v >= LF_VR_U0 && v < LF_VR_Y0)) break;
            value[i] = inst->val.r[v];
        }
    }
    for (; i < nvr; i++) {
        LfStatus st;
        if (!checked && ENV(inst)->me && (vr[i] >= LF_VR_Y0) &&
            (inst->run.state & LF_ST_STEP_COMPLETE)) {
            checked = 1; /* computed at the importer's (t, x) */
            st = lf_me_delays_known(inst, "fmi2GetReal");
            if (st != LF_OK) return (fmi2Status)st;
        }
        if (vr[i] < LF_NREAL) {
            if (lf_get_real(inst, vr[i], &value[i]) != LF_OK) return fmi2Error;
            continue;
        }
        if (!have_der) { /* der(x) once per call */
            if (lf_state_derivatives(inst, der) != LF_OK) return fmi2Error;
            have_der = 1;
        }
        value[i] = der[vr[i] - LF_NREAL];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    LfInstance *inst = (LfInstance *)c;
    size_t i;
    CHECK("fmi2SetReal", SET_STATES);
    if (!lf_fmi2_vrs_ok(vr, nvr, value, F2_N_REAL) &&
        !lf_fmi2_check_vrs(inst, "fmi2SetReal", vr, nvr, value, F2_N_REAL))
        return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (vr[i] >= LF_NREAL) {
            lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi2SetReal: vr[%lu] = %u is "
                   "der(%s), which is calculated and cannot be set; no value written",
                   inst->run.t, (unsigned long)i, (unsigned)vr[i],
                   lf_model.real_names[LF_VR_X0 + vr[i] - LF_NREAL]);
            return fmi2Error;
        }
    return (fmi2Status)lf_set_reals(inst, vr, nvr, value, &ENV(inst)->rtol_set);
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
    LfSetUndo u;
    size_t i;
    CHECK("fmi2SetInteger", SET_STATES);
    if (!lf_fmi2_check_vrs(inst, "fmi2SetInteger", vr, nvr, value, N_INTEGER)) return fmi2Error;
    lf_undo_save(inst, &u);
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

