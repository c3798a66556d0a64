/* loomfmu shared runtime: initialization and the step loop (lf_step.c),
 * the facades' interface to it: exit initialization, a checked step, early
 * return at events (FMI 3.0 co-simulation), inputs settled before a read.
 *
 * Early return.  With c->unsaved.stop_at_events = 1 (set by the facade, e.g. from
 * earlyReturnAllowed; not part of the FMU state), lf_do_step ends the step
 * at the first event located inside it and returns LF_OK with
 * c->ev.pending = 1, c->ev.index = its indicator and c->run.t =
 * c->run.last_successful_time = c->ev.t_event: the solver's point on the root's
 * new side (the indicator shows its new sign there, at most a gap of about
 * 1e-12 * max(1, |t|) past the root), the states there, and the outputs
 * there with the modes before the event.  lf_handle_pending_event then
 * performs the event exactly as the step loop does it inside a step (modes
 * chosen again, states reinitialized, solver restarted, the validity
 * conditions at the restart, the delays' history), so a run with early
 * returns follows the same trajectory as one without.  A pending event the
 * importer does not handle is handled at the start of the next lf_do_step.
 * Without events, stop_at_events changes nothing. */
#ifndef LF_STEP_H
#define LF_STEP_H

#include "lf_instance.h"
/* for the facades and drivers that step an instance: its life cycle and
 * outputs with the step loop (this header takes no name from them) */
#include "lf_outputs.h"
#include "lf_runtime.h"

/* Start the solver at t_start with the current states (exit initialization). */
LfStatus lf_initialize(LfInstance *c);
/* Is fmi2DoStep(t0, h) a valid call here?  (logs why not) */
LfStatus lf_check_step(LfInstance *c, double t0, double h);
/* Advance from c->run.t by h: integrate, locate events, update outputs. */
LfStatus lf_do_step(LfInstance *c, double t0, double h);
/* The same after the caller checked the call with lf_check_step (the FMI
 * facades do, to refuse it before anything changes). */
LfStatus lf_do_checked_step(LfInstance *c, double t0, double h);

/* Perform the pending event (none: LF_OK, *values_changed = 0) and update
 * the outputs at c->run.t.  *values_changed (may be NULL): a mode or a state
 * changed.  LF_ERROR: no consistent mode (logged; the instance stays at
 * t_event, the event still pending is dropped).  LF_DISCARD with
 * c->run.wants_terminate = 1: a validity condition fails across the event; as
 * inside a step, the instance goes back to the last valid point before the
 * event (c->run.t = c->run.last_successful_time = c->ev.t_ok, at most ~1e-12
 * relative before t_event) and the simulation cannot go on. */
LfStatus lf_handle_pending_event(LfInstance *c, int *values_changed);

/* Inputs set since the last step (values or derivatives): do now what the
 * next step's start would do (modes made consistent with the new inputs,
 * states reinitialized for them, solver restarted, the history's jump), so
 * that outputs, modes and states read before the next step are those of
 * the inputs set.  No-op before initialization, with nothing set, or with
 * an event pending (its handling comes first).  Identical trajectory: the
 * next step's start then has nothing to do.  Inputs set after this call
 * are handled again (at the next read or step).  LF_ERROR (logged) if no
 * mode is consistent with the inputs. */
LfStatus lf_settle_inputs(LfInstance *c);

#endif
