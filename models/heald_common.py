"""Declarations shared by the three heald-frame models (rigid, planar, spatial).

Each ``declare_*`` function adds one group of variables to a
:class:`~loomfmu.declare.model.Model` and returns the symbols and expressions the
model modules need.  Nothing here is analysis: the kinetostatic formulas,
the preset tables and the claims live in :mod:`loomfmu.heald`.

Sources: seed 000 (Pchelin, spatial model: geometry, motion law, warp
forces, influence coefficients, reduced masses) and seed 002 (Khozina,
Gavrilov, Makarov: frame and heald masses, hinge load (1)-(5)).

The hinge load (seed 002, (1)-(5), with the frame's actual accelerations).
N_rem is the force of the frame on one drive hinge, positive upwards (seed
002's sign).  Newton for the frame with healds (mass m_RR + m_heald), of
which the reduced masses M_y move with the drive locks plus their elastic
displacement y_i and the rest moves rigidly:

    n_hinge N_rem = -[ (m_RR + m_heald) (g + h'') + sum_i M_yi y_i'' + f_y ]

f_y > 0 (frame above the shed's centre line) pulls the frame down.  With a
rigid frame (y_i'' = 0) this is seed 002's (4)-(5): weight, inertia
(m_RR + M_STR m_G) a and the warp action N_OSN.  It needs the reduced masses
to be part of the frame: sum M_y <= m_RR (checked by
:func:`loomfmu.mechanics.heald_presets.preset_values`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca

from loomfmu.declare.checks import check_choice, check_mapping
from loomfmu.declare.model import Model
from loomfmu.mechanics.heald_presets import G_STD

SEED0 = "seed 000"
SEED2 = "seed 002"
DEG = math.pi / 180.0
#: Dwell boundaries of the motion law in one revolution (seed 000, phi_a cases).
BREAKPOINTS_DEG = (0.0, 40.0, 320.0)


#: print defects of seed 000: (where, printed, corrected, reason, how to get the
#: printed form).  One source for the model docstring and the derivation report.
DEFECTS = {
    "D1": ("motion law", "coefficient 1.2: H = h_m{[1.2 phi_a - sin(1.2 phi_a)]/pi - 1}",
           "360/280 = 9/7 (the cycloidal law)",
           "phi_a runs over 280 deg, so 1.2 phi_a ends at 336 deg, not 360 deg: H reaches "
           "only 0.996 h_m and jumps at the next revolution, and H', H'' jump at the top "
           "dwell (H'' by 41 % of its peak); with 9/7 H, H', H'' are continuous at both "
           "dwells and across revolutions",
           "parameter k_H = 1.2 (run time)"),
    "D2": ("motion law, cases of phi_a", "phi_a = 0 for 320..360 deg",
           "phi_a = 280 deg (the frame dwells at the top)",
           "the printed form throws the frame back to -h_m at 320 deg",
           "build option end_dwell='printed'"),
    "D3": ("(2)", "+ M_x H''", "- M_y H''",
           "solving (1) for Y'' gives M_y, not M_x; with y up (the sign under which the "
           "warp load enters as -delta_yf F_y, since f_y > 0 pulls the up-frame down) the "
           "d'Alembert force of the moving frame is -M_y H'' (a frame decelerating into the "
           "top dwell throws the slats up)", "build option inertia='printed'"),
    "D4": ("m_x1", "m_B 33/280", "m_B 33/140",
           "the tip-equivalent mass of a uniform cantilever is 33/140 of its mass "
           "(Rayleigh), the factor the seed itself uses for the lower slat's cantilevers "
           "in m_y1", "parameter k_B = 33/280 (run time)"),
}


def defect(key: str) -> str:
    """Print defect ``key`` (D1-D4) as one line: printed, corrected, reason."""
    where, printed, corrected, reason, select = DEFECTS[key]
    return (f"print defect {key} in seed 000's {where}: printed {printed}, corrected "
            f"{corrected} ({reason}; the printed form: {select})")


def influence(d11, d22):
    """The 3x3 influence matrix delta of (3): same structure for x and y."""
    return ca.vertcat(ca.horzcat(d11, d11 / 2, 0), ca.horzcat(d11 / 2, d22, d11 / 2),
                      ca.horzcat(0, d11 / 2, d11))


def stiffness(d11, d22):
    """C = delta^-1 in the seed's closed form (text after (2))."""
    r = d22 / d11 - 0.25
    m = ca.vertcat(ca.horzcat(r, -0.5, 0.25), ca.horzcat(-0.5, 1, -0.5),
                   ca.horzcat(0.25, -0.5, r))
    return m / (d22 - d11 / 2)


