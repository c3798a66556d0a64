/* loomfmu shared runtime: delays.  Per delayed expression a ring of
 * accepted samples (t, g, dg/dt), Hermite-interpolated, and the breakpoints
 * where a jump of the history reaches the equations.  This file writes the
 * history (samples at accepted steps, refined until the interpolant matches
 * the dense output); reading it, the delayed values at t, is lf_eval.c's. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_delay.h"
#include "lf_base.h"
#include "lf_eval.h"
#include "lf_inputs.h"
#include "lf_instance.h"
#include "lf_internal.h"
#include "lf_newton.h"

/* Room for the breakpoints t + tau_k of a jump of the history at t (one per
 * delay > 0, those already pending not counted).  The breakpoints passed
 * (<= t) are forgotten first.  If they do not fit, nothing is added and the
 * call is discarded with the cause: a dropped breakpoint would let a step
 * run across a jump of a delayed value (silently inaccurate, or a step size
 * underflow). */
static LfStatus breakpoints_fit(LfInstance *c, double t) {
    int i, j = 0, k, need = 0, n_pos = 0, longest = 0;
    double first = t; /* the earliest pending jump (of the longest delay) */
    for (i = 0; i < c->dl.n_bp; i++)
        if (c->dl.bp[i] > t) c->dl.bp[j++] = c->dl.bp[i];
    c->dl.n_bp = j;
    for (k = 0; k < LF_ND; k++) {
        int pending = 0;
        if (c->dl.tau[k] == 0) continue;
        n_pos++;
        if (c->dl.tau[k] > c->dl.tau[longest]) longest = k;
        for (i = 0; i < c->dl.n_bp && !pending; i++) pending = c->dl.bp[i] == t + c->dl.tau[k];
        need += !pending;
    }
    if (c->dl.n_bp + need <= LF_BP_CAP) return LF_OK;
    for (i = 0; i < c->dl.n_bp; i++) first = fmin(first, c->dl.bp[i] - c->dl.tau[longest]);
    lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
           "t = %.17g: too many input changes within one delay time: %d jumps of delayed "
           "values are pending (the most this FMU holds): each input change (or mode event) "
           "reaches the equations tau later (tau = %g s, delay %s), and those pending "
           "came about %g s apart; change the inputs at most every tau / %d = %g s "
           "(a longer communication step, or set an input only when its value changes); "
           "step discarded", t, c->dl.n_bp, c->dl.tau[longest], lf_model.delay_names[longest],
           (t - first) * n_pos / (c->dl.n_bp > 0 ? c->dl.n_bp : 1), LF_MAX_BP / n_pos,
           c->dl.tau[longest] * n_pos / LF_MAX_BP); /* reached only with delays */
    return LF_DISCARD;
}

static void add_breakpoint(LfInstance *c, double t) {
    int i;
    for (i = 0; i < c->dl.n_bp; i++)
        if (c->dl.bp[i] == t) return;
    if (c->dl.n_bp < LF_BP_CAP) c->dl.bp[c->dl.n_bp++] = t; /* room made by breakpoints_fit */
}

/* The next pending breakpoint after t, or t_end if none comes first (and
 * forget those passed); *is_bp: a breakpoint falls on the returned time. */
double lf_next_breakpoint(LfInstance *c, double t, double t_end, int *is_bp) {
    double next = t_end;
    int i, j = 0;
    *is_bp = 0;
    for (i = 0; i < c->dl.n_bp; i++) {
        if (c->dl.bp[i] <= t) continue;
        c->dl.bp[j++] = c->dl.bp[i];
        if (c->dl.bp[i] <= next) {
            next = c->dl.bp[i];
            *is_bp = 1;
        }
    }
    c->dl.n_bp = j;
    return next;
}

/* Cubic Hermite through (0, g0, d0), (h, g1, d1) at th * h. */
static double hermite(double g0, double d0, double g1, double d1, double h, double th) {
    double th2 = th * th, th3 = th2 * th;
    return (2 * th3 - 3 * th2 + 1) * g0 + (th3 - 2 * th2 + th) * h * d0 + (3 * th2 - 2 * th3) * g1 +
           (th3 - th2) * h * d1;
}

