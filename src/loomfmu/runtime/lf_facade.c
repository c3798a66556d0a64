/* loomfmu shared runtime: the FMI facades' version-independent parts
 * (lf_facade.h): used by lf_fmi2*.c and lf_fmi3*.c. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_facade.h"
#include "lf_base.h"
#include "lf_instance.h"

/* ---- registry of live instances ---------------------------------------------
 * An instance is known by this registry, so that a call with a freed
 * instance (FreeInstance twice, DoStep after FreeInstance) is refused
 * without touching the freed memory.  Limit: if the allocator has given the
 * freed address to a new instance of this FMU, the call goes to that one. */

void *lf_live_slots[LF_MAX_LIVE];
int lf_live_top = 0; /* slots in use are below */

int lf_live_add(void *c) {
    int i, top;
    for (i = 0; i < LF_MAX_LIVE; i++) {
        void *expected = NULL;
        if (__atomic_compare_exchange_n(&lf_live_slots[i], &expected, c, 0, __ATOMIC_SEQ_CST,
                                        __ATOMIC_SEQ_CST)) {
            top = __atomic_load_n(&lf_live_top, __ATOMIC_SEQ_CST);
            while (top < i + 1 &&
                   !__atomic_compare_exchange_n(&lf_live_top, &top, i + 1, 0, __ATOMIC_SEQ_CST,
                                                __ATOMIC_SEQ_CST)) {
            }
            return 1;
        }
    }
    return 0;
}

int lf_live_remove(void *c) {
    int i, top = __atomic_load_n(&lf_live_top, __ATOMIC_SEQ_CST);
    for (i = 0; i < top; i++) {
        void *expected = c;
        if (__atomic_compare_exchange_n(&lf_live_slots[i], &expected, NULL, 0, __ATOMIC_SEQ_CST,
                                        __ATOMIC_SEQ_CST))
            return 1;
    }
    return 0;
}

/* ---- experiment ---------------------------------------------------------------- */

LfStatus lf_setup_experiment(LfInstance *c, const char *fn, int tolerance_defined,
                             double tolerance, double start_time, int stop_time_defined,
                             double stop_time) {
    LfStatus status = LF_OK;
    int k;
    if (!isfinite(start_time) ||
        (stop_time_defined && !(isfinite(stop_time) && stop_time >= start_time))) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "%s: startTime = %g, stopTime = %g (expected finite, "
               "start <= stop); nothing set", fn, start_time,
               stop_time_defined ? stop_time : INFINITY);
        return LF_ERROR;
    }
    if (tolerance_defined && !(isfinite(tolerance) && tolerance > 0)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "%s: tolerance = %g, expected a finite value > 0 "
               "(values outside [%g, %g] are limited to it); nothing set", fn, tolerance,
               lf_model.real_min[LF_SET_RTOL], lf_model.real_max[LF_SET_RTOL]);
        return LF_ERROR;
    }
    c->run.t_start = c->run.t = c->run.last_successful_time = start_time;
    for (k = 0; k < LF_NU; k++) c->in.u_t0[k] = start_time; /* input derivatives set before */
    c->in.seen_t = start_time;
    c->run.t_stop = stop_time_defined ? stop_time : INFINITY;
    /* the importer's tolerance is the solvers' relative tolerance (it wins over
     * solver_rtol, which keeps its value); it is limited to solver_rtol's range */
    c->run.rtol_importer = 0.0;
    if (tolerance_defined) {
        double lo = lf_model.real_min[LF_SET_RTOL], hi = lf_model.real_max[LF_SET_RTOL];
        double tol = tolerance;
        if (!(tol >= lo && tol <= hi)) {
            tol = tol > hi ? hi : lo;
            lf_log(c, LF_WARNING, LF_LOG_WARNING, "%s: tolerance = %g is outside [%g, %g]; "
                   "using %g", fn, tolerance, lo, hi, tol);
            status = LF_WARNING;
        }
        c->run.rtol_importer = tol;
    }
    return status;
}

int lf_log_rtol_override(LfInstance *c, int rtol_set, const char *fn) {
    const char *name = lf_model.real_names[LF_SET_RTOL];
    if (!(c->run.rtol_importer > 0) || !rtol_set || c->val.r[LF_SET_RTOL] == c->run.rtol_importer)
        return 0;
    lf_log(c, LF_WARNING, LF_LOG_WARNING,
           "t = %.17g: %s = %g is overridden by the importer's tolerance = %g of %s; the "
           "solvers use %g", c->run.t_start, name, c->val.r[LF_SET_RTOL], c->run.rtol_importer, fn,
           c->run.rtol_importer);
    return 1;
}

