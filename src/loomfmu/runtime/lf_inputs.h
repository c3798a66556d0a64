/* loomfmu shared runtime: inputs as polynomials of time (lf_inputs.c):
 * set by the importer with their derivatives, interpolated, and the change
 * the solver's restart depends on. */
#ifndef LF_INPUTS_H
#define LF_INPUTS_H

#include "lf_instance.h"

/* Inputs interpolated by their time derivatives: start at t0. */
void lf_inputs_reset(LfInstance *c, double t0);
/* Input vr (an input's value reference) at the current time c->run.t. */
double lf_input_now(const LfInstance *c, unsigned vr);
/* fmi2SetReal of input vr: the new value holds from c->run.t on, its
 * derivatives are reset to 0 (FMI 2.0: set with respect to the
 * communication point where they are set). */
void lf_input_set(LfInstance *c, unsigned vr, double value);
/* Is (vr, order, value) a valid input derivative? (logs why not) */
LfStatus lf_input_derivative_check(LfInstance *c, unsigned vr, int order, double value);
void lf_input_derivative_set(LfInstance *c, unsigned vr, int order, double value);

/* The inputs (u, du/dt) at time t: the instance's values, or
 * their polynomials; did they change since the solver last started? */
void lf_inputs_at(LfInstance *c, double t, const double **u, const double **rate);
int lf_inputs_moved(LfInstance *c);
/* The common case of lf_inputs_moved, inline: 1 if every input is held now
 * and was held when the solver last started, at a value equal to the one it
 * had then: nothing moved.  0 leaves the answer to
 * lf_inputs_moved. */
static inline int lf_inputs_still(const LfInstance *c) {
    int k;
    if (c->unsaved.u_poly) return 0;
    for (k = 0; k < LF_NU; k++)
        if (c->val.r[LF_VR_U0 + k] != c->in.seen_u[k] || c->in.seen_d1[k] != 0 || c->in.seen_d2[k] != 0)
            return 0;
    return 1;
}
void lf_inputs_seen(LfInstance *c);

#endif
