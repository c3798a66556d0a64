"""The spindle's derivation as named quantities: one beam
element's matrices, the disks, the supports and the squeeze-film damper, the
assembled matrices of (12), the unbalance forces (13), the modal reduction
(spindle_modal) and the support forces.  Kept with ``Model.quantity`` for the
derivation reports (``loomfmu inspect spindle``) and ``loomfmu.inspect``;
the generated code never uses them, and every one is the very expression the
equations are built from (tests/test_spindle_quantities.py).

The print defects of seed 003 (docs/guides/spindle.md, S1-S5) are written once,
here, and shown next to the quantity they affect: S1 on the rotary-inertia
and gyroscopic element matrices (with the printed matrix as a quantity), S2
on the film coefficients, S3 on the layers' damping (both forms kept), S5 on
the coil spring.  S4 concerns (20), the transfer function of the frequency
analysis (loomfmu.spindle.analysis), not these models.
"""
from __future__ import annotations

import casadi as ca

from loomfmu.mechanics.rotor import film_integral_C, film_integral_K

SEED = "seed 003"
ELEMENT = "beam element (element 1, symbolic in the parameters)"
DISKS = "rigid disks"
SUPPORTS = "supports and the squeeze-film damper"
ASSEMBLY = "assembled matrices of (12)"
FORCING = "unbalance forcing (13)"
MODAL = "modal reduction (Ritz projection)"
FORCES = "support forces"

#: the print defects that affect these quantities: (printed, corrected, reason)
DEFECTS = {
    "S1": ("rotary-inertia (and J_p1 gyroscopic) element matrix of (11), entry (4,2): l^2",
           "-l^2", "the Hermite rotary-inertia matrix rho I/(30 l) [36 3l -36 3l; 3l 4l^2 "
           "-3l -l^2; -36 -3l 36 -3l; 3l -l^2 -3l 4l^2] is symmetric with -l^2 at (2,4) and "
           "(4,2); as printed it is not symmetric"),
    "S2": ("(2), (3): K_yy = K_xy = 0 and C_yy = C_xy = 0",
           "K_xy = K_yx = 0 and C_xy = C_yx = 0",
           "K_yy = K_xx is stated in the same line; the isotropic film has no cross terms"),
    "S3": ("(5): r_i^3", "r_i^4", "as printed C^(i) has the unit Pa s, not N s/m; (4) is the "
           "long-damper term eta r^3 l / c^4 times the layer's share (r_i / sum r)^2 times "
           "x0 Omega, and the same share r_i / sum r in (5) gives r_i^4"),
    "S5": ('legend of (1): "n -- radius of turn i"', "r_i -- radius of turn i",
           "OCR/print slip: n is the number of turns"),
}


def defect_note(key: str) -> str:
    """'print defect S3: printed ..., corrected ...: reason' for a description."""
    printed, corrected, reason = DEFECTS[key]
    return f"print defect {key}: printed {printed}; corrected {corrected}; because {reason}"


def matrix(rows) -> ca.SX:
    """An SX matrix from nested lists of SX/numbers."""
    return ca.vertcat(*[ca.horzcat(*[ca.SX(e) for e in row]) for row in rows])


def _printed_rotary(Mr) -> ca.SX:
    """The rotary-inertia matrix as seed 003 prints it (defect S1): entry
    (4,2) with the sign of l^2 flipped, (2,4) as corrected."""
    M = matrix(Mr)
    M[3, 1] = -M[3, 1]
    return M