def box_inertia(height, width, wall):
    """Second moment of area of a rectangular box about the axis parallel to ``width``."""
    return (width * height**3 - (width - 2 * wall) * (height - 2 * wall) ** 3) / 12


def shaft_angle(phi, end_dwell="corrected"):
    """Revolution count, angle in the revolution phi_r, rising-stroke angle
    phi_a and the stroke's sign (-1)^(k_f+1) of seed 000's motion law."""
    rev = ca.floor(phi / (2 * math.pi))
    phi_r = phi - 2 * math.pi * rev
    rising = phi_r - 40 * DEG
    if end_dwell == "corrected":
        phi_a = ca.fmin(ca.fmax(rising, 0), 280 * DEG)
    elif end_dwell == "printed":
        phi_a = ca.if_else(phi_r <= 320 * DEG, ca.fmax(rising, 0), 0)
    else:
        raise ValueError(f"end_dwell = {end_dwell!r}; allowed: 'corrected', 'printed'")
    return rev, phi_r, phi_a, 1 - 2 * (rev - 2 * ca.floor(rev / 2))


def motion_law(phi, h_m, k_H, end_dwell="corrected"):
    """Frame displacement H(phi) of the drive locks (seed 000, motion law).

    phi_r = phi mod 2 pi; the sign (-1)^(k_f+1) alternates each revolution
    (up in odd, down in even revolutions: one frame cycle = two revolutions,
    so a frame in opposition is the same law shifted by one revolution,
    H(phi + 2 pi) = -H(phi)).  Works on CasADi symbols and on floats.
    """
    _, _, phi_a, sign = shaft_angle(phi, end_dwell)
    return stroke(phi_a, sign, h_m, k_H)


def stroke(phi_a, sign, h_m, k_H):
    """H from the stroke's angle phi_a and sign (see :func:`motion_law`)."""
    theta = k_H * phi_a
    return h_m * ((theta - ca.sin(theta)) / math.pi - 1) * sign


def stroke_derivatives(phi_a, sign, h_m, k_H):
    """dH/dphi and d2H/dphi2 of :func:`stroke` as formulas (not automatic
    differentiation): with theta = k_H phi_a and s the stroke's sign,

        H'  = s h_m k_H (1 - cos theta) / pi,
        H'' = s h_m k_H^2 sin(theta) / pi

    while the stroke moves (0 < phi_a < 280 deg, where d phi_a / d phi = 1),
    and 0 in the dwells (phi_a constant; the revolution count and the sign
    are constant between revolutions).  At a dwell's boundary, a single
    angle where the event indicators restart the step, the dwell's 0 is
    taken; with k_H = 9/7 both derivatives are continuous there anyway."""
    theta = k_H * phi_a
    moving = ca.logic_and(phi_a > 0, phi_a < 280 * DEG)  # 1 while moving, else 0
    # a product with the 0/1 of the comparison (an if_else would take in the factor
    # omega of h' = H' omega, and h' would no longer show as H' omega)
    return (sign * h_m * k_H * (1 - ca.cos(theta)) / math.pi * moving,
            sign * h_m * k_H**2 * ca.sin(theta) / math.pi * moving)


def warp_geometry(H, l_1, l_2):
    """Shed geometry of seed 000, fig. 2: thread elongation dl and the
    direction sums s_y = sin a1 + sin a2, s_x = cos a2 - cos a1."""
    L1, L2 = ca.sqrt(l_1**2 + H**2), ca.sqrt(l_2**2 + H**2)
    return L1 + L2 - (l_1 + l_2), H / L1 + H / L2, l_2 / L2 - l_1 / L1


@dataclass
class Motion:
    phi: ca.SX
    omega: ca.SX
    h_m: ca.SX
    H: ca.SX
    h_dot: ca.SX
    h_ddot: ca.SX
    k_H: ca.SX = None
    end_dwell: str = "corrected"
    H1: ca.SX = None     # dH/dphi
    H2: ca.SX = None     # d2H/dphi2
    phi_r: ca.SX = None  # angle within the revolution
    phi_a: ca.SX = None  # the stroke's angle
    sign: ca.SX = None   # the stroke's sign (-1)^(k_f+1)