/* ---- undo ------------------------------------------------------------------------- */

void lf_undo_save(const LfInstance *c, LfSetUndo *u) {
    memcpy(u->r, c->val.r, sizeof u->r);
    memcpy(u->u_d1, c->in.u_d1, sizeof u->u_d1);
    memcpy(u->u_d2, c->in.u_d2, sizeof u->u_d2);
    memcpy(u->u_t0, c->in.u_t0, sizeof u->u_t0);
    u->u_poly = c->unsaved.u_poly;
    memcpy(u->x_set, c->val.x_set, sizeof u->x_set);
    u->inputs_changed = c->run.inputs_changed;
    u->outputs_valid = c->run.outputs_valid;
    u->solver_id = c->run.solver_id;
    u->solver_index = c->run.solver_index;
    u->delay_interp = c->dl.delay_interp;
}

void lf_undo_restore(LfInstance *c, const LfSetUndo *u) {
    memcpy(c->val.r, u->r, sizeof u->r);
    memcpy(c->in.u_d1, u->u_d1, sizeof u->u_d1);
    memcpy(c->in.u_d2, u->u_d2, sizeof u->u_d2);
    memcpy(c->in.u_t0, u->u_t0, sizeof u->u_t0);
    c->unsaved.u_poly = u->u_poly;
    memcpy(c->val.x_set, u->x_set, sizeof u->x_set);
    c->run.inputs_changed = u->inputs_changed;
    c->run.outputs_valid = u->outputs_valid;
    c->run.solver_id = u->solver_id;
    c->run.solver_index = u->solver_index;
    c->dl.delay_interp = u->delay_interp;
}

/* ---- FMU-state blobs ----------------------------------------------------------------- */

LfBlob *lf_blob_alloc(LfInstance *c, LfBlob **list, size_t n) {
    LfBlob *b = NULL;
    if (n <= (size_t)-1 - offsetof(LfBlob, data)) /* else the size wraps */
        b = (LfBlob *)c->unsaved.alloc.calloc(1, offsetof(LfBlob, data) + n);
    if (!b) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "FMU state: out of memory (%lu bytes)",
               (unsigned long)n);
        return NULL;
    }
    b->n = n;
    b->next = *list;
    *list = b;
    return b;
}

LfBlob **lf_blob_find(LfInstance *c, LfBlob **list, const char *fn, const void *s) {
    LfBlob **p = list;
    while (*p && (const void *)*p != s) p = &(*p)->next;
    if (*p) return p;
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: FMU state %p was not made by this "
           "instance or was freed; nothing done", c->run.t, fn, s);
    return NULL;
}

void lf_blob_free(LfInstance *c, LfBlob **at) {
    LfBlob *b = *at;
    *at = b->next;
    c->unsaved.alloc.free(b);
}

void lf_blobs_free(LfInstance *c, LfBlob **list) {
    while (*list) lf_blob_free(c, list);
}

/* ---- stepping ------------------------------------------------------------------------ */

int lf_step_integrable(LfInstance *c, const char *fn, double t, double h) {
    const char *why = NULL;
    char buf[200];
    if (!isfinite(t)) why = "currentCommunicationPoint is not finite";
    else if (!isfinite(h) || !(h > 0)) why = "communicationStepSize is not finite and > 0";
    else if (!isfinite(t + h)) why = "the end of the step is not finite";
    else if (fabs(t - c->run.t) > 1e-9 * fmax(1.0, fabs(c->run.t))) { /* as lf_check_step */
        snprintf(buf, sizeof buf, "expected currentCommunicationPoint = t = %.17g (the end of "
                 "the last step, or the time of the FMU state set), got %.17g (%s the FMU's "
                 "time)", c->run.t, t, t < c->run.t ? "behind" : "ahead of");
        why = buf;
    } else if (!(t + h > c->run.t)) {
        snprintf(buf, sizeof buf, "the step does not advance time (below the resolution of "
                 "time here: %g s)", nextafter(c->run.t, INFINITY) - c->run.t);
        why = buf;
    }
    if (!why) return 1;
    lf_log(c, LF_ERROR, LF_LOG_ERROR,
           "t = %.17g: %s(currentCommunicationPoint = %.17g, communicationStepSize = %g): %s; "
           "step refused, nothing changed", c->run.t, fn, t, h, why);
    return 0;
}
