"""The drive's derivation as named quantities: the speed law's
Fourier series (8) and the cam design (3), (4) that make the default cam
table (numbers at the assumed machine values of loomfmu.drive, computed at
build time), the cam series r(phi) and the drive's delay equation (9) as
expressions of the model's variables, and the delay history with its
breakpoints.  Kept with ``Model.quantity`` for the derivation reports
(``loomfmu inspect drive``) and ``loomfmu.inspect``; the generated code never
uses them (tests/test_drive_quantities.py: they are what the equations use).

The print defects of seed 001 that touch this model (docs/guides/seed_notes/
drive_spec.md, D6-D13) are written once, here, next to the quantity they
affect.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from loomfmu.mechanics.drive_law import amplitude_phase, fourier, law_constants
from loomfmu.mechanics.drive_params import DriveParams
from loomfmu.mechanics.layer_cam import cam_from_fourier, inverse_gain

SEED = "seed 001"
LAW = "speed law (5)-(8), at the assumed machine values (numbers)"
CAM = "cam design (3), (4)"
DRIVE = "drive with pure delay (9)"
HISTORY = "delay history and breakpoints"

#: seed 001's print defects in this model: (printed, corrected, reason)
DEFECTS = {
    "D3": ("(2) d_n (partial d / partial t) = g n", "d (dd/dt) = g n",
           "d depends on t only, so the derivative is total"),
    "D4": ("g1 = (D_n^2 - D_b^2)/2n_c t_c", "g1 = (D_N^2 - D_B^2)/(2 n_c t_c) (g2 alike)",
           "inline-fraction ambiguity; the bracketed form follows from integrating (2)"),
    "D5": ("(5) n^0(d_n)n_1 + K_n d_n", "n0(d) = n1 + K_n d",
           "'=' lost; the printed n1 and K_n fit only this form"),
    "D6": ("(6) n_max = n0 - n1 ln(n_max/n0) - g1 K_n^2 t + 0",
           "n_max - n0 - n1 ln(n_max/n0) - g1 K_n^2 t = 0", "'-' was read as '=' and '= 0' "
           "as '+ 0'; the printed form makes n0 rise above n_max in the layer, the "
           "derivation from (2), (5) gives the corrected form"),
    "D8": ("(8) C_i sin(i w t + phi), phi = arctg(b_i/a_i)",
           "C_i sin(i w t + psi_i), psi_i = atan2(a_i, b_i)", "a cos x + b sin x = C sin(x + "
           "psi) needs tan psi = a/b in four quadrants; phi is also the cam angle"),
    "D9": ("(9) W(S) = K exp(-S t)/(T S + 1)", "W(s) = K exp(-s tau)/(T s + 1)",
           "t is time; the text describes a pure delay tau"),
    "D10": ("r_min = the minimum radius, phi counted from it",
            "r_min = datum radius where U_p = 0 (n = n_min statically)", "the compensated cam "
            "contains T n0'(t + tau) < 0 before n_min, so its true minimum is below r_min; "
            "phi is counted from t = 0"),
    "D11": ("(4) phi(S) = f n0(S)/S, f = a ratio", "phi' = f_rad n, f_rad = 2 pi/(n_mean P) "
            "rad per spindle revolution", "f must be in rad per revolution and periodicity "
            "fixes it; the cam turns with the spindles, so phi is not linear in t"),
    "D12": ("Fourier interval t_n + t_c (stroke times at a constant speed n_c)",
            "P = T_n + T_c, the actual stroke durations", "the two agree only if n_c is the "
            "mean speed"),
    "D13": ("(3) 1/W_g(S)W(S)[...]", "[...]/(W_g(s) W(s))", "inline-fraction ambiguity"),
}


def defect_note(key: str) -> str:
    """'print defect D9: printed ..., corrected ...: reason' for a description."""
    printed, corrected, reason = DEFECTS[key]
    return f"print defect {key}: printed {printed}; corrected {corrected}; because {reason}"


def law_quantities(m, cam: str, harmonics_m: int) -> None:
    """The speed law's series (8) and the cam designed from it (3), numbers
    at DriveParams' assumed values (what the default cam table is made of)."""
    Q = m.quantity
    p = DriveParams()
    c = law_constants(p)
    C0, a, b = fourier(p, harmonics_m)
    rad_s = 2 * math.pi  # rad/s per rev/s: the model's speeds are rad/s
    Q("P", c.P, unit="s", description="period of the speed law, one double stroke "
      "(interlayer and layer); " + defect_note("D12"), symbol="P",
      source=SEED + " (8), corrected (D12): P = T_n + T_c", group=LAW)
    Q("omega_P", c.omega, unit="rad/s", description="fundamental angular frequency of the "
      "speed law's series", symbol=r"\omega", source="derived: 2 pi / P (not stated in "
      + SEED + ")", group=LAW)
    Q("n1", c.n1 * rad_s, unit="rad/s", description="intercept of the linear law n0(d) = n1 + "
      "K_n d between the cop diameter d and the speed (" + defect_note("D5") + "); n1 = "
      "(D_N n_min - D_B n_max)/(D_N - D_B), may be negative", symbol="n_1",
      source=SEED + " (5)", group=LAW)
    Q("K_n", c.K_n * rad_s, unit="rad/(s.m)", description="slope of the linear law (5): K_n = "
      "(n_max - n_min)/(D_N - D_B)", symbol="K_n", source=SEED + " (5)", group=LAW)
    Q("Delta", c.Delta * rad_s, unit="rad/s", description="n_max - n_min - n1 ln(n_max/n_min), "
      "which the winding (2) with (5) makes g1 K_n^2 T_c and g2 K_n^2 T_n (" +
      defect_note("D3") + ")", symbol=r"\Delta", source="derived: integrating seed 001 "
      "(2) with (5) (docs/guides/seed_notes/drive_spec.md)", group=LAW)
    Q("g1", c.g1, unit="m2", description="winding constant of the layer (slow stroke, d: "
      "D_N -> D_B), Delta/(K_n^2 T_c), from the stroke's duration T_c (" +
      defect_note("D4") + "; D12: the seed's n_c t_c replaced by the actual duration)",
      symbol="g_1", source=SEED + " (2), (6)", group=LAW)
    Q("g2", c.g2, unit="m2", description="winding constant of the interlayer (fast stroke), "
      "Delta/(K_n^2 T_n)", symbol="g_2", source=SEED + " (2), (7)", group=LAW)
    Q("n0_mean", C0 / 2 * rad_s, unit="rad/s", description="mean of the optimal speed law n0(t) "
      "over a period; n0 solves (6) in the layer and (7) in the interlayer ("
      + defect_note("D6") + ")", symbol=r"C_0/2", source=SEED + " (5)-(8)", group=LAW)
    Q("a_k", a * rad_s, unit="rad/s", description=f"cosine coefficients of n0(t), k = 1 ... "
      f"{harmonics_m}: n0 = C0/2 + sum a_k cos k w t + b_k sin k w t", symbol="a_k",
      source=SEED + " (8)", group=LAW)
    Q("b_k", b * rad_s, unit="rad/s", description="sine coefficients of n0(t)", symbol="b_k",
      source=SEED + " (8)", group=LAW)
    C, psi = amplitude_phase(a, b)
    Q("C_k", C * rad_s, unit="rad/s", description="amplitudes of (8): C_k = sqrt(a_k^2 + b_k^2)",
      symbol="C_k", source=SEED + " (8)", group=LAW)
    Q("psi_k", psi, unit="rad", description="phases of (8), n0 = C0/2 + sum C_k sin(k w t + "
      "psi_k); " + defect_note("D8"), symbol=r"\psi_k", source=SEED + " (8), corrected (D8)",
      group=LAW)
    Q("psi_k_printed", np.arctan(b / a), unit="rad", description="the phases as printed, "
      "arctg(b_k/a_k) (not used: wrong quantity and quadrant); " + defect_note("D8"),
      symbol=r"\varphi_{\mathrm{printed}}", source=SEED + " (8) as printed", group=LAW)
    if cam == "compensated":
        G = inverse_gain(p, harmonics_m) / rad_s
        Q("alpha_k", G.real, description="real part of G_k = 1/(W W_g)(i k w) = (1 + i k w T)"
          "(1 + i k w T_g) e^{i k w tau}/(K k_g), in m per rad/s; " + defect_note("D13"),
          symbol=r"\alpha_k", source=SEED + " (3), (9), corrected (D9, D13)", group=CAM)
        Q("beta_k", G.imag, description="imaginary part of G_k, in m per rad/s",
          symbol=r"\beta_k", source=SEED + " (3), (9)", group=CAM)
    R0, ar, br = cam_from_fourier(p, C0, a, b, compensate=(cam == "compensated"))
    how = ("ar_k = alpha_k a_k + beta_k b_k, br_k = alpha_k b_k - beta_k a_k (compensated)"
           if cam == "compensated" else "ar_k = a_k/(K k_g), br_k = b_k/(K k_g) "
           "(uncompensated: proportional to the speed law)")
    Q("R_0", R0, unit="m", description="mean cam radius in time, r_min + (C0/2 - n_min)/"
      "(K k_g)", symbol="R_0", source=SEED + " (3)", group=CAM)
    Q("ar_k", ar, unit="m", description=f"cam radius in time r(t) = R_0 + sum ar_k cos k w t "
      f"+ br_k sin k w t: {how}", symbol=r"a^r_k", source=SEED + " (3)", group=CAM)
    Q("br_k", br, unit="m", description="sine coefficients of the cam radius in time",
      symbol=r"b^r_k", source=SEED + " (3)", group=CAM)


