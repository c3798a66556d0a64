"""Heald frame, rigid fidelity: motion law, warp forces and hinge load.

No elastic coordinates: the frame follows the drive locks, h = H(phi)
(seed 000's motion law with corrections D1, D2), and the hinge load is
seed 002's kinetostatic load, N_rem = -[(m_RR + m_heald)(g + h'') + f_y] /
n_hinge, evaluated continuously over the eight phases
(:mod:`loomfmu.heald.hinge` has the seed's per-phase formulas).
"""
from __future__ import annotations

import math

from loomfmu.declare import Model
from loomfmu.models.heald_common import (
    apply_values, check_option, declare_hinge_outputs, declare_loads, declare_motion,
    declare_motion_outputs, declare_warp, declare_warp_outputs)


def build(*, end_dwell: str = "corrected", preset: str | None = None) -> Model:
    """The rigid heald frame; ``end_dwell`` and ``preset`` as for ``heald_frame.build``."""
    check_option("end_dwell", end_dwell, ("corrected", "printed"))
    m = Model("heald_frame_rigid", description="Heald frame as a rigid body: motion law, "
              "warp forces and the drive-hinge load, seeds 000 and 002",
              stop_time=4 * math.pi / 60 * 2, step_size=1e-3, h_fixed=2e-5,
              options={"end_dwell": end_dwell, "preset": preset})
    mo = declare_motion(m, end_dwell=end_dwell)
    w = declare_warp(m, mo)
    ld = declare_loads(m)
    declare_motion_outputs(m, mo)
    declare_warp_outputs(m, w)
    declare_hinge_outputs(m, ld, mo, w)
    if preset is not None:
        from loomfmu.heald.presets import preset_values
        apply_values(m, preset_values(preset, m.name))
    m.port("shaft", "flange", speed="omega", description="main shaft (speed imposed)")
    m.port("warp", "warp", elongation="dl",
           description="warp sheet through the frame's healds")
    return m