def rotor_quantities(m, sp) -> None:
    """Element 1, the disks, the supports and the assembled M, C, G, K of
    ``sp`` (models/spindle.py's SpindleRotor), kept on ``m`` in derivation order."""
    Q = m.quantity
    r, sup = sp.rotor, sp.support
    planar = ("in one bending plane, DOF (v1, v1', v2, v2') of its two nodes "
              "(translations in m, slopes in rad)")
    l, A, I, EI = r.element_section(0)
    Ke, Mt, Mr = r.element_matrices(0)
    Q("l_e", l, unit="m", description="length of element 1 (footstep to node 1)",
      symbol="l", source="derived: L_s / n_low (the mesh)", group=ELEMENT)
    Q("A_e", A, unit="m2", description="section area of element 1", symbol="A",
      source="derived: pi d^2 / 4 with d = k_d d_low", group=ELEMENT)
    Q("I_e", I, unit="m4", description="second moment of area of element 1 (I_d = rho I l: "
      "diametral, I_p = 2 I_d: polar, per unit length rho I and 2 rho I)", symbol="I",
      source="derived: pi d^4 / 64 with d = k_d d_low", group=ELEMENT)
    Q("K_e", matrix(Ke), description="stiffness matrix of element 1 " + planar + "; "
      "entries in N/m, N/rad, N.m/rad" + ("; Timoshenko element (shear)" if r.timoshenko
                                          else "; Euler-Bernoulli"),
      symbol=r"[K_p]", source=SEED + " (11), [K_p] = EI/l^3 [12 6l -12 6l; ...]; "
      "Przemieniecki's element for the Timoshenko option", group=ELEMENT)
    Q("M_t", matrix(Mt), description="translational (consistent) mass matrix of element 1 "
      + planar + "; entries in kg, kg.m, kg.m2", symbol=r"[M_T]",
      source="derived: consistent Hermite mass rho A l/420 [156 22l 54 -13l; ...]; the "
      "seed's translational term is lost in the OCR of (11)", group=ELEMENT)
    Q("M_r", matrix(Mr), description="rotary-inertia matrix of element 1 " + planar
      + "; " + defect_note("S1"), symbol=r"[M_R]",
      source=SEED + " (11), m R^2/(120 l) [36 3l -36 3l; ...], corrected (S1)", group=ELEMENT)
    Q("M_r_printed", _printed_rotary(Mr), description="the rotary-inertia matrix of element "
      "1 as printed (not used: not symmetric); " + defect_note("S1"),
      symbol=r"[M_R]_{\mathrm{printed}}", source=SEED + " (11) as printed", group=ELEMENT)
    Q("G_e", 2 * matrix(Mr), description="gyroscopic matrix of element 1 per unit spin speed "
      "(N.s/rad units): 2 M_r, coupling the x plane to the y plane (+) and back (-); "
      + defect_note("S1"), symbol=r"[J_{p1}]",
      source=SEED + " (11), [J_p1] = m R^2/(60 l) [...] = 2 M_r (I_p = 2 I_d), corrected (S1)",
      group=ELEMENT)
    Q("C_e", r.structural_damping * matrix(Ke), description="structural damping matrix of "
      "element 1: beta K_e (stiffness-proportional; entries in N.s/m, N.s/rad, N.m.s/rad)",
      symbol=r"[C_p]", source="assumption: the seed gives no blade damping; beta K_e",
      group=ELEMENT)
    _disk_quantities(m, sp)
    _support_quantities(m, sup)
    kinds = ("mass", "damping (supports and structural)",
             "gyroscopic, per unit spin speed Omega (rad/s)", "stiffness (the film's grows "
             "with Omega)")
    dofs = ", ".join(sp.dofs[:6]) + f", ... ({len(sp.dofs)} DOF)"
    for name, mat, kind, sym in (("M", sp.M, kinds[0], "[M]"), ("C", sp.C, kinds[1], "[C]"),
                                 ("G", sp.G, kinds[2], "[G]"), ("K", sp.K, kinds[3], "[K]")):
        Q(name, mat, description=f"assembled {kind} matrix of M q'' + (C + Omega G) q' + K q "
          f"= F, symbolic in the parameters; q = ({dofs}): translations m, slopes rad",
          symbol=sym, source=SEED + " (12), assembled from the elements of (11), the disks, "
          "the supports and the housing of fig. 4", group=ASSEMBLY)


