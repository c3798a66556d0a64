/* loomfmu shared runtime: the FMI 2.0 facade's check of a call's state
 * (lf_fmi2.c: lf_fmi2_allowed), inline on its hot path, for the facade's
 * files; the types and the other shared declarations are in
 * lf_fmi2_internal.h. */
#ifndef LF_FMI2_H
#define LF_FMI2_H

#include "lf_fmi2_internal.h"

/* The hot path of lf_fmi2_allowed (every fmi2DoStep and get/set call): 1 if
 * `c` is live and in one of the states of `mask`, without a call that
 * prepares a log line.  0 leaves the answer (and the log) to
 * lf_fmi2_allowed. */
static inline int lf_fmi2_in_state(fmi2Component c, int mask) {
    const LfInstance *inst = lf_live(c);
    int bits;
    if (!inst) return 0;
    bits = (int)inst->run.state;
    if (ENV(inst)->me && inst->run.state == LF_ST_STEP_COMPLETE)
        bits = ENV(inst)->me_cont ? M2_CONT : M2_EVENT;
    return (bits & mask) != 0;
}

#define CHECK(fn, mask)                                                              \
    do {                                                                             \
        if (!lf_fmi2_in_state(c, mask) && !lf_fmi2_allowed(c, fn, mask))             \
            return fmi2Error;                                                        \
    } while (0)

#endif
