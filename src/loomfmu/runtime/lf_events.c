/* loomfmu shared runtime: events located inside an accepted step on the
 * solver's dense output, the step redone up to the root, the state carried
 * across it, the modes chosen again (lf_modes.c) and the solver restarted;
 * the early return's deferred event.  Called by the step loop (lf_step.c)
 * and the known breaks (lf_breaks.c); calls only files below it. */
#include <math.h>
#include <string.h>

#include "lf_events.h"
#include "lf_base.h"
#include "lf_delay.h"
#include "lf_eval.h"
#include "lf_instance.h"
#include "lf_internal.h"
#include "lf_modes.h"
#include "lf_newton.h"
#include "lf_validity.h"

#define LF_EVENT_MAX_ITER 200

/* ---- stepping ------------------------------------------------------------ */

static int crossed(double a, double b) { return (a > 0 && b <= 0) || (a < 0 && b >= 0); }

/* Event indicator k on the dense output at time t. */
static LfStatus event_at(LfInstance *c, int k, double t, double *g) {
    LfStatus st;
    c->solver.method->dense(&c->solver, t, c->unsaved.x_tmp);
    st = lf_eval_events(c, t, c->unsaved.x_tmp, c->unsaved.e_new);
    *g = c->unsaved.e_new[k];
    return st;
}

/* Illinois (modified regula falsi) on [ta, tb] where indicator k changes
 * sign; returns the final bracket [*t_left, *t_right]: t_left on the old
 * side, t_right on the new side of the root. */
static LfStatus locate_root(LfInstance *c, int k, double ta, double ga, double tb,
                            double gb, double *t_left, double *t_right) {
    int side = 0, it;
    double tol = 8.0 * 2.220446049250313e-16 * fmax(fabs(ta), fabs(tb)) + 1e-15;
    for (it = 0; it < LF_EVENT_MAX_ITER && tb - ta > tol; it++) {
        double tm = tb - gb * (tb - ta) / (gb - ga), gm;
        LfStatus st;
        if (!(tm > ta && tm < tb)) tm = 0.5 * (ta + tb);
        st = event_at(c, k, tm, &gm);
        if (st != LF_OK) return st;
        if (crossed(ga, gm)) {
            tb = tm;
            gb = gm;
            if (side == -1) ga *= 0.5;
            side = -1;
        } else {
            ta = tm;
            ga = gm;
            if (side == 1) gb *= 0.5;
            side = 1;
        }
    }
    *t_left = ta;
    *t_right = tb;
    return LF_OK;
}

/* the gap over an event grows (x4) up to this many times, and never beyond
 * LF_EVENT_GAP_MAX * max(1, |t|) nor the end of the step that saw the root */
#define LF_EVENT_GAP_TRIES 12
#define LF_EVENT_GAP_MAX 1e-6

/* Carry the state from the root's old side (t_left, x_left) across the
 * bracket to the new side by an Euler step over a gap that grows until
 * indicator k shows its new sign, and restart the solver there.  The caller
 * makes the gap reach LF_EVENT_GAP * max(1, |t|) past the root: the model's
 * own switch (an fmin, a floor) may sit a few ulps away from the
 * indicator's root, and a restart between the two would put the first stage
 * on the old branch.  The Euler error is O(gap^2).  The gap stays below
 * t_limit (the end of the step that saw the sign change) and
 * LF_EVENT_GAP_MAX * max(1, |t|).  If the indicator keeps its old sign
 * there (a root it only touches, e.g. (t - 1)^2, or one the redone
 * trajectory does not reach), *crossed_out = 0: no event; the solver
 * restarts at the last point tried, with that point's indicators. */
static LfStatus cross_gap(LfInstance *c, int k, double t_left, const double *x_left,
                          double gap, double t_limit, int *crossed_out) {
    double f[LF_DIM(LF_NX)], x[LF_DIM(LF_NX)], old = c->ev.e_old[k];
    double gap_max = fmin(t_limit - t_left, LF_EVENT_GAP_MAX * fmax(1.0, fabs(t_left)));
    int i, j;
    LfStatus st = lf_rhs(c, t_left, x_left, f);
    if (st != LF_OK) return st;
    *crossed_out = 0;
    if (!(gap_max > 0)) gap_max = gap;
    for (i = 0; i < LF_EVENT_GAP_TRIES; i++, gap *= 4.0) {
        if (gap > gap_max) gap = gap_max;
        for (j = 0; j < LF_NX; j++) x[j] = x_left[j] + gap * f[j];
        st = lf_eval_events(c, t_left + gap, x, c->unsaved.e_new);
        if (st != LF_OK) return st;
        if (crossed(old, c->unsaved.e_new[k])) {
            *crossed_out = 1;
            break;
        }
        if (gap >= gap_max) break;
    }
    lf_solver_reset(&c->solver, t_left + gap, x);
    memcpy(c->ev.e_old, c->unsaved.e_new, sizeof(double) * LF_NE);
    return LF_OK;
}

