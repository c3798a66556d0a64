"""Backrest (whip roll) of a loom with Coulomb friction in both pivots.

Source: seed 004 (Savvin, Titov, Gerasimova), equations (1)-(13).  Frame
(the seed's figure is missing; reconstructed so that every printed sign of
(3)-(13) is reproduced): side view, x to the front of the loom, y up, origin
at the lever pivot O1.  The lever O1O2 (length r1) carries the roller axis
O2 = O1 + r1 (-cos phi1, sin phi1); phi1 is the lever angle, phi2 the
roller's angle relative to the lever (clockwise positive, both).  The warp
wraps over the roller: the lower branch 1 (tension S1) runs back down to the
warp beam at alpha1, the upper branch 2 (S2) forward to the healds at alpha2.

Derived here, not typed: the kinetic energy T, the potential V (roller
weight), the generalized forces by virtual work (warp tensions, spring,
friction torques) and Lagrange's equations; the reaction R2 by Newton's law
for the roller.  Each step is kept as a named quantity (``Model.quantity``,
shown by ``loomfmu inspect backrest``); tests check them against the seed's
(7), (10) and (11).

Build options: ``friction`` ("events" or "regularized", ``eps``),
``shedding`` (True: a built-in shedding elongation A_shed, one pick per
main-shaft revolution at omega_loom; False: the warp is stretched only through the front port's input,
as in a loom scene) and ``fronts`` (1: one upper branch, port ``warp_front``;
2: two half-sheets, the ends of heald frames A and B, ports ``warp_front_a``
and ``warp_front_b``, each with its own elongation input and tension output,
the roller loaded by their sum).

Print defects corrected (the same text is attached to the quantities they
affect, so docstring and report have one source):
"""
from __future__ import annotations

import math

import casadi as ca

from loomfmu.declare.checks import check_bool, check_choice, check_number
from loomfmu.declare.model import Model
from loomfmu.mechanics.friction import coulomb_joint
from loomfmu.mechanics.lagrange import generalized_forces, lagrange_equations

SEED = "seed 004"
A = "assumption: the seed gives no numbers; "
DEG = math.pi / 180
#: the default of the parameter g (m/s2)
G = 9.81
#: allowed regularization speeds (rad/s): the range of the parameter eps
EPS_RANGE = (1e-9, 10.0)
#: values of the build option ``fronts``
FRONTS = (1, 2)
#: the heald frame's defaults (models/heald_common.py, seed 000) the warp
#: defaults follow: ends per frame, tension per end at the closed and the
#: open shed (N), the shed's elongation per end at the open shed (m, from
#: h_m = 0.029, l_1 = 0.05, k_z = 5)
HEALD_ENDS, HEALD_T_MIN, HEALD_T_MAX, HEALD_DL_MAX = 1000, 0.3, 0.8, 0.009478

#: print defects of seed 004: (where, printed, corrected, reason)
DEFECTS = {
    "B1": ("(5), (7)", "spring moment F r sin(theta)", "F r2 sin(theta)",
           "r is the roller radius; the spring's arm O1A is r2, as (8) and (9) have it"),
    "B2": ("(8)", "m_c g r1 phi_i", "m_c g r1 cos(phi_n)",
           "setting (7) to zero gives the cosine of the weight's arm, as (4) has it"),
    "B3": ("text before (8)", "S1 = S2 = 0", "S1 = S2 = S0",
           "(8) itself contains S0: the equilibrium is taken under the static tension"),
    "B4": ("(11)", "phi'', phi'", "phi1'', phi1'",
           "O2 moves with the lever only, so only the lever's rate and acceleration enter"),
}


def defect(key: str) -> str:
    """Print defect ``key`` (B1-B4) as one line: printed, corrected, reason."""
    where, printed, corrected, reason = DEFECTS[key]
    return f"print defect {key} in {where}: printed {printed}, corrected {corrected} ({reason})"


#: (one line per defect, marked "B1  ...": the FMU's documentation lists them)
__doc__ += "".join(f"{k}  {defect(k)}\n" for k in DEFECTS) + (
    "Friction: the seed's normal pressure N_i is the full reaction |R_i| (its\n"
    "conclusion 2) and r_if the friction-circle radius rho_i mu_i / sqrt(1 + mu_i^2).\n")


def friction_radius(rho, mu):
    """Radius of the friction circle of a pin of radius rho (seed 004, (6))."""
    return rho * mu / ca.sqrt(1 + mu**2)


