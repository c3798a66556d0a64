"""Main shaft of a loom as a speed source: the shaft that drives the heald
frames (scene ``loom``, loomfmu.machines.loom).

    theta' = omega,   omega = omega_0 (1 + delta cos(theta - theta_b))

omega_0 is the mean speed (one revolution per pick); delta the speed
fluctuation within a revolution that the beat-up's load causes on a real
loom (default 0: constant speed, which is what the heald frame's motion law
assumes: it takes the speed's derivative as zero), theta_b the shaft angle
of the fastest point.  The shaft is stiff and its motor strong: the torque
the frames take back is not modelled, so its ``frames`` port carries the
speed only (a flange port with a subset of its roles, loomfmu.declare.ports).
"""
from __future__ import annotations

import math

import casadi as ca

from loomfmu.declare.model import Model

A = "assumption: "


def build() -> Model:
    """The loom main shaft (no build options)."""
    m = Model("loom_shaft", description="Loom main shaft as a speed source: mean speed "
              "with an optional once-per-revolution fluctuation; drives the heald frames",
              stop_time=1.0, step_size=1e-3, h_fixed=1e-4)
    P = m.parameter
    omega_0 = P("omega_0", 8 * math.pi, unit="rad/s", display_unit="rpm",
                description="mean main-shaft speed (one revolution per pick)", min=0.1,
                max=500.0, source=A + "240 picks/min (8 pi rad/s), the backrest's loom "
                "speed omega_loom (200-300 picks/min)")
    delta = P("delta", 0.0, description="relative speed fluctuation within a revolution",
              min=0.0, max=0.5, source=A + "0: constant speed, as the heald frame's motion "
              "law assumes; 0.02-0.05 on looms with a heavy sley")
    theta_b = P("theta_b", 0.0, unit="rad", description="shaft angle of the fastest point "
                "of the fluctuation", min=-10.0, max=10.0, source=A + "reference angle")
    theta = m.state("theta", 0.0, unit="rad", description="main-shaft angle")
    omega = omega_0 * (1 + delta * ca.cos(theta - theta_b))
    m.eq(m.der(theta), omega)
    m.output("omega_out", omega, unit="rad/s", display_unit="rpm",
             description="main-shaft speed")
    m.output("theta_out", theta, unit="rad", description="main-shaft angle")
    m.port("frames", "flange", speed="omega_out", description="main shaft to the heald "
           "frames' drive (speed imposed; the frames' torque is not fed back)")
    return m
