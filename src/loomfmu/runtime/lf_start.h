/* loomfmu shared runtime: start values of the states and modes
 * (lf_start.c). */
#ifndef LF_START_H
#define LF_START_H

#include "lf_instance.h"

/* Start values of the states from the parameters. */
LfStatus lf_initial_states(LfInstance *c);

/* Before the solver starts: states and modes initialization
 * starts from */
LfStatus lf_prepare_initial(LfInstance *c);

#endif
