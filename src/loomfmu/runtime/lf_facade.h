/* loomfmu shared runtime: what the FMI 2.0 and FMI 3.0 facades share,
 * independent of the FMI version (lf_facade.c): the registry of live
 * instances, the experiment's setup, undo of a refused set call, the state
 * derivatives, the list of FMU-state blobs, the check of a step's
 * arguments.  Every function that logs takes the calling FMI function's
 * name, so that the log says which call was refused. */
#ifndef LF_FACADE_H
#define LF_FACADE_H

#include <math.h>
#include <stddef.h>

#include "lf_instance.h"
#include "lf_me.h" /* the model-exchange core: lf_state_derivatives, lf_me_* */

/* ---- live instances (lock-free; instances may live in several threads) --- */

/* 1 if c was added (at most LF_MAX_LIVE instances live at once). */
int lf_live_add(void *c);
/* 1 if c was live (and is not any more): only one caller can free it. */
int lf_live_remove(void *c);
/* The registry (lf_facade.c): the live instances among the first
 * lf_live_top slots, the others NULL. */
#define LF_MAX_LIVE 1024
extern void *lf_live_slots[LF_MAX_LIVE];
extern int lf_live_top;
/* The instance if c is live, else NULL (never dereferences c; inline: every
 * FMI call asks). */
static inline LfInstance *lf_live(void *c) {
    int i, top = __atomic_load_n(&lf_live_top, __ATOMIC_SEQ_CST);
    if (!c) return NULL;
    for (i = 0; i < top; i++)
        if (__atomic_load_n(&lf_live_slots[i], __ATOMIC_SEQ_CST) == c) return (LfInstance *)c;
    return NULL;
}

/* ---- experiment ------------------------------------------------------------ */

/* Start and stop time, and the importer's tolerance (fmi2SetupExperiment,
 * fmi3EnterInitializationMode): LF_OK, LF_WARNING (tolerance outside
 * solver_rtol's range: clipped, logged) or LF_ERROR (non-finite start, stop
 * before start: logged, nothing set). */
LfStatus lf_setup_experiment(LfInstance *c, const char *fn, int tolerance_defined,
                             double tolerance, double start_time, int stop_time_defined,
                             double stop_time);
/* When the importer's tolerance (of `fn`) overrides a solver_rtol the
 * importer set (rtol_set): logs both values and gives 1; else 0. */
int lf_log_rtol_override(LfInstance *c, int rtol_set, const char *fn);

/* ---- undo of a refused set call -------------------------------------------- */

/* What setting Reals and Integers can change: a refused call changes nothing. */
typedef struct {
    double r[LF_NREAL];
    double u_d1[LF_DIM(LF_NU)], u_d2[LF_DIM(LF_NU)], u_t0[LF_DIM(LF_NU)];
    int x_set[LF_DIM(LF_NX)];
    int inputs_changed, outputs_valid, solver_id, delay_interp, u_poly, solver_index;
} LfSetUndo;

void lf_undo_save(const LfInstance *c, LfSetUndo *u);
void lf_undo_restore(LfInstance *c, const LfSetUndo *u);

/* ---- FMU states: blobs of lf_state_write's bytes in the instance's list ---- */

typedef struct LfBlob {
    struct LfBlob *next;
    size_t n;
    unsigned char data[1];
} LfBlob;

/* A new blob of n bytes at the head of *list; NULL (logged) if out of memory. */
LfBlob *lf_blob_alloc(LfInstance *c, LfBlob **list, size_t n);
/* Where *list holds s, or NULL (logged with `fn`) if s is not one of its
 * blobs: never dereferences a pointer the list does not hold. */
LfBlob **lf_blob_find(LfInstance *c, LfBlob **list, const char *fn, const void *s);
/* Unlinks and frees the blob at *at. */
void lf_blob_free(LfInstance *c, LfBlob **at);
/* Frees every blob of the list. */
void lf_blobs_free(LfInstance *c, LfBlob **list);

/* ---- stepping ------------------------------------------------------------------ */

/* A step the runtime can integrate (`fn`: fmi2DoStep, fmi3DoStep): finite
 * time and step, h > 0, starting at the FMU's time, an end later than the
 * FMU's time.  Otherwise logged and 0, with nothing changed. */
int lf_step_integrable(LfInstance *c, const char *fn, double t, double h);

/* The hot path of fmi2DoStep's checks: 1 if (t, h) passes both
 * lf_step_integrable and lf_check_step (lf_step.h), computed without the
 * calls that prepare their log lines; 0 leaves the answer (and the log) to
 * them.  The same conditions: finite t, h > 0 and t + h; t within 1e-9 of
 * the FMU's time (relative beyond 1); an end later than the FMU's time and
 * not past stopTime. */
static inline int lf_step_args_ok(const LfInstance *c, double t, double h) {
    double t_end = t + h, tc = c->run.t;
    /* (a finite t + h has a finite t and h: an infinite or NaN term makes
     * the sum so; t == tc, the common case, is within any tolerance) */
    return isfinite(t_end) && h > 0 &&
           (t == tc || fabs(t - tc) <= 1e-9 * (fabs(tc) > 1.0 ? fabs(tc) : 1.0)) &&
           t_end > tc && !(t_end > c->run.t_stop * (1 + 1e-12) + 1e-12);
}

#endif