def build(*, friction: str = "events", eps: float = 1e-3, shedding: bool = True,
          fronts: int = 1) -> Model:
    """friction: "events" (stick/slip state machine) or "regularized"
    (torque ~ tanh(speed / eps), eps in rad/s).  shedding: True adds the
    built-in shedding elongation (parameters A_shed, omega_loom); False leaves the
    warp to the front ports' inputs.  fronts: 1 (port warp_front: input
    warp_pull, output S2) or 2 (ports warp_front_a, warp_front_b: inputs
    warp_pull_a, warp_pull_b, outputs S2a, S2b, each half of the sheet)."""
    check_choice("friction", friction, ("events", "regularized"))
    eps = check_number("eps", eps, lo=EPS_RANGE[0], hi=EPS_RANGE[1], unit="rad/s")
    shedding = check_bool("shedding", shedding)
    fronts = check_choice("fronts", fronts, FRONTS)
    m = Model("backrest" if friction == "events" else "backrest_regularized",
              description="Loom backrest (whip roll): lever and roller with Coulomb "
              "friction in both pivots, stick-slip (seed 004)",
              stop_time=1.0, step_size=1e-3, h_fixed=2e-5,
              options={"friction": friction, "eps": eps, "shedding": shedding,
                       "fronts": fronts},
              reference_method="DOP853" if friction == "events" else "Radau")
    p = _parameters(m, shedding)
    x = _states(m, p)
    warp = _warp(m, p, x, shedding, fronts)
    spring = _spring(m, p, x)
    _lagrange(m, p, x, warp, spring)
    R1, R2, N1, N2 = _reactions(m, p, x, warp, spring)
    _friction(m, p, x, N1, N2, eps if friction == "regularized" else None)
    _outputs(m, x, warp, spring, N1, N2, fronts)
    m.figure("frame", frame_svg({n: m.var(n).start for n in FIGURE_PARAMETERS}),
             caption="The frame reconstructed from the signs of (3)-(13) (the seed's figure "
             "is missing), drawn at the default parameters: side view, x to the front of "
             "the loom, y up, origin at the lever pivot O1; lever O1O2 (r1) at phi1 above "
             "the rear horizontal, roller (radius r) on O2, spring arm O1A (r2) at gamma "
             "to the extension of O2O1, spring at theta to O1A; lower warp branch 1 (S1) "
             "back down to the warp beam at alpha1, upper branch 2 (S2) forward to the "
             "healds at alpha2. Angles not to scale where they are small.")
    return m


#: the parameters the frame's sketch is drawn with (their defaults)
FIGURE_PARAMETERS = ("r1", "r", "r2", "phi_n", "alpha1", "alpha2", "theta", "gamma")


