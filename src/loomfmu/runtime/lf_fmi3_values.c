/* loomfmu shared runtime: FMI 3.0 getters and setters.
 *
 * Float64: every Real of the runtime (settings, parameters, states, inputs,
 * outputs, locals), the state derivatives der(x_k) and time (read only).  Int32:
 * the modes and solver_index; Int64: the Enumerations `solver` and
 * `delay_interpolation` (FMI 3.0 reads and writes Enumerations as Int64).
 * Every variable is a scalar, so nValues must equal nValueReferences.  Any
 * other type: fmi3Error, logged ("no variables of type ...").  A refused set
 * call changes nothing (the runtime's undo, lf_facade.h). */
#include <math.h>
#include <stddef.h>
#include <stdio.h>

#include "lf_facade_ops.h"
#include "lf_fmi3.h"

/* FMI 3.0: values are read from initialization mode on; inputs are set in
 * event, step and continuous-time mode, the others before initialization ends
 * (the runtime refuses those later, by kind) */
#define GET_STATES (F3_INIT | F3_RUNNING | F3_TERMINATED | F3_ERROR)
#define SET_STATES (F3_INSTANTIATED | F3_INIT | F3_EVENT | F3_STEP | F3_CONT)
/* Longest value-reference array accepted (a reference may come more than
 * once, but not this often): refused before either array is read. */
#define NVR_LIMIT(n_vars) (16 * (size_t)(n_vars) + 16)

int lf_fmi3_check_vrs(LfInstance *c, const char *fn, const fmi3ValueReference vr[],
                      size_t nvr, const void *value, size_t n_values, unsigned vr0,
                      unsigned n_vars) {
    size_t i;
    if (n_values != nvr) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: nValues = %lu, expected "
               "nValueReferences = %lu (every variable of this FMU is a scalar); no value "
               "read or written", c->run.t, fn, (unsigned long)n_values, (unsigned long)nvr);
        return 0;
    }
    if (nvr == 0) return 1;
    if (!vr || !value) {
        lf_fmi3_null_arg(c, fn, !vr ? "valueReferences (with nValueReferences > 0)"
                                    : "values (with nValueReferences > 0)");
        return 0;
    }
    if (nvr > NVR_LIMIT(n_vars)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: nValueReferences = %lu, expected at "
               "most %lu (the FMU has %u variables of this type); no value read or written",
               c->run.t, fn, (unsigned long)nvr, (unsigned long)NVR_LIMIT(n_vars), n_vars);
        return 0;
    }
    for (i = 0; i < nvr; i++)
        if (vr[i] < vr0 || vr[i] - vr0 >= n_vars) {
            if (n_vars == 0)
                lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: valueReferences[%lu] = %u, "
                       "but the FMU has no variables of this type; no value read or written",
                       c->run.t, fn, (unsigned long)i, (unsigned)vr[i]);
            else
                lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: valueReferences[%lu] = %u is "
                       "not a variable of this type (expected %u ... %u); no value read or "
                       "written", c->run.t, fn, (unsigned long)i, (unsigned)vr[i], vr0,
                       vr0 + n_vars - 1);
            return 0;
        }
    return 1;
}

/* ---- Float64 ------------------------------------------------------------- */

/* A Float64 value reference: a Real, a state derivative, time or an event
 * indicator (the Integers' references lie between the derivatives and
 * time). */
