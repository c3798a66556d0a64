/* loomfmu shared runtime: validity conditions (Model.require) after an
 * accepted step (lf_validity.c). */
#ifndef LF_VALIDITY_H
#define LF_VALIDITY_H

#include "lf_instance.h"

/* After an accepted step: LF_DISCARD with the state at the last valid time where one fails. */
LfStatus lf_check_validity(LfInstance *c);
LfStatus lf_validity_at_start(LfInstance *c);
/* after the solver restarted (an event): the conditions at the restart
 * point; where one fails, the step ends at (t_ok, x_ok) with the modes q_ok
 * (the last point checked before the restart) */
LfStatus lf_validity_restart(LfInstance *c, double t_ok, const double *x_ok,
                             const double *q_ok);

#endif