def frame_svg(p: dict) -> str:
    """An SVG sketch of the backrest's frame at the parameter values ``p``
    (the names of :data:`FIGURE_PARAMETERS`, SI units)."""
    scale, ox, oy = 900.0, 330.0, 150.0  # px per m; O1 on the canvas

    def pt(x, y):  # model (m, y up) -> canvas (px, y down)
        return ox + scale * x, oy - scale * y

    def line(a, b, style):
        return (f'<line x1="{a[0]:.1f}" y1="{a[1]:.1f}" x2="{b[0]:.1f}" y2="{b[1]:.1f}" '
                f'{style}/>')

    def label(xy, text, dx=0, dy=0, size=15):
        return (f'<text x="{xy[0] + dx:.1f}" y="{xy[1] + dy:.1f}" font-size="{size}" '
                f'font-style="italic">{text}</text>')

    def arc(c, r_px, a0, a1):  # angles in model radians (counter-clockwise)
        p0 = (c[0] + r_px * math.cos(a0), c[1] - r_px * math.sin(a0))
        p1 = (c[0] + r_px * math.cos(a1), c[1] - r_px * math.sin(a1))
        sweep = 0 if a1 > a0 else 1
        return (f'<path d="M{p0[0]:.1f},{p0[1]:.1f} A{r_px},{r_px} 0 0 {sweep} '
                f'{p1[0]:.1f},{p1[1]:.1f}" fill="none" stroke="#555"/>')

    phi, r1, r, r2 = p["phi_n"], p["r1"], p["r"], p["r2"]
    a1, a2, th, ga = p["alpha1"], p["alpha2"], p["theta"], p["gamma"]
    thin = 'stroke="#777" stroke-dasharray="4 3"'
    O1 = pt(0, 0)
    o2 = (-r1 * math.cos(phi), r1 * math.sin(phi))
    O2 = pt(*o2)
    ext = -phi  # direction of the extension of O2O1 beyond O1 (model angle)
    a_dir = ext - ga
    A = pt(r2 * math.cos(a_dir), r2 * math.sin(a_dir))
    spring_dir = a_dir + math.pi - th  # the spring makes theta with the arm O1A
    S_end = (A[0] + 110 * math.cos(spring_dir), A[1] - 110 * math.sin(spring_dir))
    # warp branches: tangent to the roller, wrapping over it
    t2 = (o2[0] - r * math.sin(a2), o2[1] + r * math.cos(a2))
    t1 = (o2[0] - r * math.sin(a1), o2[1] + r * math.cos(a1))
    T2, T1 = pt(*t2), pt(*t1)
    end2 = (T2[0] + 330 * math.cos(a2), T2[1] - 330 * math.sin(a2))
    end1 = (T1[0] - 200 * math.cos(a1), T1[1] + 200 * math.sin(a1))
    parts = [
        # axes at O1
        line((O1[0] - 300, O1[1]), (O1[0] + 330, O1[1]), thin),
        line(O1, (O1[0] + 60, O1[1]), 'stroke="#000" marker-end="url(#arr)"'),
        line(O1, (O1[0], O1[1] - 60), 'stroke="#000" marker-end="url(#arr)"'),
        label(O1, "x", 62, 16), label(O1, "y", -14, -52),
        # lever, spring arm, spring
        line(O1, O2, 'stroke="#1f4e79" stroke-width="6" stroke-linecap="round"'),
        line(O1, A, 'stroke="#1f4e79" stroke-width="6" stroke-linecap="round"'),
        line(O1, pt(0.13 * math.cos(ext), 0.13 * math.sin(ext)), thin),
        f'<polyline points="{A[0]:.1f},{A[1]:.1f} ' + " ".join(
            f"{A[0] + k * 11 * math.cos(spring_dir) + (7 if k % 2 else -7) * math.sin(spring_dir):.1f},"
            f"{A[1] - k * 11 * math.sin(spring_dir) + (7 if k % 2 else -7) * math.cos(spring_dir):.1f}"
            for k in range(1, 10)) + f' {S_end[0]:.1f},{S_end[1]:.1f}" fill="none" '
        'stroke="#9c2a00" stroke-width="2"/>',
        label(S_end, "spring (k_s, F_s)", 6, 4, 13),
        # roller and warp
        f'<circle cx="{O2[0]:.1f}" cy="{O2[1]:.1f}" r="{scale * r:.1f}" fill="#e8eef5" '
        'stroke="#1f4e79" stroke-width="2"/>',
        line(T2, end2, 'stroke="#2e7d32" stroke-width="3"'),
        line(T1, end1, 'stroke="#2e7d32" stroke-width="3"'),
        label(end2, "2: S<tspan baseline-shift=\"sub\" font-size=\"11\">2</tspan>, to "
              "the healds", -170, -10, 13),
        label(end1, "1: S<tspan baseline-shift=\"sub\" font-size=\"11\">1</tspan>, to "
              "the warp beam", 8, 0, 13),
        # angles
        line(T2, (T2[0] + 90, T2[1]), thin), arc(T2, 70, 0, a2),
        label(T2, "α<tspan baseline-shift=\"sub\" font-size=\"11\">2</tspan>", 74,
              -6),
        line(T1, (T1[0] - 90, T1[1]), thin), arc(T1, 45, math.pi, math.pi + a1),
        label(T1, "α<tspan baseline-shift=\"sub\" font-size=\"11\">1</tspan>", -66,
              30),
        arc(O1, 62, math.pi - phi, math.pi),
        label(O1, "φ<tspan baseline-shift=\"sub\" font-size=\"11\">1</tspan>", -92,
              -4),
        arc(O1, 50, a_dir, ext),
        label(O1, "γ", 62 * math.cos((a_dir + ext) / 2) - 4,
              -62 * math.sin((a_dir + ext) / 2) + 5),
        arc(A, 34, a_dir + math.pi, spring_dir),
        label(A, "θ", 26 * math.cos((a_dir + math.pi + spring_dir) / 2) - 4,
              -26 * math.sin((a_dir + math.pi + spring_dir) / 2) + 5),
        # points
        f'<circle cx="{O1[0]:.1f}" cy="{O1[1]:.1f}" r="4"/>',
        f'<circle cx="{O2[0]:.1f}" cy="{O2[1]:.1f}" r="4"/>',
        f'<circle cx="{A[0]:.1f}" cy="{A[1]:.1f}" r="4"/>',
        label(O1, "O<tspan baseline-shift=\"sub\" font-size=\"11\">1</tspan>", 6, -10),
        label(O2, "O<tspan baseline-shift=\"sub\" font-size=\"11\">2</tspan>", -8, 20),
        label(A, "A", 8, 16),
        label(pt(*[(a + b) / 2 for a, b in zip((0, 0), o2)]), "r<tspan baseline-shift="
              "\"sub\" font-size=\"11\">1</tspan>", -6, -10, 13),
    ]
    return ('<svg xmlns="http://www.w3.org/2000/svg" width="720" height="330" '
            'viewBox="0 0 720 330" role="img" aria-label="backrest frame: lever O1O2, '
            'roller, spring arm O1A, warp branches 1 and 2"><defs><marker id="arr" '
            'viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7" '
            'orient="auto"><path d="M0,0 L10,5 L0,10 z"/></marker></defs>'
            '<rect width="720" height="330" fill="#fff"/>' + "".join(parts) + "</svg>")