def declare_motion(m: Model, *, end_dwell: str) -> Motion:
    """Parameters h_m, k_H; input omega; state phi; motion law and its events."""
    P = m.parameter
    k_H = P("k_H", 9 / 7, description="motion-law coefficient (phi_a scale)",
            source=SEED0 + ", motion law: printed 1.2, corrected to 360/280 = 9/7 (defect D1)",
            min=1.0, max=1.5)
    h_m = P("h_m", 0.029, unit="m", description="largest frame displacement from the middle",
            source=SEED0, min=0.001, max=0.2)
    omega = m.input("omega", 60.0, unit="rad/s", display_unit="rpm",
                    description="main-shaft angular speed "
                    "(held constant over a communication step; its derivative is taken "
                    "as zero in the frame acceleration)", min=0.0, max=500.0)
    phi = m.state("phi", 0.0, unit="rad", description="main-shaft angle (0: start of the "
                  "bottom dwell; a second frame in opposition, as in a plain weave, starts "
                  "at 2 pi: one stroke per revolution, H(phi + 2 pi) = -H(phi))")
    m.eq(m.der(phi), omega)
    _, phi_r, phi_a, sign = shaft_angle(phi, end_dwell)
    H = stroke(phi_a, sign, h_m, k_H)
    H1, H2 = stroke_derivatives(phi_a, sign, h_m, k_H)
    # sin((phi - phi_k)/2), zero once a revolution at the break phi_k,
    # written sin(phi/2) cos(phi_k/2) - cos(phi/2) sin(phi_k/2): one sine and
    # one cosine of phi/2 for the three indicators (the compiler makes them
    # one sincos) where three sines were a third of the rigid frame's step
    s_half, c_half = ca.sin(phi / 2), ca.cos(phi / 2)
    for deg in BREAKPOINTS_DEG:
        a = deg * DEG / 2
        m.event(f"dwell_{int(deg)}deg", s_half * math.cos(a) - c_half * math.sin(a),
                description=f"main shaft passes {deg:g} deg (dwell boundary): "
                f"sin((phi - {deg:g} deg)/2), expanded")
    return Motion(phi, omega, h_m, H, H1 * omega, H2 * omega**2, k_H, end_dwell, H1, H2,
                  phi_r, phi_a, sign)


#: Values of the build option ``warp_tension``.
WARP_TENSION = ("geometry", "input")
#: Start of the tension input: what the geometry tension is at the start angle
#: phi = 0 (bottom dwell, open shed), n_n T_max with seed 000's n_n and T_max.
T_INPUT_START = 1000.0 * 0.8


@dataclass
class Warp:
    T: ca.SX
    dl: ca.SX
    f_x: ca.SX
    f_y: ca.SX
    n_n: ca.SX = None
    s_x: ca.SX = None
    s_y: ca.SX = None
    dl_max: ca.SX = None
    L1: ca.SX = None
    L2: ca.SX = None
    mode: str = "geometry"


