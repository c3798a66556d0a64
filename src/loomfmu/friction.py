"""Coulomb friction in a joint, with a stick/slip state machine written once.

Like the Modelica Standard Library's ``PartialFriction``, the mode logic is
shared and each joint supplies only its friction law: the relative speed (a
state), its acceleration (``der`` of that state), the friction torque (an
algebraic unknown) and the normal force that scales the friction, which may
depend on accelerations (an algebraic loop the FMU solves by Newton).

Modes (named constants):

* ``STUCK`` (0): the relative acceleration is zero and the friction torque is
  whatever keeps it so; consistent while |torque| <= r_static * normal.
* ``FORWARD`` (+1) / ``BACKWARD`` (-1): torque = -mode * r_kinetic * normal;
  consistent while mode * speed > 0 (or, at speed zero, mode * accel >= 0).

Switching: while slipping, the event indicator is the speed (a zero crossing
means the joint may stick); while stuck, it is r_static * normal - |torque|
(it crosses zero at breakaway).  At each event the runtime takes the first
consistent mode in the priority order STUCK, FORWARD, BACKWARD (static
friction holds where it can) and reinitializes a stuck joint's speed to zero.

``SPEED_TOL``: below this relative speed (in the joint's speed unit) a
slipping joint's consistency is judged by its acceleration; the speed right
after a located event is of the order accel * 1e-12 s, far below it.  Change
it only for joints whose speeds are of order 1e-8 themselves.
"""
from __future__ import annotations

import casadi as ca

from .checks import check_number
from .declare import Model


def _coefficient(name: str, value):
    """A friction radius/coefficient: an expression (a parameter) or a number >= 0."""
    if isinstance(value, (ca.SX, ca.MX)):
        return value
    return check_number(name, value, lo=0.0)

STUCK, FORWARD, BACKWARD = 0, 1, -1
MODE_LABELS = {STUCK: "stuck", FORWARD: "forward", BACKWARD: "backward"}
SPEED_TOL = 1e-8


def coulomb_joint(m: Model, name: str, *, speed: ca.SX, torque: ca.SX, normal,
                  r_kinetic, r_static, start: int = STUCK,
                  regularized_eps=None) -> ca.SX | None:
    """Add the friction law of joint ``name``; return its mode symbol.

    speed: the state holding the joint's relative speed; its ``der`` is the
    relative acceleration.  torque: the algebraic variable for the friction
    torque (or force) acting on that relative coordinate.  normal: |reaction|.
    r_kinetic, r_static: friction radii (or coefficients) in slip and stick.
    regularized_eps: if given, no modes: torque = -r_kinetic normal
    tanh(speed / eps), the smooth variant whose cost and error can be charted
    against the event-driven one; returns None.
    """
    if not isinstance(m, Model):
        raise ValueError(f"m = {m!r:.60}; allowed: a loomfmu Model")
    for arg, sym in (("speed", speed), ("torque", torque)):
        if not (isinstance(sym, ca.SX) and sym.is_symbolic() and sym.numel() == 1):
            raise ValueError(f"{arg} = {sym!r:.60}; allowed: one declared variable's symbol")
    r_kinetic = _coefficient("r_kinetic", r_kinetic)
    r_static = _coefficient("r_static", r_static)
    if isinstance(r_kinetic, float) and isinstance(r_static, float) and r_static < r_kinetic:
        raise ValueError(f"r_static = {r_static!r}, r_kinetic = {r_kinetic!r}; allowed: "
                         "r_static >= r_kinetic (static friction holds at least as much)")
    if regularized_eps is not None and not isinstance(regularized_eps, (ca.SX, ca.MX)):
        regularized_eps = check_number("regularized_eps", regularized_eps, lo=0.0,
                                       lo_open=True)
    if start not in (STUCK, FORWARD, BACKWARD) or isinstance(start, bool):
        raise ValueError(f"start = {start!r}; allowed: STUCK (0), FORWARD (1), BACKWARD (-1)")
    accel = m.der(speed)
    if regularized_eps is not None:
        m.eq(torque, -r_kinetic * normal * ca.tanh(speed / regularized_eps))
        return None
    q = m.mode(f"mode_{name}", start, (STUCK, FORWARD, BACKWARD),
               description=f"friction mode of joint {name}: 0 stuck, 1 forward, -1 backward")
    stuck = q == STUCK
    m.eq(ca.if_else(stuck, accel, torque + q * r_kinetic * normal))
    margin = r_static * normal - ca.fabs(torque)
    m.event(f"switch_{name}", ca.if_else(stuck, margin, speed),
            description=f"joint {name}: speed crosses zero (slipping) or breakaway (stuck)")
    slip_ok = q * ca.if_else(ca.fabs(speed) < SPEED_TOL, accel, speed)
    m.mode_rule(q, ca.if_else(stuck, margin, slip_ok), events=[f"switch_{name}"])
    m.reinit(speed, ca.if_else(stuck, 0, speed))
    return q
