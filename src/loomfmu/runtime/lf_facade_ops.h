/* loomfmu shared runtime: bodies of FMI functions whose logic does not
 * depend on the FMI version (lf_facade_ops.c), so that lf_fmi2*.c and
 * lf_fmi3*.c are thin wrappers: the state names of a mask, debug logging,
 * setting Reals with undo, and the six FMU-state operations on the
 * instance's list of blobs (lf_facade.h).  Each takes the calling FMI
 * function's name `fn` for its log lines and returns LF_OK, LF_WARNING or
 * LF_ERROR (nothing changed on LF_ERROR); the caller has checked the
 * instance and its interface state. */
#ifndef LF_FACADE_OPS_H
#define LF_FACADE_OPS_H

#include <stddef.h>

#include "lf_facade.h"

/* The names of the states whose bits are set in `mask` (bit i: names[i]),
 * comma separated, into buf (truncated to size). */
void lf_state_names(int mask, const char *const names[], int n_names, char *buf,
                    size_t size);

/* 1 if the instance's interface state `bits` is one of `mask`'s; else logs
 * "fn must not be called in state X; allowed in: ..." (with the facade's
 * names of the bits) and gives 0. */
int lf_check_state(LfInstance *c, const char *fn, int bits, int mask,
                   const char *const names[], int n_names);

/* Debug logging on or off: every category (n = 0) or the n named ones (all
 * known, or nothing changes). */
LfStatus lf_set_debug_logging(LfInstance *c, const char *fn, int on, size_t n,
                              const char *const categories[]);

/* Set Reals vr[i] (runtime value references, < LF_NREAL) to v[i]: all or
 * none (a refused value undoes the call); LF_WARNING if an input is outside
 * its range.  *rtol_set = 1 if solver_rtol was set. */
LfStatus lf_set_reals(LfInstance *c, const unsigned vr[], size_t nvr, const double v[],
                      int *rtol_set);

/* ---- FMU states: the instance's blobs (`list`) ---- */
/* Store the instance's state in *state (a new blob, or the one *state holds). */
LfStatus lf_fmustate_get(LfInstance *c, LfBlob **list, const char *fn, void **state);
/* Restore the state of blob `state` (checked field by field by lf_state_read). */
LfStatus lf_fmustate_set(LfInstance *c, LfBlob **list, const char *fn, void *state);
/* Free blob *state (NULL: nothing) and set *state = NULL. */
LfStatus lf_fmustate_free(LfInstance *c, LfBlob **list, const char *fn, void **state);
LfStatus lf_fmustate_size(LfInstance *c, LfBlob **list, const char *fn, void *state,
                          size_t *size);
LfStatus lf_fmustate_serialize(LfInstance *c, LfBlob **list, const char *fn, void *state,
                               unsigned char *bytes, size_t size);
/* A new blob with a copy of the bytes (checked when set), into *state. */
LfStatus lf_fmustate_deserialize(LfInstance *c, LfBlob **list, const char *fn,
                                 const unsigned char *bytes, size_t size, void **state);

#endif
