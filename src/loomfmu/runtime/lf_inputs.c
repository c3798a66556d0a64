/* loomfmu shared runtime: inputs interpolated inside the step (FMI 2.0
 * fmi2SetRealInputDerivatives, canInterpolateInputs); the outputs' time
 * derivatives are lf_outputs.c's.  Calls only lf_base.c (logging).
 *
 * Input k is the polynomial
 *     u_k(t) = r[LF_VR_U0 + k] + u_d1[k] s + u_d2[k] s^2 / 2,  s = t - u_t0[k],
 * anchored at the communication point where its value or a derivative was
 * last set (FMI 2.0: inputs and their derivatives are set with respect to
 * the beginning of a communication step).  fmi2SetReal of an input sets its
 * value and resets both derivatives to 0 (held from there on); setting a
 * derivative first moves the anchor to the current time (value and slope of
 * the polynomial there), then replaces that order's coefficient.  Nothing
 * else changes them: after fmi2DoStep the polynomial continues, so a master
 * that sets nothing gets the same input curve on.
 *
 * Every generated function sees u(t) and du/dt at its own t (lf_eval_fn):
 * the solvers' stages, rodas4's df/dt, event location on the dense output,
 * the delays' history and its slope. */
#include <math.h>
#include <string.h>

#include "lf_inputs.h"
#include "lf_base.h"
#include "lf_instance.h"
#include "lf_internal.h"

#define LF_INPUT_ORDER_MAX 2

static int input_index(unsigned vr) { return (int)vr - (int)LF_VR_U0; }

static void poly_flag(LfInstance *c) {
    int k;
    c->unsaved.u_poly = 0;
    for (k = 0; k < LF_NU; k++)
        if (c->in.u_d1[k] != 0 || c->in.u_d2[k] != 0) c->unsaved.u_poly = 1;
}

/* value and slope of input k at t */
static double input_at(const LfInstance *c, int k, double t, double *slope) {
    double s = t - c->in.u_t0[k];
    *slope = c->in.u_d1[k] + c->in.u_d2[k] * s;
    return c->val.r[LF_VR_U0 + k] + s * (c->in.u_d1[k] + 0.5 * c->in.u_d2[k] * s);
}

void lf_inputs_reset(LfInstance *c, double t0) {
    int k;
    for (k = 0; k < LF_DIM(LF_NU); k++) {
        c->in.u_d1[k] = c->in.u_d2[k] = c->unsaved.u_zero[k] = c->unsaved.u_rate[k] = 0.0;
        c->in.u_t0[k] = t0;
    }
    c->unsaved.u_poly = 0;
    lf_inputs_seen(c);
}

void lf_inputs_at(LfInstance *c, double t, const double **u, const double **rate) {
    int k;
    if (!c->unsaved.u_poly) {
        *u = &c->val.r[LF_VR_U0];
        *rate = c->unsaved.u_zero;
        return;
    }
    for (k = 0; k < LF_NU; k++) c->unsaved.u_now[k] = input_at(c, k, t, &c->unsaved.u_rate[k]);
    *u = c->unsaved.u_now;
    *rate = c->unsaved.u_rate;
}

double lf_input_now(const LfInstance *c, unsigned vr) {
    double slope;
    return input_at(c, input_index(vr), c->run.t, &slope);
}

/* Anchor input k at the current time (same polynomial, new origin). */
static void rebase(LfInstance *c, int k) {
    double slope, value = input_at(c, k, c->run.t, &slope);
    c->val.r[LF_VR_U0 + k] = value;
    c->in.u_d1[k] = slope;
    c->in.u_t0[k] = c->run.t;
}

void lf_input_set(LfInstance *c, unsigned vr, double value) {
    int k = input_index(vr);
    if (value != lf_input_now(c, vr)) c->run.inputs_changed = 1;
    c->val.r[vr] = value;
    c->in.u_d1[k] = c->in.u_d2[k] = 0.0;
    c->in.u_t0[k] = c->run.t;
    c->run.outputs_valid = 0;
    poly_flag(c);
}

LfStatus lf_input_derivative_check(LfInstance *c, unsigned vr, int order, double value) {
    if (vr >= LF_NREAL || lf_model.real_kind[vr] != LF_KIND_INPUT) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi2SetRealInputDerivatives: value "
               "reference %u is not a Real input (inputs: %u ... %u); nothing set", c->run.t, vr,
               (unsigned)LF_VR_U0, (unsigned)(LF_VR_U0 + LF_NU - 1));
        return LF_ERROR;
    }
    if (order < 1 || order > LF_INPUT_ORDER_MAX) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi2SetRealInputDerivatives: order = %d "
               "for input %s; allowed 1 ... %d (0 is not allowed by FMI 2.0; this FMU "
               "interpolates inputs up to order %d); nothing set", c->run.t, order,
               lf_model.real_names[vr], LF_INPUT_ORDER_MAX, LF_INPUT_ORDER_MAX);
        return LF_ERROR;
    }
    if (!isfinite(value)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: fmi2SetRealInputDerivatives: derivative "
               "of order %d of input %s = %g, expected a finite value; nothing set", c->run.t,
               order, lf_model.real_names[vr], value);
        return LF_ERROR;
    }
    return LF_OK;
}

void lf_input_derivative_set(LfInstance *c, unsigned vr, int order, double value) {
    int k = input_index(vr);
    rebase(c, k);
    if (order == 1) c->in.u_d1[k] = value;
    else c->in.u_d2[k] = value;
    c->run.outputs_valid = 0;
    poly_flag(c);
}

/* ---- restarts ------------------------------------------------------------ */

/* (the larger magnitude written out: fmax is a library call, and this runs
 * at every communication point) */
static int differ(double a, double b) {
    double fa = fabs(a), fb = fabs(b);
    return fabs(a - b) > 4 * LF_EPS * (fa > fb ? fa : fb);
}

/* Did any input's value, slope or second derivative at c->run.t change since
 * the solver last started (lf_inputs_seen)?  Rounding-level differences (a
 * master that sets u(t_c) computed its own way) do not count.  An input
 * held now and then (no derivatives) has moved iff its value differs: the
 * polynomials below reduce to that exactly. */
int lf_inputs_moved(LfInstance *c) {
    int k;
    for (k = 0; k < LF_NU; k++) {
        double dt, slope, value, old;
        if (!c->unsaved.u_poly && c->in.seen_d1[k] == 0 && c->in.seen_d2[k] == 0) {
            /* (equal values: the common case, decided without differ) */
            if (c->val.r[LF_VR_U0 + k] != c->in.seen_u[k] && differ(c->val.r[LF_VR_U0 + k], c->in.seen_u[k]))
                return 1;
            continue;
        }
        dt = c->run.t - c->in.seen_t;
        value = input_at(c, k, c->run.t, &slope);
        old = c->in.seen_u[k] + dt * (c->in.seen_d1[k] + 0.5 * c->in.seen_d2[k] * dt);
        if (differ(value, old) || differ(slope, c->in.seen_d1[k] + c->in.seen_d2[k] * dt) ||
            c->in.u_d2[k] != c->in.seen_d2[k])
            return 1;
    }
    return 0;
}

void lf_inputs_seen(LfInstance *c) {
    int k;
    for (k = 0; k < LF_NU; k++) {
        c->in.seen_u[k] = input_at(c, k, c->run.t, &c->in.seen_d1[k]);
        c->in.seen_d2[k] = c->in.u_d2[k];
    }
    c->in.seen_t = c->run.t;
}