def declare_warp(m: Model, mo: Motion, warp_tension: str = "geometry") -> Warp:
    """Shed and warp parameters (seed 000, fig. 2) and the warp loads.

    warp_tension: 'geometry' (seed 000: T grows linearly with the shed's
    elongation from n_n T_min to n_n T_max) or 'input' (T is an input, the
    total tension of this frame's ends, e.g. from a backrest; it must not be
    negative: validity condition ``warp_taut``).
    """
    check_option("warp_tension", warp_tension, WARP_TENSION)
    P = m.parameter
    l_1 = P("l_1", 0.05, unit="m", description="depth of the front shed", source=SEED0,
            min=0.005, max=1.0)
    k_z = P("k_z", 5.0, description="shed asymmetry l_2/l_1 (1: symmetric shed)",
            source=SEED0, min=0.1, max=50.0)
    n_n = P("n_n", 1000.0, description="number of warp ends drawn through this frame's "
            "healds (a plain weave with two frames: half the sheet's ends each)",
            source=SEED0 + " (n_n = 1000 warp threads; read as the ends through the one "
            "frame modelled, whose tension T loads it); presets: " + SEED2 + " table 2 "
            "(threads per frame)",
            min=1.0, max=1e5)
    l_2 = k_z * l_1
    dl, s_y, s_x = warp_geometry(mo.H, l_1, l_2)
    dl_max = warp_geometry(mo.h_m, l_1, l_2)[0]
    if warp_tension == "geometry":
        T_min = P("T_min", 0.3, unit="N", description="least working tension of one thread",
                  source=SEED0 + " (read as per-thread values: total T = n_n x per-thread); "
                  "presets: 0.3/0.8 of T_max", min=0.0, max=100.0)
        T_max = P("T_max", 0.8, unit="N", description="greatest working tension of one "
                  "thread", source=SEED0 + "; presets: " + SEED2 + " table 2 note, F_T by "
                  "yarn / (sin a1 + sin a2) at the open shed", min=0.0, max=100.0)
        m.constraint("tension_order", T_max - T_min, "the least working tension T_min "
                     "exceeds the greatest T_max")
        T = n_n * (T_min + (T_max - T_min) * dl / dl_max)
    else:
        T = m.input("T", T_INPUT_START, unit="N", description="total tension of the warp "
                    "ends through this frame (n_n ends; absolute, positive in tension), "
                    "e.g. a backrest's front tension; start: the geometry tension at phi = 0 "
                    "(open shed), n_n T_max = 1000 x 0.8 N (seed 000)", max=1e6)
        m.require("warp_taut", T, "warp in compression: the tension input T is negative; "
                  "the heald frame model is not valid for a warp that pushes")
    L1, L2 = ca.sqrt(l_1**2 + mo.H**2), ca.sqrt(l_2**2 + mo.H**2)
    return Warp(T, dl, T * s_x, T * s_y, n_n, s_x, s_y, dl_max, L1, L2, warp_tension)


def declare_warp_outputs(m: Model, w: Warp) -> None:
    if w.mode == "geometry":
        m.output("T", w.T, unit="N", description="total working tension of the warp ends "
                 "through the frame")
    else:
        m.output("T_end", w.T / w.n_n, unit="N", description="mean tension of one warp "
                 "end through the frame (T / n_n; seed 000: 0.3 to 0.8 N)")
    m.output("dl", w.dl, unit="m", description="elongation of each warp end through the "
             "frame imposed by the shed, measured from the closed shed (frame at the "
             "middle, h = 0, where the ends run straight over l_1 + l_2: the at-rest state "
             "of the warp port); positive stretches; zero or more")
    m.output("f_x", w.f_x, unit="N", description="horizontal warp load on the top slat")
    m.output("f_y", w.f_y, unit="N", description="vertical warp load on the top slat "
             "(positive: towards the shed's centre line)")


def declare_ports(m: Model, w: Warp) -> None:
    """The main-shaft flange and the warp connection (tension too in 'input' mode)."""
    m.port("shaft", "flange", speed="omega", description="main shaft (speed imposed)")
    roles = {"elongation": "dl"} if w.mode == "geometry" else {"elongation": "dl",
                                                                "tension": "T"}
    m.port("warp", "warp", description="the warp ends through the frame's healds: the "
           "shed's elongation out" + ("" if w.mode == "geometry" else
                                      ", their total tension in"), **roles)


def declare_motion_outputs(m: Model, mo: Motion) -> None:
    m.output("h", mo.H, unit="m", description="frame displacement from the middle position")
    m.output("h_dot", mo.h_dot, unit="m/s", description="frame velocity")
    m.output("h_ddot", mo.h_ddot, unit="m/s2", description="frame acceleration")


@dataclass
class Loads:
    m_RR: ca.SX
    m_heald: ca.SX
    n_hinge: ca.SX
    g: ca.SX


def declare_loads(m: Model) -> Loads:
    """Frame and heald masses, hinge count, gravity (seed 002, (1)-(5))."""
    P = m.parameter
    m_RR = P("m_RR", 4.6, unit="kg", description="mass of the heald frame without healds",
             source=SEED2 + " table 1 (STB-180, aluminium frames 3.6-5.2 kg; 4.6 kg: Texo "
             "and Remiz B); presets: table 1 by maker and width", min=0.1, max=100.0)
    m_heald = P("m_heald", 9.0 / G_STD, unit="kg", description="mass of the healds in the "
                "frame (M_STR m_G)", source=SEED2 + " table 2 (STB-180: 9.0 N); presets: "
                "table 2 by width", min=0.0, max=50.0)
    n_hinge = P("n_hinge", 2.0, description="number of drive hinges of the frame (n_OSh)",
                source="assumption: seed 002 leaves n_OSh open; two lifting points per "
                "frame is the usual cam-shedding layout", min=1.0, max=8.0)
    g = P("g", G_STD, unit="m/s2", description="gravitational acceleration",
          source=SEED2 + " (1): G = m g; standard gravity", min=0.0, max=20.0)
    return Loads(m_RR, m_heald, n_hinge, g)


