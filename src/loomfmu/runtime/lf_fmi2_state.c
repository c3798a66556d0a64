/* loomfmu shared runtime: FMI 2.0 FMU states (get, set, free, serialize):
 * wrappers of lf_facade_ops.c over the instance's list of blobs, so that
 * fmi2FreeInstance frees every state the importer did not, and a pointer
 * this instance did not make is refused without being dereferenced.  Bytes
 * are checked when deserialized (size, checksum, this FMU and FMI version,
 * every field's value) and again when a state is set. */
#include "lf_fmi2.h"

#define STATE_STATES (LF_ST_INSTANTIATED | LF_ST_INIT | RUNNING | ME_RUNNING | LF_ST_TERMINATED)
/* FMI 2.0, 2.1.3: after fmi2Error a stored state may be set again */
#define RESTORE_STATES (STATE_STATES | LF_ST_ERROR)
#define LIST(c) (&ENV((LfInstance *)(c))->states)

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    CHECK("fmi2GetFMUstate", STATE_STATES);
    return (fmi2Status)lf_fmustate_get((LfInstance *)c, LIST(c), "fmi2GetFMUstate", state);
}

/* A state of a co-simulation instance whose step was discarded (StepFailed)
 * set in a model-exchange instance: its time and states are the last
 * accepted ones, from which model exchange goes on (StepFailed is no state
 * of model exchange; the instance keeps its event or continuous-time mode). */
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    LfInstance *inst = (LfInstance *)c;
    LfStatus st;
    CHECK("fmi2SetFMUstate", RESTORE_STATES);
    st = lf_fmustate_set(inst, LIST(c), "fmi2SetFMUstate", state);
    if (st == LF_OK && ENV(inst)->me && inst->run.state == LF_ST_STEP_FAILED)
        inst->run.state = LF_ST_STEP_COMPLETE;
    return (fmi2Status)st;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    CHECK("fmi2FreeFMUstate", RESTORE_STATES);
    return (fmi2Status)lf_fmustate_free((LfInstance *)c, LIST(c), "fmi2FreeFMUstate", state);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *n) {
    CHECK("fmi2SerializedFMUstateSize", RESTORE_STATES);
    return (fmi2Status)lf_fmustate_size((LfInstance *)c, LIST(c), "fmi2SerializedFMUstateSize",
                                        state, n);
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[],
                                 size_t n) {
    CHECK("fmi2SerializeFMUstate", RESTORE_STATES);
    return (fmi2Status)lf_fmustate_serialize((LfInstance *)c, LIST(c), "fmi2SerializeFMUstate",
                                             state, (unsigned char *)bytes, n);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t n,
                                   fmi2FMUstate *state) {
    CHECK("fmi2DeSerializeFMUstate", RESTORE_STATES);
    return (fmi2Status)lf_fmustate_deserialize((LfInstance *)c, LIST(c),
                                               "fmi2DeSerializeFMUstate",
                                               (const unsigned char *)bytes, n, state);
}
