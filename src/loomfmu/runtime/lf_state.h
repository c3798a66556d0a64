/* loomfmu shared runtime: the FMU state as a flat byte string (lf_state.c). */
#ifndef LF_STATE_H
#define LF_STATE_H

#include <stddef.h>
#include "lf_runtime.h"

/* Bytes needed for the instance's current state. */
size_t lf_state_size(const LfInstance *c);
/* Write the state into buf (lf_state_size bytes). */
void lf_state_write(const LfInstance *c, unsigned char *buf);
/* Restore a state written by lf_state_write of an instance of this FMU;
 * LF_ERROR with a log line if it is not one. */
LfStatus lf_state_read(LfInstance *c, const unsigned char *buf, size_t n);

#endif