def _parameters(m: Model, shedding: bool) -> dict:
    P = m.parameter
    p = {}
    p["r1"] = P("r1", 0.15, unit="m", description="lever length O1O2", min=0.02, max=1.0,
                source=A + "backrest swing levers are 0.1-0.2 m")
    p["r"] = P("r", 0.05, unit="m", description="roller radius (warp mid-line)", min=0.01,
               max=0.3, source=A + "backrest tube diameter 90-110 mm")
    p["m_c"] = P("m_c", 20.0, unit="kg", description="roller mass", min=0.1, max=500.0,
                 source=A + "steel tube 100 x 4 mm, 1.9 m, with journals")
    p["g"] = P("g", G, unit="m/s2", description="gravitational acceleration (the roller's "
               "weight m_c g)", min=0.0, max=30.0,
               source="assumption: 9.81 m/s2, standard gravity rounded (the seed gives no "
               "value; the heald frame's g is 9.80665)")
    p["J_c"] = P("J_c", 0.0426, unit="kg.m2", description="roller moment of inertia about "
                 "O2", min=1e-5, max=10.0, source=A + "thick tube m (r_o^2 + r_i^2) / 2")
    p["J_1"] = P("J_1", 0.05, unit="kg.m2", description="lever assembly inertia about O1 "
                 "(centre of mass at O1, as (12) implies)", min=1e-5, max=10.0,
                 source=A + "two side levers and a rocking shaft")
    p["r2"] = P("r2", 0.08, unit="m", description="spring arm O1A", min=0.01, max=0.5,
                source=SEED + " (5), (8), (9); value " + A + "short arm of a two-arm lever")
    p["theta"] = P("theta", 80 * DEG, unit="rad", description="angle between spring and "
                   "arm O1A", min=1 * DEG, max=179 * DEG,
                   source=SEED + " (5); value " + A + "near 90 deg")
    p["gamma"] = P("gamma", 20 * DEG, unit="rad", description="angle between O1A and the "
                   "extension of O2O1 (enters (12) only)", min=-math.pi, max=math.pi,
                   source=SEED + " (12); value " + A + "layout")
    p["phi_n"] = P("phi_n", 10 * DEG, unit="rad", description="initial (equilibrium) lever "
                   "angle", min=-80 * DEG, max=80 * DEG, source=SEED + " (8), (9); value "
                   + A + "lever slightly above the rear horizontal")
    p["alpha1"] = P("alpha1", 60 * DEG, unit="rad", description="angle of the lower branch "
                    "(to the warp beam) to the horizontal", min=0.0, max=math.pi / 2,
                    source=SEED + " (3); value " + A + "30-90 deg as the beam empties")
    p["alpha2"] = P("alpha2", 8 * DEG, unit="rad", description="angle of the upper branch "
                    "(to the healds) to the horizontal", min=-math.pi / 4, max=math.pi / 2,
                    source=SEED + " (3); value " + A + "branch near horizontal")
    p["k_s"] = P("k_s", 5e4, unit="N/m", description="spring stiffness", min=1e2, max=1e7,
                 source=SEED + " (9); value " + A + "two springs of 25 kN/m")
    ends = 2 * HEALD_ENDS
    c2 = round(ends * (HEALD_T_MAX - HEALD_T_MIN) / HEALD_DL_MAX, -2)
    c1 = 2 * c2
    p["S0"] = P("S0", ends * HEALD_T_MIN, unit="N", description="static warp tension "
                "(whole sheet; closed shed, all elongations zero)", min=10.0, max=2e4,
                source=SEED + " (8); value " + A + "the heald frame's closed-shed tension: "
                f"2 frames x n_n = {HEALD_ENDS} ends x T_min = {HEALD_T_MIN} N (seed 000); "
                "with c2 and A_shed the tension spans 2 n_n x [T_min, T_max] over a pick "
                "and its mean is 2 n_n x the mean tension per end")
    p["c1"] = P("c1", c1, unit="N/m", description="stiffness of the lower branch (whole "
                "sheet)", min=1e3, max=1e8, source=A + "2 c2: the lower branch (0.35 m) is "
                "half as long as the upper (0.7 m)")
    p["c2"] = P("c2", c2, unit="N/m", description="stiffness of the upper branch (whole "
                "sheet; each half-sheet c2/2)", min=1e3, max=1e8,
                source=A + "the heald frame's tension law (seed 000): 2 n_n (T_max - "
                f"T_min) / dl_max = 2 x {HEALD_ENDS} x {HEALD_T_MAX - HEALD_T_MIN:g} N / "
                f"{HEALD_DL_MAX * 1e3:.2f} mm, rounded")
    p["b1"] = P("b1", float(round(0.03 * c1 / (2 * math.pi * 8))), unit="N.s/m",
                description="damping of the lower branch (whole sheet)", min=0.0, max=1e6,
                source=A + "0.03 c1 / omega at 8 Hz")
    p["b2"] = P("b2", float(round(0.03 * c2 / (2 * math.pi * 8))), unit="N.s/m",
                description="damping of the upper branch (whole sheet; each half-sheet "
                "b2/2)", min=0.0, max=1e6, source=A + "0.03 c2 / omega at 8 Hz")
    p["rho1"] = P("rho1", 0.020, unit="m", description="pin radius at O1", min=1e-3,
                  max=0.2, source=A + "rocking-shaft bearing")
    p["mu1"] = P("mu1", 0.12, description="sliding friction coefficient at O1", min=0.0,
                 max=1.0, source=A + "plain steel bearing, poor lubrication")
    p["rho2"] = P("rho2", 0.015, unit="m", description="pin radius at O2", min=1e-3,
                  max=0.2, source=A + "roller journal")
    p["mu2"] = P("mu2", 0.10, description="sliding friction coefficient at O2", min=0.0,
                 max=1.0, source=A + "plain roller journal")
    p["k_static"] = P("k_static", 1.3, description="static / kinetic friction ratio",
                      min=1.0, max=3.0, source=A + "1.2-1.5 for boundary-lubricated steel")
    if shedding:
        p["A_shed"] = P("A_shed", HEALD_DL_MAX, unit="m", description="built-in shedding "
                        "elongation of the upper branch (every end), (1 - cos)/2 over each "
                        "pick", min=0.0, max=0.05, source=A + "the heald frame's elongation "
                        "per end at the open shed (seed 000 geometry at its defaults); a "
                        "scene builds shedding=False and drives the front ports instead")
        p["omega_loom"] = P("omega_loom", 8 * math.pi, unit="rad/s", display_unit="rpm",
                            description="main-shaft speed for the built-in shedding (one "
                            "pick per main-shaft revolution)", min=2 * math.pi / 60,
                            max=2000 * 2 * math.pi / 60, source=A + "200-300 picks/min; "
                            "240 rpm = 8 pi rad/s, the loom_shaft model's omega_0; range "
                            "1-2000 rpm")
    return p


