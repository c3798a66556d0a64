/* loomfmu shared runtime: known breaks, indicators predicted ahead
 * (lf_breaks.c). */
#ifndef LF_BREAKS_H
#define LF_BREAKS_H

#include "lf_instance.h"

/* t_bound, or earlier: where the next step is to land, a margin before
 * the predicted zero of an indicator known ahead (sets c->kb.index;
 * lf_cross_known_break of lf_events.c crosses it) */
double lf_known_break(LfInstance *c, double t_bound);

#endif
