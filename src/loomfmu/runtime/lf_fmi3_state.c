/* loomfmu shared runtime: FMI 3.0 FMU states (get, set, free, serialize),
 * on the version-independent operations of lf_facade_ops.h (blobs of the
 * runtime's state format in the instance's list).
 *
 * The states an instance made are freed with it (lf_fmi3.c's
 * lf_fmi3_free_states, as in FMI 2.0), so that this file only calls down
 * into the facade's checks and the operations.
 *
 * The facade's mode (event, step or continuous-time mode) is not part of a
 * state: fmi3SetFMUState restores the model's values and the solver, and a
 * running instance stays in its mode. */
#include <stddef.h>

#include "lf_facade_ops.h"
#include "lf_fmi3.h"

/* FMI 3.0: states are got and set in every state but error, where a state
 * may be set again */
#define STATE_STATES (F3_INSTANTIATED | F3_INIT | F3_RUNNING | F3_TERMINATED)
#define RESTORE_STATES (STATE_STATES | F3_ERROR)
#define LIST(c) (&ENV3((LfInstance *)(c))->states)

static fmi3Status status(LfStatus st) { return st == LF_OK ? fmi3OK : fmi3Error; }

fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *state) {
    CHECK3("fmi3GetFMUState", STATE_STATES);
    return status(lf_fmustate_get((LfInstance *)c, LIST(c), "fmi3GetFMUState", state));
}

fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState state) {
    LfInstance *inst = (LfInstance *)c;
    Fmi3Env *e;
    int was_running;
    CHECK3("fmi3SetFMUState", RESTORE_STATES);
    e = ENV3(inst);
    was_running = inst->run.state == LF_ST_STEP_COMPLETE;
    if (lf_fmustate_set(inst, LIST(c), "fmi3SetFMUState", state) != LF_OK) return fmi3Error;
    /* A state of a co-simulation step that was discarded is, for model
     * exchange, a consistent point at the last accepted time (the runtime
     * keeps states and outputs there): event mode. */
    if (e->kind == F3_ME && inst->run.state == LF_ST_STEP_FAILED) inst->run.state = LF_ST_STEP_COMPLETE;
    /* A running instance keeps its mode; one that was not running enters
     * event mode (model exchange, co-simulation with eventModeUsed) or step
     * mode, as after fmi3ExitInitializationMode. */
    if (inst->run.state != LF_ST_STEP_COMPLETE) {
        e->in_event_mode = e->in_cont_mode = 0;
    } else if (!was_running) {
        e->in_event_mode = e->kind == F3_ME || e->event_mode_used;
        e->in_cont_mode = 0;
    }
    e->events_seen = inst->stats.n_events;
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *state) {
    CHECK3("fmi3FreeFMUState", RESTORE_STATES);
    return status(lf_fmustate_free((LfInstance *)c, LIST(c), "fmi3FreeFMUState", state));
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState state, size_t *size) {
    CHECK3("fmi3SerializedFMUStateSize", RESTORE_STATES);
    return status(lf_fmustate_size((LfInstance *)c, LIST(c), "fmi3SerializedFMUStateSize",
                                   state, size));
}

fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState state, fmi3Byte bytes[],
                                 size_t size) {
    CHECK3("fmi3SerializeFMUState", RESTORE_STATES);
    return status(lf_fmustate_serialize((LfInstance *)c, LIST(c), "fmi3SerializeFMUState",
                                        state, bytes, size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte bytes[], size_t size,
                                   fmi3FMUState *state) {
    CHECK3("fmi3DeserializeFMUState", RESTORE_STATES);
    return status(lf_fmustate_deserialize((LfInstance *)c, LIST(c), "fmi3DeserializeFMUState",
                                          bytes, size, state));
}
