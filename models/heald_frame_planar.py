"""Heald frame, planar fidelity: in-plane (vertical) bending of the slats only.

The vertical half of seed 000's equations (2), with the corrections D1-D3 of
models/heald_frame.py; no horizontal coordinates.  In the spatial model the
horizontal and vertical coordinates are coupled only through the common
warp tension, which both receive as a given function of the frame position,
so this model's vertical outputs and hinge load equal the spatial model's
(the horizontal displacement is what it leaves out; docs/guides/heald_fidelity.md).
"""
from __future__ import annotations

import math

import casadi as ca

from loomfmu.declare.model import Model
from loomfmu.models.heald_common import (
    WARP_TENSION,
    apply_preset,
    check_option,
    declare_hinge_outputs,
    declare_loads,
    declare_motion,
    declare_motion_outputs,
    declare_ports,
    declare_section,
    declare_warp,
    declare_warp_outputs,
    vertical,
)


def build(*, end_dwell: str = "corrected", inertia: str = "corrected",
          preset: str | None = None, warp_tension: str = "geometry") -> Model:
    """The planar heald frame; options as for ``heald_frame.build``."""
    check_option("end_dwell", end_dwell, ("corrected", "printed"))
    check_option("inertia", inertia, ("corrected",))  # M_x (printed D3) does not exist here
    check_option("warp_tension", warp_tension, WARP_TENSION)
    m = Model("heald_frame_planar", description="Heald frame, in-plane slat bending "
              "(3 DOF) under warp tension and frame inertia, seeds 000 and 002",
              stop_time=4 * math.pi / 60 * 2, step_size=1e-3, h_fixed=2e-5,
              options={"end_dwell": end_dwell, "preset": preset,
                       "warp_tension": warp_tension})
    sec = declare_section(m, horizontal=False)
    mo = declare_motion(m, end_dwell=end_dwell)
    w = declare_warp(m, mo, warp_tension)
    ld = declare_loads(m)
    by = vertical(sec)
    C_y, dy_f, M_y = by
    Y = ca.vertcat(*[m.state(f"y{i}", 0.0, unit="m", nominal=1e-4,
                             description=f"vertical displacement of top-slat point {i}, "
                             "relative to the drive locks") for i in (1, 2, 3)])
    VY = ca.vertcat(*[m.state(f"vy{i}", 0.0, unit="m/s", nominal=0.01,
                              description=f"velocity of y{i}") for i in (1, 2, 3)])
    for i in range(3):
        m.eq(m.der(Y[i]), VY[i])
    AY = ca.vertcat(*[m.der(VY[i]) for i in range(3)])
    m.eq(M_y * AY, -C_y @ (Y + dy_f * w.f_y) - sec.mu * VY - M_y * mo.h_ddot)
    declare_motion_outputs(m, mo)
    m.output("y2_out", Y[1], unit="m", description="vertical displacement of the top "
             "slat's mid-section")
    declare_warp_outputs(m, w)
    declare_hinge_outputs(m, ld, mo, w, elastic=ca.dot(M_y, AY), reduced_mass=ca.sum1(M_y))
    apply_preset(m, preset)
    m.set_starts_from(Y, -dy_f * w.f_y)
    declare_ports(m, w)
    from loomfmu.models.heald_derivation import declare_quantities, frame_figure
    declare_quantities(m, mo=mo, w=w, sec=sec, by=by)
    frame_figure(m, spatial=False)
    return m
