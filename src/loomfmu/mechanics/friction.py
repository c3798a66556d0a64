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

from loomfmu.declare.checks import check_number
from loomfmu.declare.model import Model


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
                  regularized_eps=None, tex: str = "", source: str = "") -> ca.SX | None:
    """Add the friction law of joint ``name``; return its mode symbol.

    speed: the state holding the joint's relative speed; its ``der`` is the
    relative acceleration.  torque: the algebraic variable for the friction
    torque (or force) acting on that relative coordinate.  normal: |reaction|.
    r_kinetic, r_static: friction radii (or coefficients) in slip and stick.
    regularized_eps: if given, no modes: torque = -r_kinetic normal
    tanh(speed / eps), the smooth variant whose cost and error can be charted
    against the event-driven one; returns None.
    tex: the joint's LaTeX subscript in the derivation's quantities (default
    ``name``); source: where the friction law comes from (seed and equation).

    The law, its limits, the modes' equations, event indicator, consistency
    conditions and priority are kept as the model's quantities (group
    "stick/slip in joint <name>"), for ``loomfmu inspect``.
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
    t_unit, s_unit = m.var(torque.name()).unit, m.var(speed.name()).unit
    sub = tex or name
    group = f"stick/slip in joint {name}"
    law = source or "Coulomb's law"
    m.quantity(f"{name}_kinetic_limit", r_kinetic * normal, unit=t_unit, group=group,
               symbol=rf"r_{{{sub}f}} N_{{{sub}}}", description=f"kinetic friction limit "
               f"of joint {name}: |torque| while slipping (friction radius x normal force)",
               source=law)
    m.quantity(f"{name}_static_limit", r_static * normal, unit=t_unit, group=group,
               symbol=rf"r^{{s}}_{{{sub}f}} N_{{{sub}}}", description=f"static friction limit "
               f"of joint {name}: the largest |torque| a stuck joint carries",
               source="derived: static friction radius x normal force")
    if regularized_eps is not None:
        law_expr = -r_kinetic * normal * ca.tanh(speed / regularized_eps)
        m.quantity(f"{name}_law", law_expr, unit=t_unit, group=group,
                   symbol=rf"M_{{{sub}f}}", description=f"friction torque of joint {name}, "
                   "regularized: -r_f N tanh(speed / eps) (no stick: holds no static "
                   "friction above kinetic)", source="assumption: smooth sign(), " + law)
        m.eq(torque, law_expr)
        return None
    q = m.mode(f"mode_{name}", start, (STUCK, FORWARD, BACKWARD),
               description=f"friction mode of joint {name}: 0 stuck, 1 forward, -1 backward")
    stuck = q == STUCK
    residual = ca.if_else(stuck, accel, torque + q * r_kinetic * normal)
    m.eq(residual)
    m.quantity(f"{name}_law", residual, unit="", group=group,
               symbol=rf"f_{{{sub}}}",
               description=f"the equation f = 0 of joint {name} in each mode q (the "
               "model's equation; its unit is the acceleration's when stuck, the torque's when "
               "slipping): stuck, the relative acceleration is zero and the torque is "
               "whatever keeps it so; slipping forward (+1) or backward (-1), the torque is "
               "kinetic friction against the motion", source=law)
    margin = m.quantity(f"{name}_stick_margin", r_static * normal - ca.fabs(torque),
                        unit=t_unit, group=group, symbol=rf"r^{{s}}_{{{sub}f}} N_{{{sub}}} - "
                        rf"|M_{{{sub}f}}|", description=f"joint {name} stuck: how far the "
                        "torque is from breakaway; the stuck mode is consistent while >= 0",
                        source="derived: Coulomb's static friction")
    indicator = m.quantity(f"{name}_event_indicator", ca.if_else(stuck, margin, speed),
                           unit="", group=group, symbol=rf"z_{{{sub}}}",
                           description=f"event indicator of joint {name} (event "
                           f"switch_{name}): the stick margin ({t_unit}) while stuck "
                           f"(breakaway where it crosses zero), the relative speed ({s_unit}) "
                           "while slipping (the joint may stick where it crosses zero)",
                           source="derived: the zero crossings of the mode conditions")
    m.event(f"switch_{name}", indicator,
            description=f"joint {name}: speed crosses zero (slipping) or breakaway (stuck)")
    slip_ok = m.quantity(f"{name}_slip_condition",
                         q * ca.if_else(ca.fabs(speed) < SPEED_TOL, accel, speed), unit="",
                         group=group, symbol=rf"q_{{{sub}}} \dot\varphi_{{{sub}}}",
                         description=f"joint {name} slipping in direction q: consistent "
                         f"while >= 0: q x speed ({s_unit}), or q x acceleration where "
                         f"|speed| < SPEED_TOL = {SPEED_TOL:g}",
                         source="derived: kinetic friction opposes the motion")
    validity = ca.if_else(stuck, margin, slip_ok)
    m.quantity(f"{name}_mode_priority", ca.DM([STUCK, FORWARD, BACKWARD]), unit="",
               group=group, symbol=rf"q_{{{sub}}} \in (0, 1, -1)",
               description=f"the modes of joint {name} in priority order: stuck, forward, "
               "backward; at each event the runtime takes the first whose condition (stick "
               "margin or slip condition) is >= 0, so static friction holds where it can, "
               "and sets a stuck joint's speed to zero", source="derived: MSL PartialFriction's "
               "rule, written once (loomfmu.mechanics.friction)")
    m.mode_rule(q, validity, events=[f"switch_{name}"])
    m.reinit(speed, ca.if_else(stuck, 0, speed))
    return q
