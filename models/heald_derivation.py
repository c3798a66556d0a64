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


#: the parameters the frame's sketch is drawn with (their start values)
FIGURE_PARAMETERS = ("l", "l_n", "s_L", "h1", "b1", "d1")

FIGURE_CAPTION = (
    "The slat model of seed 000 (its fig. 1 is missing), drawn at the default "
    "parameters, heights to scale: the frame in its plane (z along the slats, y up) "
    "with the plane's normal x drawn obliquely, towards the long (back) side of the "
    "shed; the axes move with the drive locks, which follow h = H(phi). Top slat "
    "of length l, lower slat, side stays of length s_L; two lifting hooks (drive "
    "hinges, n_hinge) under the lower slat, l_n in from its ends; the coordinates "
    "y1, y2, y3 {x}of the top slat's left corner, mid-section and right corner, "
    "with the reduced masses m_y{mx}; the warp loads {f} at the mid-section; "
    "the slats' box section h1 x b1, wall d1. The layout is read from (3): "
    "the corners' vertical influence delta_y11 = l_n^3 / 3EJ_x is that of the lower "
    "slat's cantilevers beyond the hooks{hb}.")


def frame_svg(p: dict, *, spatial: bool) -> str:
    """An SVG sketch of the heald frame's slat model at the parameter values
    ``p`` (the names of :data:`FIGURE_PARAMETERS`, and ``h_B`` when
    ``spatial``, SI units): the x coordinates, f_x and the side stays'
    cantilevers h_B only when ``spatial``."""
    import math
    l, l_n, s_L, h1 = p["l"], p["l_n"], p["s_L"], p["h1"]
    scale = 520.0 / l  # px per m
    ox, oy = 90.0, 250.0  # the lower slat's left end, on the canvas
    ob = (0.45 * math.cos(math.radians(35)), 0.45 * math.sin(math.radians(35)))

    def pt(zz, yy, xx=0.0):  # frame (m): z along the slats, y up, x out of the plane
        return (ox + scale * (zz + ob[0] * xx), oy - scale * (yy + ob[1] * xx))

    def line(a, b, style):
        return (f'<line x1="{a[0]:.1f}" y1="{a[1]:.1f}" x2="{b[0]:.1f}" y2="{b[1]:.1f}" '
                f'{style}/>')

    def label(xy, s, dx=0, dy=0, size=14, anchor="start"):
        return (f'<text x="{xy[0] + dx:.1f}" y="{xy[1] + dy:.1f}" font-size="{size}" '
                f'font-style="italic" text-anchor="{anchor}">{s}</text>')

    def sub(s, i):
        return f'{s}<tspan baseline-shift="sub" font-size="10">{i}</tspan>'

    def arrow(a, b, colour="#000", width=1.5):
        return line(a, b, f'stroke="{colour}" stroke-width="{width}" '
                    'marker-end="url(#harr)"')

    def dim(a, b, text, dx=0, dy=0):
        return (line(a, b, 'stroke="#555" marker-start="url(#harr)" marker-end="url(#harr)"')
                + label(((a[0] + b[0]) / 2, (a[1] + b[1]) / 2), text, dx, dy, 13, "middle"))

    def bar(z0, z1, y0, y1, fill):
        a, b = pt(z0, y1), pt(z1, y0)
        return (f'<rect x="{a[0]:.1f}" y="{a[1]:.1f}" width="{b[0] - a[0]:.1f}" '
                f'height="{b[1] - a[1]:.1f}" fill="{fill}" stroke="#1f4e79" '
                'stroke-width="1.5"/>')

    top = s_L  # the top slat's axis
    hs = h1 / 2
    w_stay = 0.03
    parts = [
        bar(0, l, -hs, hs, "#e8eef5"),                           # lower slat
        bar(0, w_stay, hs, top - hs, "#dfe7f0"),                 # side stays
        bar(l - w_stay, l, hs, top - hs, "#dfe7f0"),
        bar(0, l, top - hs, top + hs, "#cddbeb"),                # top slat
        label(pt(l / 4, top + hs), "top slat", 0, -6, 13, "middle"),
        label(pt(l / 2, -hs), "lower slat", 0, 16, 13, "middle"),
        label(pt(l, top / 2), "side stay", 8, 16, 13),
    ]
    # drive hinges: lifting hooks l_n in from the lower slat's ends, moved by H(phi)
    for zh in (l_n, l - l_n):
        a = pt(zh, -hs)
        parts += [f'<circle cx="{a[0]:.1f}" cy="{a[1] + 7:.1f}" r="6" fill="#fff" '
                  'stroke="#000" stroke-width="1.5"/>',
                  line((a[0], a[1] + 13), (a[0], a[1] + 40), 'stroke="#000" stroke-width="3"'),
                  arrow((a[0] + 14, a[1] + 44), (a[0] + 14, a[1] + 14), "#9c2a00")]
    hook = pt(l - l_n, -hs)
    a = pt(l_n, -hs)
    parts += [label(hook, "h = H(φ)", 20, 34, 13),
              label(a, "drive hinge (lifting hook)", 24, 36, 12),
              dim((pt(0, -hs)[0], a[1] + 30), (a[0], a[1] + 30), sub("l", "n"), 0, 16)]
    # the coordinates of the top slat's points 1, 2, 3 (and the reduced masses)
    for i, zi in ((1, 0.0), (2, l / 2), (3, l)):
        c = pt(zi, top)
        parts += [f'<circle cx="{c[0]:.1f}" cy="{c[1]:.1f}" r="5" fill="#1f4e79"/>',
                  arrow(c, (c[0], c[1] - 58), "#2e7d32", 2),
                  label((c[0], c[1] - 58), sub("y", i), -4, -6, 15, "end")]
        if spatial:
            e = pt(zi, top, 0.22)
            parts += [arrow(c, e, "#6a1b9a", 2), label(e, sub("x", i), 6, 2, 15)]
        masses = sub("m", f"y{i}") + (" " + sub("m", f"x{i}") if spatial else "")
        parts.append(label(c, masses, {1: 10, 2: -8, 3: -10}[i], 30, 12,
                           {1: "start", 2: "end", 3: "end"}[i]))
    # warp loads on the mid-section
    c = pt(l / 2, top)
    parts += [arrow((c[0] + 40, c[1] - 55), (c[0] + 40, c[1] - 17), "#b71c1c", 2),
              label((c[0] + 40, c[1] - 55), sub("f", "y"), 6, 8, 15)]
    if spatial:
        a = pt(l / 2 + 0.05, top - 0.1, -0.2)
        b = pt(l / 2 + 0.01, top - 0.02, -0.02)
        parts += [arrow(a, b, "#b71c1c", 2), label(a, sub("f", "x"), 4, 14, 15)]
        hb = p["h_B"]
        for zs in (0.0, l):  # the side stays' cantilevers: held across the frame h_B below
            g = pt(zs, top - hb)
            parts.append(f'<rect x="{g[0] - 9:.1f}" y="{g[1] - 4:.1f}" width="18" height="8" '
                         'fill="#999"/>')
        g = pt(0, top - hb)
        parts += [label(g, "stays held across the frame here", 14, 4, 12),
                  dim((g[0] - 24, g[1]), (pt(0, top)[0] - 24, pt(0, top)[1]),
                      sub("h", "B"), -14, 4)]
    # dimensions: l along the top slat, s_L the frame's height
    a, b = pt(0, top + hs), pt(l, top + hs)
    parts.append(dim((a[0], a[1] - 75), (b[0], b[1] - 75), "l", 0, -6))
    a, b = pt(0, 0), pt(0, top)
    parts.append(dim((a[0] - 60, a[1]), (b[0] - 60, b[1]), sub("s", "L"), -14, 4))
    # axes, moving with the drive locks
    o = (40.0, 350.0)
    parts += [arrow(o, (o[0] + 50, o[1])), label(o, "z", 52, 5),
              arrow(o, (o[0], o[1] - 50)), label(o, "y", -4, -54),
              label(o, "axes move with the drive locks", 64, 18, 11)]
    if spatial:
        parts += [arrow(o, (o[0] + 40 * math.cos(math.radians(35)),
                            o[1] - 40 * math.sin(math.radians(35)))), label(o, "x", 36, -28)]
    # the slats' box section
    bx0, by0, k = 660.0, 250.0, 600.0  # px per m of the section
    wb, hh, d1 = p["b1"] * k, p["h1"] * k, max(p["d1"] * k, 1.5)
    parts += [f'<rect x="{bx0:.1f}" y="{by0:.1f}" width="{wb:.1f}" height="{hh:.1f}" '
              'fill="#cddbeb" stroke="#1f4e79" stroke-width="1.5"/>',
              f'<rect x="{bx0 + d1:.1f}" y="{by0 + d1:.1f}" width="{wb - 2 * d1:.1f}" '
              f'height="{hh - 2 * d1:.1f}" fill="#fff" stroke="#1f4e79"/>',
              label((bx0, by0), "slat section", wb / 2, -10, 12, "middle"),
              label((bx0, by0 + hh / 2), sub("h", "1"), -6, 4, 13, "end"),
              label((bx0, by0 + hh), sub("b", "1"), wb / 2, 16, 13, "middle"),
              label((bx0 + wb, by0 + 10), sub("d", "1") + " wall", 6, 4, 12)]
    return ('<svg xmlns="http://www.w3.org/2000/svg" width="720" height="380" '
            'viewBox="0 0 720 380" role="img" aria-label="heald frame slat model: top '
            'and lower slats, side stays, drive hinges, coordinates of the top slat\'s '
            'points 1, 2, 3"><defs><marker id="harr" viewBox="0 0 10 10" refX="9" '
            'refY="5" markerWidth="9" markerHeight="9" markerUnits="userSpaceOnUse" '
            'orient="auto-start-reverse">'
            '<path d="M0,0 L10,5 L0,10 z"/></marker></defs>'
            '<rect width="720" height="380" fill="#fff"/>' + "".join(parts) + "</svg>")


def frame_figure(m: Model, *, spatial: bool) -> None:
    """Keep the sketch of the slat model on ``m`` (a planar or spatial frame)."""
    names = FIGURE_PARAMETERS + (("h_B",) if spatial else ())
    caption = FIGURE_CAPTION.format(
        x="(vertical, relative to the drive locks) and x1, x2, x3 (across the frame) "
        if spatial else "(vertical, relative to the drive locks) ",
        mx=" and m_x" if spatial else "", f="f_y and f_x" if spatial else "f_y",
        hb=", their horizontal one delta_x11 = h_B^3 / 3EJ_z that of the side stays "
        "held across the frame h_B below the top slat (the place of that hold is an "
        "assumption: the seed gives only its distance)" if spatial else "")
    m.figure("frame", frame_svg({n: m.var(n).start for n in names}, spatial=spatial),
             caption=caption)