/* Indicators between the ends of an accepted step.  A step's ends alone
 * miss an indicator that leaves its sign and comes back inside the step: a
 * stuck joint's breakaway margin driven by time (its states constant, so
 * the solver's error estimate is zero and its step grows tenfold each
 * step).  Two rules, for every model:
 *
 * 1. Each accepted step is scanned on the dense output: the indicators at
 *    its midpoint, and the quadratic through the three samples per
 *    indicator.  Where that quadratic's extremum, inside the interval or
 *    within half of it beyond an end, comes closer to zero than
 *    LF_EVENT_VERTEX_MARGIN times the midpoint's distance from the chord
 *    (or two sign changes show), the halves are scanned again, down to
 *    LF_EVENT_SCAN_DEPTH levels.  The earliest interval with a sign
 *    change is where the root is located.
 * 2. The next step is bounded so that the indicators stay resolved: an
 *    indicator's second difference over the step, |g(a) - 2 g(m) + g(b)|,
 *    which grows as h^2, may be at most LF_EVENT_CURV times its size
 *    max(|g|) (about 6 steps per period of an oscillating indicator).
 *    Where the curvature vanishes (an inflection) but the indicator
 *    changes by more than LF_EVENT_CURV of its size over the step, the
 *    next step is at most LF_EVENT_GROWTH times as long; where the
 *    extremum comes near zero just after the step, the next step ends
 *    before twice its distance.  Without these
 *    bounds a step could alias a whole oscillation, which no sampling
 *    inside it can see.  The bound never shrinks the step below a quarter
 *    of the last one at once. */

/* Does the quadratic through samples ga, gm, gb of one indicator at the
 * start, middle and end of an interval come closer to zero at its extremum
 * than LF_EVENT_VERTEX_MARGIN times the midpoint's distance from the chord
 * (or cross it)?  *th: where the extremum lies, in units of the interval
 * (0 start, 1 end; may lie outside). */

/* Could the samples hide a sign change?  Not if the ends differ in sign
 * (one crossing, which locate_root brackets); yes if two sign changes show,
 * or if the extremum comes near zero inside the interval or within half of
 * it beyond either end (the quadratic is only a model: a shallow excursion
 * that it puts just outside may lie just inside). */
static int may_hide_roots(double ga, double gm, double gb) {
    double th;
    if (crossed(ga, gb)) return 0;
    if (crossed(ga, gm) || crossed(gm, gb)) return 1;
    return lf_near_zero_extremum(ga, gm, gb, &th) && th > -0.5 && th < 1.5;
}

static int any_crossed(const double *ga, const double *gb) {
    int k;
    for (k = 0; k < LF_NE; k++)
        if (crossed(ga[k], gb[k])) return 1;
    return 0;
}

typedef struct {
    double ta, tb;                  /* earliest interval with a sign change */
    double ga[LF_DIM(LF_NE)], gb[LF_DIM(LF_NE)];
    int found;
    double h_bound;                 /* bound on the next step (rule 2) */
} EventScan;

/* Rule 2: the bound on the next step from the samples ga, gm, gb of the
 * indicators at the start, middle and end of a step of length h. */
static void curvature_bound(const double *ga, const double *gm, const double *gb, double h,
                            double *h_bound) {
    int k;
    for (k = 0; k < LF_NE; k++) {
        double d2 = fabs(ga[k] - 2.0 * gm[k] + gb[k]), th;
        double size = lf_max(fabs(ga[k]), lf_max(fabs(gm[k]), fabs(gb[k])));
        if (d2 > 0 && size > 0) *h_bound = lf_min(*h_bound, h * sqrt(LF_EVENT_CURV * size / d2));
        /* at an inflection d2 vanishes: a varying indicator's step grows
         * at most LF_EVENT_GROWTH-fold until its curvature shows again */
        if (fabs(gb[k] - ga[k]) > LF_EVENT_CURV * size)
            *h_bound = lf_min(*h_bound, LF_EVENT_GROWTH * h);
        /* an extremum near zero just after the step: the next step
         * ends short of twice its distance */
        if (lf_near_zero_extremum(ga[k], gm[k], gb[k], &th) && th > 1.0 && th < 2.0)
            *h_bound = lf_min(*h_bound, 2.0 * (th - 1.0) * h);
    }
}

