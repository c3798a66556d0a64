/* loomfmu shared runtime: exact directional derivatives of the unknowns
 * (state derivatives, outputs, algebraic locals) with respect to the knowns
 * (states, inputs), from CasADi's symbolic Jacobians (codegen: wjac/rjac,
 * djac, dirj).  Version independent: the FMI 2.0 and 3.0 facades call it
 * (fmi2GetDirectionalDerivative, fmi3GetDirectionalDerivative) after
 * checking their own state machine. */
#ifndef LF_DIRDER_H
#define LF_DIRDER_H

#include <stddef.h>

#include "lf_instance.h"

/* out[i] = sum_j d(unknown_vr[i]) / d(known_vr[j]) seed[j], exact, at the
 * instance's current point: time c->run.t, the states r[LF_VR_X0..], the inputs
 * at c->run.t (held values or their polynomials), the modes and parameters.
 * Delayed values with tau = 0 are differentiated through (d = g(t, x, u)),
 * those with tau > 0 are held (they depend on the past only).
 *
 * Value references: the runtime's Real vr (lf_model.h), and der(x_k) =
 * LF_NREAL + k (the FMI model descriptions' numbering):
 *   unknowns: der(x_k), outputs and algebraic locals (LF_VR_Y0 .. LF_NREAL-1);
 *   knowns:   states (LF_VR_X0 ..) and inputs (LF_VR_U0 ..).
 * A known listed twice adds its seeds.
 *
 * LF_ERROR with a log naming the bad argument and the allowed ranges, out
 * untouched: any other vr, NULL arrays with n > 0, a non-finite seed, nu or
 * nk above 16 (LF_NREAL + LF_NX) + 16 (the getters' bound; nothing read).
 * LF_DISCARD with a log and the time: the equations cannot be solved at
 * this point (Newton fails, dF/dw singular) or a derivative is not finite.
 * Before initialization the point is the start values (as for outputs).
 * Changes nothing the trajectory depends on. */
LfStatus lf_directional_derivative(LfInstance *c, const unsigned *unknown_vr, size_t nu,
                                   const unsigned *known_vr, size_t nk, const double *seed,
                                   double *out);

#endif