/* Samples closer than LF_HIST_THIN * tau / LF_HIST_CAP are thinned: a
 * sample between two such neighbours is dropped when the cubic Hermite
 * through them reproduces it within the solver's tolerance (times
 * LF_HIST_QUARTER_SCALE).  The history of a slow delayed signal in a model
 * whose other parts take very short steps (a drive composed with a fast
 * rotor) then fits; a model whose steps are longer keeps every sample. */
#define LF_HIST_THIN 4.0
/* The Hermite error of a smooth g over an interval is, to leading order,
 * g'''' h^4 th^2 (1 - th)^2 / 24: at the quarter points 9/16 of its value
 * at the midpoint.  Checked at the quarter points against 9/16 of the
 * tolerance, the midpoint's error is bounded as before (and a deviation odd
 * about the midpoint, which vanishes there, is seen). */
#define LF_HIST_QUARTER_SCALE 0.5625

/* Drop the last sample of delay k when the new one (t, g, dg/dt) makes it
 * redundant (see LF_HIST_THIN); a jump (two samples at one time) is kept. */
static void hist_thin(LfInstance *c, int k, double t, double g, double d) {
    long n = c->dl.hist_count[k];
    double t0, t1, h, mid;
    if (n < 2) return;
    t0 = LF_HT(c, k, n - 2);
    t1 = LF_HT(c, k, n - 1);
    h = t - t0;
    if (!(t1 > t0 && t > t1 && h < LF_HIST_THIN * c->dl.tau[k] / LF_HIST_CAP)) return;
    mid = hermite(LF_HG(c, k, n - 2), LF_HD(c, k, n - 2), g, d, h, (t1 - t0) / h);
    if (!(fabs(mid - LF_HG(c, k, n - 1)) <=
          LF_HIST_QUARTER_SCALE * (c->solver.opt.atol + c->solver.opt.rtol * fabs(mid))))
        return;
    c->dl.hist_count[k]--;
    if (c->unsaved.hist_cursor[k] >= c->dl.hist_count[k])
        c->unsaved.hist_cursor[k] = c->dl.hist_count[k] - 1;
}

/* The history of delay k cannot take the sample at t: say why, and what to
 * change for the solver in use (the samples are at least one per step,
 * more where the Hermite interpolant misses the solver's by more than the
 * tolerances: hist_refine). */
static void history_full(LfInstance *c, int k, double t) {
    const LfSolver *s = &c->solver;
    char advice[200];
    if (s->method && !s->method->adaptive)
        snprintf(advice, sizeof advice, "%s takes fixed steps of solver_h_fixed = %g s: raise "
                 "it to at least tau / %d = %g s, or loosen solver_rtol / solver_atol, which "
                 "bound the history's interpolation error", s->method->name, s->opt.h_fixed,
                 LF_HIST_CAP, c->dl.tau[k] / LF_HIST_CAP);
    else /* every communication point ends a step, and every step adds a sample */
        snprintf(advice, sizeof advice, "communication steps of at least tau / %d = %g s "
                 "(each ends a solver step), and looser solver_rtol / solver_atol",
                 LF_HIST_CAP, c->dl.tau[k] / LF_HIST_CAP);
    lf_log(c, LF_DISCARD, LF_LOG_DISCARD,
           "t = %.17g: history of delay %s is full: the equations read back to t - tau = "
           "%.17g, and the %d samples it holds (the most it can) start at t = %.17g, %g s "
           "apart on average; the steps are too short for tau = %g s (%s)", t,
           lf_model.delay_names[k], t - c->dl.tau[k], LF_HIST_CAP, LF_HT(c, k, 0),
           (t - LF_HT(c, k, 0)) / (LF_HIST_CAP - 1), c->dl.tau[k], advice);
}

/* Append (t, g, dg/dt) at an accepted point; `jump`: the history is
 * discontinuous here (input change, reinit), so its values reach the
 * equations tau later: a breakpoint. */
