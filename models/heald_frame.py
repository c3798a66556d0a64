"""Spatial vibrations of a loom heald frame (ATPR-180), 6 elastic DOF.

Source: seed 000 (Pchelin, "Modelling the dynamics of a loom heald frame on
the basis of a spatial model"), equations (1)-(3), the influence
coefficients, C = delta^-1, the reduced masses, the motion law H(phi) and the
warp forces f_x, f_y.

Coordinates (moving with the frame's drive locks, which follow h = H(phi)):
x1, x3 horizontal (out of the frame plane) displacement of the top slat's
left/right corners, x2 of its mid-section; y1, y2, y3 the same vertically.
y points up like h; x points to the long (back) side of the shed.

Print defects of the seed, corrected (listed at the end of this docstring
from heald_common.DEFECTS, the one source of the docstring, the derivation
report and docs/guides/heald_frame.md's table): D1 the motion-law coefficient, D2
the end dwell, D3 the inertia term of (2), D4 the side stay's reduced mass.

Additions: the hinge load N_rem of seed 002 from the frame's
actual accelerations (see models/heald_common.py), presets of seed 002's
tables 1-2 (``build(preset="STB-180 Elitex")``), and the build option
``h_B_law="variable"``: the side stays' cantilever length follows the frame,
h_B(t) = h_B + H - H_hB (H_hB: the frame position at which it equals h_B;
default the top position h_m), with stiffness and reduced mass evaluated at
h_B(t) (quasi-static: the mass-rate term is neglected, as the seed's
"increase in stiffness and decrease in reduced mass" describes).
"""
from __future__ import annotations

import math

import casadi as ca

from loomfmu.declare.model import Model
from loomfmu.models.heald_common import (  # noqa: F401  (re-exported for tests)
    BREAKPOINTS_DEG,
    DEFECTS,
    DEG,
    SEED0,
    WARP_TENSION,
    apply_preset,
    apply_values,
    box_inertia,
    check_option,
    declare_hinge_outputs,
    declare_loads,
    declare_motion,
    declare_motion_outputs,
    declare_ports,
    declare_section,
    declare_warp,
    declare_warp_outputs,
    defect,
    horizontal,
    influence,
    motion_law,
    stiffness,
    vertical,
)

SEED = SEED0
#: (one line per defect, marked "D1  ...": the FMU's documentation lists them)
__doc__ += "\n" + "".join(f"{k}  {defect(k)}\n" for k in DEFECTS)


def build(*, end_dwell: str = "corrected", inertia: str = "corrected",
          h_B_law: str = "constant", preset: str | None = None,
          warp_tension: str = "geometry") -> Model:
    """The spatial heald frame.

    end_dwell, inertia: 'corrected' or 'printed' (defects D2, D3).
    h_B_law: 'constant' (the seed) or 'variable' (cantilever length follows the frame).
    preset: a name of :func:`loomfmu.mechanics.heald_presets.preset_names` (start values).
    warp_tension: 'geometry' (seed 000: T from the shed's elongation; output T) or
        'input' (T, the total tension of the frame's ends, is an input: the warp
        port takes tension in and gives the elongation dl out).
    """
    check_option("end_dwell", end_dwell, ("corrected", "printed"))
    check_option("inertia", inertia, ("corrected", "printed"))
    check_option("h_B_law", h_B_law, ("constant", "variable"))
    check_option("warp_tension", warp_tension, WARP_TENSION)
    m = Model("heald_frame", description="Spatial vibrations of a loom heald frame "
              "(ATPR-180): 6-DOF slat bending under warp tension, seed 000; hinge load, "
              "seed 002",
              stop_time=4 * math.pi / 60 * 2, step_size=1e-3, h_fixed=2e-5,
              options={"end_dwell": end_dwell, "inertia": inertia, "h_B_law": h_B_law,
                       "preset": preset, "warp_tension": warp_tension})
    sec = declare_section(m, horizontal=True)
    k_B = m.parameter("k_B", 33 / 140, description="reduced-mass factor of the side stay's "
                      "cantilever", source=SEED + ", m_x1: printed 33/280, corrected to "
                      "33/140 (defect D4)", min=0.0, max=1.0)
    mo = declare_motion(m, end_dwell=end_dwell)
    w = declare_warp(m, mo, warp_tension)
    ld = declare_loads(m)
    h_B = None
    if h_B_law == "variable":
        H_hB = m.parameter("H_hB", 0.029, unit="m", description="frame position at which "
                           "the side stays' cantilever length equals h_B", source="assumption: "
                           "seed 000 gives h_B = 0.15 m without its frame position; the top "
                           "position (h_m) makes the variable length the shorter one, which "
                           "the seed's 'increase in stiffness' implies", min=-0.2, max=0.2)
        h_B = ca.fmax(sec.h_B + mo.H - H_hB, 0.2 * sec.h_B)
    bx, by = horizontal(sec, k_B, h_B), vertical(sec)
    C_x, dx_f, M_x = bx
    C_y, dy_f, M_y = by

    X = ca.vertcat(*[m.state(f"x{i}", 0.0, unit="m", nominal=1e-3,
                             description=f"horizontal displacement of top-slat point {i} "
                             "(1, 3: corners, 2: mid-section)") for i in (1, 2, 3)])
    VX = ca.vertcat(*[m.state(f"vx{i}", 0.0, unit="m/s", nominal=0.1,
                              description=f"velocity of x{i}") for i in (1, 2, 3)])
    Y = ca.vertcat(*[m.state(f"y{i}", 0.0, unit="m", nominal=1e-4,
                             description=f"vertical displacement of top-slat point {i}, "
                             "relative to the drive locks") for i in (1, 2, 3)])
    VY = ca.vertcat(*[m.state(f"vy{i}", 0.0, unit="m/s", nominal=0.01,
                              description=f"velocity of y{i}") for i in (1, 2, 3)])

    # -- equations (2) --------------------------------------------------------------
    M_H = M_y if inertia == "corrected" else -M_x
    for i in range(3):
        m.eq(m.der(X[i]), VX[i])
        m.eq(m.der(Y[i]), VY[i])
    AX = ca.vertcat(*[m.der(VX[i]) for i in range(3)])
    AY = ca.vertcat(*[m.der(VY[i]) for i in range(3)])
    m.eq(M_x * AX, -C_x @ (X - dx_f * w.f_x) - sec.mu * VX)
    m.eq(M_y * AY, -C_y @ (Y + dy_f * w.f_y) - sec.mu * VY - M_H * mo.h_ddot)

    # -- outputs ---------------------------------------------------------------------
    declare_motion_outputs(m, mo)
    m.output("x1_out", X[0], unit="m", description="horizontal displacement of the "
             "top slat's left corner")
    m.output("x2_out", X[1], unit="m", description="horizontal displacement of the "
             "top slat's mid-section")
    m.output("y2_out", Y[1], unit="m", description="vertical displacement of the top "
             "slat's mid-section")
    declare_warp_outputs(m, w)
    declare_hinge_outputs(m, ld, mo, w, elastic=ca.dot(M_y, AY), reduced_mass=ca.sum1(M_y))
    apply_preset(m, preset)
    # start at the static deflection under the warp load at the start angle
    m.set_starts_from(ca.vertcat(X, Y), ca.vertcat(dx_f * w.f_x, -dy_f * w.f_y))
    declare_ports(m, w)
    from loomfmu.models.heald_derivation import declare_quantities, frame_figure
    declare_quantities(m, mo=mo, w=w, sec=sec, bx=bx, by=by, k_B=k_B, inertia=inertia)
    frame_figure(m, spatial=True)
    return m