class _X:
    """The coordinates, rates and friction unknowns, and the kinematics."""

    def __init__(self, m: Model, p: dict):
        self.dphi1 = m.state("dphi1", 0.0, unit="rad", description="lever angle from its "
                             "initial (equilibrium) value phi_n")
        self.phi2 = m.state("phi2", 0.0, unit="rad", description="roller angle relative to "
                            "the lever")
        self.w1 = m.state("omega1", 0.0, unit="rad/s", description="lever rate (pivot O1)")
        self.w2 = m.state("omega2", 0.0, unit="rad/s", description="roller rate relative to "
                          "the lever (pivot O2)")
        self.M1f = m.algebraic("M1f", unit="N.m", description="friction torque in pivot O1")
        self.M2f = m.algebraic("M2f", unit="N.m", description="friction torque in pivot O2")
        self.phi1 = p["phi_n"] + self.dphi1
        self.q, self.qd = ca.vertcat(self.dphi1, self.phi2), ca.vertcat(self.w1, self.w2)
        self.qdd = ca.vertcat(m.der(self.w1), m.der(self.w2))
        m.eq(m.der(self.dphi1), self.w1)
        m.eq(m.der(self.phi2), self.w2)
        K = "coordinates and kinematics"
        self.O2 = m.quantity("r_O2", p["r1"] * ca.vertcat(-ca.cos(self.phi1),
                                                           ca.sin(self.phi1)),
                             unit="m", group=K, symbol=r"\vec r_{O_2}",
                             description="roller axis O2 (x to the front, y up, from O1); the "
                             "generalized coordinates are the lever angle phi1 = phi_n + "
                             "dphi1 and the roller's angle phi2 relative to the lever",
                             source=SEED + ", fig. 1 (missing; frame reconstructed from the "
                             "signs of (3)-(13))")
        self.v_O2 = m.quantity("v_O2", ca.jacobian(self.O2, self.q) @ self.qd, unit="m/s",
                               group=K, symbol=r"\vec v_{O_2}", description="velocity of "
                               "O2", source="derived: d r_O2 / dt")
        self.a_O2 = m.quantity("a_O2", ca.jacobian(self.v_O2, self.q) @ self.qd
                               + ca.jacobian(self.v_O2, self.qd) @ self.qdd, unit="m/s2",
                               group=K, symbol=r"\vec a_{O_2}", description="acceleration "
                               "of O2", source="derived: d v_O2 / dt")