static LfStatus hist_append(LfInstance *c, double t, const double *g, int jump) {
    int k;
    if (jump && breakpoints_fit(c, t) != LF_OK) return LF_DISCARD;
    for (k = 0; k < LF_ND; k++) {
        /* every later query is at s >= t - tau (stages run at or after the
         * last accepted point t); the sample at or before that is kept for
         * the interpolation, and samples within rounding of it (a jump) */
        double oldest_needed = t - c->dl.tau[k] - 16 * LF_EPS * fmax(1.0, fabs(t));
        if (c->dl.tau[k] == 0) continue; /* read at the current time, never from here */
        while (c->dl.hist_count[k] >= 2 && LF_HT(c, k, 1) < oldest_needed) {
            c->dl.hist_start[k] = (c->dl.hist_start[k] + 1) % LF_HIST_CAP;
            c->dl.hist_count[k]--;
            if (c->unsaved.hist_cursor[k] > 0) c->unsaved.hist_cursor[k]--;
        }
        if (!jump) hist_thin(c, k, t, g[k], g[LF_ND + k]);
        if (c->dl.hist_count[k] == LF_HIST_CAP) {
            history_full(c, k, t);
            return LF_DISCARD;
        }
        LF_HT(c, k, c->dl.hist_count[k]) = t;
        LF_HG(c, k, c->dl.hist_count[k]) = g[k];
        LF_HD(c, k, c->dl.hist_count[k]) = g[LF_ND + k];
        c->dl.hist_count[k]++;
        if (jump && c->dl.tau[k] > 0) add_breakpoint(c, t + c->dl.tau[k]);
    }
    return LF_OK;
}

LfStatus lf_hist_push(LfInstance *c, double t, const double *x, int jump) {
    double g[LF_DIM(2 * LF_ND)];
    LfStatus st;
    if (LF_ND == 0) return LF_OK;
    st = lf_hist_sample_end(c, t, x, g);
    if (st != LF_OK) return st;
    return hist_append(c, t, g, jump);
}

/* After an accepted step: the history up to its end, sampled on the dense
 * output (hermite) or only at the step's end (linear, the naive way). */

#define LF_HIST_MAX_DEPTH 12

/* -DLF_HIST_SKIPPING=0: a sample at every accepted step (tests compare) */
#ifndef LF_HIST_SKIPPING
#define LF_HIST_SKIPPING 1
#endif

/* -DLF_HIST_STATS: the accepted steps whose end was sampled or skipped,
 * printed to stderr at exit (tests/test_compose.py; one instance at a time) */
#ifdef LF_HIST_STATS
static long hs_sampled, hs_skipped;
static void __attribute__((destructor)) hs_print(void) {
    fprintf(stderr, "hist_stats: sampled %ld skipped %ld\n", hs_sampled, hs_skipped);
}
#define HSTAT(x) ((void)(x))
#else
#define HSTAT(x) ((void)0)
#endif

/* g and dg/dt at (t, x), for the history (g[0 .. LF_ND - 1] the values,
 * g[LF_ND ...] their time derivatives): the unknowns w (dg/dt needs x') and
 * the generated history function.  One per accepted step is the least a
 * history needs (the sample at the step's end); the C-level benchmark times
 * it (loomfmu bench limit: the limit of a delay model). */
LfStatus lf_hist_sample(LfInstance *c, double t, const double *x, double *g) {
    LfStatus st = lf_solve_w(c, t, x, c->unsaved.w_tmp);
    if (st != LF_OK) return st;
    return lf_eval_fn(c, LF_FN_HIST, t, x, c->unsaved.w_tmp, g, &g[LF_ND], NULL);
}

#ifdef LF_HISTOUT_FN
/* The point the generated functions see at (t, x) with w: the inputs at t
 * and their rates as lf_eval_fn passes them. */
static void inputs_of(LfInstance *c, double t, const double **u, const double **u_rate) {
    if (c->unsaved.u_poly) {
        lf_inputs_at(c, t, u, u_rate);
    } else {
        *u = &c->val.r[LF_VR_U0];
        *u_rate = c->unsaved.u_zero;
    }
}
#endif

