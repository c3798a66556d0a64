"""Symbolic mechanics on CasADi: Lagrange's equations of the second kind and
generalized forces from virtual work.

Generalized forces are taken from the power of the applied forces,
P = sum F.v + sum M.omega, which is linear in the generalized velocities:
Q_i = dP/d(qdot_i) is then the virtual work per unit delta q_i.
"""
from __future__ import annotations

import casadi as ca


def generalized_forces(power: ca.SX, qdot: ca.SX) -> ca.SX:
    """Q = dP/dqdot for a power P linear in the generalized velocities."""
    if ca.depends_on(ca.jacobian(power, qdot), qdot):
        raise ValueError("power must be linear in the generalized velocities qdot")
    return ca.jacobian(power, qdot).T


def lagrange_equations(T: ca.SX, V: ca.SX, q: ca.SX, qdot: ca.SX, qddot: ca.SX,
                       Q: ca.SX) -> ca.SX:
    """Residuals d/dt(dL/dqdot) - dL/dq - Q of Lagrange's equations, L = T - V.

    qddot: the symbols standing for the generalized accelerations (e.g.
    ``model.der(qdot)``).  The total time derivative is expanded by the chain
    rule through q and qdot (T and V must not depend on time explicitly).
    """
    L = T - V
    p = ca.jacobian(L, qdot).T  # generalized momenta
    dp_dt = ca.jacobian(p, qdot) @ qddot + ca.jacobian(p, q) @ qdot
    return dp_dt - ca.jacobian(L, q).T - Q
