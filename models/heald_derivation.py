"""The heald frame's derivation as named quantities.

:func:`declare_quantities` keeps, with :meth:`loomfmu.declare.model.Model.quantity`,
the intermediate quantities of seed 000's derivation in its order: slat
sections, influence coefficients delta (3), the stiffness C = delta^-1 (as
the symbolic inverse and as the seed's closed form, which the equations use),
reduced masses, the motion law H(phi) (corrected, and as printed), the shed
geometry and the warp forces, and the d'Alembert load of (2) (corrected, and
as printed).  The print defects D1-D4 are those of models/heald_frame.py's
docstring; each quantity they touch names them in its description or source.

The generated code never uses these: the equations are what runs, and
tests/test_heald_quantities.py checks that the quantities evaluate to what the
equations use.
"""
from __future__ import annotations

import casadi as ca

from loomfmu.declare.model import Model
from loomfmu.models.heald_common import (
    SEED0,
    Bending,
    Motion,
    Section,
    Warp,
    defect,
    motion_law,
)

G_SEC = "1. slat and side-stay sections"
G_DELTA = "2. influence coefficients (seed 000, (3))"
G_C = "3. stiffness C = delta^-1"
G_M = "4. reduced masses"
G_H = "5. motion law H(phi)"
G_W = "6. shed geometry and warp forces"
G_EQ = "7. loads of the equations of motion (2)"

D1, D2, D3, D4 = (defect(k) for k in ("D1", "D2", "D3", "D4"))


def _influence(m: Model, b: Bending, axis: str) -> None:
    Q = m.quantity
    sub = f"{axis}"
    Q(f"delta_{sub}11", b.d11, unit="m/N", group=G_DELTA, symbol=rf"\delta_{{{sub}11}}",
      description=f"influence coefficient: deflection of {axis}1 under a unit force at "
      f"{axis}1 (= delta_{sub}33)", source=SEED0 + ", (3)")
    Q(f"delta_{sub}22", b.d22, unit="m/N", group=G_DELTA, symbol=rf"\delta_{{{sub}22}}",
      description=f"influence coefficient: deflection of {axis}2 under a unit force at "
      f"{axis}2", source=SEED0 + ", (3)")
    Q(f"delta_{sub}", b.delta, unit="m/N", group=G_DELTA, symbol=rf"\delta_{{{sub}}}",
      description=f"influence matrix of {axis}1, {axis}2, {axis}3 (symmetric; "
      f"delta_{sub}12 = delta_{sub}23 = delta_{sub}11/2, delta_{sub}13 = 0)",
      source=SEED0 + ", (3) and the matrix delta after it")
    Q(f"delta_{sub}f", b.d_f, unit="m/N", group=G_DELTA, symbol=rf"\delta_{{{sub}f}}",
      description=f"influence of the warp load at the top slat's mid-section on {axis}1, "
      f"{axis}2, {axis}3", source=SEED0 + ", (3)")


def _stiffness(m: Model, b: Bending, axis: str, closed_source: str) -> None:
    Q = m.quantity
    sub = f"{axis}"
    Q(f"C_{sub}_inv", ca.inv(b.delta), unit="N/m", group=G_C,
      symbol=rf"C_{{{sub}}} = \delta_{{{sub}}}^{{-1}}",
      description=f"stiffness matrix of the {axis} coordinates as the symbolic inverse of "
      f"delta_{sub} (what (1) multiplied by C gives in (2))",
      source="derived: inverse of delta_" + sub)
    Q(f"C_{sub}", b.C, unit="N/m", group=G_C, symbol=rf"C_{{{sub}}}",
      description=f"stiffness matrix of the {axis} coordinates in the seed's closed form "
      f"(1/(delta_{sub}22 - delta_{sub}11/2) [[r, -1/2, 1/4], [-1/2, 1, -1/2], "
      f"[1/4, -1/2, r]], r = delta_{sub}22/delta_{sub}11 - 1/4); the equations use this "
      "form", source=closed_source)