/* lf_hist_sample at a step's end (or where the solver (re)starts), where
 * the outputs are likely read next at the same point: with the combined
 * function (LF_HISTOUT_FN) g, dg/dt and the outputs at once, the outputs
 * kept with their point (c->ho_*) for lf_hist_outputs.  The delayed values
 * d at t are those lf_eval_fn computes for the call (the history as it is
 * before this sample is appended). */
LfStatus lf_hist_sample_end(LfInstance *c, double t, const double *x, double *g) {
#ifdef LF_HISTOUT_FN
    double y[LF_DIM(LF_NY + LF_NZ)];
    const double *u, *u_rate;
    LfStatus st;
    c->unsaved.ho_valid = 0;
    st = lf_solve_w(c, t, x, c->unsaved.w_tmp);
    if (st != LF_OK) return st;
    if (lf_eval_fn(c, LF_FN_HISTOUT, t, x, c->unsaved.w_tmp, g, &g[LF_ND], y) != LF_OK) return LF_ERROR;
    if (lf_first_nonfinite(y, LF_NY + LF_NZ) >= 0) return LF_OK; /* reported where read */
    inputs_of(c, t, &u, &u_rate);
    c->unsaved.ho_t = t;
    memcpy(c->unsaved.ho_x, x, sizeof(double) * LF_NX);
    memcpy(c->unsaved.ho_u, u, sizeof(double) * LF_NU);
    memcpy(c->unsaved.ho_ur, u_rate, sizeof(double) * LF_NU);
    memcpy(c->unsaved.ho_p, &c->val.r[LF_VR_P0], sizeof(double) * LF_NP);
    memcpy(c->unsaved.ho_q, c->val.q, sizeof(double) * LF_NQ);
    memcpy(c->unsaved.ho_d, c->dl.dval, sizeof(double) * LF_ND);
    memcpy(c->unsaved.ho_w, c->unsaved.w_tmp, sizeof(double) * LF_NW);
    memcpy(c->unsaved.ho_y, y, sizeof(double) * (LF_NY + LF_NZ));
    c->unsaved.ho_valid = 1;
    return LF_OK;
#else
    return lf_hist_sample(c, t, x, g);
#endif
}

/* The outputs kept by lf_hist_sample_end, if they are those of the
 * instance's point now (t, the states, inputs and their rates, parameters,
 * modes and the delayed values at t, and w if given: implicit models' w
 * depends on Newton's start) bit for bit: copied to y, 1; else 0.  Explicit
 * models (w NULL): w_tmp and w_cur are set to the kept w, as the solve
 * there would set them. */
int lf_hist_outputs(LfInstance *c, const double *w, double *y) {
#ifdef LF_HISTOUT_FN
    const double *x = &c->val.r[LF_VR_X0], *u, *u_rate;
    if (!c->unsaved.ho_valid || memcmp(&c->unsaved.ho_t, &c->run.t, sizeof c->run.t) ||
        memcmp(c->unsaved.ho_x, x, sizeof(double) * LF_NX) ||
        memcmp(c->unsaved.ho_p, &c->val.r[LF_VR_P0], sizeof(double) * LF_NP) ||
        memcmp(c->unsaved.ho_q, c->val.q, sizeof(double) * LF_NQ))
        return 0;
    inputs_of(c, c->run.t, &u, &u_rate);
    if (memcmp(c->unsaved.ho_u, u, sizeof(double) * LF_NU) ||
        memcmp(c->unsaved.ho_ur, u_rate, sizeof(double) * LF_NU))
        return 0;
    if (w && memcmp(c->unsaved.ho_w, w, sizeof(double) * LF_NW)) return 0;
    if (lf_delayed_values(c, c->run.t, x) != LF_OK ||
        memcmp(c->unsaved.ho_d, c->dl.dval, sizeof(double) * LF_ND))
        return 0;
    if (!w) {
        memcpy(c->unsaved.w_tmp, c->unsaved.ho_w, sizeof(double) * LF_NW);
        memcpy(c->val.w_cur, c->unsaved.ho_w, sizeof(double) * LF_NW);
    }
    memcpy(y, c->unsaved.ho_y, sizeof(double) * (LF_NY + LF_NZ));
    return 1;
#else
    (void)c;
    (void)w;
    (void)y;
    return 0;
#endif
}

