/* loomfmu shared runtime: outputs and algebraic locals at the current
 * point, their time derivatives (lf_outputs.c). */
#ifndef LF_OUTPUTS_H
#define LF_OUTPUTS_H

#include "lf_instance.h"

/* the outputs and locals at the current point */
LfStatus lf_update_outputs(LfInstance *c);
/* output derivative of order 1 of output/local vr at the current time */
LfStatus lf_output_derivative(LfInstance *c, unsigned vr, double *value);

#endif