def declare_quantities(m: Model, *, mo: Motion, w: Warp, sec: Section | None = None,
                       bx: Bending | None = None, by: Bending | None = None,
                       k_B=None, inertia: str = "corrected") -> None:
    """Declare the derivation's quantities of a heald-frame model, in order.

    sec, by: the slats' section and vertical bending (planar and spatial);
    bx, k_B: the horizontal bending and its cantilever factor (spatial);
    inertia: the model's option (the d'Alembert load used by the equations).
    """
    Q = m.quantity
    closed = SEED0 + ", C = delta^-1 closed form (text after (2))"
    if sec is not None:
        Q("J_x", sec.J_x, unit="m4", group=G_SEC, symbol=r"J_x",
          description="second moment of area of the slat's box section for bending in the "
          "frame plane (b1 h1^3 - (b1 - 2 d1)(h1 - 2 d1)^3)/12",
          source=SEED0 + ", numeric example: box section h1 x b1, wall d1 (heald-bar plate "
          "neglected, as the seed says)")
        if bx is not None:
            Q("J_y", sec.J_y, unit="m4", group=G_SEC, symbol=r"J_y",
              description="second moment of area of the slat's box section for bending "
              "across the frame", source=SEED0 + ", numeric example")
            Q("J_z", sec.J_z, unit="m4", group=G_SEC, symbol=r"J_z",
              description="second moment of area of the side stay for bending across the "
              "frame (s_w s_t^3/12)", source="assumption: 30 x 6 mm strip (parameters s_w, "
              "s_t); the seed gives no side-stay section")
        Q("m_l", sec.m_l, unit="kg", group=G_SEC, symbol=r"m_\ell",
          description="mass of one slat (gamma x box-section area x l)", source=SEED0)
        Q("m_h", sec.m_h, unit="kg", group=G_SEC, symbol=r"m_h",
          description="mass of one side stay", source="derived: gamma s_w s_t s_L "
          "(assumed section, see J_z)")
    planes = [(b, a) for b, a in ((by, "y"), (bx, "x")) if b is not None]
    for b, axis in planes:
        _influence(m, b, axis)
    for b, axis in planes:
        _stiffness(m, b, axis, closed)
    if bx is not None:
        Q("m_B", bx.m_B, unit="kg", group=G_M, symbol=r"m_B",
          description="mass of the side stay's cantilever part above the drive lock "
          "(length h_B)", source=SEED0 + ", m_x1")
        Q("M_x", bx.M, unit="kg", group=G_M, symbol=r"M_x",
          description="reduced masses of x1, x2, x3: m_l/4 + k_B m_B, m_l/2, m_l/4 + k_B m_B "
          "(k_B = 33/140; " + D4 + ")", source=SEED0 + ", m_x1, m_x2 (corrected D4)")
        Q("M_x_printed", ca.vertcat(sec.m_l / 4 + bx.m_B * 33 / 280, sec.m_l / 2,
                                    sec.m_l / 4 + bx.m_B * 33 / 280),
          unit="kg", group=G_M, symbol=r"M_x^{\mathrm{printed}}",
          description="reduced masses of x1, x2, x3 as printed (m_B 33/280); not used: "
          + D4, source=SEED0 + ", m_x1 as printed")
    if by is not None:
        Q("M_y", by.M, unit="kg", group=G_M, symbol=r"M_y",
          description="reduced masses of y1, y2, y3: m_l/4 + m_h + m_l (l_n/l) 33/140, "
          "m_l/2, the same as y1", source=SEED0 + ", m_y1, m_y2")

    # -- motion law ----------------------------------------------------------------
    phi_r, phi_a, sign = mo.phi_r, mo.phi_a, mo.sign  # the nodes the model uses
    Q("phi_r", phi_r, unit="rad", group=G_H, symbol=r"\phi_r",
      description="main-shaft angle within the current revolution",
      source=SEED0 + ", motion law: phi_r = phi - 2 pi (k_f - 1)")
    Q("phi_a", phi_a, unit="rad", group=G_H, symbol=r"\phi_a",
      description="angle of the stroke: 0 in the dwell 0..40 deg, phi_r - 40 deg up to "
      "320 deg, then " + ("280 deg (" + D2 + ")" if mo.end_dwell == "corrected" else
                          "0 as printed (build option end_dwell='printed'; " + D2 + ")"),
      source=SEED0 + ", motion law, cases of phi_a")
    Q("stroke_sign", sign, group=G_H, symbol=r"(-1)^{k_f+1}",
      description="direction of the stroke: +1 up in odd revolutions, -1 down in even ones "
      "(one frame cycle is two revolutions)", source=SEED0 + ", motion law")
    Q("H", mo.H, unit="m", group=G_H, symbol=r"H(\phi)",
      description="displacement of the drive locks from the middle: h_m {[k_H phi_a - "
      "sin(k_H phi_a)]/pi - 1} (-1)^(k_f+1), k_H = 9/7 (" + D1 + "); output h",
      source=SEED0 + ", motion law (corrected D1" +
      (", D2)" if mo.end_dwell == "corrected" else "; D2 printed by the build option)"))
    Q("H_printed", motion_law(mo.phi, mo.h_m, 1.2, "printed"), unit="m", group=G_H,
      symbol=r"H^{\mathrm{printed}}(\phi)",
      description="the motion law exactly as printed (coefficient 1.2, phi_a = 0 after "
      "320 deg); not used: " + D1 + "; " + D2, source=SEED0 + ", motion law as printed")
    Q("dH_dphi", mo.H1, unit="m", group=G_H, symbol=r"H'(\phi)",
      description="first derivative of H by the shaft angle (per rad): h_m k_H (1 - "
      "cos(k_H phi_a)) / pi (-1)^(k_f+1) while the frame moves (0 < phi_a < 280 deg), 0 in "
      "the dwells (at a boundary, a single angle, the dwell's 0); h' = H' omega",
      source="derived: d/dphi of H (d phi_a / d phi = 1 while the frame moves)")
    Q("d2H_dphi2", mo.H2, unit="m", group=G_H, symbol=r"H''(\phi)",
      description="second derivative of H by the shaft angle (per rad^2); h'' = H'' "
      "omega^2 (omega held over a step: its derivative taken as zero); h_m k_H^2 "
      "sin(k_H phi_a) / pi (-1)^(k_f+1) while the frame moves, 0 in the dwells",
      source="derived: d/dphi of H'")

    # -- shed geometry and warp forces --------------------------------------------------
    Q("L_1", w.L1, unit="m", group=G_W, symbol=r"\sqrt{l_1^2 + h^2}",
      description="length of the front shed's branch of a warp end", source=SEED0 + ", fig. 2")
    Q("L_2", w.L2, unit="m", group=G_W, symbol=r"\sqrt{l_2^2 + h^2}",
      description="length of the back shed's branch (l_2 = k_z l_1)", source=SEED0 + ", fig. 2")
    Q("dl_shed", w.dl, unit="m", group=G_W, symbol=r"dl",
      description="elongation of a warp end by the shed, from the closed shed (h = 0); "
      "output dl", source=SEED0 + ": dl = sqrt(l_1^2 + h^2) + sqrt(l_2^2 + h^2) - (l_1 + l_2)")
    Q("dl_max", w.dl_max, unit="m", group=G_W, symbol=r"dl_{\max}",
      description="dl at the open shed (h = h_m)", source=SEED0)
    if w.mode == "geometry":
        Q("T_shed", w.T, unit="N", group=G_W, symbol=r"T",
          description="total working tension of the frame's n_n ends, proportional to the "
          "elongation: n_n [T_min + (T_max - T_min) dl/dl_max]; output T",
          source=SEED0 + " (T_min, T_max read as per end)")
    else:
        Q("T_input", w.T, unit="N", group=G_W, symbol=r"T",
          description="total tension of the frame's n_n ends, the input T (build option "
          "warp_tension='input'; seed 000 computes it from dl instead)",
          source="input, e.g. a backrest's front tension")
    Q("sin_sum", w.s_y, group=G_W, symbol=r"\left(\sin\alpha_1 + \sin\alpha_2\right)",
      description="vertical direction sum of the two shed branches", source=SEED0 + ", fig. 2")
    Q("cos_diff", w.s_x, group=G_W, symbol=r"\left(\cos\alpha_2 - \cos\alpha_1\right)",
      description="horizontal direction sum of the two shed branches (zero for a symmetric "
      "shed, k_z = 1)", source=SEED0 + ", fig. 2")
    Q("f_y_warp", w.f_y, unit="N", group=G_W, symbol=r"f_y",
      description="vertical warp load on the top slat, T (sin a1 + sin a2), positive towards "
      "the shed's centre line; output f_y", source=SEED0 + ", f_y = T_3 cos a3")
    Q("f_x_warp", w.f_x, unit="N", group=G_W, symbol=r"f_x",
      description="horizontal warp load on the top slat, T (cos a2 - cos a1); output f_x",
      source=SEED0 + ", f_x = T_3 sin a3")

    # -- loads of (2) -------------------------------------------------------------------
    if by is not None:
        Q("Y_static", -by.d_f * w.f_y, unit="m", group=G_EQ, symbol=r"Y_{\mathrm{st}}",
          description="static deflection of y1, y2, y3 under the warp load, -delta_yf f_y "
          "(the start values of y at the start time)",
          source=SEED0 + ", (1) with the accelerations zero")
        M_H = by.M if inertia == "corrected" else -bx.M
        Q("F_inertia_y", -M_H * mo.h_ddot, unit="N", group=G_EQ, symbol=r"F_{\ddot H}",
          description="d'Alembert load of the moving frame on y1, y2, y3 in (2), -M_y H''" +
          (" (" + D3 + ")" if inertia == "corrected" else
           ", as printed +M_x H'' (build option inertia='printed'; " + D3 + ")"),
          source=SEED0 + ", (2), corrected D3" if inertia == "corrected" else
          SEED0 + ", (2) as printed")
        if bx is not None and inertia == "corrected":
            Q("F_inertia_y_printed", bx.M * mo.h_ddot, unit="N", group=G_EQ,
              symbol=r"F_{\ddot H}^{\mathrm{printed}}",
              description="the printed d'Alembert load of (2), +M_x H''; not used: " + D3,
              source=SEED0 + ", (2) as printed")
    if bx is not None:
        Q("X_static", bx.d_f * w.f_x, unit="m", group=G_EQ, symbol=r"X_{\mathrm{st}}",
          description="static deflection of x1, x2, x3 under the warp load, delta_xf f_x "
          "(the start values of x)",
          source=SEED0 + ", (1) with the accelerations zero")
