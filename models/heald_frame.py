"""Spatial vibrations of a loom heald frame (ATPR-180), 6 elastic DOF.

Source: seed 000 (Pchelin, "Modelling the dynamics of a loom heald frame on
the basis of a spatial model"), equations (1)-(3), the influence
coefficients, C = delta^-1, the reduced masses, the motion law H(phi) and the
warp forces f_x, f_y.

Coordinates (moving with the frame's drive locks, which follow h = H(phi)):
x1, x3 horizontal (out of the frame plane) displacement of the top slat's
left/right corners, x2 of its mid-section; y1, y2, y3 the same vertically.
y points up like h; x points to the long (back) side of the shed.

Print defects of the seed, and what this model does (README, "Heald frame"):

D1  Motion-law coefficient.  Printed: H = h_m{[1.2 phi_a - sin(1.2 phi_a)]/pi - 1}.
    phi_a runs over 280 deg = 4.887 rad, so 1.2 phi_a ends at 336 deg, not
    360 deg: H reaches only 0.996 h_m, and H' and H'' jump at the dwell
    (H'' by 41 % of its peak).  Corrected: 360/280 = 9/7, the cycloidal law,
    for which H, H', H'' are continuous at both dwells and across
    revolutions.  Parameter ``k_H`` (start 9/7; the printed 1.2 is allowed).
D2  End dwell.  Printed: phi_a = 0 for 320..360 deg, which would throw the
    frame back to -h_m at 320 deg.  Corrected: phi_a = 280 deg (the frame
    dwells at the top).  Build option ``end_dwell="printed"`` keeps the
    printed form.
D3  Inertia term of (2).  Printed: M_y Y'' = -C_y(Y + d_yf F_y) - mu Y' + M_x H''.
    Solving (1) for Y'' gives M_y (the vertical masses), not M_x.  And with y
    up (the sign for which the warp load enters as -d_yf F_y, since f_y > 0
    pulls the up-frame down), the d'Alembert force of the moving frame is
    -M_y H'' (a frame decelerating into the top dwell throws the slats up).
    Corrected: -M_y H''.  Build option ``inertia="printed"`` gives +M_x H''.
D4  Reduced mass of the side stay's cantilever: printed m_B 33/280.  The
    tip-equivalent mass of a uniform cantilever is 33/140 m (Rayleigh), the
    factor the seed itself uses for the lower slat's cantilevers in m_y1.
    Parameter ``k_B`` (start 33/140; the printed 33/280 is allowed).
"""
from __future__ import annotations

import math

import casadi as ca

from loomfmu.declare import Model

SEED = "seed 000"
DEG = math.pi / 180.0
#: Dwell boundaries of the motion law in one revolution (seed 000, phi_a cases).
BREAKPOINTS_DEG = (0.0, 40.0, 320.0)


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


def motion_law(phi, h_m, k_H, end_dwell="corrected"):
    """Frame displacement H(phi) of the drive locks (seed 000, motion law).

    phi_r = phi mod 2 pi; the sign (-1)^(k_f+1) alternates each revolution
    (up in odd, down in even revolutions: one frame cycle = two revolutions).
    """
    rev = ca.floor(phi / (2 * math.pi))
    phi_r = phi - 2 * math.pi * rev
    rising = phi_r - 40 * DEG
    if end_dwell == "corrected":
        phi_a = ca.fmin(ca.fmax(rising, 0), 280 * DEG)
    elif end_dwell == "printed":
        phi_a = ca.if_else(phi_r <= 320 * DEG, ca.fmax(rising, 0), 0)
    else:
        raise ValueError(f"end_dwell = {end_dwell!r}; allowed: 'corrected', 'printed'")
    sign = 1 - 2 * (rev - 2 * ca.floor(rev / 2))
    theta = k_H * phi_a
    return h_m * ((theta - ca.sin(theta)) / math.pi - 1) * sign