def _disk_quantities(m, sp) -> None:
    Q = m.quantity
    bob = [d for d in sp.rotor.disks if d[0] == sp.nodes["bobbin"]][-1]
    Q("m_bob", bob[1], unit="kg", description="mass of the bobbin's equivalent disk: tube "
      "and fill times the yarn", symbol=r"m_{p1}", source=SEED + " (11) [M_p], V.1 "
      "(empty and full bobbin); derived: m_b + fill m_y", group=DISKS)
    Q("Id_bob", bob[2], unit="kg.m2", description="diametral moment of inertia of the "
      "bobbin's equivalent disk", symbol=r"J_{d1}", source=SEED + " (11) [M_p]; derived: "
      "Id_b + fill Id_y", group=DISKS)
    Q("Ip_bob", bob[3], unit="kg.m2", description="polar moment of inertia of the bobbin's "
      "equivalent disk: its gyroscopic coupling is Omega Ip_bob between the slopes (ax, ay)",
      symbol=r"J_{p1}", source=SEED + " (11) [C_12] = omega J_p1; derived: Ip_b + fill Ip_y",
      group=DISKS)


def _support_quantities(m, sup) -> None:
    Q = m.quantity
    for name, key, unit, what, sym in (
            ("K_u", "K_u", "N/m", "stiffness", "K_{u}"), ("C_u", "C_u", "N.s/m", "damping",
                                                          "C_{u}")):
        Q(name, matrix(sup[key]), unit=unit, description=f"bolster bearing (upper support) "
          f"{what} coefficients [[xx, xy], [yx, yy]] on the blade's x, y",
          symbol=rf"[{sym}]", source=SEED + " (11), 8-coefficient support [K_ii], [C_ii]",
          group=SUPPORTS)
    for name, key, unit, what, sym in (
            ("K_f", "K_f", "N/m", "stiffness", "K_1"), ("C_f", "C_f", "N.s/m", "damping",
                                                        "C_1")):
        Q(name, matrix(sup[key]), unit=unit, description=f"footstep bearing {what} "
          "coefficients [[xx, xy], [yx, yy]] between the blade's foot and the housing",
          symbol=rf"[{sym}]", source=SEED + ", fig. 4: bearing (K_1XX ... C_1YY)",
          group=SUPPORTS)
    Q("r_i", ca.vertcat(*sup["radii"]), unit="m", description="radii of the coil spring's "
      "turns, r_{i+1} - r_i = c", symbol="r_i", source=SEED + " after (5): c = r_{i+1} - r_i",
      group=SUPPORTS)
    Q("k_spring", sup["k_spring"], unit="N/m", description="structural stiffness of the "
      "coil spring K = E a^3 l / (12 pi sum r_i^3); " + defect_note("S5"), symbol="K",
      source=SEED + " (1)", group=SUPPORTS)
    Q("eps_i0", ca.vertcat(*sup["eps"]), description="relative eccentricity of each film "
      "layer, eps_i0 = 1 - ((n-1) c - delta0)/c r_i / sum_{j<n} r_j",
      symbol=r"\varepsilon_{i0}", source=SEED + " after (5)", group=SUPPORTS)
    Q("J_K", ca.vertcat(*[film_integral_K(e) for e in sup["eps"]]), description="the "
      "integral of (4) for each layer, int_0^{pi/2} cos^2 t sin t (1 - eps_i0 cos t)^-2.28 dt, "
      "by 16-point Gauss-Legendre", symbol=r"J_K^{(i)}", source=SEED + " (4)",
      group=SUPPORTS)
    Q("J_C", ca.vertcat(*[film_integral_C(e) for e in sup["eps"]]), description="the "
      "integral of (5) for each layer, int_0^{pi/2} sin t cos t (1 - eps_i0 cos t)^-1.28 dt, "
      "by 16-point Gauss-Legendre", symbol=r"J_C^{(i)}", source=SEED + " (5)",
      group=SUPPORTS)
    Q("k_i1", ca.vertcat(*sup["K_i1"]), description="film stiffness of each layer per unit "
      "spin speed, K^(i)/Omega, in N/m per rad/s (the layers in series give K_XX = Omega / "
      "sum 1/k_i1, which stays 0 at rest)", symbol=r"k_{\Omega}^{(i)}",
      source=SEED + " (4), divided by the speed", group=SUPPORTS)
    Q("K_i", sup["Omega"] * ca.vertcat(*sup["K_i1"]), unit="N/m", description="film stiffness of "
      "each layer K^(i) = 11.9808 eta x0 Omega r_i^5 l / (c^4 (sum r)^2) int_0^{pi/2} cos^2 t "
      "sin t (1 - eps_i0 cos t)^-2.28 dt (16-point Gauss-Legendre)",
      symbol=r"K_{XX}^{(i)}", source=SEED + " (4)", group=SUPPORTS)
    used, other = sup["damper"], "printed" if sup["damper"] == "corrected" else "corrected"
    power = 4 if used == "corrected" else 3
    Q("C_i", ca.vertcat(*sup[f"C_i_{used}"]), unit="N.s/m" if used == "corrected" else "",
      description=f"film damping of each layer C^(i) = 9.36 eta r_i^{power}"
      " l / (c^3 sum r) int_0^{pi/2} sin t cos t (1 - eps_i0 cos t)^-1.28 dt, the "
      f"{used} form (build option damper); " + defect_note("S3"),
      symbol=r"C_{XX}^{(i)}", source=SEED + f" (5), {used} (S3)", group=SUPPORTS)
    Q(f"C_i_{other}", ca.vertcat(*sup[f"C_i_{other}"]), unit="N.s/m" if other == "corrected"
      else "", description=f"the {other} form of (5), not used by this build"
      + (" (unit Pa s)" if other == "printed" else "") + "; " + defect_note("S3"),
      symbol=rf"C_{{XX}}^{{(i)}}\,\mathrm{{{other}}}", source=SEED + f" (5), {other}",
      group=SUPPORTS)
    Q("K_film", sup["k_film"], unit="N/m", description="squeeze-film stiffness K_XX = K_YY "
      "= 1 / sum 1/K^(i), the layers in series; " + defect_note("S2"), symbol=r"K_{XX}",
      source=SEED + " (2), corrected (S2)", group=SUPPORTS)
    Q("C_film", sup["c_film"], unit="N.s/m" if used == "corrected" else "",
      description="squeeze-film damping C_XX = C_YY = 1 / sum 1/C^(i); " + defect_note("S2"),
      symbol=r"C_{XX}", source=SEED + " (3), corrected (S2)", group=SUPPORTS)
    Q("K_2", sup["k_spring"] + sup["k_film"], unit="N/m", description="the housing's support "
      "stiffness (coil spring and film in parallel), isotropic", symbol="K_2",
      source=SEED + ", fig. 4: support seat (K_2XX); derived: K + K_XX", group=SUPPORTS)


