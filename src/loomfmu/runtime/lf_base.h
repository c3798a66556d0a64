/* loomfmu shared runtime: logging and the generated functions' work arrays
 * (lf_base.c), the bottom of the runtime's call layers. */
#ifndef LF_BASE_H
#define LF_BASE_H

#include "lf_instance.h"

/* the names of the log categories, by LfLogCategory */
extern const char *const lf_log_category_names[LF_N_LOG];

void lf_log(LfInstance *c, LfStatus status, LfLogCategory cat, const char *fmt, ...);

/* size and allocate the CasADi work arrays (c->unsaved.arg, res, iw, w)
 * for the largest generated function; 0 if out of memory */
int lf_alloc_casadi_work(LfInstance *c);

#endif
