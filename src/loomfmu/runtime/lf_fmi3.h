/* loomfmu shared runtime: the FMI 3.0 facade's check of a call's state
 * (lf_fmi3.c: lf_fmi3_allowed) for the facade's files; the types and the
 * other shared declarations are in lf_fmi3_internal.h. */
#ifndef LF_FMI3_H
#define LF_FMI3_H

#include "lf_fmi3_internal.h"

/* Return fmi3Error from the calling function unless instance c is live and
 * in one of the states of mask (logged by lf_fmi3_allowed). */
#define CHECK3(fn, mask)                                                             \
    do {                                                                             \
        if (!lf_fmi3_allowed(c, fn, mask)) return fmi3Error;                         \
    } while (0)

#endif