def unbalance_quantity(m, F) -> None:
    """The force vector (13) on every DOF."""
    m.quantity("F", F, unit="N", description="unbalance forces m e Omega^2 (cos(phi + "
               "phase), sin(phi + phase)) of the bobbin and the whorl on their nodes' x, y "
               "(0 on every other DOF)", symbol=r"\{F(t)\}", source=SEED + " (13)",
               group=FORCING)


def modal_quantities(m, B, omega, Mr, Cr, Gr, Kr, Fr) -> None:
    """The reduction q = B eta of spindle_modal and its reduced matrices."""
    Q = m.quantity
    Q("omega_k", omega, unit="rad/s", description="undamped natural frequencies of the "
      "kept planar modes (not spinning, film stiffness at basis_rpm, default parameters)",
      symbol=r"\omega_k", source="derived: K_x X = omega^2 M_x X on the x-plane DOF",
      group=MODAL)
    Q("B", B, description="Ritz basis: column 2k is mode k in the x plane, 2k+1 in the y "
      "plane, each scaled to 1 at its largest translation (numbers, computed at build "
      "time; rows: translations m/m, slopes rad/m)", symbol="[B]",
      source="derived: modal truncation of " + SEED + " (17) without damping and "
      "gyroscopic terms", group=MODAL)
    for name, mat, unit, what in (("M_m", Mr, "kg", "mass"), ("C_m", Cr, "N.s/m", "damping"),
                                  ("G_m", Gr, "", "gyroscopic (per rad/s)"),
                                  ("K_m", Kr, "N/m", "stiffness")):
        Q(name, mat, unit=unit, description=f"reduced {what} matrix B^T {name[0]} B, "
          "symbolic in the parameters", symbol=rf"[{name[0]}_r]",
          source="derived: Ritz projection of " + SEED + " (12)", group=MODAL)
    Q("F_m", Fr, unit="N", description="reduced forces B^T F", symbol=r"\{F_r\}",
      source="derived: Ritz projection of " + SEED + " (13)", group=MODAL)