/* Does the cubic Hermite through the end samples miss g (a sample at
 * th * h) by more than the solver's tolerance times `scale`? */
static int hermite_misses(const LfInstance *c, const double *ga, const double *gb, double h,
                          double th, const double *g, double scale) {
    int k;
    for (k = 0; k < LF_ND; k++) {
        double herm;
        if (c->dl.tau[k] == 0) continue;
        herm = hermite(ga[k], ga[LF_ND + k], gb[k], gb[LF_ND + k], h, th);
        if (fabs(herm - g[k]) > scale * (c->solver.opt.atol + c->solver.opt.rtol * fabs(g[k])))
            return 1;
    }
    return 0;
}

/* g at th * h of the accepted step from ta, on the solver's dense output */
static LfStatus sample_inside(LfInstance *c, double ta, double h, double th, double *g) {
    double x[LF_DIM(LF_NX)], t = ta + th * h;
    c->solver.method->dense(&c->solver, t, x);
    return lf_hist_sample(c, t, x, g);
}

/* The history's error estimated from the samples already held, without
 * evaluating g inside the step.  The quintic Hermite P through the sample
 * before the step's start (tp), the start (ta) and the end (tb), values and
 * slopes, is two orders more accurate than the cubic Hermite H through ta,
 * tb; P - H, which vanishes doubly at ta and tb, estimates H's error (even
 * and odd parts about the midpoint alike): P - H = Q(th) (m0 + m1 (th - thp))
 * with Q(th) = th^2 (th - 1)^2 and m0, m1 fixed by P's value and slope at tp.
 * Where g is resolved by the samples this matches the error measured on the
 * dense output to a few per cent; where it is not (g varying within a step),
 * the samples no longer join as one quintic and the estimate is of the
 * order of g's variation, i.e. far above the tolerance.  Trusted only with
 * LF_HIST_EST_MARGIN to spare and with the neighbouring intervals of
 * comparable length (LF_HIST_EST_RATIO); elsewhere the error is measured on
 * the dense output (hist_refine). */
#define LF_HIST_EST_MARGIN 0.125
#define LF_HIST_EST_RATIO 4.0

/* P - H = Q(th) (m0 + m1 (th - thp)) over the interval from a (value ga,
 * slope da) to b (gb, db) of length h, with the sample before a (gp, dp) at
 * thp = (t_p - t_a) / h < 0 (see above): m0, m1. */
static void quintic_terms(double gp, double dp, double thp, double ga, double da, double gb,
                          double db, double h, double *m0, double *m1) {
    double q = thp * thp * (thp - 1) * (thp - 1);
    double dq = 2 * thp * (thp - 1) * (2 * thp - 1);
    double r0 = gp - hermite(ga, da, gb, db, h, thp);
    double r1 = h * dp - ((6 * thp * thp - 6 * thp) * (ga - gb) +
                          h * ((3 * thp * thp - 4 * thp + 1) * da + (3 * thp * thp - 2 * thp) * db));
    *m0 = r0 / q;
    *m1 = (r1 - dq * *m0) / q;
}

/* Is the estimated error of the cubic Hermite over the accepted step
 * (ta, tb] (samples ga, gb) at the quarter points within
 * LF_HIST_EST_MARGIN x LF_HIST_QUARTER_SCALE x the tolerance, for every
 * delay > 0?  0 where it cannot be estimated: no sample before ta, a jump
 * at ta (two samples there), or intervals of too unequal lengths. */
