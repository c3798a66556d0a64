/* loomfmu shared runtime: the model-exchange core, independent of the FMI
 * version (lf_me.c; used by lf_fmi2_me.c and lf_fmi3_me.c).
 *
 * In model exchange the importer integrates: it sets the time and the
 * states, reads the derivatives and event indicators, and calls
 * lf_me_completed_step after every accepted step and lf_me_event_update in
 * event mode.  The instance's interface state stays LF_ST_STEP_COMPLETE
 * after initialization (event mode / continuous-time mode are the facade's
 * business); the instance's time is c->run.t, its states c->val.r[LF_VR_X0 ..].
 *
 * Every function takes the calling FMI function's name `fn` for its log
 * lines.  Bad arguments (NULL, a size other than the model's, non-finite
 * values) give LF_ERROR with nothing changed; equations that cannot be
 * solved at the point give LF_DISCARD with the time in the log.
 *
 * Delays: the history holds the points of lf_me_completed_step (and the
 * start).  An evaluation that needs a delayed value beyond the last stored
 * point (a step longer than the delay, or no completed step) gives
 * LF_DISCARD and says so: never a silently extrapolated value. */
#ifndef LF_ME_H
#define LF_ME_H

#include <stddef.h>

#include "lf_instance.h"

/* der(x) at the instance's time and states (before initialization: at the
 * start values), with the inputs at that time; LF_ERROR (logged) if the
 * equations cannot be solved there.  (No delay check: lf_me_derivatives.) */
LfStatus lf_state_derivatives(LfInstance *c, double *dx);

/* Exit initialization in model exchange: lf_initialize (start values,
 * modes, delays' history at the start, indicators at the start). */
LfStatus lf_me_initialize(LfInstance *c);

/* Time t (finite, not before the start time); outputs recomputed on demand. */
LfStatus lf_me_set_time(LfInstance *c, const char *fn, double t);
/* States x[0 .. nx-1]: nx must be the model's, every value finite. */
LfStatus lf_me_set_states(LfInstance *c, const char *fn, const double *x, size_t nx);
LfStatus lf_me_get_states(LfInstance *c, const char *fn, double *x, size_t nx);
/* Nominal values of the states (1.0 each). */
LfStatus lf_me_nominals(LfInstance *c, const char *fn, double *x_nominal, size_t nx);
/* der(x) at (t, x, u): closed form or Newton; LF_DISCARD (logged with the
 * time) where the equations cannot be solved or a delayed value is not
 * known yet. */
LfStatus lf_me_derivatives(LfInstance *c, const char *fn, double *dx, size_t nx);
/* Event indicators at (t, x, u) in the current modes (ne = LF_NE). */
LfStatus lf_me_event_indicators(LfInstance *c, const char *fn, double *e, size_t ne);
/* Are the delayed values at the instance's time known from the history?
 * LF_OK, or LF_DISCARD with a log naming `fn`, the delay and the times. */
LfStatus lf_me_delays_known(LfInstance *c, const char *fn);

/* Can the delays' history take a point at the instance's time?  LF_OK, or
 * LF_ERROR with a log if the time is before the history's end (set back
 * without restoring an FMU state): a misuse, the instance unchanged. */
LfStatus lf_me_check_time(LfInstance *c, const char *fn);

/* After an accepted step of the importer at (t, x): the delays' history
 * takes the point, the validity conditions (Model.require) are checked
 * (*terminate = 1 and a log where one fails), and *enter_event_mode = 1
 * if an event indicator changed its sign since the last event (an importer
 * without root finding learns of the event here). */
LfStatus lf_me_completed_step(LfInstance *c, const char *fn, int *enter_event_mode,
                              int *terminate);

/* The result of an event update (FMI 2 fmi2EventInfo, FMI 3 the out
 * arguments of fmi3UpdateDiscreteStates). */
typedef struct {
    int discrete_states_need_update; /* always 0: the modes settle in one call */
    int terminate;                   /* a validity condition failed */
    int nominals_changed;            /* always 0 */
    int states_changed;              /* the states were reinitialized */
    int next_time_defined;           /* a known time event follows (a delay's jump) */
    double next_time;
} LfMeEventInfo;

/* Event mode at (t, x): the modes of the indicators that changed sign are
 * chosen again (in priority order, states reinitialized), then every mode
 * made consistent (lf_consistent_modes); the delays' history takes the
 * point; the validity conditions are checked. */
LfStatus lf_me_event_update(LfInstance *c, const char *fn, LfMeEventInfo *info);

/* Leaving event mode: the indicators here are the reference for the sign
 * changes the next completed step or event update looks for. */
LfStatus lf_me_enter_continuous(LfInstance *c, const char *fn);

#endif