static int float64_vrs(LfInstance *c, const char *fn, const fmi3ValueReference vr[],
                       size_t nvr, const void *values, size_t n_values) {
    size_t i;
    if (!lf_fmi3_check_vrs(c, fn, vr, nvr, values, n_values, 0, F3_VR_EVT0 + LF_NE)) return 0;
    for (i = 0; i < nvr; i++)
        if (vr[i] >= F3_VR_INT0 && vr[i] < F3_VR_TIME) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: valueReferences[%lu] = %u is not "
                   "a Float64 (Float64: 0 ... %u, and %u ... %u: time and the event indicators); "
                   "no value read or written", c->run.t, fn, (unsigned long)i, (unsigned)vr[i],
                   F3_VR_INT0 - 1, F3_VR_TIME, F3_VR_EVT0 + LF_NE - 1);
            return 0;
        }
    return 1;
}

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                          fmi3Float64 values[], size_t nValues) {
    LfInstance *inst = (LfInstance *)c;
    size_t i;
    int have_der = 0, have_evt = 0;
    double der[LF_DIM(LF_NX)], evt[LF_DIM(LF_NE)];
    LfStatus st;
    CHECK3("fmi3GetFloat64", GET_STATES);
    if (!float64_vrs(inst, "fmi3GetFloat64", vr, nvr, values, nValues)) return fmi3Error;
    /* model exchange: outputs, locals and der(x) are computed at the
     * importer's (t, x), whose delayed values must be in the history */
    for (i = 0; i < nvr; i++)
        if (vr[i] >= LF_VR_Y0 && vr[i] < F3_VR_INT0) {
            st = lf_fmi3_me_delays_known(inst, "fmi3GetFloat64");
            if (st != LF_OK) return st == LF_DISCARD ? fmi3Discard : fmi3Error;
            break;
        }
    for (i = 0; i < nvr; i++) {
        if (vr[i] < LF_NREAL) {
            if (lf_get_real(inst, vr[i], &values[i]) != LF_OK) return fmi3Error;
        } else if (vr[i] == F3_VR_TIME) {
            values[i] = inst->run.t;
        } else if (vr[i] >= F3_VR_EVT0) {
            if (!have_evt) { /* the indicators at the instance's time and states */
                if (lf_me_event_indicators(inst, "fmi3GetFloat64", evt, LF_NE) != LF_OK)
                    return fmi3Error;
                have_evt = 1;
            }
            values[i] = evt[vr[i] - F3_VR_EVT0];
        } else {
            if (!have_der) { /* der(x) at the instance's time and states, once per call */
                if (lf_state_derivatives(inst, der) != LF_OK) return fmi3Error;
                have_der = 1;
            }
            values[i] = der[vr[i] - F3_VR_DER0];
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Float64 values[], size_t nValues) {
    LfInstance *inst = (LfInstance *)c;
    size_t i;
    LfStatus st;
    CHECK3("fmi3SetFloat64", SET_STATES);
    if (!float64_vrs(inst, "fmi3SetFloat64", vr, nvr, values, nValues)) return fmi3Error;
    for (i = 0; i < nvr; i++)
        if (vr[i] >= LF_NREAL) {
            lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi3SetFloat64: "
                   "valueReferences[%lu] = %u is %s (cannot be set); no value written",
                   inst->run.t, (unsigned long)i, (unsigned)vr[i],
                   vr[i] == F3_VR_TIME ? "time, the independent variable"
                   : vr[i] >= F3_VR_EVT0 ? "an event indicator" : "a state derivative");
            return fmi3Error;
        }
    st = lf_set_reals(inst, vr, nvr, values, &ENV3(inst)->rtol_set);
    return st == LF_OK ? fmi3OK : st == LF_WARNING ? fmi3Warning : fmi3Error;
}

/* ---- Int32 (modes, solver_index) and Int64 (Enumerations) ----------------- */

static int is_enumeration(unsigned ivr) {
    return ivr == LF_VR_SOLVER || (LF_ND > 0 && ivr == LF_VR_DINTERP);
}

/* Every reference of the call an Integer of the right kind (Enumeration or
 * not), else logged. */
static int integer_kind(LfInstance *c, const char *fn, const fmi3ValueReference vr[],
                        size_t nvr, int enumeration) {
    size_t i;
    for (i = 0; i < nvr; i++) {
        unsigned ivr = (unsigned)vr[i] - F3_VR_INT0;
        if (is_enumeration(ivr) != enumeration) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: valueReferences[%lu] = %u is %s; "
                   "use %s; no value read or written", c->run.t, fn, (unsigned long)i,
                   (unsigned)vr[i], enumeration ? "an Int32" : "an Enumeration",
                   enumeration ? "fmi3GetInt32/fmi3SetInt32" : "fmi3GetInt64/fmi3SetInt64");
            return 0;
        }
    }
    return 1;
}

static fmi3Status get_integers(LfInstance *c, const char *fn, const fmi3ValueReference vr[],
                               size_t nvr, void *values, size_t n_values, int enumeration) {
    size_t i;
    if (!lf_fmi3_check_vrs(c, fn, vr, nvr, values, n_values, F3_VR_INT0, LF_N_INTEGER) ||
        !integer_kind(c, fn, vr, nvr, enumeration))
        return fmi3Error;
    for (i = 0; i < nvr; i++) {
        int v;
        if (lf_get_integer(c, (unsigned)vr[i] - F3_VR_INT0, &v) != LF_OK) return fmi3Error;
        if (enumeration) ((fmi3Int64 *)values)[i] = v;
        else ((fmi3Int32 *)values)[i] = v;
    }
    return fmi3OK;
}