static int estimate_fine(const LfInstance *c, double ta, const double *ga, double tb,
                         const double *gb) {
    static const double th[2] = {0.25, 0.75};
    double h = tb - ta;
    int k, i;
    for (k = 0; k < LF_ND; k++) {
        long n = c->dl.hist_count[k];
        double tp, thp, m0, m1;
        if (c->dl.tau[k] == 0) continue;
        if (n < 2) return 0;
        tp = LF_HT(c, k, n - 2); /* the sample at ta is n - 1 */
        if (LF_HT(c, k, n - 1) != ta || !(tp < ta) || ta - tp > LF_HIST_EST_RATIO * h || LF_HIST_EST_RATIO * (ta - tp) < h)
            return 0;
        thp = (tp - ta) / h;
        quintic_terms(LF_HG(c, k, n - 2), LF_HD(c, k, n - 2), thp, ga[k], ga[LF_ND + k], gb[k],
                      gb[LF_ND + k], h, &m0, &m1);
        for (i = 0; i < 2; i++) {
            double e = 0.03515625 * (m0 + m1 * (th[i] - thp)); /* Q(1/4) = Q(3/4) = 9/256 */
            double g = hermite(ga[k], ga[LF_ND + k], gb[k], gb[LF_ND + k], h, th[i]);
            if (!(fabs(e) <= LF_HIST_EST_MARGIN * LF_HIST_QUARTER_SCALE *
                                 (c->solver.opt.atol + c->solver.opt.rtol * fabs(g))))
                return 0;
        }
    }
    return 1;
}

/* Sample the history inside the accepted step (ta, tb] on the solver's dense
 * output: bisect while the cubic Hermite through the end samples misses g
 * at the quarter points by more than LF_HIST_QUARTER_SCALE times the
 * solver's tolerance, then push the samples in time order (tb last).  ga,
 * gb: samples at ta, tb.  (The midpoint alone is blind to a deviation odd
 * about it: a signal of many harmonics, such as the drive's cam, once gave
 * a 3e-4 relative error at rtol 1e-6 that way.)  The midpoint is sampled
 * only where the interval is split.  An interval whose error estimated from
 * the samples held is far below the tolerance (estimate_fine) is pushed
 * without sampling inside it: in the drive's verification run every step
 * (one evaluation of g per step, the sample at its end). */
static LfStatus hist_refine(LfInstance *c, double ta, const double *ga, double tb,
                            const double *gb, int depth) {
    double gm[LF_DIM(2 * LF_ND)], gq[LF_DIM(2 * LF_ND)], h = tb - ta;
    int i, fine = 1;
    LfStatus st;
    if (depth >= LF_HIST_MAX_DEPTH || estimate_fine(c, ta, ga, tb, gb))
        return hist_append(c, tb, gb, 0);
    for (i = 0; i < 2 && fine; i++) {
        double th = i == 0 ? 0.25 : 0.75;
        st = sample_inside(c, ta, h, th, gq);
        if (st != LF_OK) return st;
        fine = !hermite_misses(c, ga, gb, h, th, gq, LF_HIST_QUARTER_SCALE);
    }
    if (fine) return hist_append(c, tb, gb, 0);
    st = sample_inside(c, ta, h, 0.5, gm);
    if (st != LF_OK) return st;
    st = hist_refine(c, ta, ga, ta + 0.5 * h, gm, depth + 1);
    if (st != LF_OK) return st;
    return hist_refine(c, ta + 0.5 * h, gm, tb, gb, depth + 1);
}

/* The samples at the step's start as the history holds them (the last
 * sample of every delay > 0, taken at t_old when the step before ended or
 * the solver restarted): 1, or 0 if some delay's last sample is not at
 * t_old. */
static int stored_start(const LfInstance *c, double t_old, double *ga) {
    int k;
    for (k = 0; k < LF_ND; k++) {
        long n = c->dl.hist_count[k];
        ga[k] = 0.0;
        ga[LF_ND + k] = 0.0;
        if (c->dl.tau[k] == 0) continue;
        if (n == 0 || LF_HT(c, k, n - 1) != t_old) return 0;
        ga[k] = LF_HG(c, k, n - 1);
        ga[LF_ND + k] = LF_HD(c, k, n - 1);
    }
    return 1;
}

