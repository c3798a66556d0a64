/* loomfmu shared runtime: the instance's life cycle (lf_runtime.c):
 * instantiate, reset, free, and getting and setting values by value
 * reference.  The instance's type is lf_instance.h's (included here for the
 * facades' convenience); the step loop, inputs and outputs the facades call
 * have their own headers (lf_step.h, lf_inputs.h, lf_outputs.h). */
#ifndef LF_RUNTIME_H
#define LF_RUNTIME_H

#include "lf_instance.h"

LfInstance *lf_instantiate(const char *name, LfLogFn log, void *log_env,
                           LfAllocator alloc);
void lf_free(LfInstance *c);
void lf_reset_values(LfInstance *c);

LfStatus lf_set_real(LfInstance *c, unsigned vr, double value);
LfStatus lf_get_real(LfInstance *c, unsigned vr, double *value);
LfStatus lf_set_solver(LfInstance *c, int id);
LfStatus lf_get_integer(LfInstance *c, unsigned vr, int *value);
LfStatus lf_set_integer(LfInstance *c, unsigned vr, int value);

#endif