def _states(m: Model, p: dict) -> _X:
    x = _X(m, p)
    E = "energies"
    x.T = m.quantity("T", 0.5 * p["J_1"] * x.w1**2 + 0.5 * p["m_c"] * ca.dot(x.v_O2, x.v_O2)
                     + 0.5 * p["J_c"] * (x.w1 + x.w2) ** 2, unit="J", group=E, symbol="T",
                     description="kinetic energy: lever about O1, roller's translation with "
                     "O2, roller's absolute rotation (phi1' + phi2')",
                     source="derived: seed 004 names Lagrange's equations of the second "
                     "kind, gives no T")
    x.V = m.quantity("V", p["m_c"] * p["g"] * x.O2[1], unit="J", group=E, symbol="V",
                     description="potential energy of the roller's weight (the lever's "
                     "centre of mass is at O1; the spring acts as a force, (9))",
                     source="derived: its moment -dV/dphi1 is the seed's (4)")
    return x


def _warp(m: Model, p: dict, x: _X, shedding: bool, fronts: int) -> dict:
    W = "warp branches"
    letoff = m.input("letoff", 0.0, unit="m", description="elongation imposed on the lower "
                     "branch from the warp beam's side (port warp_back), measured from the "
                     "static state; positive stretches it (a let-off that releases warp into "
                     "the branch is negative)", min=-0.5, max=0.5)
    halves = [""] if fronts == 1 else ["_a", "_b"]
    whose = {"": "the whole sheet", "_a": "the ends of heald frame A (half the sheet)",
             "_b": "the ends of heald frame B (half the sheet)"}
    shed_text = "; adds to the built-in shedding" if shedding else ""
    pulls = [m.input(f"warp_pull{h}", 0.0, unit="m", description=f"elongation imposed on "
                     f"the upper branch's ends of {whose[h]} by the loom (shedding, beat-up, "
                     f"take-up; port warp_front{h}), measured from the static state "
                     f"(closed shed); positive stretches them{shed_text}",
                     min=-0.5, max=0.5) for h in halves]
    if shedding:
        shed = m.quantity("shed", p["A_shed"] * (1 - ca.cos(p["omega_loom"] * m.t)) / 2,
                          unit="m", group=W, symbol=r"\Delta_{sh}", description="built-in "
                          "shedding elongation of every end of the upper branch",
                          source=A + "one (1 - cos)/2 pulse per pick")
    else:
        shed = 0
    turn = p["r"] * (x.dphi1 + x.phi2)
    D1 = m.quantity("Delta_1", p["r1"] * (ca.cos(p["alpha1"] + p["phi_n"])
                                          - ca.cos(p["alpha1"] + x.phi1)) + turn + letoff,
                    unit="m", group=W, symbol=r"\Delta_1", description="elongation of the "
                    "lower branch from the static state: the lever's translation of O2 along "
                    "the branch, the roller's turn r (phi1 - phi_n + phi2) and the input "
                    "letoff", source=SEED + " (13) integrated (d l_1n = h_1 d phi1, h_1 the "
                    "arm of S1 moved to O2) and completed with the roller's turn")
    D2g = p["r1"] * (ca.cos(p["alpha2"] + x.phi1) - ca.cos(p["alpha2"] + p["phi_n"])) - turn
    share = 1 if fronts == 1 else 0.5
    tex = {"": "2", "_a": "2a", "_b": "2b"}
    w = {"D": [D1], "S": [], "names": halves, "pulls": pulls, "letoff": letoff}
    for h, pull in zip(halves, pulls):
        w["D"].append(m.quantity(
            f"Delta_2{h}", D2g + pull + shed, unit="m", group=W, symbol=rf"\Delta_{{{tex[h]}}}",
            description=f"elongation of the upper branch's ends of {whose[h]} from the static "
            "state: the lever's translation of O2, minus the roller's turn, plus the input "
            f"warp_pull{h}" + (" and the built-in shedding" if shedding else ""),
            source="derived: the seed's (13) for branch 2 (its text says the same holds)"))
    D = ca.vertcat(*w["D"])
    D_rate = ca.jacobian(D, x.q) @ x.qd + ca.jacobian(D, m.t)
    w["dD_dq"] = ca.jacobian(D, x.q)
    for k, h in enumerate([None] + halves):
        c, b, S0 = ((p["c1"], p["b1"], p["S0"]) if h is None else
                    (share * p["c2"], share * p["b2"], share * p["S0"]))
        name, sym = ("S_1", "S_1") if h is None else (f"S_2{h}", f"S_{{{tex[h]}}}")
        w["S"].append(m.quantity(
            name, S0 + c * D[k] + b * D_rate[k], unit="N", group=W, symbol=sym,
            description=("tension of the lower branch (whole sheet)" if h is None else
                         f"tension of the upper branch's ends of {whose[h]}") + ": static "
            "tension plus a linear spring and damper on the elongation (absolute; valid "
            "while >= 0, see the validity conditions)",
            source=A + "linear visco-elastic warp; the seed leaves the law open"))
    return w