/* Scan (ta, tb] of the accepted step (rule 1); depth 0 also sets rule 2's
 * bound.  Stops at the first interval with a sign change. */
static LfStatus scan_events(LfInstance *c, double ta, const double *ga, double tb,
                            const double *gb, int depth, EventScan *out) {
    double gm[LF_DIM(LF_NE)], xm[LF_DIM(LF_NX)], tm = 0.5 * (ta + tb);
    int k, resolved = 1;
    LfStatus st;
    if (depth < LF_EVENT_SCAN_DEPTH && tm > ta && tm < tb) {
        c->solver.method->dense(&c->solver, tm, xm);
        st = lf_eval_events(c, tm, xm, gm);
        if (st != LF_OK) return st;
        for (k = 0; k < LF_NE; k++)
            if (may_hide_roots(ga[k], gm[k], gb[k])) resolved = 0;
        if (depth == 0) curvature_bound(ga, gm, gb, tb - ta, &out->h_bound);
        if (!resolved) {
            st = scan_events(c, ta, ga, tm, gm, depth + 1, out);
            if (st != LF_OK || out->found) return st;
            return scan_events(c, tm, gm, tb, gb, depth + 1, out);
        }
        /* no hidden sign change: a crossing is in one of the halves */
        if (any_crossed(ga, gm)) {
            tb = tm;
            gb = gm;
        } else if (any_crossed(gm, gb)) {
            ta = tm;
            ga = gm;
        }
    }
    if (any_crossed(ga, gb)) {
        out->found = 1;
        out->ta = ta;
        out->tb = tb;
        memcpy(out->ga, ga, sizeof(double) * LF_NE);
        memcpy(out->gb, gb, sizeof(double) * LF_NE);
    }
    return LF_OK;
}

/* Event `first` at the solver's point (the root's new side, where cross_gap
 * restarted it): modes, reinit, solver restart, the validity conditions at
 * the restart (t_ok, x_ok, q_ok: the last point before the event) and the
 * history. */
static LfStatus apply_event(LfInstance *c, int first, double t_ok, const double *x_ok,
                            const double *q_ok, int *changed) {
    LfSolver *s = &c->solver;
    LfStatus st;
    c->stats.n_events++;
    c->kb.ready = 0; /* states may be reinitialized: predict the known breaks again */
    c->kb.dt = 0.0;  /* no chunk length to carry over the restart (lf_known_break) */
    if (changed) *changed = 0;
    if (LF_NQ > 0) {
        memcpy(c->unsaved.x_tmp, s->x, sizeof(double) * LF_NX);
        st = lf_event_update(c, first, s->t, c->unsaved.x_tmp, changed);
        if (st != LF_OK) return st;
        lf_solver_reset(s, s->t, c->unsaved.x_tmp);
        st = lf_eval_events(c, s->t, s->x, c->ev.e_old);
        if (st != LF_OK) return st;
    }
    lf_log(c, LF_OK, LF_LOG_EVENTS, "t = %.17g: event %s, solver restarted", s->t,
           lf_model.event_names[first]);
    st = lf_validity_restart(c, t_ok, x_ok, q_ok);
    if (st != LF_OK) return st;
    return lf_hist_push(c, s->t, s->x, lf_model.event_mode[first] >= 0);
}

/* Early return: the event at the solver's point is left for
 * lf_apply_pending_event. */
static LfStatus defer_event(LfInstance *c, int first, double t_ok, const double *x_ok,
                            const double *q_ok) {
    c->ev.pending = 1;
    c->ev.index = first;
    c->ev.t_event = c->solver.t;
    c->ev.t_ok = t_ok;
    memcpy(c->ev.x_ok, x_ok, sizeof(double) * LF_NX);
    memcpy(c->ev.q_ok, q_ok, sizeof(double) * LF_NQ);
    lf_log(c, LF_OK, LF_LOG_EVENTS, "t = %.17g: event %s, step ends here (early return)",
           c->solver.t, lf_model.event_names[first]);
    return LF_OK;
}

LfStatus lf_apply_pending_event(LfInstance *c, int *changed) {
    int k = c->ev.index;
    if (changed) *changed = 0;
    if (!c->ev.pending) return LF_OK;
    c->ev.pending = 0;
    c->ev.index = -1;
    return apply_event(c, k, c->ev.t_ok, c->ev.x_ok, c->ev.q_ok, changed);
}

