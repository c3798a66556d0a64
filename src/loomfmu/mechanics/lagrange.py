"""Symbolic mechanics on CasADi: Lagrange's equations of the second kind and
generalized forces from virtual work.

Generalized forces are taken from the power of the applied forces,
P = sum F.v + sum M.omega, which is linear in the generalized velocities:
Q_i = dP/d(qdot_i) is then the virtual work per unit delta q_i.
"""
from __future__ import annotations

import casadi as ca


def _check_sx(name: str, value, n: int | None = None) -> ca.SX:
    """A CasADi SX expression (column) with n elements (if given)."""
    if not isinstance(value, ca.SX):
        raise ValueError(f"{name} = {value!r:.60}; allowed: a CasADi SX expression")
    if n is not None and value.numel() != n:
        raise ValueError(f"{name}: {value.numel()} elements; allowed: {n}")
    return value


def _check_symbols(name: str, value) -> ca.SX:
    value = _check_sx(name, value)
    if not value.is_valid_input():
        raise ValueError(f"{name} = {value!r:.60}; allowed: a vector of pure symbols")
    return value


def generalized_forces(power: ca.SX, qdot: ca.SX) -> ca.SX:
    """Q = dP/dqdot for a power P linear in the generalized velocities."""
    _check_sx("power", power, 1)
    _check_symbols("qdot", qdot)
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
    _check_sx("T", T, 1)
    _check_sx("V", V, 1)
    n = _check_symbols("q", q).numel()
    _check_symbols("qdot", qdot)
    _check_sx("qdot", qdot, n)
    _check_sx("qddot", qddot, n)
    _check_sx("Q", Q, n)
    L = T - V
    p = ca.jacobian(L, qdot).T  # generalized momenta
    dp_dt = ca.jacobian(p, qdot) @ qddot + ca.jacobian(p, q) @ qdot
    return dp_dt - ca.jacobian(L, q).T - Q