def _spring(m: Model, p: dict, x: _X) -> dict:
    SP = "spring"
    F0 = m.quantity("F_0", (p["m_c"] * p["g"] * p["r1"] * ca.cos(p["phi_n"])
                            + p["r1"] * p["S0"] * (ca.sin(p["phi_n"] + p["alpha1"])
                                                   - ca.sin(p["phi_n"] + p["alpha2"])))
                    / (p["r2"] * ca.sin(p["theta"])), unit="N", group=SP, symbol="F_0",
                    description="spring preload: (7) = 0 at phi1 = phi_n with S1 = S2 = S0 "
                    "and no friction", source=SEED + " (8); " + defect("B2") + "; "
                    + defect("B3"))
    F_s = m.quantity("F_s", F0 - p["k_s"] * x.dphi1 * p["r2"] * ca.sin(p["theta"]), unit="N",
                     group=SP, symbol="F_{s}", description="spring force",
                     source=SEED + " (9)")
    M_s = m.quantity("M_s", F_s * p["r2"] * ca.sin(p["theta"]), unit="N.m", group=SP,
                     symbol="M_{s}", description="moment of the spring about O1",
                     source=SEED + " (5); " + defect("B1"))
    return {"F0": F0, "F_s": F_s, "M_s": M_s}


def _lagrange(m: Model, p: dict, x: _X, w: dict, spring: dict) -> None:
    Q_G = "generalized forces (virtual work)"
    n = len(w["S"])
    S_held, M_held = ca.SX.sym("S_held", n), ca.SX.sym("M_held")
    power = (-ca.dot(S_held, w["dD_dq"] @ x.qd) + M_held * x.w1 + x.M1f * x.w1
             + x.M2f * x.w2)
    held = ca.vertcat(S_held, M_held)
    values = ca.vertcat(*w["S"], spring["M_s"])
    x.Q = m.quantity("Q", ca.substitute(generalized_forces(power, x.qd), held, values),
                     unit="N.m", group=Q_G, symbol="Q",
                     description="generalized forces (Q_1 about O1, Q_2 about O2): the "
                     "coefficients of phi1', phi2' in the power of the applied forces (warp "
                     "tensions, spring, friction torques) held at their values; the weight is "
                     "in V (Q_1 is not zero at the static equilibrium: the weight's moment is "
                     "missing; M_1 below adds it), and Q - dV/dq equals the seed's (7) and "
                     "(10) (test)",
                     source=SEED + " (1), (2), (7), (10); " + defect("B1"))
    m.quantity("M_1", x.Q[0] - ca.gradient(x.V, x.q)[0], unit="N.m", group=Q_G,
               symbol="M_1", description="moment about O1 of every force on the lever and "
               "roller, the roller's weight included: Q_1 - dV/dphi1, the left side of the "
               "seed's (7); zero at the static equilibrium (phi1 = phi_n, S1 = S2 = S0, no "
               "friction), where Q_1 alone equals the weight's moment m_c g r1 cos(phi_n)",
               source=SEED + " (4), (7); " + defect("B1"))
    L = "Lagrange's equations"
    m.quantity("M_q", ca.hessian(x.T, x.qd)[0], unit="kg.m2", group=L, symbol="M(q)",
               description="generalized mass matrix d2T / dq' dq'",
               source="derived from T")
    first = len(m.equations)
    res = lagrange_equations(x.T, x.V, x.q, x.qd, x.qdd, x.Q)
    for residual in ca.vertsplit(res):
        m.eq(residual)
    m.quantity("lagrange", res, unit="N.m", group=L, symbol=r"\frac{d}{dt}\frac{\partial "
               r"L}{\partial \dot q} - \frac{\partial L}{\partial q} - Q",
               description="Lagrange's equations of the second kind, L = T - V, each = 0: "
               f"the model's equations E{first + 1} and E{first + 2} (model.equations"
               f"[{first}:{first + 2}])", source=SEED + ", Lagrange's equations of the "
               "second kind [1]; derived by CasADi AD (loomfmu.mechanics.lagrange)")


def _reactions(m: Model, p: dict, x: _X, w: dict, spring: dict):
    R = "reactions"
    e1 = ca.vertcat(-ca.cos(p["alpha1"]), -ca.sin(p["alpha1"]))
    e2 = ca.vertcat(ca.cos(p["alpha2"]), ca.sin(p["alpha2"]))
    S1, S2 = w["S"][0], sum(w["S"][1:])
    R2 = m.quantity("R_2", p["m_c"] * x.a_O2 - (S1 * e1 + S2 * e2 + p["m_c"]
                                                 * ca.vertcat(0, -p["g"])),
                    unit="N", group=R, symbol=r"\vec R_2", description="reaction the roller "
                    "exerts on its pin O2 (x, y): Newton's law for the roller, m_c a_O2 = "
                    "warp + weight - R2", source=SEED + " (11); " + defect("B4"))
    psi = x.phi1 + p["gamma"] + p["theta"]
    R1 = m.quantity("R_1", R2 + spring["F_s"] * ca.vertcat(-ca.cos(psi), ca.sin(psi)),
                    unit="N", group=R, symbol=r"\vec R_1", description="reaction in the "
                    "lever's pin O1 (x, y): the lever loaded by -R2 and the spring",
                    source=SEED + " (12)")
    N1 = m.quantity("N_1", ca.norm_2(R1), unit="N", group=R, symbol="N_1",
                    description="normal force of the friction in O1: the full reaction |R1|",
                    source=SEED + ", conclusion 2")
    N2 = m.quantity("N_2", ca.norm_2(R2), unit="N", group=R, symbol="N_2",
                    description="normal force of the friction in O2: the full reaction |R2|",
                    source=SEED + ", conclusion 2")
    return R1, R2, N1, N2


