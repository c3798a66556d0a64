/* loomfmu shared runtime: FMI 3.0 FMU states (get, set, free, serialize).
 *
 * An FMU state is a blob of lf_state_write's bytes (the runtime's format,
 * checksummed and checked field by field by lf_state_read) in the
 * instance's list (lf_facade.h), so that fmi3FreeInstance frees every state
 * the importer did not, and a pointer this instance did not make is refused
 * without being dereferenced.  The facade's mode (event, step or
 * continuous-time mode) is not part of a state: fmi3SetFMUState restores
 * the model's values and the solver, and the instance stays in its mode. */
#include <stddef.h>
#include <string.h>

#include "lf_fmi3_internal.h"
#include "lf_state.h"

/* FMI 3.0: states are got and set in every state but error, where a state
 * may be set again */
#define STATE_STATES (F3_INSTANTIATED | F3_INIT | F3_RUNNING | F3_TERMINATED)
#define RESTORE_STATES (STATE_STATES | F3_ERROR)

void lf_fmi3_free_states(LfInstance *inst) { lf_blobs_free(inst, &ENV3(inst)->states); }

static LfBlob **find(LfInstance *c, const char *fn, fmi3FMUState s) {
    return lf_blob_find(c, &ENV3(c)->states, fn, s);
}

fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *state) {
    LfInstance *inst = (LfInstance *)c;
    const char *fn = "fmi3GetFMUState";
    LfBlob **old = NULL, *b;
    size_t n;
    CHECK3(fn, STATE_STATES);
    if (!state) return lf_fmi3_null_arg(inst, fn, "FMUState");
    if (*state && !(old = find(inst, fn, *state))) return fmi3Error;
    n = lf_state_size(inst);
    if (old && (*old)->n == n) {
        b = *old;
    } else {
        if (!(b = lf_blob_alloc(inst, &ENV3(inst)->states, n))) return fmi3Error;
        if (*state) lf_blob_free(inst, find(inst, fn, *state));
    }
    lf_state_write(inst, b->data);
    *state = b;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState state) {
    LfInstance *inst = (LfInstance *)c;
    const char *fn = "fmi3SetFMUState";
    Fmi3Env *e;
    LfBlob **b;
    int in_event, in_cont;
    CHECK3(fn, RESTORE_STATES);
    if (!state) return lf_fmi3_null_arg(inst, fn, "FMUState");
    if (!(b = find(inst, fn, state))) return fmi3Error;
    e = ENV3(inst);
    in_event = e->in_event_mode;
    in_cont = e->in_cont_mode;
    if (lf_state_read(inst, (*b)->data, (*b)->n) != LF_OK) return fmi3Error;
    /* the mode stays where it was if the state is of a running instance */
    if (inst->state != LF_ST_STEP_COMPLETE) in_event = in_cont = 0;
    e->in_event_mode = in_event;
    e->in_cont_mode = in_cont;
    e->events_seen = inst->n_events;
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *state) {
    LfInstance *inst = (LfInstance *)c;
    LfBlob **b;
    CHECK3("fmi3FreeFMUState", RESTORE_STATES);
    if (!state) return lf_fmi3_null_arg(inst, "fmi3FreeFMUState", "FMUState");
    if (!*state) return fmi3OK; /* FMI 3.0: a NULL state is ignored */
    if (!(b = find(inst, "fmi3FreeFMUState", *state))) return fmi3Error;
    lf_blob_free(inst, b);
    *state = NULL;
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState state, size_t *size) {
    LfInstance *inst = (LfInstance *)c;
    LfBlob **b;
    CHECK3("fmi3SerializedFMUStateSize", RESTORE_STATES);
    if (!size) return lf_fmi3_null_arg(inst, "fmi3SerializedFMUStateSize", "size");
    if (!(b = find(inst, "fmi3SerializedFMUStateSize", state))) return fmi3Error;
    *size = (*b)->n;
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState state, fmi3Byte bytes[],
                                 size_t size) {
    LfInstance *inst = (LfInstance *)c;
    LfBlob **b;
    CHECK3("fmi3SerializeFMUState", RESTORE_STATES);
    if (!bytes) return lf_fmi3_null_arg(inst, "fmi3SerializeFMUState", "serializedState");
    if (!(b = find(inst, "fmi3SerializeFMUState", state))) return fmi3Error;
    if (size < (*b)->n) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi3SerializeFMUState: expected a "
               "buffer of %lu bytes but was %lu", inst->t, (unsigned long)(*b)->n,
               (unsigned long)size);
        return fmi3Error;
    }
    memcpy(bytes, (*b)->data, (*b)->n);
    return fmi3OK;
}

/* The bytes are copied; they are checked (checksum, this FMU, every field)
 * when the state is set.  A size larger than any state of this FMU is
 * refused here, before anything is allocated or read. */
fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte bytes[], size_t size,
                                   fmi3FMUState *state) {
    LfInstance *inst = (LfInstance *)c;
    const char *fn = "fmi3DeserializeFMUState";
    LfBlob **old = NULL, *b;
    CHECK3(fn, RESTORE_STATES);
    if (!bytes) return lf_fmi3_null_arg(inst, fn, "serializedState");
    if (!state) return lf_fmi3_null_arg(inst, fn, "FMUState");
    if (size > lf_state_max_size()) {
        lf_log(inst, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: size = %lu bytes, expected %lu ... "
               "%lu (the sizes of this FMU's states; fmi3SerializedFMUStateSize gives a "
               "state's size); nothing done", inst->t, fn, (unsigned long)size,
               (unsigned long)lf_state_min_size(), (unsigned long)lf_state_max_size());
        return fmi3Error;
    }
    if (*state && !(old = find(inst, fn, *state))) return fmi3Error;
    if (!(b = lf_blob_alloc(inst, &ENV3(inst)->states, size))) return fmi3Error;
    memcpy(b->data, bytes, size);
    if (*state) lf_blob_free(inst, find(inst, fn, *state));
    *state = b;
    return fmi3OK;
}
