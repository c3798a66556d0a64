"""Spindle drive of a ring-spinning frame: first-order lag with pure delay,
driven by the layer (builder) cam.

Source: seed 001 (Razumeev, Movshovich), (3), (4), (9):
W(s) = K e^(-s tau) / (T s + 1), corrected from the printed
K exp(-S t)/(TS + 1) (defect D9: the delay is tau, t is time).

    T n' + n = K u(t - tau)                      the drive (9)
    u = U_z + cam_on k_g (r(phi) - r_min) + u_ext  drive input signal (3)
    phi' = f_rad n / (2 pi)                      cam geared to the spindles (4)
    r(phi) = A_0 + sum_j A_j cos(j phi) + B_j sin(j phi)   cam profile table

The speeds n, n_min (and n_out) are in rad/s, shown in rpm (FMI
displayUnit); K in rad/(s V); f_rad is the cam angle per spindle
revolution, hence the 2 pi.  U_z = n_min / K is the set point (r = r_min gives n_min statically, defect
D10 of the spec).  The cam turns with the spindles, so its angle depends on
the realised speed: the delayed signal depends on the state phi and the
FMU keeps its history (cubic Hermite between accepted steps by default).

The derivation (speed law, cam design, cam series, delay equation, history)
is kept as named quantities by models/drive_derivation.py, with the print
defects D3-D6, D8-D13 (printed form, corrected form, reason; DEFECTS there)
next to the quantities they affect (``loomfmu inspect drive``).
"""
from __future__ import annotations

import math

import casadi as ca

from loomfmu.declare.checks import check_choice, check_int, check_number
from loomfmu.declare.model import Model
from loomfmu.mechanics.drive_law import MAX_HARMONICS
from loomfmu.mechanics.drive_params import FMU_RANGES, RAD_S, DriveParams
from loomfmu.mechanics.layer_cam import cam_profile_phi
from loomfmu.mechanics.layer_cam import f_rad as cam_ratio
from loomfmu.models.drive_derivation import (
    cam_quantities,
    drive_quantities,
    history_quantities,
    law_quantities,
)

SEED = "seed 001"
A = "assumption: the seed gives no numbers; "


def cam_table(cam: str, harmonics: int, m: int) -> tuple[float, list[float], list[float]]:
    """Default cam table (A_0, A_j, B_j) from the speed-law analysis
    (loomfmu.drive: seed 001 (5)-(8), (3)-(4), the assumed machine values)."""
    p = DriveParams()
    if cam == "none":
        return p.r_min, [0.0] * harmonics, [0.0] * harmonics
    A0, Aj, Bj = cam_profile_phi(p, m, compensate=(cam == "compensated"), M=harmonics)
    return float(A0), [float(v) for v in Aj], [float(v) for v in Bj]