def force_quantities(m, sup, xb, vb, d, dv, h, vh) -> tuple[ca.SX, ca.SX]:
    """The support forces on the blade (bolster, footstep) and on the housing
    (coil-spring damper), as 2-vectors; returns (bolster, footstep) for the
    outputs.  xb, vb: the bolster node's (x, y) and rates; d, dv: the
    footstep's displacement relative to the housing and its rate; h, vh:
    the housing's (x, y) and rates."""
    Q = m.quantity
    Fu = -(matrix(sup["K_u"]) @ xb + matrix(sup["C_u"]) @ vb)
    Fl = -(matrix(sup["K_f"]) @ d + matrix(sup["C_f"]) @ dv)
    Fd = -((sup["k_spring"] + sup["k_film"]) * h + sup["c_film"] * vh)
    Q("F_u", Fu, unit="N", description="force (x, y) of the bolster bearing on the blade: "
      "-(K_u q_b + C_u q_b')", symbol=r"F_{u}", source="derived: 8-coefficient support, "
      + SEED + " (11)", group=FORCES)
    Q("F_l", Fl, unit="N", description="force (x, y) of the footstep bearing on the blade: "
      "-(K_f (q_0 - h) + C_f (q_0' - h'))", symbol=r"F_{l}", source="derived: bearing of "
      + SEED + ", fig. 4", group=FORCES)
    Q("F_d", Fd, unit="N", description="force (x, y) of the coil-spring squeeze-film damper "
      "on the housing: -(K_2 h + C_XX h')", symbol=r"F_{d}", source="derived: support seat "
      "of " + SEED + ", fig. 4, with (1)-(5)", group=FORCES)
    return Fu, Fl


def static_correction_quantities(m, R, F, dF, q, v) -> None:
    """The residual flexibility R of the dropped modes and the corrected
    recovery q = B eta + R F, v = B eta' + R F' (spindle_modal with
    static_correction=True)."""
    Q = m.quantity
    src = ("derived: mode-acceleration (static correction) method, Craig & Kurdila, "
           "Fundamentals of Structural Dynamics, 2nd ed. (2006), sec. on mode "
           "acceleration / residual flexibility; exact for static loads for any Ritz basis")
    Q("R_res", R, unit="m/N", description="residual flexibility of the dropped modes "
      "R = K^-1 - B (B^T K B)^-1 B^T (numbers, K at the default parameters and the film "
      "stiffness at basis_rpm)", symbol="[R]", source=src, group=MODAL)
    Q("q_corr", q, description="recovered displacements B eta + R F (m, rad)",
      symbol=r"\{q_c\}", source=src, group=MODAL)
    Q("F_dot", dF, description="time derivative of the unbalance forces (N/s) "
      "dF/dphi * Omega (exact at constant speed; the speed's rate is not an input)",
      symbol=r"\{\dot F\}", source="derived: d/dt of " + SEED + " (13)", group=MODAL)
    Q("v_corr", v, description="recovered rates B eta' + R F' (m/s, rad/s)",
      symbol=r"\{v_c\}", source=src, group=MODAL)