static fmi3Status set_integers(LfInstance *c, const char *fn, const fmi3ValueReference vr[],
                               size_t nvr, const void *values, size_t n_values,
                               int enumeration) {
    LfSetUndo u;
    size_t i;
    if (!lf_fmi3_check_vrs(c, fn, vr, nvr, values, n_values, F3_VR_INT0, LF_N_INTEGER) ||
        !integer_kind(c, fn, vr, nvr, enumeration))
        return fmi3Error;
    lf_undo_save(c, &u);
    for (i = 0; i < nvr; i++) {
        long long v = enumeration ? (long long)((const fmi3Int64 *)values)[i]
                                  : (long long)((const fmi3Int32 *)values)[i];
        unsigned ivr = (unsigned)vr[i] - F3_VR_INT0;
        if (ivr >= LF_VR_Q0 && ivr < LF_VR_Q0 + LF_NQ) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: valueReferences[%lu] = %u (%s) is "
                   "a mode, an output chosen by the model, and cannot be set; no value written",
                   c->run.t, fn, (unsigned long)i, (unsigned)vr[i],
                   lf_model.mode_names[ivr - LF_VR_Q0]);
            lf_undo_restore(c, &u);
            return fmi3Error;
        }
        if (v < -2147483647LL || v > 2147483647LL) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: values[%lu] = %lld for %u is "
                   "outside the range of the variable; no value written", c->run.t, fn,
                   (unsigned long)i, v, (unsigned)vr[i]);
            lf_undo_restore(c, &u);
            return fmi3Error;
        }
        if (lf_set_integer(c, ivr, (int)v) != LF_OK) {
            lf_undo_restore(c, &u);
            return fmi3Error;
        }
    }
    return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                        fmi3Int32 values[], size_t nValues) {
    CHECK3("fmi3GetInt32", GET_STATES);
    return get_integers((LfInstance *)c, "fmi3GetInt32", vr, nvr, values, nValues, 0);
}

fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                        const fmi3Int32 values[], size_t nValues) {
    CHECK3("fmi3SetInt32", SET_STATES);
    return set_integers((LfInstance *)c, "fmi3SetInt32", vr, nvr, values, nValues, 0);
}

fmi3Status fmi3GetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                        fmi3Int64 values[], size_t nValues) {
    CHECK3("fmi3GetInt64", GET_STATES);
    return get_integers((LfInstance *)c, "fmi3GetInt64", vr, nvr, values, nValues, 1);
}

fmi3Status fmi3SetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                        const fmi3Int64 values[], size_t nValues) {
    CHECK3("fmi3SetInt64", SET_STATES);
    return set_integers((LfInstance *)c, "fmi3SetInt64", vr, nvr, values, nValues, 1);
}

/* ---- types this FMU has no variables of ----------------------------------- */

static fmi3Status none_of_type(fmi3Instance c, const char *fn, const char *type,
                               size_t nvr) {
    LfInstance *inst = (LfInstance *)c;
    if (nvr == 0) return fmi3OK; /* nothing asked */
    lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: no variables of type %s in this FMU "
           "(nValueReferences = %lu); no value read or written", inst->run.t, fn, type,
           (unsigned long)nvr);
    return fmi3Error;
}

#define NONE_GET(Type, CType)                                                              \
    fmi3Status fmi3Get##Type(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,    \
                             CType values[], size_t nValues) {                             \
        (void)vr; (void)values; (void)nValues;                                             \
        CHECK3("fmi3Get" #Type, GET_STATES);                                               \
        return none_of_type(c, "fmi3Get" #Type, #Type, nvr);                               \
    }
#define NONE_SET(Type, CType)                                                              \
    fmi3Status fmi3Set##Type(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,    \
                             const CType values[], size_t nValues) {                       \
        (void)vr; (void)values; (void)nValues;                                             \
        CHECK3("fmi3Set" #Type, SET_STATES);                                               \
        return none_of_type(c, "fmi3Set" #Type, #Type, nvr);                               \
    }

NONE_GET(Float32, fmi3Float32)
NONE_SET(Float32, fmi3Float32)
NONE_GET(Int8, fmi3Int8)
NONE_SET(Int8, fmi3Int8)
NONE_GET(UInt8, fmi3UInt8)
NONE_SET(UInt8, fmi3UInt8)
NONE_GET(Int16, fmi3Int16)
NONE_SET(Int16, fmi3Int16)
NONE_GET(UInt16, fmi3UInt16)
NONE_SET(UInt16, fmi3UInt16)
NONE_GET(UInt32, fmi3UInt32)
NONE_SET(UInt32, fmi3UInt32)
NONE_GET(UInt64, fmi3UInt64)
NONE_SET(UInt64, fmi3UInt64)
NONE_GET(Boolean, fmi3Boolean)
NONE_SET(Boolean, fmi3Boolean)
NONE_GET(String, fmi3String)
NONE_SET(String, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    CHECK3("fmi3GetBinary", GET_STATES);
    return none_of_type(c, "fmi3GetBinary", "Binary", nvr);
}

fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[],
                         size_t nValues) {
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    CHECK3("fmi3SetBinary", SET_STATES);
    return none_of_type(c, "fmi3SetBinary", "Binary", nvr);
}
