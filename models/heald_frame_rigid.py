"""Heald frame, rigid fidelity: motion law, warp forces and hinge load.

No elastic coordinates: the frame follows the drive locks, h = H(phi)
(seed 000's motion law with corrections D1, D2), and the hinge load is
seed 002's kinetostatic load, N_rem = -[(m_RR + m_heald)(g + h'') + f_y] /
n_hinge, evaluated continuously over the eight phases
(:mod:`loomfmu.heald.hinge` has the seed's per-phase formulas).
"""
from __future__ import annotations

import math

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
    declare_warp,
    declare_warp_outputs,
)


def build(*, end_dwell: str = "corrected", preset: str | None = None,
          warp_tension: str = "geometry") -> Model:
    """The rigid heald frame; options as for ``heald_frame.build``."""
    check_option("end_dwell", end_dwell, ("corrected", "printed"))
    check_option("warp_tension", warp_tension, WARP_TENSION)
    m = Model("heald_frame_rigid", description="Heald frame as a rigid body: motion law, "
              "warp forces and the drive-hinge load, seeds 000 and 002",
              stop_time=4 * math.pi / 60 * 2, step_size=1e-3, h_fixed=2e-5,
              options={"end_dwell": end_dwell, "preset": preset,
                       "warp_tension": warp_tension})
    mo = declare_motion(m, end_dwell=end_dwell)
    w = declare_warp(m, mo, warp_tension)
    ld = declare_loads(m)
    declare_motion_outputs(m, mo)
    declare_warp_outputs(m, w)
    declare_hinge_outputs(m, ld, mo, w)
    apply_preset(m, preset)
    declare_ports(m, w)
    from loomfmu.models.heald_derivation import declare_quantities
    declare_quantities(m, mo=mo, w=w)
    return m