def mesh_svg(lay: dict) -> str:
    """An SVG drawing of the finite-element mesh ``lay`` (from
    models/spindle.py's ``mesh_layout``: node heights ``z`` (m), element
    diameters ``d`` (m), node ``roles``, disk nodes, the bolster spring's
    node, the housing's node and the number of film layers), so that the
    figure shows the very mesh the model is built on."""
    z, d = lay["z"], lay["d"]
    top, bottom, height, width = 30.0, 70.0, 510.0, 720.0
    scale = (height - top - bottom) / max(z[-1], 1e-9)  # px per m along the blade
    k_d = 6.0  # diameters drawn k_d times their scale, or the blade is a line
    cx = 330.0

    def Z(zz):
        return height - bottom - scale * zz

    def text(x, y, s, size=13, anchor="start", style="italic"):
        return (f'<text x="{x:.1f}" y="{y:.1f}" font-size="{size}" text-anchor="{anchor}" '
                f'font-style="{style}">{s}</text>')

    parts = []
    # elements: one quadrilateral each, its diameter at the element's middle
    for e, de in enumerate(d):
        half = k_d * scale * de / 2
        y0, y1 = Z(z[e]), Z(z[e + 1])
        parts.append(f'<rect class="element" x="{cx - half:.1f}" y="{y1:.1f}" '
                     f'width="{2 * half:.1f}" height="{y0 - y1:.1f}" fill="#e8eef5" '
                     'stroke="#1f4e79" stroke-width="1.2"/>')
        parts.append(text(cx + half + 4, (y0 + y1) / 2 + 4, f"e{e + 1}", 11, "start",
                          "normal"))
    # disks: whorl and bobbin
    for node, name, w, h in ((lay["whorl"], "whorl (m_w, I_dw, I_pw)", 0.024, 0.010),
                             (lay["bobbin"], "bobbin's equivalent disk", 0.022, 0.040)):
        half, hh = k_d * scale * w / 2 / 3, scale * h / 2
        parts.append(f'<rect x="{cx - half:.1f}" y="{Z(z[node]) - hh:.1f}" '
                     f'width="{2 * half:.1f}" height="{2 * hh:.1f}" fill="#f3d9b1" '
                     'stroke="#9c5a00" stroke-width="1.5" opacity="0.85"/>')
        parts.append(text(cx - half - 8, Z(z[node]) - hh + (0 if h < 0.02 else 10), name, 12,
                          "end"))
    # the axis and the nodes
    parts.append(f'<line x1="{cx}" y1="{Z(0) + 30:.1f}" x2="{cx}" y2="{Z(z[-1]) - 25:.1f}" '
                 'stroke="#777" stroke-dasharray="6 3 1 3"/>')
    for k, zk in enumerate(z):
        parts.append(f'<circle class="node" cx="{cx}" cy="{Z(zk):.1f}" r="3.5" fill="#000"/>')
        role = lay["roles"].get(k, "")
        parts.append(text(cx + 52, Z(zk) + 4, f"n{k}", 12, "start", "normal"))
        parts.append(text(cx + 78, Z(zk) + 4, f"z = {zk * 1e3:.1f} mm" +
                          (f" ({role})" if role else ""), 11, "start", "normal"))
        parts.append(f'<line x1="{cx + 6}" y1="{Z(zk):.1f}" x2="{cx + 48}" y2="{Z(zk):.1f}" '
                     'stroke="#bbb"/>')

    def spring(x0, x1, y, label, below=False):
        n, dx = 8, (x1 - x0) / 10
        pts = [f"{x0:.1f},{y:.1f}", f"{x0 + dx:.1f},{y:.1f}"]
        pts += [f"{x0 + dx * (1 + k):.1f},{y + (5 if k % 2 else -5):.1f}" for k in range(n)]
        pts += [f"{x1 - dx:.1f},{y:.1f}", f"{x1:.1f},{y:.1f}"]
        return (f'<polyline points="{" ".join(pts)}" fill="none" stroke="#9c2a00" '
                'stroke-width="1.5"/>' + text((x0 + x1) / 2, y + (20 if below else -9),
                                             label, 11, "middle"))

    def ground(x, y0, y1):
        hatch = "".join(f'<line x1="{x:.1f}" y1="{y:.1f}" x2="{x - 7:.1f}" y2="{y + 7:.1f}" '
                        'stroke="#555"/>' for y in range(int(y0), int(y1), 7))
        return f'<line x1="{x:.1f}" y1="{y0:.1f}" x2="{x:.1f}" y2="{y1:.1f}" ' \
               f'stroke="#555" stroke-width="2"/>' + hatch

    # upper support: the bolster bearing, 8 coefficients (k, c direct and cross)
    yb = Z(z[lay["bolster"]])
    half = k_d * scale * d[lay["bolster"] - 1] / 2
    xg = cx - 200
    parts.append(spring(xg, cx - half, yb, ""))
    parts.append(ground(xg, yb - 18, yb + 18))
    parts.append(text(xg - 40, yb + 34, "bolster bearing (upper support):", 12))
    parts.append(text(xg - 40, yb + 49, "k_u, c_u, k_uxy, c_uxy", 11))
    # lower support: the footstep film to the housing (m_p), the housing on the
    # coil spring with the squeeze-film layers between its turns, to the frame
    yf = Z(z[lay["housing"]])
    hb = 30.0
    parts.append(f'<rect x="{cx - hb:.1f}" y="{yf - 14:.1f}" width="{2 * hb:.1f}" '
                 'height="28" fill="none" stroke="#2e7d32" stroke-width="2"/>')
    parts.append(spring(cx - hb, cx - 4, yf + 5, ""))
    parts.append(text(cx + hb + 4, yf + 26, "housing m_p (own x, y); film k_f, c_f to "
                      "the blade", 11))
    layers = lay["layers"]
    parts.append(spring(xg, cx - hb, yf, ""))
    for i in range(layers):  # the film layers between the spring's turns
        x = xg + (cx - hb - xg) * (i + 1) / (layers + 1)
        parts.append(f'<line x1="{x:.1f}" y1="{yf - 14:.1f}" x2="{x:.1f}" '
                     f'y2="{yf + 14:.1f}" stroke="#2e7d32" stroke-dasharray="3 2"/>')
    parts.append(ground(xg, yf - 18, yf + 18))
    parts.append(text(xg - 40, yf + 32, "footstep bearing (lower support): coil spring,", 12))
    parts.append(text(xg - 40, yf + 47, f"{layers} squeeze-film layers: k_spring + K_film, "
                      "C_film", 11))
    # dimensions along the blade
    xd = cx + 270
    for (a, b), label in ((lay["span_low"], f"L_s ({lay['n_low']} el.)"),
                          (lay["span_w"], "L_w"),
                          (lay["span_up"], f"L_up ({lay['n_cone']} el.)")):
        parts.append(f'<line x1="{xd}" y1="{Z(z[a]):.1f}" x2="{xd}" y2="{Z(z[b]):.1f}" '
                     'stroke="#000" marker-start="url(#sarr)" marker-end="url(#sarr)"/>')
        parts.append(text(xd + 6, (Z(z[a]) + Z(z[b])) / 2 + 4, label, 12))
    # axes
    xa, ya = width - 60, height - 14
    parts.append(f'<line x1="{xa}" y1="{ya}" x2="{xa}" y2="{ya - 45}" stroke="#000" '
                 'marker-end="url(#sarr)"/>' + text(xa + 6, ya - 38, "z", 14))
    parts.append(f'<line x1="{xa}" y1="{ya}" x2="{xa + 45}" y2="{ya}" stroke="#000" '
                 'marker-end="url(#sarr)"/>' + text(xa + 40, ya - 6, "x", 14))
    n = len(z)
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" '
            f'height="{height:.0f}" viewBox="0 0 {width:.0f} {height:.0f}" role="img" '
            f'aria-label="spindle finite-element mesh: {n} nodes, {len(d)} elements, '
            'bolster and footstep supports, whorl and bobbin disks"><defs><marker '
            'id="sarr" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" '
            'markerHeight="7" orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z"/>'
            f'</marker></defs><rect width="{width:.0f}" height="{height:.0f}" fill="#fff"/>'
            + "".join(parts) + "</svg>")