def build(*, cam: str = "compensated", harmonics: int = 96, m: int = 40,
          max_delay: float = 5.0) -> Model:
    """cam: default cam table, "compensated" (m-term inverse of W),
    "uncompensated" (proportional to the speed law) or "none" (flat, r_min);
    harmonics: size of the cam table in phi (1 ... 512); m: harmonics of the
    speed law the cam is designed for (1 ... MAX_HARMONICS); max_delay:
    longest tau (s, (0, 3600]) the FMU's history holds."""
    check_choice("cam", cam, ("compensated", "uncompensated", "none"))
    harmonics = check_int("harmonics", harmonics, lo=1, hi=512)
    m = check_int("m", m, lo=1, hi=MAX_HARMONICS)
    max_delay = check_number("max_delay", max_delay, lo=0.0, hi=3600.0, lo_open=True, unit="s")
    m_ = Model("drive", description="Ring-spinning spindle drive: first-order lag with pure "
               "delay, fed by the layer cam geared to the spindles (seed 001)",
               stop_time=30.0, step_size=0.01, h_fixed=1e-3,
               options={"cam": cam, "harmonics": harmonics, "m": m, "max_delay": max_delay})
    P = m_.parameter

    def rng(name):  # the bounds DriveParams checks too
        lo, hi = FMU_RANGES[name][:2]
        return dict(min=lo, max=hi if name != "tau" else max_delay)

    dp = DriveParams()  # the assumed machine values, documented in loomfmu.mechanics.drive_params
    K = P("K", dp.K * RAD_S, unit="rad/(s.V)", description="static gain of the drive",
          **rng("K"), source=SEED + " (9); value " + A + "1800 rpm/V (0-10 V <-> "
          "0-18000 rpm)")
    T = P("T", dp.T, unit="s", description="time constant of the drive", **rng("T"),
          source=SEED + " (9); value " + A + "ring-frame inertia, inverter ramps")
    tau = P("tau", dp.tau, unit="s", description="pure delay of the drive", **rng("tau"),
            source=SEED + " (9), printed as t (defect D9); value " + A +
            "regulator dead time and belt slip")
    k_g = P("k_g", dp.k_g, unit="V/m", description="gain of the layer sensor W_g", **rng("k_g"),
            source=SEED + " (3), W_g not given: assumption W_g = k_g")
    r_min = P("r_min", dp.r_min, unit="m", description="cam datum radius (signal zero, n = n_min)",
              **rng("r_min"), source=SEED + " (3), read as a datum (defect D10); value " + A)
    n_min = P("n_min", dp.n_min * RAD_S, unit="rad/s", display_unit="rpm",
              description="spindle speed at the set point U_z", **rng("n_min"),
              source=A + "12000 rpm, 10-20 krpm as in seed 003")
    f_rad = P("f_rad", cam_ratio(dp), unit="rad", description="cam angle per spindle revolution",
              min=0.0, max=1.0, source=SEED + " (4), units fixed (defect D11): 2 pi / "
              "(mean speed x double-stroke period) for the assumed law")
    cam_on = P("cam_on", 1.0 if cam != "none" else 0.0, description="1: the cam drives the "
               "speed; 0: only U_z + u_ext (open loop)", min=0.0, max=1.0,
               source="model option")
    A0, Aj, Bj = cam_table(cam, harmonics, m)
    a0 = P("cam_A0", A0, unit="m", description="cam profile: mean radius", min=0.0, max=1.0,
           source="loomfmu.mechanics.layer_cam.cam_profile_phi (seed 001 (3), (8))")
    coeffs = []
    for j in range(1, harmonics + 1):
        coeffs.append((P(f"cam_A{j}", Aj[j - 1], unit="m", min=-1.0, max=1.0,
                         description=f"cam profile: cos({j} phi) coefficient",
                         source="loomfmu.mechanics.layer_cam.cam_profile_phi"),
                       P(f"cam_B{j}", Bj[j - 1], unit="m", min=-1.0, max=1.0,
                         description=f"cam profile: sin({j} phi) coefficient",
                         source="loomfmu.mechanics.layer_cam.cam_profile_phi")))
    u_ext = m_.input("u_ext", 0.0, unit="V", description="external control signal added to "
                     "the drive input", min=-100.0, max=100.0)
    n = m_.state("n", 12000.0 * RAD_S / 60.0, unit="rad/s", display_unit="rpm",
                 description="spindle speed")
    phi = m_.state("phi", 0.0, unit="rad", description="cam angle")

    if cam != "none":
        law_quantities(m_, cam, m)
    r = a0 + sum(a * ca.cos(j * phi) + b * ca.sin(j * phi)
                 for j, (a, b) in enumerate(coeffs, 1))
    cam_quantities(m_, phi, n, r, coeffs, a0, f_rad)
    U_z, U_p = n_min / K, cam_on * k_g * (r - r_min)
    u = U_z + U_p + u_ext
    u_delayed = m_.delay("u", u, tau, max_delay=max_delay,
                         description="drive input signal, tau ago")
    drive_quantities(m_, U_z=U_z, U_p=U_p, u=u, u_delayed=u_delayed, n=n, K=K)
    m_.eq(T * m_.der(n), K * u_delayed - n)
    m_.eq(m_.der(phi), f_rad * n / (2 * math.pi))  # f_rad per revolution, n in rad/s
    m_.set_starts_from(n, K * u)  # steady state of the initial signal
    history_quantities(m_, u=u, tau=tau, K=K, max_delay=max_delay)

    m_.output("n_out", n, unit="rad/s", display_unit="rpm", description="spindle speed")
    m_.output("u", u, unit="V", description="drive input signal")
    m_.output("u_delayed", u_delayed, unit="V", description="drive input signal, tau ago")
    m_.output("r", r, unit="m", description="cam radius at the follower")
    m_.output("phi_out", phi, unit="rad", description="cam angle")
    m_.port("spindles", "flange", speed="n_out", description="spindle speed to the spindles")
    return m_