/* Sampling the history at every accepted step is more than a slow delayed
 * signal needs where the steps are set by a fast part of the model (a
 * drive composed with a rotor: 5 us steps against a 0.5 s delay of a cam
 * signal that samples a millisecond apart resolve).  A step's end is not
 * sampled when, for every delay > 0,
 *  - the step is shorter than tau / LF_HIST_SKIP_MIN_STEPS (models whose
 *    steps are as long as their history needs never skip: the drive alone
 *    keeps every sample, bit for bit as before; so does x' = -x(t - tau)
 *    down to rtol 1e-13 (tests/test_delay_convergence.py), whose solution's
 *    derivatives jump at multiples of tau, unseen by the samples before),
 *  - the interval from the last sample stays shorter than the spacing the
 *    last intervals' error estimate allows (the quintic estimate of
 *    estimate_fine, which scales as h^4, at LF_HIST_SKIP_SAFETY of the
 *    tolerance; at most LF_HIST_SKIP_GROWTH times the last interval and
 *    LF_HIST_SKIP_MAX_SPACING tau) and than tau minus LF_HIST_SKIP_ROOM
 *    steps of the current size (the equations never read past the last
 *    sample: t - tau before its time),
 * and the history's last three samples are ordinary (no jump).  The
 * decision uses the samples held only, so a restored FMU state continues
 * bit for bit.  The sample after skipped ones is appended at the step's end
 * (the interval's error is the one the estimate allowed; there is no dense
 * output before the step's start to refine it). */
#define LF_HIST_SKIP_MIN_STEPS 1e4
#define LF_HIST_SKIP_MAX_SPACING (1.0 / 64)
#define LF_HIST_SKIP_SAFETY 0.25
#define LF_HIST_SKIP_GROWTH 2.0
#define LF_HIST_SKIP_ROOM 16.0

/* The interval from the last sample of delay k its last two intervals'
 * estimate allows (0: none, e.g. fewer than three samples or a jump). */
static double allowed_spacing(const LfInstance *c, int k) {
    long n = c->dl.hist_count[k];
    double t0, t1, t2, h, hp, thp, m0, m1, e, g2, tol, ratio;
    if (n < 3) return 0.0;
    t0 = LF_HT(c, k, n - 3);
    t1 = LF_HT(c, k, n - 2);
    t2 = LF_HT(c, k, n - 1);
    h = t2 - t1;
    hp = t1 - t0;
    if (!(h > 0) || !(hp > 0) || hp > LF_HIST_EST_RATIO * h || LF_HIST_EST_RATIO * hp < h)
        return 0.0;
    g2 = LF_HG(c, k, n - 1);
    thp = (t0 - t1) / h;
    quintic_terms(LF_HG(c, k, n - 3), LF_HD(c, k, n - 3), thp, LF_HG(c, k, n - 2),
                  LF_HD(c, k, n - 2), g2, LF_HD(c, k, n - 1), h, &m0, &m1);
    /* the larger of the estimates at the quarter points */
    e = 0.03515625 * fmax(fabs(m0 + m1 * (0.25 - thp)), fabs(m0 + m1 * (0.75 - thp)));
    tol = LF_HIST_SKIP_SAFETY * LF_HIST_QUARTER_SCALE *
          (c->solver.opt.atol + c->solver.opt.rtol * fabs(g2));
    if (!isfinite(e)) return 0.0;
    ratio = e > 0 ? sqrt(sqrt(tol / e)) : LF_HIST_SKIP_GROWTH;
    return h * fmin(ratio, LF_HIST_SKIP_GROWTH);
}

/* May the history skip the sample at the end of the step just accepted? */
static int may_skip(const LfInstance *c) {
    const LfSolver *s = &c->solver;
    int k, any = 0;
    for (k = 0; k < LF_ND; k++) {
        long n = c->dl.hist_count[k];
        double since;
        if (c->dl.tau[k] == 0) continue;
        if (n < 3 || s->t - s->t_old > c->dl.tau[k] / LF_HIST_SKIP_MIN_STEPS) return 0;
        since = s->t - LF_HT(c, k, n - 1);
        if (!(since > 0) ||
            since + LF_HIST_SKIP_ROOM * (s->t - s->t_old) > c->dl.tau[k] ||
            !(since < allowed_spacing(c, k)) ||
            !(since < LF_HIST_SKIP_MAX_SPACING * c->dl.tau[k]))
            return 0;
        any = 1;
    }
    return any;
}