def cam_quantities(m, phi, n, r, coeffs, a0, f_rad) -> None:
    """The cam table as the FMU holds it, the cam series r(phi) and the cam angle (4)."""
    Q = m.quantity
    Q("A_j", ca.vertcat(a0, *[a for a, _ in coeffs]), unit="m", description="cam table: "
      "A_0 (mean radius) and the cos(j phi) coefficients, FMU parameters cam_A0, cam_A1, "
      "... (the cam radius in time resampled at the cam angle and transformed by FFT)",
      symbol="A_j", source="derived: loomfmu.mechanics.layer_cam.cam_profile_phi from r(t) of " + SEED
      + " (3) and phi(t) of (4)", group=CAM)
    Q("B_j", ca.vertcat(*[b for _, b in coeffs]), unit="m", description="cam table: the "
      "sin(j phi) coefficients, FMU parameters cam_B1, ...", symbol="B_j",
      source="derived: loomfmu.mechanics.layer_cam.cam_profile_phi", group=CAM)
    Q("r_cam", r, unit="m", description="cam radius at the follower, the cam series "
      "r(phi) = A_0 + sum_j A_j cos j phi + B_j sin j phi; " + defect_note("D10"),
      symbol=r"r(\varphi)", source=SEED + " (3) (the profile in polar form)", group=CAM)
    Q("phi_dot", f_rad * n / (2 * math.pi), unit="rad/s", description="cam angular "
      "speed: the cam is geared to the spindles, phi' = f_rad n / (2 pi) (f_rad per "
      "spindle revolution, n in rad/s); " + defect_note("D11"),
      symbol=r"\dot\varphi", source=SEED + " (4), corrected (D11)", group=CAM)


