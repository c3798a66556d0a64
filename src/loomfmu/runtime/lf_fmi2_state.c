/* loomfmu shared runtime: FMI 2.0 FMU states (get, set, free, serialize).
 *
 * An FMU state is a blob of lf_state_write's bytes (checksummed, checked
 * field by field by lf_state_read) in the instance's list, so that
 * fmi2FreeInstance frees every state the importer did not, and a pointer
 * this instance did not make is refused without being dereferenced. */
#include <stddef.h>
#include <string.h>

#include "lf_fmi2_internal.h"
#include "lf_state.h"

/* ---- FMU state (lf_state.c): blobs in the instance's list --------------- */

#define STATE_STATES (LF_ST_INSTANTIATED | LF_ST_INIT | RUNNING | ME_RUNNING | LF_ST_TERMINATED)
/* FMI 2.0, 2.1.3: after fmi2Error a stored state may be set again */
#define RESTORE_STATES (STATE_STATES | LF_ST_ERROR)

static LfBlob *blob_alloc(LfInstance *c, size_t n) {
    return lf_blob_alloc(c, &ENV(c)->states, n);
}

/* Where the instance's list holds `s`, or NULL (logged) if it is not one of
 * its states: never dereferences a pointer it did not make. */
static LfBlob **find_state(LfInstance *c, const char *fn, fmi2FMUstate s) {
    return lf_blob_find(c, &ENV(c)->states, fn, s);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    LfInstance *inst = (LfInstance *)c;
    LfBlob **old = NULL, *b;
    size_t n;
    CHECK("fmi2GetFMUstate", STATE_STATES);
    if (!state) return lf_fmi2_null_arg(inst, "fmi2GetFMUstate", "FMUstate");
    if (*state && !(old = find_state(inst, "fmi2GetFMUstate", *state))) return fmi2Error;
    n = lf_state_size(inst);
    if (old && (*old)->n == n) {
        b = *old;
    } else {
        if (!(b = blob_alloc(inst, n))) return fmi2Error; /* *state left as it was */
        if (*state) lf_blob_free(inst, find_state(inst, "fmi2GetFMUstate", *state));
    }
    lf_state_write(inst, b->data);
    *state = b;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    LfInstance *inst = (LfInstance *)c;
    LfBlob **b;
    CHECK("fmi2SetFMUstate", RESTORE_STATES);
    if (!state) return lf_fmi2_null_arg(inst, "fmi2SetFMUstate", "FMUstate");
    if (!(b = find_state(inst, "fmi2SetFMUstate", state))) return fmi2Error;
    return lf_state_read(inst, (*b)->data, (*b)->n) == LF_OK ? fmi2OK : fmi2Error;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    LfInstance *inst = (LfInstance *)c;
    LfBlob **b;
    CHECK("fmi2FreeFMUstate", RESTORE_STATES);
    if (!state) return lf_fmi2_null_arg(inst, "fmi2FreeFMUstate", "FMUstate");
    if (!*state) return fmi2OK; /* FMI 2.0: a NULL state is ignored */
    if (!(b = find_state(inst, "fmi2FreeFMUstate", *state))) return fmi2Error;
    lf_blob_free(inst, b);
    *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *n) {
    LfInstance *inst = (LfInstance *)c;
    LfBlob **b;
    CHECK("fmi2SerializedFMUstateSize", RESTORE_STATES);
    if (!n) return lf_fmi2_null_arg(inst, "fmi2SerializedFMUstateSize", "size");
    if (!(b = find_state(inst, "fmi2SerializedFMUstateSize", state))) return fmi2Error;
    *n = (*b)->n;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[],
                                 size_t n) {
    LfInstance *inst = (LfInstance *)c;
    LfBlob **b;
    CHECK("fmi2SerializeFMUstate", RESTORE_STATES);
    if (!bytes) return lf_fmi2_null_arg(inst, "fmi2SerializeFMUstate", "serializedState");
    if (!(b = find_state(inst, "fmi2SerializeFMUstate", state))) return fmi2Error;
    if (n < (*b)->n) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR,
               "fmi2SerializeFMUstate: expected a buffer of %lu bytes but was %lu",
               (unsigned long)(*b)->n, (unsigned long)n);
        return fmi2Error;
    }
    memcpy(bytes, (*b)->data, (*b)->n);
    return fmi2OK;
}

/* The bytes are copied; they are checked (checksum, this FMU, every field,
 * the size against the fields) when the state is set.  A size larger than
 * any state of this FMU is refused here, before anything is allocated or
 * read (near SIZE_MAX the blob's size would wrap).  Short ones are copied
 * (harmless) and refused by fmi2SetFMUstate. */
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t n,
                                   fmi2FMUstate *state) {
    LfInstance *inst = (LfInstance *)c;
    LfBlob **old = NULL, *b;
    CHECK("fmi2DeSerializeFMUstate", RESTORE_STATES);
    if (!bytes) return lf_fmi2_null_arg(inst, "fmi2DeSerializeFMUstate", "serializedState");
    if (!state) return lf_fmi2_null_arg(inst, "fmi2DeSerializeFMUstate", "FMUstate");
    if (n > lf_state_max_size()) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: fmi2DeSerializeFMUstate: size = %lu bytes, expected %lu ... %lu "
               "(the sizes of this FMU's states; fmi2SerializedFMUstateSize gives a state's "
               "size); nothing done", inst->t, (unsigned long)n,
               (unsigned long)lf_state_min_size(), (unsigned long)lf_state_max_size());
        return fmi2Error;
    }
    if (*state && !(old = find_state(inst, "fmi2DeSerializeFMUstate", *state)))
        return fmi2Error;
    if (!(b = blob_alloc(inst, n))) return fmi2Error;
    memcpy(b->data, bytes, n);
    if (*state) lf_blob_free(inst, find_state(inst, "fmi2DeSerializeFMUstate", *state));
    *state = b;
    return fmi2OK;
}