/* Rule 2's bound left pending after a step the known-break scan vouched for
 * (c->unsaved.kb_sure == -INFINITY; also after an FMU state is set, and at the
 * start): taken now, from the last step's samples as scan_events takes them
 * (its start from x_old, its midpoint on the dense output, its end e_old),
 * the indicators evaluated without solving for w (every one predicted: none
 * reads w; the caller checks).  Taking it again changes nothing (the same
 * samples, the same bound).  Nothing to take where the solver restarted
 * since (no dense output): lf_known_break bounds that step instead. */
LfStatus lf_event_bound_pending(LfInstance *c) {
    LfSolver *s = &c->solver;
    double ga[LF_DIM(LF_NE)], gm[LF_DIM(LF_NE)], xm[LF_DIM(LF_NX)], hb = INFINITY;
    double tm = 0.5 * (s->t_old + s->t), h_step = s->t - s->t_old;
    if (c->unsaved.kb_sure != -INFINITY) return LF_OK;
    c->unsaved.kb_sure = s->t;
    if (!(tm > s->t_old && tm < s->t)) return LF_OK;
    s->method->dense(s, tm, xm);
    if (lf_eval_fn1(c, LF_FN_EVT, s->t_old, s->x_old, c->val.w_cur, ga) != LF_OK ||
        lf_eval_fn1(c, LF_FN_EVT, tm, xm, c->val.w_cur, gm) != LF_OK ||
        lf_first_nonfinite(ga, LF_NE) >= 0 || lf_first_nonfinite(gm, LF_NE) >= 0) {
        lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: event indicators not finite", tm);
        return LF_DISCARD;
    }
    curvature_bound(ga, gm, c->ev.e_old, h_step, &hb);
    hb = fmax(hb, 0.25 * h_step);
    if (s->h > hb) s->h = hb;
    return LF_OK;
}

/* After an accepted step: find the earliest crossing (scan_events).  The
 * step is then redone from t_old to the root's old side, so that no stage
 * straddles the discontinuity (the dense output of the straddling step is
 * contaminated by it), and the solver restarts on the new side. */