def drive_quantities(m, *, U_z, U_p, u, u_delayed, n, K) -> None:
    """The drive signal (3) and the delay equation (9)."""
    Q = m.quantity
    Q("U_z", U_z, unit="V", description="set-point signal n_min / K: r = r_min gives "
      "n = n_min statically; " + defect_note("D10"), symbol=r"U_{\mathrm{z}}",
      source=SEED + " (3)", group=DRIVE)
    Q("U_p", U_p, unit="V", description="layer-sensor signal cam_on k_g (r - r_min) (W_g = "
      "k_g: assumption)", symbol=r"U_{\mathrm{p}}", source=SEED + " (3)", group=DRIVE)
    Q("u_in", u, unit="V", description="drive input signal U_z + U_p + u_ext",
      symbol="u", source=SEED + " (3), fig. 2", group=DRIVE)
    Q("u_tau", u_delayed, unit="V", description="the delayed signal u(t - tau), tau the "
      "pure delay (parameter tau), read from the FMU's history; " + defect_note("D9"),
      symbol=r"u(t-\tau)", source=SEED + " (9): e^{-s tau}, corrected (D9)", group=DRIVE)
    Q("T_ndot", K * u_delayed - n, unit="rad/s", description="the delay equation (9) in the "
      "time domain: T n' = K u(t - tau) - n (the lag 1/(T s + 1) after the delay)",
      symbol=r"T\dot n", source=SEED + " (9), corrected (D9)", group=DRIVE)


def history_quantities(m, *, u, tau, K, max_delay: float) -> None:
    """What the FMU keeps of the delayed signal, and where it cuts its steps."""
    Q = m.quantity
    Q("history_span", max_delay, unit="s", description="the history kept: u over [t - "
      "max_delay, t] (values and time derivatives from the solver's dense output, cubic "
      "Hermite between samples); a tau above it is refused at initialization (build option "
      "max_delay)", symbol=r"\tau_{\max}", source="derived: loomfmu runtime (docs/guides/runtime.md"
      ", Delays)", group=HISTORY)
    Q("u_before_start", u, unit="V", description="the history before t = 0: constant at "
      "the signal's start value u(0), so the drive starts in the steady state n(0) = K u(0)",
      symbol=r"u(t<0)", source="derived: assumption of a steady start", group=HISTORY)
    Q("n_start", K * u, unit="rad/s", description="start speed, the steady state of the "
      "initial signal (recomputed from the parameters)", symbol="n(0)",
      source="derived: (9) at rest, n = K u", group=HISTORY)
    Q("breakpoint_lag", tau, unit="s", description="an input jump (u_ext) at t_j is a jump "
      "of the history that reappears in u(t - tau) at t_j + tau: a breakpoint where the "
      "solver ends its step and restarts (at most 8192 pending); steps never exceed tau",
      symbol=r"\Delta t_{\mathrm{break}}", source="derived: method of steps for (9)", group=HISTORY)