def hinge_load(ld: Loads, mo: Motion, w: Warp, elastic=0.0):
    """N_rem: force of the frame on one drive hinge, positive up (see module doc).

    elastic: sum_i M_yi y_i'' of the elastic coordinates (0 for a rigid frame).
    """
    mass = ld.m_RR + ld.m_heald
    return -(mass * (ld.g + mo.h_ddot) + elastic + w.f_y) / ld.n_hinge


def declare_hinge_outputs(m: Model, ld: Loads, mo: Motion, w: Warp, elastic=0.0,
                          reduced_mass=None) -> None:
    """reduced_mass: the slats' reduced vertical masses, which are part of the
    frame: m_RR >= their sum is required (seed 002's m_RR is the whole frame)."""
    if reduced_mass is not None:
        m.constraint("reduced_mass_in_frame", ld.m_RR - reduced_mass,
                     "the slats' reduced vertical masses exceed the frame mass m_RR")
    m.output("N_rem", hinge_load(ld, mo, w, elastic), unit="N",
             description="force of the frame on one drive hinge, positive up (seed 002 "
             "N_REM, from the actual accelerations and warp load)")
    m.output("G_rem", (ld.m_RR + ld.m_heald) * ld.g, unit="N",
             description="weight of the frame with its healds (seed 002 (1))")


@dataclass
class Section:
    """Slat and side-stay geometry and the quantities derived from it."""

    l: ca.SX
    h_B: ca.SX
    E: ca.SX
    mu: ca.SX
    J_x: ca.SX      # vertical bending of the slats
    J_y: ca.SX      # horizontal bending of the slats
    J_z: ca.SX      # side stay across the frame
    m_l: ca.SX      # one slat
    m_h: ca.SX      # one side stay
    rho_stay: ca.SX  # side-stay mass per length
    l_n: ca.SX


def declare_section(m: Model, *, horizontal: bool) -> Section:
    """Frame geometry and material (seed 000, numeric example); ``horizontal``
    adds the side-stay cantilever h_B (out-of-plane bending only)."""
    P = m.parameter
    l = P("l", 1.8, unit="m", description="length of the top slat", source=SEED0 +
          "; presets: nominal loom width (seed 000 takes 1.8 m for the 180 cm loom)",
          min=0.3, max=6.0)
    l_n = P("l_n", 0.45, unit="m", description="length of the lower slat's cantilever "
            "parts (outside the lifting hooks)", source=SEED0, min=0.01, max=2.0)
    E = P("E", 0.7e11, unit="Pa", description="Young's modulus of the slats (aluminium)",
          source=SEED0 + " (printed unit kg m^-2 is a defect; 0.7e11 Pa is aluminium)",
          min=1e9, max=5e11)
    rho = P("gamma", 2700.0, unit="kg/m3", description="density of the slat material",
            source=SEED0, min=100.0, max=20000.0)
    h1 = P("h1", 0.100, unit="m", description="slat box section: height (in the frame "
           "plane)", source=SEED0, min=0.005, max=0.5)
    b1 = P("b1", 0.010, unit="m", description="slat box section: width (across the frame)",
           source=SEED0, min=0.002, max=0.2)
    d1 = P("d1", 0.0014, unit="m", description="slat box section: wall thickness",
           source=SEED0, min=0.0002, max=0.05)
    h_B = None
    if horizontal:
        h_B = P("h_B", 0.15, unit="m", description="cantilever length of the side stays "
                "above the drive locks (constant, as in the seed, unless the build option "
                "h_B_law='variable')", source=SEED0, min=0.01, max=1.0)
    s_w = P("s_w", 0.030, unit="m", description="side stay section: width in the frame "
            "plane", source="assumption: the seed gives no side-stay section; a 30 x 6 mm "
            "aluminium strip is a typical heald-frame stay", min=0.002, max=0.2)
    s_t = P("s_t", 0.006, unit="m", description="side stay section: thickness across the "
            "frame", source="assumption: see s_w", min=0.001, max=0.1)
    s_L = P("s_L", 0.35, unit="m", description="side stay length (frame height)",
            source="assumption: typical heald frame height 330-360 mm", min=0.05, max=2.0)
    mu = P("mu", 30.0, unit="N.s/m", description="damping coefficient of every coordinate",
           source=SEED0, min=0.0, max=1e5)
    # a box wall can be at most half the section (d1 = b1/2: a solid bar; the area
    # and inertia formulas hold up to there and go wrong beyond)
    m.constraint("box_wall_width", b1 - 2 * d1, "the slat's wall thickness d1 must not "
                 "exceed half its width b1 (2 d1 <= b1)")
    m.constraint("box_wall_height", h1 - 2 * d1, "the slat's wall thickness d1 must not "
                 "exceed half its height h1 (2 d1 <= h1)")
    m_l = rho * (h1 * b1 - (h1 - 2 * d1) * (b1 - 2 * d1)) * l
    return Section(l, h_B, E, mu, box_inertia(h1, b1, d1), box_inertia(b1, h1, d1),
                   s_w * s_t**3 / 12, m_l, rho * s_w * s_t * s_L, rho * s_w * s_t, l_n)