def build(*, end_dwell: str = "corrected", inertia: str = "corrected") -> Model:
    """The spatial heald frame; options select the printed variants D2, D3."""
    if inertia not in ("corrected", "printed"):
        raise ValueError(f"inertia = {inertia!r}; allowed: 'corrected', 'printed'")
    m = Model("heald_frame", description="Spatial vibrations of a loom heald frame "
              "(ATPR-180): 6-DOF slat bending under warp tension, seed 000",
              stop_time=4 * math.pi / 60 * 2, step_size=1e-3, h_fixed=2e-5,
              options={"end_dwell": end_dwell, "inertia": inertia})
    P = m.parameter
    # -- frame geometry and material (seed 000, numeric example) -------------
    l = P("l", 1.8, unit="m", description="length of the top slat", source=SEED,
          min=0.3, max=6.0)
    l_n = P("l_n", 0.45, unit="m", description="length of the lower slat's cantilever "
            "parts (outside the lifting hooks)", source=SEED, min=0.01, max=2.0)
    E = P("E", 0.7e11, unit="Pa", description="Young's modulus of the slats (aluminium)",
          source=SEED + " (printed unit kg m^-2 is a defect; 0.7e11 Pa is aluminium)",
          min=1e9, max=5e11)
    rho = P("gamma", 2700.0, unit="kg/m3", description="density of the slat material",
            source=SEED, min=100.0, max=20000.0)
    h1 = P("h1", 0.100, unit="m", description="slat box section: height (in the frame plane)",
           source=SEED, min=0.005, max=0.5)
    b1 = P("b1", 0.010, unit="m", description="slat box section: width (across the frame)",
           source=SEED, min=0.002, max=0.2)
    d1 = P("d1", 0.0014, unit="m", description="slat box section: wall thickness",
           source=SEED, min=0.0002, max=0.05)
    h_B = P("h_B", 0.15, unit="m", description="cantilever length of the side stays above "
            "the drive locks (held constant, as in the seed)", source=SEED, min=0.01, max=1.0)
    # side stays: the seed gives no section or mass
    s_w = P("s_w", 0.030, unit="m", description="side stay section: width in the frame plane",
            source="assumption: the seed gives no side-stay section; a 30 x 6 mm aluminium "
            "strip is a typical heald-frame stay", min=0.002, max=0.2)
    s_t = P("s_t", 0.006, unit="m", description="side stay section: thickness across the frame",
            source="assumption: see s_w", min=0.001, max=0.1)
    s_L = P("s_L", 0.35, unit="m", description="side stay length (frame height)",
            source="assumption: typical heald frame height 330-360 mm", min=0.05, max=2.0)
    k_H = P("k_H", 9 / 7, description="motion-law coefficient (phi_a scale)",
            source=SEED + ", motion law: printed 1.2, corrected to 360/280 = 9/7 (defect D1)",
            min=1.0, max=1.5)
    k_B = P("k_B", 33 / 140, description="reduced-mass factor of the side stay's cantilever",
            source=SEED + ", m_x1: printed 33/280, corrected to 33/140 (defect D4)",
            min=0.0, max=1.0)
    mu = P("mu", 30.0, unit="N.s/m", description="damping coefficient of every coordinate",
           source=SEED, min=0.0, max=1e5)
    h_m = P("h_m", 0.029, unit="m", description="largest frame displacement from the middle",
            source=SEED, min=0.001, max=0.2)
    # -- shed and warp (seed 000, fig. 2) ------------------------------------
    l_1 = P("l_1", 0.05, unit="m", description="depth of the front shed", source=SEED,
            min=0.005, max=1.0)
    k_z = P("k_z", 5.0, description="shed asymmetry l_2/l_1 (1: symmetric shed)", source=SEED,
            min=0.1, max=50.0)
    n_n = P("n_n", 1000.0, description="number of warp threads in the frame", source=SEED,
            min=1.0, max=1e5)
    T_min = P("T_min", 0.3, unit="N", description="least working tension of one thread",
              source=SEED + " (read as per-thread values: total T = n_n x per-thread)",
              min=0.0, max=100.0)
    T_max = P("T_max", 0.8, unit="N", description="greatest working tension of one thread",
              source=SEED, min=0.0, max=100.0)
    # -- input: the main shaft ------------------------------------------------
    omega = m.input("omega", 60.0, unit="rad/s", description="main-shaft angular speed "
                    "(held constant over a communication step; its derivative is taken "
                    "as zero in the frame acceleration)", min=0.0, max=500.0)

    # -- derived quantities ----------------------------------------------------
    J_x = box_inertia(h1, b1, d1)          # vertical bending of the slats
    J_y = box_inertia(b1, h1, d1)          # horizontal bending of the slats
    J_z = s_w * s_t**3 / 12                # side stay bending across the frame
    m_l = rho * (h1 * b1 - (h1 - 2 * d1) * (b1 - 2 * d1)) * l
    m_h = rho * s_w * s_t * s_L
    m_B = rho * s_w * s_t * h_B
    dx11 = h_B**3 / (3 * E * J_z)
    dx22 = h_B**3 / (6 * E * J_z) + l**3 / (48 * E * J_y)
    dx_f = ca.vertcat(dx11 / 2, dx11 / 2 + 5 * l**3 / (384 * E * J_y), dx11 / 2)
    dy11 = l_n**3 / (3 * E * J_x)
    dy22 = (l_n**3 + l**3 / 8) / (6 * E * J_x)
    dy_f = ca.vertcat(dy11 / 2, dy11 / 2 + 5 * l**3 / (384 * E * J_x), dy11 / 2)
    C_x, C_y = stiffness(dx11, dx22), stiffness(dy11, dy22)
    M_x = ca.vertcat(m_l / 4 + m_B * k_B, m_l / 2, m_l / 4 + m_B * k_B)
    m_y1 = m_l / 4 + m_h + m_l * (l_n / l) * 33 / 140
    M_y = ca.vertcat(m_y1, m_l / 2, m_y1)

    # -- states ------------------------------------------------------------------
    phi = m.state("phi", 0.0, unit="rad", description="main-shaft angle (0: start of the "
                  "bottom dwell)")
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

    # -- motion law and its derivatives (by CasADi AD of H(phi)) ----------------
    H = motion_law(phi, h_m, k_H, end_dwell)
    H1 = ca.jacobian(H, phi)
    H2 = ca.jacobian(H1, phi)
    h_dot, h_ddot = H1 * omega, H2 * omega**2

    # -- warp forces (seed 000, fig. 2) ---------------------------------------------
    l_2 = k_z * l_1
    L1, L2 = ca.sqrt(l_1**2 + H**2), ca.sqrt(l_2**2 + H**2)
    dl = L1 + L2 - (l_1 + l_2)
    dl_max = ca.sqrt(l_1**2 + h_m**2) + ca.sqrt(l_2**2 + h_m**2) - (l_1 + l_2)
    T = n_n * (T_min + (T_max - T_min) * dl / dl_max)
    f_y = T * (H / L1 + H / L2)
    f_x = T * (l_2 / L2 - l_1 / L1)

    # -- equations (2) ----------------------------------------------------------------
    m.eq(m.der(phi), omega)
    M_H = M_y if inertia == "corrected" else -M_x
    for i in range(3):
        m.eq(m.der(X[i]), VX[i])
        m.eq(m.der(Y[i]), VY[i])
    m.eq(M_x * ca.vertcat(*[m.der(VX[i]) for i in range(3)]),
         -C_x @ (X - dx_f * f_x) - mu * VX)
    m.eq(M_y * ca.vertcat(*[m.der(VY[i]) for i in range(3)]),
         -C_y @ (Y + dy_f * f_y) - mu * VY - M_H * h_ddot)

    # -- breakpoints of the motion law: the solvers restart there ------------------
    for deg in BREAKPOINTS_DEG:
        m.event(f"dwell_{int(deg)}deg", ca.sin((phi - deg * DEG) / 2),
                description=f"main shaft passes {deg:g} deg (dwell boundary)")

    # -- outputs ---------------------------------------------------------------------
    m.output("h", H, unit="m", description="frame displacement from the middle position")
    m.output("h_dot", h_dot, unit="m/s", description="frame velocity")
    m.output("h_ddot", h_ddot, unit="m/s2", description="frame acceleration")
    m.output("x1_out", X[0], unit="m", description="horizontal displacement of the "
             "top slat's left corner")
    m.output("x2_out", X[1], unit="m", description="horizontal displacement of the "
             "top slat's mid-section")
    m.output("y2_out", Y[1], unit="m", description="vertical displacement of the top "
             "slat's mid-section")
    m.output("T", T, unit="N", description="total working tension of the warp in the frame")
    m.output("dl", dl, unit="m", description="warp elongation by the shed")
    m.output("f_x", f_x, unit="N", description="horizontal warp load on the top slat")
    m.output("f_y", f_y, unit="N", description="vertical warp load on the top slat "
             "(positive: towards the shed's centre line)")
    # start at the static deflection under the warp load of the bottom dwell
    static = ca.vertcat(dx_f * f_x, -dy_f * f_y)
    m.set_starts_from(ca.vertcat(X, Y), static)
    m.port("shaft", "shaft", speed="omega", description="main shaft (speed imposed)")
    m.port("warp", "warp", elongation="dl", tension="T",
           description="warp sheet through the frame's healds")
    return m
