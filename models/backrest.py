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
for the roller.  Tests check them against the seed's (7), (10) and (11).

Print defects corrected (docs/backrest.md):
B1  (5), (7): spring arm printed ``r`` (the roller radius); corrected ``r2``,
    the arm of (8), (9).
B2  (8): ``m_c g r1 phi_i`` corrected to ``m_c g r1 cos(phi_n)``: setting (7)
    to zero gives the cosine (and (4) has it).
B3  text before (8): ``S1 = S2 = 0`` corrected to ``S0`` ((8) contains S0).
B4  (11): ``phi''``, ``phi'`` corrected to ``phi1''``, ``phi1'`` (O2 moves with phi1 only).
Friction: the seed's normal pressure N_i is the full reaction |R_i| (its
conclusion 2) and r_if the friction-circle radius rho_i mu_i / sqrt(1 + mu_i^2).
"""
from __future__ import annotations

import math

import casadi as ca

from loomfmu.checks import check_choice, check_number
from loomfmu.declare import Model
from loomfmu.friction import coulomb_joint
from loomfmu.symbolic import generalized_forces, lagrange_equations

SEED = "seed 004"
A = "assumption: the seed gives no numbers; "
DEG = math.pi / 180
#: allowed regularization speeds (rad/s): the range of the parameter eps
EPS_RANGE = (1e-9, 10.0)


def friction_radius(rho, mu):
    """Radius of the friction circle of a pin of radius rho (seed 004, (6))."""
    return rho * mu / ca.sqrt(1 + mu**2)


def build(*, friction: str = "events", eps: float = 1e-3) -> Model:
    """friction: "events" (stick/slip state machine) or "regularized"
    (torque ~ tanh(speed / eps), eps in rad/s)."""
    check_choice("friction", friction, ("events", "regularized"))
    eps = check_number("eps", eps, lo=EPS_RANGE[0], hi=EPS_RANGE[1], unit="rad/s")
    m = Model("backrest" if friction == "events" else "backrest_regularized",
              description="Loom backrest (whip roll): lever and roller with Coulomb "
              "friction in both pivots, stick-slip (seed 004)",
              stop_time=1.0, step_size=1e-3, h_fixed=2e-5,
              options={"friction": friction, "eps": eps},
              reference_method="DOP853" if friction == "events" else "Radau")
    P = m.parameter
    r1 = P("r1", 0.15, unit="m", description="lever length O1O2", min=0.02, max=1.0,
           source=A + "backrest swing levers are 0.1-0.2 m")
    r = P("r", 0.05, unit="m", description="roller radius (warp mid-line)", min=0.01, max=0.3,
          source=A + "backrest tube diameter 90-110 mm")
    m_c = P("m_c", 20.0, unit="kg", description="roller mass", min=0.1, max=500.0,
            source=A + "steel tube 100 x 4 mm, 1.9 m, with journals")
    J_c = P("J_c", 0.0426, unit="kg.m2", description="roller moment of inertia about O2",
            min=1e-5, max=10.0, source=A + "thick tube m (r_o^2 + r_i^2) / 2")
    J_1 = P("J_1", 0.05, unit="kg.m2", description="lever assembly inertia about O1 "
            "(centre of mass at O1, as (12) implies)", min=1e-5, max=10.0,
            source=A + "two side levers and a rocking shaft")
    r2 = P("r2", 0.08, unit="m", description="spring arm O1A", min=0.01, max=0.5,
           source=SEED + " (5), (8), (9); value " + A + "short arm of a two-arm lever")
    theta = P("theta", 80 * DEG, unit="rad", description="angle between spring and arm O1A",
              min=1 * DEG, max=179 * DEG, source=SEED + " (5); value " + A + "near 90 deg")
    gamma = P("gamma", 20 * DEG, unit="rad", description="angle between O1A and the "
              "extension of O2O1 (enters (12) only)", min=-math.pi, max=math.pi,
              source=SEED + " (12); value " + A + "layout")
    phi_n = P("phi_n", 10 * DEG, unit="rad", description="initial (equilibrium) lever angle",
              min=-80 * DEG, max=80 * DEG, source=SEED + " (8), (9); value " + A +
              "lever slightly above the rear horizontal")
    alpha1 = P("alpha1", 60 * DEG, unit="rad", description="angle of the lower branch "
               "(to the warp beam) to the horizontal", min=0.0, max=math.pi / 2,
               source=SEED + " (3); value " + A + "30-90 deg as the beam empties")
    alpha2 = P("alpha2", 8 * DEG, unit="rad", description="angle of the upper branch "
               "(to the healds) to the horizontal", min=-math.pi / 4, max=math.pi / 2,
               source=SEED + " (3); value " + A + "branch near horizontal")
    k_s = P("k_s", 5e4, unit="N/m", description="spring stiffness", min=1e2, max=1e7,
            source=SEED + " (9); value " + A + "two springs of 25 kN/m")
    S0 = P("S0", 3000.0, unit="N", description="static warp tension (whole sheet)",
           min=10.0, max=2e4, source=SEED + " (8); value " + A + "4000 ends x 0.75 N")
    c1 = P("c1", 6e5, unit="N/m", description="stiffness of the lower branch",
           min=1e3, max=1e8, source=A + "4000 ends x 50 N / 0.35 m")
    c2 = P("c2", 3e5, unit="N/m", description="stiffness of the upper branch",
           min=1e3, max=1e8, source=A + "4000 ends x 50 N / 0.7 m")
    b1 = P("b1", 360.0, unit="N.s/m", description="damping of the lower branch",
           min=0.0, max=1e6, source=A + "0.03 c1 / omega at 8 Hz")
    b2 = P("b2", 180.0, unit="N.s/m", description="damping of the upper branch",
           min=0.0, max=1e6, source=A + "0.03 c2 / omega at 8 Hz")
    rho1 = P("rho1", 0.020, unit="m", description="pin radius at O1", min=1e-3, max=0.2,
             source=A + "rocking-shaft bearing")
    mu1 = P("mu1", 0.12, description="sliding friction coefficient at O1", min=0.0, max=1.0,
            source=A + "plain steel bearing, poor lubrication")
    rho2 = P("rho2", 0.015, unit="m", description="pin radius at O2", min=1e-3, max=0.2,
             source=A + "roller journal")
    mu2 = P("mu2", 0.10, description="sliding friction coefficient at O2", min=0.0, max=1.0,
            source=A + "plain roller journal")
    k_static = P("k_static", 1.3, description="static / kinetic friction ratio",
                 min=1.0, max=3.0, source=A + "1.2-1.5 for boundary-lubricated steel")
    A_shed = P("A_shed", 0.002, unit="m", description="built-in shedding elongation of the "
               "upper branch, (1 - cos) over each pick", min=0.0, max=0.05,
               source=A + "+-20 % tension swing at c2; set 0 and drive the input instead")
    n_loom = P("n_loom", 240.0, unit="rpm", description="loom speed for the built-in shedding",
               min=1.0, max=2000.0, source=A + "200-300 picks/min")
    g = 9.81

    letoff = m.input("letoff", 0.0, unit="m", description="warp released from the beam "
                     "into the lower branch (let-off)", min=-0.5, max=0.5)
    pull = m.input("warp_pull", 0.0, unit="m", description="elongation imposed on the upper "
                   "branch by the loom (shedding, beat-up, take-up); adds to the built-in "
                   "shedding", min=-0.5, max=0.5)

    dphi1 = m.state("dphi1", 0.0, unit="rad", description="lever angle from its initial "
                    "(equilibrium) value phi_n")
    phi2 = m.state("phi2", 0.0, unit="rad", description="roller angle relative to the lever")
    w1 = m.state("omega1", 0.0, unit="rad/s", description="lever rate (pivot O1)")
    w2 = m.state("omega2", 0.0, unit="rad/s", description="roller rate relative to the "
                 "lever (pivot O2)")
    M1f = m.algebraic("M1f", unit="N.m", description="friction torque in pivot O1")
    M2f = m.algebraic("M2f", unit="N.m", description="friction torque in pivot O2")
    phi1 = phi_n + dphi1

    q, qd = ca.vertcat(dphi1, phi2), ca.vertcat(w1, w2)
    qdd = ca.vertcat(m.der(w1), m.der(w2))
    m.eq(m.der(dphi1), w1)
    m.eq(m.der(phi2), w2)

    # -- geometry and energies ------------------------------------------------------
    O2 = r1 * ca.vertcat(-ca.cos(phi1), ca.sin(phi1))
    v_O2 = ca.jacobian(O2, q) @ qd
    T = 0.5 * J_1 * w1**2 + 0.5 * m_c * ca.dot(v_O2, v_O2) + 0.5 * J_c * (w1 + w2) ** 2
    V = m_c * g * O2[1]

    # -- warp branches (13), completed for branch 2 and the roller's turn -----------
    shed = A_shed * (1 - ca.cos(2 * math.pi * n_loom / 60 * m.t)) / 2
    turn = r * (phi1 - phi_n + phi2)
    D1 = r1 * (ca.cos(alpha1 + phi_n) - ca.cos(alpha1 + phi1)) + turn - letoff
    D2 = r1 * (ca.cos(alpha2 + phi1) - ca.cos(alpha2 + phi_n)) - turn + pull + shed
    D = ca.vertcat(D1, D2)
    D_rate = ca.jacobian(D, q) @ qd + ca.jacobian(D, m.t)
    S = ca.vertcat(S0 + c1 * D1 + b1 * D_rate[0], S0 + c2 * D2 + b2 * D_rate[1])

    # -- spring (8), (9) ------------------------------------------------------------------
    F0 = (m_c * g * r1 * ca.cos(phi_n)
          + r1 * S0 * (ca.sin(phi_n + alpha1) - ca.sin(phi_n + alpha2))) / (r2 * ca.sin(theta))
    F_s = F0 - k_s * (phi1 - phi_n) * r2 * ca.sin(theta)

    # -- generalized forces by virtual work (forces held, displacements virtual) ----
    S_held, F_held = ca.SX.sym("S_held", 2), ca.SX.sym("F_held")
    power = (-ca.dot(S_held, ca.jacobian(D, q) @ qd) + F_held * r2 * ca.sin(theta) * w1
             + M1f * w1 + M2f * w2)
    Q = ca.substitute(generalized_forces(power, qd), ca.vertcat(S_held, F_held),
                      ca.vertcat(S, F_s))
    for residual in ca.vertsplit(lagrange_equations(T, V, q, qd, qdd, Q)):
        m.eq(residual)

    # -- reactions: Newton for the roller (11), lever equilibrium (12) --------------
    a_O2 = ca.jacobian(v_O2, q) @ qd + ca.jacobian(v_O2, qd) @ qdd
    e1 = ca.vertcat(-ca.cos(alpha1), -ca.sin(alpha1))
    e2 = ca.vertcat(ca.cos(alpha2), ca.sin(alpha2))
    R2 = m_c * a_O2 - (S[0] * e1 + S[1] * e2 + m_c * ca.vertcat(0, -g))
    psi = phi1 + gamma + theta
    R1 = R2 + F_s * ca.vertcat(-ca.cos(psi), ca.sin(psi))
    N1, N2 = ca.norm_2(R1), ca.norm_2(R2)

    # -- Coulomb friction in both pivots -----------------------------------------------
    r_1f, r_2f = friction_radius(rho1, mu1), friction_radius(rho2, mu2)
    eps_arg = None
    if friction == "regularized":
        eps_arg = P("eps", eps, unit="rad/s", description="regularization speed: friction "
                    "torque = -r_f N tanh(speed / eps)", min=EPS_RANGE[0], max=EPS_RANGE[1],
                    source="assumption: numerical regularization width, not physics")
    coulomb_joint(m, "O1", speed=w1, torque=M1f, normal=N1, r_kinetic=r_1f,
                  r_static=k_static * r_1f, regularized_eps=eps_arg)
    coulomb_joint(m, "O2", speed=w2, torque=M2f, normal=N2, r_kinetic=r_2f,
                  r_static=k_static * r_2f, regularized_eps=eps_arg)

    # -- outputs --------------------------------------------------------------------------
    m.output("phi1_out", phi1, unit="rad", description="lever angle")
    m.output("phi2_out", phi2, unit="rad", description="roller angle relative to the lever")
    m.output("omega1_out", w1, unit="rad/s", description="lever rate")
    m.output("omega2_out", w2, unit="rad/s", description="roller rate relative to the lever")
    m.output("S1", S[0], unit="N", description="tension of the lower branch")
    m.output("S2", S[1], unit="N", description="tension of the upper branch")
    m.output("M1f_out", M1f, unit="N.m", description="friction torque in pivot O1")
    m.output("M2f_out", M2f, unit="N.m", description="friction torque in pivot O2")
    m.output("N1", N1, unit="N", description="full reaction in pivot O1")
    m.output("N2", N2, unit="N", description="full reaction in pivot O2")
    m.output("F_spring", F_s, unit="N", description="spring force")
    m.port("warp_front", "warp", elongation="warp_pull", tension="S2",
           description="upper branch towards the healds")
    m.port("warp_back", "warp", elongation="letoff", tension="S1",
           description="lower branch from the warp beam")
    return m