@dataclass
class Bending:
    """One bending plane: influence coefficients, stiffness, reduced masses."""

    d11: ca.SX
    d22: ca.SX
    d_f: ca.SX      # influence of the warp load at the mid-section on y1, y2, y3
    C: ca.SX        # seed's closed form of delta^-1 (what the equations use)
    M: ca.SX        # reduced masses (column)
    m_B: ca.SX = None  # mass of the side stay's cantilever (horizontal only)

    def __iter__(self):  # C, d_f, M = vertical(sec)
        return iter((self.C, self.d_f, self.M))

    @property
    def delta(self):
        return influence(self.d11, self.d22)


def vertical(sec: Section) -> Bending:
    """In-plane (vertical) influence, stiffness and reduced masses (seed 000)."""
    l, E, J_x, l_n = sec.l, sec.E, sec.J_x, sec.l_n
    dy11 = l_n**3 / (3 * E * J_x)
    dy22 = (l_n**3 + l**3 / 8) / (6 * E * J_x)
    dy_f = ca.vertcat(dy11 / 2, dy11 / 2 + 5 * l**3 / (384 * E * J_x), dy11 / 2)
    m_y1 = sec.m_l / 4 + sec.m_h + sec.m_l * (l_n / l) * 33 / 140
    return Bending(dy11, dy22, dy_f, stiffness(dy11, dy22), ca.vertcat(m_y1, sec.m_l / 2, m_y1))


def horizontal(sec: Section, k_B, h_B=None) -> Bending:
    """Out-of-plane influence, stiffness and reduced masses (seed 000);
    ``h_B``: the side stays' cantilever length (default: the parameter)."""
    h_B = sec.h_B if h_B is None else h_B
    l, E, J_y = sec.l, sec.E, sec.J_y
    dx11 = h_B**3 / (3 * E * sec.J_z)
    dx22 = h_B**3 / (6 * E * sec.J_z) + l**3 / (48 * E * J_y)
    dx_f = ca.vertcat(dx11 / 2, dx11 / 2 + 5 * l**3 / (384 * E * J_y), dx11 / 2)
    m_B = sec.rho_stay * h_B
    M_x = ca.vertcat(sec.m_l / 4 + m_B * k_B, sec.m_l / 2, sec.m_l / 4 + m_B * k_B)
    return Bending(dx11, dx22, dx_f, stiffness(dx11, dx22), M_x, m_B)


def apply_preset(m: Model, preset: str | None) -> None:
    """Start values of seed 002's preset ``preset`` for the parameters ``m``
    has (with the tension as an input, T_min and T_max are not parameters)."""
    if preset is None:
        return
    from loomfmu.mechanics.heald_presets import preset_values
    names = {v.name for v in m.of_kind("parameter")}
    apply_values(m, {k: v for k, v in preset_values(preset, m.name).items() if k in names})


def apply_values(m: Model, values: dict[str, float] | None) -> None:
    """Set parameter start values (e.g. a preset), each checked against its range."""
    values = check_mapping("values", values, [v.name for v in m.of_kind("parameter")],
                           what=f"parameters of {m.name}")
    for name, value in values.items():
        var = m.var(name)
        var.check_value(value)
        var.start = value
    m.check_constraints()


def check_option(name: str, value, allowed) -> None:
    """ValueError unless ``value`` is one of ``allowed`` (a build option)."""
    check_choice(name, value, allowed)