def _friction(m: Model, p: dict, x: _X, N1, N2, eps) -> None:
    F = "friction laws"
    radii = []
    for i in (1, 2):
        radii.append(m.quantity(
            f"r_{i}f", friction_radius(p[f"rho{i}"], p[f"mu{i}"]), unit="m", group=F,
            symbol=rf"r_{{{i}f}}", description=f"friction radius of pin O{i}: the friction "
            "circle's radius rho mu / sqrt(1 + mu^2); kinetic torque limit r_f N, static "
            "k_static r_f N", source=SEED + f" (6), (10) name r_{i}f; formula: friction "
            "circle of a pin (assumption: the seed gives none)"))
    eps_arg = None
    if eps is not None:
        eps_arg = m.parameter("eps", eps, unit="rad/s", description="regularization speed: "
                              "friction torque = -r_f N tanh(speed / eps)", min=EPS_RANGE[0],
                              max=EPS_RANGE[1], source="assumption: numerical regularization "
                              "width, not physics")
    for i, (w, M, N, r_f) in enumerate(((x.w1, x.M1f, N1, radii[0]),
                                        (x.w2, x.M2f, N2, radii[1])), start=1):
        coulomb_joint(m, f"O{i}", speed=w, torque=M, normal=N, r_kinetic=r_f,
                      r_static=p["k_static"] * r_f, regularized_eps=eps_arg,
                      tex=str(i), source=SEED + " (6), (10): M_if = -r_if N_i sign(phi_i')")


def _outputs(m: Model, x: _X, w: dict, spring: dict, N1, N2, fronts: int) -> None:
    m.output("phi1_out", x.phi1, unit="rad", description="lever angle")
    m.output("phi2_out", x.phi2, unit="rad", description="roller angle relative to the lever")
    m.output("omega1_out", x.w1, unit="rad/s", description="lever rate")
    m.output("omega2_out", x.w2, unit="rad/s", description="roller rate relative to the "
             "lever")
    S1, S2 = w["S"][0], sum(w["S"][1:])
    m.output("S1", S1, unit="N", description="tension of the lower branch (whole sheet; "
             "absolute, positive in tension)")
    m.output("S2", S2, unit="N", description="tension of the upper branch (whole sheet; "
             "absolute, positive in tension)")
    if fronts == 2:
        for h, S in zip(("a", "b"), w["S"][1:]):
            m.output(f"S2{h}", S, unit="N", description=f"tension of the upper branch's ends"
                     f" of heald frame {h.upper()} (half the sheet; absolute, positive in "
                     "tension)")
    m.output("M1f_out", x.M1f, unit="N.m", description="friction torque in pivot O1")
    m.output("M2f_out", x.M2f, unit="N.m", description="friction torque in pivot O2")
    m.output("N1", N1, unit="N", description="full reaction in pivot O1")
    m.output("N2", N2, unit="N", description="full reaction in pivot O2")
    m.output("F_spring", spring["F_s"], unit="N", description="spring force")
    m.require("warp_back_taut", S1, "warp in compression (lower branch): the model is not "
              "valid for a slack warp")
    if fronts == 1:
        m.port("warp_front", "warp", elongation="warp_pull", tension="S2",
               description="upper branch towards the healds (all ends): elongation in, "
               "tension out")
        m.require("warp_front_taut", S2, "warp in compression (upper branch): the model is "
                  "not valid for a slack warp")
    else:
        for h in ("a", "b"):
            F = h.upper()
            m.port(f"warp_front_{h}", "warp", elongation=f"warp_pull_{h}", tension=f"S2{h}",
                   description=f"upper branch, the ends of heald frame {F} (half the "
                   "sheet): elongation in, tension out")
            m.require(f"warp_front_{h}_taut", w["S"][1 + "ab".index(h)],
                      f"warp in compression (upper branch, frame {F}'s ends): the model is "
                      "not valid for a slack warp")
    m.port("warp_back", "warp", elongation="letoff", tension="S1",
           description="lower branch from the warp beam: elongation in, tension out")
