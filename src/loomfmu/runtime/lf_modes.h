/* loomfmu shared runtime: event indicators at a point and the discrete
 * modes (lf_modes.c). */
#ifndef LF_MODES_H
#define LF_MODES_H

#include "lf_instance.h"

LfStatus lf_eval_events(LfInstance *c, double t, const double *x, double *e);
LfStatus lf_consistent_modes(LfInstance *c, double t, double *x, int touched);
LfStatus lf_initial_modes(LfInstance *c);

/* The modes after the event of indicator k (-1: none, e.g. an input jump)
 * at (t, x), without a solver (model exchange): the event's own mode first,
 * then every mode made consistent; x is updated with the
 * reinitialized states; *changed (may be NULL): a mode or a state changed.
 * LF_ERROR (logged) if no value of some mode is consistent. */
LfStatus lf_event_update(LfInstance *c, int k, double t, double *x, int *changed);

#endif
