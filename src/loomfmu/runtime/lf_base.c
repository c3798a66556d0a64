/* loomfmu shared runtime: the base every runtime file stands on: logging
 * and the CasADi work arrays of the generated functions.  It calls no other
 * runtime file (the layers: docs/guides/runtime.md). */
#include <stdarg.h>
#include <stdio.h>

#include "lf_base.h"
#include "lf_instance.h"
#include "lf_internal.h"

const char *const lf_log_category_names[LF_N_LOG] = LF_LOG_CATEGORY_NAMES;

void lf_log(LfInstance *c, LfStatus status, LfLogCategory cat, const char *fmt, ...) {
    char buf[512];
    va_list ap;
    /* warnings, discards and errors are always reported; the rest on request */
    if (!c || !c->unsaved.log) return;
    if (!c->unsaved.log_on[cat] && cat != LF_LOG_ERROR && cat != LF_LOG_DISCARD &&
        cat != LF_LOG_WARNING)
        return;
    if (c->unsaved.quiet && cat == LF_LOG_DISCARD) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    c->unsaved.log(c->unsaved.log_env, c->unsaved.name, status, lf_log_category_names[cat], buf);
}

static void *work_calloc(LfInstance *c, size_t n, size_t size) {
    return c->unsaved.alloc.calloc(n > 0 ? n : 1, size);
}

/* Size the CasADi work arrays for the largest of the generated functions. */
int lf_alloc_casadi_work(LfInstance *c) {
    long long n_arg = 0, n_res = 0, n_iw = 0, n_w = 0;
    int k;
    for (k = 0; k < LF_N_FN_ALL; k++) {
        long long a = 0, r = 0, i = 0, w = 0;
        if (lf_function_of(k)->work(&a, &r, &i, &w)) return 0;
        if (a > n_arg) n_arg = a;
        if (r > n_res) n_res = r;
        if (i > n_iw) n_iw = i;
        if (w > n_w) n_w = w;
    }
    c->unsaved.arg = (const double **)work_calloc(c, (size_t)n_arg, sizeof(double *));
    c->unsaved.res = (double **)work_calloc(c, (size_t)n_res, sizeof(double *));
    c->unsaved.iw = (long long *)work_calloc(c, (size_t)n_iw, sizeof(long long));
    c->unsaved.w = (double *)work_calloc(c, (size_t)n_w, sizeof(double));
    return c->unsaved.arg && c->unsaved.res && c->unsaved.iw && c->unsaved.w;
}
