"""Port kinds: what a connector means, fixed once for every model.

A port groups a model's variables by *role*.  Its kind fixes, for each role,
the physical quantity (a canonical unit; a model may declare any unit of the
same quantity, and a scene converts) and the sign convention.  Within one
port the roles of a kind alternate causality: in a ``flange`` the speed goes
one way and the torque the other, in a ``warp`` connection the elongation one
way and the tension the other.  So two ports of one kind connect both ways:
each role present on both ends is an output on one and an input on the other.

A port may carry a subset of its kind's roles (a heald frame that computes
its warp tension from the shed geometry only gives the elongation).
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Role:
    """One role of a port kind: its canonical unit, its group (roles of the
    two groups of a kind have opposite causality in one port) and meaning."""

    unit: str
    group: int          # 0 or 1
    meaning: str


@dataclass(frozen=True)
class PortKind:
    name: str
    roles: dict[str, Role]
    description: str


PORT_KINDS: dict[str, PortKind] = {k.name: k for k in (
    PortKind("flange", {
        "speed": Role("rad/s", 0, "angular speed of the shaft (positive in the machine's "
                                  "running direction)"),
        "torque": Role("N.m", 1, "torque the shaft carries across the connection "
                                 "(positive when it drives the side that takes the speed)"),
    }, "a rotational flange: speed one way, torque the other"),
    PortKind("warp", {
        "elongation": Role("m", 0, "elongation imposed on the warp ends that pass through "
                                   "this connection, measured from the static (at-rest) "
                                   "state; positive stretches them"),
        "tension": Role("N", 1, "total tension of the warp ends that pass through this "
                                "connection (all ends at a backrest's single front; one "
                                "frame's ends at a heald frame); absolute, positive in "
                                "tension: a warp cannot push"),
    }, "a warp connection: elongation one way, tension the other"),
    PortKind("translational", {
        "position": Role("m", 0, "position of the connection point"),
        "velocity": Role("m/s", 0, "velocity of the connection point"),
        "force": Role("N", 1, "force transmitted through the connection"),
    }, "a translational flange: position and velocity one way, force the other"),
)}


def port_kind(kind: str) -> PortKind:
    """The :class:`PortKind` named ``kind``, or ValueError listing the known ones."""
    if not isinstance(kind, str) or kind not in PORT_KINDS:
        raise ValueError(f"port kind = {kind!r:.60}; allowed: one of "
                         f"{', '.join(sorted(PORT_KINDS))}")
    return PORT_KINDS[kind]
