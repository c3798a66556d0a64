/* loomfmu shared runtime: event location in a step, crossing, the early
 * return's deferred event (lf_events.c). */
#ifndef LF_EVENTS_H
#define LF_EVENTS_H

#include "lf_instance.h"

/* Event location after a step. */
LfStatus lf_handle_events(LfInstance *c);
/* early return (lf_step.h): perform the event located and deferred by
 * lf_handle_events when c->unsaved.stop_at_events is set (nothing pending: LF_OK) */
LfStatus lf_apply_pending_event(LfInstance *c, int *changed);
/* After a step that landed a margin before a known break (lf_breaks.c),
 * cross it as an event (the gap may reach up to t_limit) */
LfStatus lf_cross_known_break(LfInstance *c, double t_limit);
/* Rule 2's bound on the next step, left pending after a step
 * the known-break scan vouched for (c->unsaved.kb_sure == -INFINITY), taken from the
 * last step's samples (every indicator predicted; lf_known_break) */
LfStatus lf_event_bound_pending(LfInstance *c);

#endif