/* The last sample of every delay > 0, when all are at one time (the history
 * sampled there); else returns 0. */
static int last_samples(const LfInstance *c, double *t_last, double *ga) {
    int k, first = 1;
    for (k = 0; k < LF_ND; k++) {
        long n = c->dl.hist_count[k];
        ga[k] = 0.0;
        ga[LF_ND + k] = 0.0;
        if (c->dl.tau[k] == 0) continue;
        if (n == 0 || (!first && LF_HT(c, k, n - 1) != *t_last)) return 0;
        *t_last = LF_HT(c, k, n - 1);
        first = 0;
        ga[k] = LF_HG(c, k, n - 1);
        ga[LF_ND + k] = LF_HD(c, k, n - 1);
    }
    return !first;
}

LfStatus lf_hist_step(LfInstance *c, int skippable) {
    double ga[LF_DIM(2 * LF_ND)], gb[LF_DIM(2 * LF_ND)], t_last = 0.0;
    LfSolver *s = &c->solver;
    int k = 0;
    LfStatus st;
    while (k < LF_ND && c->dl.tau[k] == 0) k++;
    if (k == LF_ND) return LF_OK; /* only zero delays: no history is kept */
    if (c->dl.delay_interp == LF_DELAY_LINEAR || !(s->t > s->t_old))
        return lf_hist_push(c, s->t, s->x, 0);
    if (skippable && LF_HIST_SKIPPING && may_skip(c)) {
        HSTAT(hs_skipped++);
        return LF_OK;
    }
    HSTAT(hs_sampled++);
    if (stored_start(c, s->t_old, ga)) {
        st = lf_hist_sample_end(c, s->t, s->x, gb);
        if (st != LF_OK) return st;
        return hist_refine(c, s->t_old, ga, s->t, gb, 0);
    }
    if (!last_samples(c, &t_last, ga) || !(t_last < s->t_old))
        return lf_hist_push(c, s->t, s->x, 0);
    /* after skipped samples (see LF_HIST_SKIP_MIN_STEPS) */
    st = lf_hist_sample_end(c, s->t, s->x, gb);
    if (st != LF_OK) return st;
    return hist_append(c, s->t, gb, 0);
}

/* Delays from the parameters; each must fit the history the FMU holds. */
LfStatus lf_init_delays(LfInstance *c, LfSolverOptions *opt) {
    int k;
    if (LF_ND == 0) return LF_OK;
    if (lf_eval_fn(c, LF_FN_TAU, c->run.t, &c->val.r[LF_VR_X0], c->val.w_cur, c->dl.tau, NULL, NULL) != LF_OK)
        return LF_ERROR;
    for (k = 0; k < LF_ND; k++) {
        if (!(c->dl.tau[k] >= 0) || c->dl.tau[k] > lf_model.delay_max[k]) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR,
                   "delay %s = %g s: allowed 0 ... %g s, the longest delay this FMU's "
                   "history was built to hold (rebuild with a larger max_delay)",
                   lf_model.delay_names[k], c->dl.tau[k], lf_model.delay_max[k]);
            return LF_ERROR;
        }
        /* a step longer than the delay would need history not yet computed */
        if (c->dl.tau[k] > 0 && opt->h_max > c->dl.tau[k]) opt->h_max = c->dl.tau[k];
        if (c->dl.tau[k] > 0 && opt->h_fixed > c->dl.tau[k]) {
            lf_log(c, LF_WARNING, LF_LOG_WARNING,
                   "solver_h_fixed = %g s is longer than delay %s = %g s: rk4 steps are "
                   "limited to the delay", opt->h_fixed, lf_model.delay_names[k], c->dl.tau[k]);
            opt->h_fixed = c->dl.tau[k];
        }
    }
    return LF_OK;
}