static LfStatus handle_events(LfInstance *c, double *h_bound) {
    LfSolver *s = &c->solver;
    double t_left = s->t, t_right = s->t, margin, t_stop, t_end_step, e_end[LF_DIM(LF_NE)];
    double t_ok, x_ok[LF_DIM(LF_NX)], q_ok[LF_DIM(LF_NQ)];
    double h_step = s->t - s->t_old;
    int k, first = -1, crossed_gap;
    EventScan scan;
    LfStatus st = lf_eval_events(c, s->t, s->x, e_end);
    if (st != LF_OK) return st;
    scan.found = 0;
    scan.h_bound = INFINITY;
    if (c->unsaved.kb_cert && !any_crossed(c->ev.e_old, e_end)) {
        /* Every indicator is known ahead (a function of time, the
         * parameters, the held inputs and the clock states, not of w), and
         * the scan of their prediction (lf_breaks.c), which resolves them by
         * the same rules, found no root in this step: rule 1 has nothing to
         * add.  Rule 2's bound exists for the events' scan of the next step;
         * it is left pending (c->unsaved.kb_sure = -INFINITY) and taken before the
         * next step only if that step is not vouched for in turn
         * (lf_event_bound_pending, from lf_known_break), while this step's
         * dense output is still there.  Taken now where the solver restarts
         * before the next step: a known break crossed here, a delay's
         * breakpoint (a restart loses the dense output). */
        double tm = 0.5 * (s->t_old + s->t), xm[LF_DIM(LF_NX)], gm[LF_DIM(LF_NE)];
        if (LF_ND == 0 && !(c->kb.index >= 0 && s->t == c->kb.t_land)) {
            memcpy(c->ev.e_old, e_end, sizeof(double) * LF_NE);
            c->unsaved.kb_sure = -INFINITY;
            return LF_OK;
        }
        c->unsaved.kb_sure = s->t;
        if (tm > s->t_old && tm < s->t) {
            c->solver.method->dense(&c->solver, tm, xm);
            if (lf_eval_fn1(c, LF_FN_EVT, tm, xm, c->val.w_cur, gm) != LF_OK ||
                lf_first_nonfinite(gm, LF_NE) >= 0) {
                lf_log(c, LF_DISCARD, LF_LOG_DISCARD, "t = %.17g: event indicators not finite",
                       tm);
                return LF_DISCARD;
            }
            curvature_bound(c->ev.e_old, gm, e_end, h_step, &scan.h_bound);
        }
        *h_bound = fmax(scan.h_bound, 0.25 * h_step);
        memcpy(c->ev.e_old, e_end, sizeof(double) * LF_NE);
        return LF_OK;
    }
    c->unsaved.kb_sure = s->t; /* rule 2's bound for this step: taken below */
    st = scan_events(c, s->t_old, c->ev.e_old, s->t, e_end, 0, &scan);
    if (st != LF_OK) return st;
    /* rule 2: at most 4 times shorter than this step */
    *h_bound = fmax(scan.h_bound, 0.25 * h_step);
    for (k = 0; scan.found && k < LF_NE; k++) {
        double tl, tr;
        if (!crossed(scan.ga[k], scan.gb[k])) continue;
        st = locate_root(c, k, scan.ta, scan.ga[k], scan.tb, scan.gb[k], &tl, &tr);
        if (st != LF_OK) return st;
        if (first < 0 || tr < t_right) {
            t_left = tl;
            t_right = tr;
            first = k;
        }
    }
    if (first < 0) {
        memcpy(c->ev.e_old, e_end, sizeof(double) * LF_NE);
        return LF_OK;
    }
    t_end_step = s->t;
    /* stop a margin before the root: the stages of the redone step must
     * not reach the model's switch, which rounding can move by a few ulps */
    margin = LF_EVENT_GAP * fmax(1.0, fabs(t_left));
    t_stop = fmax(t_left - margin, s->t_old);
    memcpy(c->unsaved.x_tmp, s->x_old, sizeof(double) * LF_NX);
    lf_solver_reset(s, s->t_old, c->unsaved.x_tmp);
    while (s->t < t_stop) {
        st = s->method->step(s, t_stop);
        if (st != LF_OK) return st;
        /* the validity conditions on the redone steps (a failure before the
         * event ends the step there) */
        st = lf_check_validity(c);
        if (st != LF_OK) return st;
    }
    /* the last point before the event, where the conditions held */
    t_ok = s->t;
    memcpy(x_ok, s->x, sizeof x_ok);
    memcpy(q_ok, c->val.q, sizeof q_ok);
    st = cross_gap(c, first, s->t, s->x, t_right - s->t + margin, t_end_step, &crossed_gap);
    if (st != LF_OK) return st;
    if (!crossed_gap) {
        lf_log(c, LF_OK, LF_LOG_EVENTS, "t = %.17g: indicator %s touched zero and kept its "
               "sign: no event, solver restarted", s->t, lf_model.event_names[first]);
        st = lf_validity_restart(c, t_ok, x_ok, q_ok);
        if (st != LF_OK) return st;
        return lf_hist_push(c, s->t, s->x, 0);
    }
    if (c->unsaved.stop_at_events) return defer_event(c, first, t_ok, x_ok, q_ok);
    return apply_event(c, first, t_ok, x_ok, q_ok, NULL);
}

LfStatus lf_cross_known_break(LfInstance *c, double t_limit) {
    LfSolver *s = &c->solver;
    double t_ok, x_ok[LF_DIM(LF_NX)], q_ok[LF_DIM(LF_NQ)], margin;
    int k = c->kb.index, crossed_gap;
    LfStatus st;
    if (k < 0 || s->t != c->kb.t_land || !(s->t > s->t_old)) return LF_OK;
    c->kb.index = -1;
    t_ok = s->t;
    margin = LF_EVENT_GAP * fmax(1.0, fabs(t_ok));
    /* landed at the communication point: the next step finds the event */
    if (c->kb.t_right + margin > t_limit) return LF_OK;
    memcpy(x_ok, s->x, sizeof x_ok);
    memcpy(q_ok, c->val.q, sizeof q_ok);
    st = cross_gap(c, k, t_ok, x_ok, c->kb.t_right - t_ok + margin, t_limit, &crossed_gap);
    if (st != LF_OK) return st;
    if (!crossed_gap) {
        lf_log(c, LF_OK, LF_LOG_EVENTS, "t = %.17g: indicator %s, predicted to cross zero, "
               "kept its sign: no event, solver restarted", s->t, lf_model.event_names[k]);
        st = lf_validity_restart(c, t_ok, x_ok, q_ok);
        if (st != LF_OK) return st;
        return lf_hist_push(c, s->t, s->x, 0);
    }
    c->unsaved.n_known_breaks++;
    if (c->unsaved.stop_at_events) return defer_event(c, k, t_ok, x_ok, q_ok);
    return apply_event(c, k, t_ok, x_ok, q_ok, NULL);
}

LfStatus lf_handle_events(LfInstance *c) {
    double h_bound = INFINITY;
    LfStatus st = handle_events(c, &h_bound);
    if (st == LF_OK && c->solver.h > h_bound) c->solver.h = h_bound;
    return st;
}
