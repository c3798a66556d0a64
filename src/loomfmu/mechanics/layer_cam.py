"""Layer cam that compensates the drive's delay and lag (seed 001, (3), (4), (9)).

Signals, read off (3): drive input u = U_з + U_п, sensor U_п = W_g (r - r_min),
spindle speed n = W u, with W(s) = K e^{-s tau}/(T s + 1) (defect D9) and
W_g(s) = k_g/(T_g s + 1) (assumption, not in the seed); U_з = n_min/K.

Compensated cam (3), harmonic by harmonic in the periodic steady state:
r(t) = R0 + sum_k ar_k cos k w t + br_k sin k w t with
R0 = r_min + (C0/2 - n_min)/(K k_g) and (ar_k, br_k) = G_k applied to (a_k, b_k),
G_k = 1/(W(i k w) W_g(i k w)) = (1 + i k w T)(1 + i k w T_g) e^{i k w tau}/(K k_g).
"Applying" H = alpha + i beta to a cos x + b sin x = Im[(b + i a) e^{ix}] gives
(alpha a + beta b) cos x + (alpha b - beta a) sin x.

Cam angle (4), corrected D11: phi(t) = f_rad int_0^t n dt, f_rad = 2 pi/(n_mean P)
rad per spindle revolution (one cam turn per double stroke).  The profile
r(phi) is tabulated as a Fourier series in phi, the drive FMU's cam table.
"""
from __future__ import annotations

import numpy as np

from loomfmu.declare.checks import (
    check_array,
    check_bool,
    check_int,
    check_number,
    check_optional_number,
)
from loomfmu.mechanics.drive_law import (
    MAX_HARMONICS,
    check_coefficients,
    check_times,
    fourier,
    invert_increasing,
    law_constants,
    revolutions,
    speed_law,
    speed_slope,
    trig_eval,
)
from loomfmu.mechanics.drive_params import RPM, DriveParams, check_params

#: default number of phi samples for the profile FFT
N_PHI = 2048
#: most phi samples of the profile FFT
MAX_N_PHI = 2**20


def check_series(name: str, value) -> tuple[float, np.ndarray, np.ndarray]:
    """A table (mean, cos coefficients, sin coefficients): finite, equal lengths."""
    try:
        mean, a, b = value
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r:.60}; allowed: a tuple (mean, a, b) of a "
                         "number and two equal-length coefficient arrays") from None
    a, b = check_coefficients(a, b, (f"{name}[1]", f"{name}[2]"))
    return check_number(f"{name}[0]", mean), a, b


def _apply_response(H, a, b):
    """Coefficients of the response of the complex gains H to a cos + b sin."""
    al, be = H.real, H.imag
    return al * a + be * b, al * b - be * a


def _harmonics(p: DriveParams, m: int) -> np.ndarray:
    m = check_int("m", m, lo=0, hi=MAX_HARMONICS)
    return np.arange(1, m + 1) * law_constants(p).omega


def inverse_gain(p: DriveParams, m: int) -> np.ndarray:
    """G_k = 1/(W W_g)(i k w), k = 1..m, in m per (rev/s)."""
    x = _harmonics(p, m)
    return (1 + 1j * x * p.T) * (1 + 1j * x * p.T_g) * np.exp(1j * x * p.tau) / (p.K * p.k_g)


def forward_gain(p: DriveParams, m: int) -> np.ndarray:
    """(W W_g)(i k w), k = 1..m: cam radius -> spindle speed, (rev/s) per m."""
    x = _harmonics(p, m)
    return p.K * p.k_g * np.exp(-1j * x * p.tau) / ((1 + 1j * x * p.T) * (1 + 1j * x * p.T_g))


def U_z(p: DriveParams) -> float:
    """Set-point signal U_з = n_min/K (V): r = r_min gives n = n_min statically."""
    return p.n_min / p.K


def f_rad(p: DriveParams) -> float:
    """Cam-train ratio, rad of cam per spindle revolution: 2 pi/(n_mean P) (D11)."""
    return 2 * np.pi / law_constants(p).revs_per_period


def cam_from_fourier(p: DriveParams, C0, a, b, *, compensate: bool, sigma: bool = False):
    """(R0, ar, br) of r(t) from given coefficients of n0 (see cam_coefficients)."""
    check_params(p)
    C0 = check_number("C0", C0)
    a, b = check_coefficients(a, b)
    compensate, sigma = check_bool("compensate", compensate), check_bool("sigma", sigma)
    m = len(a)
    R0 = p.r_min + (C0 / 2 - p.n_min) / (p.K * p.k_g)
    if compensate:
        ar, br = _apply_response(inverse_gain(p, m), a, b)
    else:
        ar, br = a / (p.K * p.k_g), b / (p.K * p.k_g)
    if sigma:
        s = np.sinc(np.arange(1, m + 1) / (m + 1))
        ar, br = ar * s, br * s
    return float(R0), ar, br


def cam_coefficients(p: DriveParams, m: int, *, compensate: bool, sigma: bool = False):
    """Cam radius r(t) = R0 + sum_{k<=m} ar_k cos k w t + br_k sin k w t (m).

    compensate=True: harmonic-by-harmonic inverse of W W_g (module docstring);
    compensate=False: the naive cam r - r_min = (n0 - n_min)/(K k_g).
    sigma=True multiplies by Lanczos factors sinc(k/(m+1)) (less Gibbs
    overshoot at the reversals; then the drive follows the sigma-smoothed series).
    """
    return cam_from_fourier(p, *fourier(p, m), compensate=compensate, sigma=sigma)


def cam_radius(t, cam, p: DriveParams) -> np.ndarray:
    """r(t) in m from (R0, ar, br)."""
    R0, ar, br = check_series("cam", cam)
    return trig_eval(t, R0, ar, br, law_constants(p).omega)


def cam_radius_ideal(t, p: DriveParams) -> np.ndarray:
    """Untruncated compensated cam (T_g = 0 only), exact time-domain form of (3):
    r = r_min + [n0(t + tau) + T dn0/dt(t + tau) - n_min]/(K k_g).  It jumps at
    the reversals (dn0/dt does); with T_g > 0 it would need delta functions."""
    if check_params(p).T_g != 0:
        raise ValueError(f"p.T_g = {p.T_g!r} s; allowed: 0 (cam_radius_ideal)")
    ta = check_times("t", t) + p.tau
    return p.r_min + (speed_law(ta, p) + p.T * speed_slope(ta, p) - p.n_min) / (p.K * p.k_g)


def cam_angle(t, p: DriveParams, *, coeffs=None) -> np.ndarray:
    """phi(t) = f_rad int_0^t n dt (rad), n = n0 (coeffs None, exact) or the
    series with coeffs = (C0, a, b) (closed form of section 3 of the spec)."""
    fr = f_rad(p)
    t = check_times("t", t)
    if coeffs is None:
        return fr * revolutions(t, p)
    C0, a, b = check_series("coeffs", coeffs)
    kw = np.arange(1, len(a) + 1) * law_constants(p).omega
    x = np.multiply.outer(t, kw)
    return fr * (C0 / 2 * t + np.sin(x) @ (np.asarray(a) / kw)
                 + (1 - np.cos(x)) @ (np.asarray(b) / kw))


def time_of_angle(phi, p: DriveParams, *, coeffs=None) -> np.ndarray:
    """Inverse of :func:`cam_angle` (phi may exceed 2 pi or be negative)."""
    c_ = law_constants(p)
    phi = check_array("phi", phi, ndim=None, min_size=0, unit="rad")
    if coeffs is not None:
        coeffs = check_series("coeffs", coeffs)
    turns = np.floor(phi / (2 * np.pi))
    rest = phi - 2 * np.pi * turns
    if coeffs is None:
        speed = lambda t: speed_law(t, p)
    else:
        speed = lambda t: trig_eval(t, coeffs[0] / 2, coeffs[1], coeffs[2], c_.omega)
    fr = f_rad(p)
    t = invert_increasing(lambda t: cam_angle(t, p, coeffs=coeffs),
                          lambda t: fr * speed(t), rest, 0.0, c_.P,
                          tol=1e-13 * c_.P, x0=rest / (2 * np.pi) * c_.P)
    return t + turns * c_.P


def _profile_samples(p, m, compensate, sigma, phi):
    coeffs = fourier(p, m)
    cam = cam_from_fourier(p, *coeffs, compensate=compensate, sigma=sigma)
    return cam_radius(time_of_angle(phi, p, coeffs=coeffs), cam, p)


def cam_profile_phi(p: DriveParams, m: int, *, compensate: bool, sigma: bool = False,
                    n_phi: int = N_PHI, M: int | None = None, tol: float = 1e-7):
    """Cam radius as a function of the cam angle: (A0, A, B), A[j-1] = A_j, with
    r(phi) = A0 + sum_j A_j cos j phi + B_j sin j phi (m; phi in rad, period 2 pi).

    The cam is designed for n = the m-term series of n0 (what the compensated
    drive realises), so phi(t) is the series' cam angle.  phi(t) is inverted on
    n_phi equidistant angles and r(t(phi)) is transformed by FFT.  M None: the
    smallest M whose tail sum_{j>M} |A_j| + |B_j| is below tol (m), a bound on
    the truncation error of the table (see :func:`profile_error` for the measured one).
    """
    n_phi = check_int("n_phi", n_phi, lo=16, hi=MAX_N_PHI)
    if n_phi % 2:
        raise ValueError(f"n_phi = {n_phi!r}; allowed: even, in [16, {MAX_N_PHI}]")
    tol = check_number("tol", tol, lo=0.0, lo_open=True, unit="m")
    if M is not None:
        M = check_int("M", M, lo=0, hi=n_phi // 2 - 1)
    compensate, sigma = check_bool("compensate", compensate), check_bool("sigma", sigma)
    phi = 2 * np.pi * np.arange(n_phi) / n_phi
    c = np.fft.rfft(_profile_samples(p, m, compensate, sigma, phi)) / n_phi
    A = 2 * c[1:n_phi // 2].real
    B = -2 * c[1:n_phi // 2].imag
    if M is None:
        tail = np.cumsum((np.abs(A) + np.abs(B))[::-1])[::-1]   # tail[j] = sum_{i>=j}
        below = np.nonzero(tail < tol)[0]
        if len(below) == 0 or below[0] > len(A) // 2:
            raise ValueError(f"cam_profile_phi: tol = {tol!r} m needs more than {len(A) // 2} "
                             f"terms, the most n_phi = {n_phi} resolves (n_phi >= 4 M); "
                             f"raise n_phi (default {N_PHI}) or pass M")
        M = int(below[0])
    if not 0 <= M < n_phi // 2:
        raise ValueError(f"cam_profile_phi: M must be in [0, {n_phi // 2 - 1}], got {M!r}")
    return float(c[0].real), A[:M], B[:M]


def profile_radius(phi, prof) -> np.ndarray:
    """r(phi) in m from the table (A0, A, B)."""
    A0, A, B = check_series("prof", prof)
    return trig_eval(phi, A0, A, B, 1.0)


def profile_error(p: DriveParams, m: int, prof, *, compensate: bool, sigma: bool = False,
                  n_check: int = 4001) -> float:
    """max |r(phi) from the table - r(t(phi))| (m) on n_check angles that are
    not FFT nodes."""
    n_check = check_int("n_check", n_check, lo=1, hi=MAX_N_PHI)
    phi = 2 * np.pi * (np.arange(n_check) + 0.5) / n_check
    return float(np.max(np.abs(profile_radius(phi, prof)
                               - _profile_samples(p, m, compensate, sigma, phi))))


def pressure_angle(phi, prof) -> np.ndarray:
    """Follower pressure angle (rad) of a radial knife-edge follower,
    tan alpha = (dr/dphi)/r, from the table (A0, A, B)."""
    A0, A, B = check_series("prof", prof)
    j = np.arange(1, len(A) + 1)
    drdphi = trig_eval(phi, 0.0, j * np.asarray(B), -j * np.asarray(A), 1.0)
    return np.arctan2(drdphi, profile_radius(phi, prof))


def drive_response_coefficients(p: DriveParams, cam):
    """Periodic steady-state speed for the cam signal r(t) = (R0, ar, br):
    (n_mean, an, bn) in rev/s with n = n_mean + sum an_k cos k w t + bn_k sin k w t.

    u = U_з + W_g (r - r_min), n = W u, each harmonic through the exact
    frequency response (exact for a periodic input after the transient)."""
    check_params(p)
    R0, ar, br = check_series("cam", cam)
    n_mean = p.K * (U_z(p) + p.k_g * (R0 - p.r_min))
    an, bn = _apply_response(forward_gain(p, len(ar)), np.asarray(ar), np.asarray(br))
    return float(n_mean), an, bn


def simulate_drive_steady(p: DriveParams, cam, t) -> np.ndarray:
    """n(t) in rev/s of the drive in periodic steady state under the cam signal
    r(t) = (R0, ar, br): the independent check for the FMU's tracking error."""
    n_mean, an, bn = drive_response_coefficients(p, cam)
    return trig_eval(t, n_mean, an, bn, law_constants(p).omega)


def tracking_error(t, n, p: DriveParams, m: int | None = None, *, phi=None,
                   t_transient: float | None = None) -> float:
    """max |n(t) - n_ref| in rpm over the whole periods after t_transient.

    t, n: samples (s, rev/s), t increasing.  n_ref = n0 (m None) or its m-term
    series.  phi: if given (rad, the cam angle integrated with the realised
    n, phi(0) = 0), n_ref is evaluated at the time at which the design cam
    angle equals phi: this removes the constant phase offset that the
    transient leaves in the cam angle (the cam is driven by the spindle).
    t_transient: default 30 (T + T_g) + tau (the lag transient decays as e^{-t/T}).
    """
    t = check_array("t", t, increasing=True, unit="s")
    n = check_array("n", n, unit="rev/s")
    if t.shape != n.shape:
        raise ValueError(f"t, n: shapes {t.shape} and {n.shape}; allowed: equal lengths")
    if phi is not None:
        phi = check_array("phi", phi, unit="rad")
        if phi.shape != t.shape:
            raise ValueError(f"phi: shape {phi.shape}; allowed: the shape of t {t.shape}")
    if m is not None:
        m = check_int("m", m, lo=0, hi=MAX_HARMONICS)
    c_ = law_constants(p)
    t_transient = check_optional_number("t_transient", t_transient, lo=0.0, unit="s")
    if t_transient is None:
        t_transient = 30 * (p.T + p.T_g) + p.tau
    periods = np.floor((t[-1] - t_transient) / c_.P * (1 + 1e-12))
    if periods < 1:
        raise ValueError(f"t: ends at t[-1] = {t[-1]:g} s; allowed: t[-1] >= t_transient + "
                         f"P = {t_transient + c_.P:g} s")
    sel = t >= t[-1] - periods * c_.P - 1e-9 * c_.P
    coeffs = None if m is None else fourier(p, m)
    tr = t[sel] if phi is None else time_of_angle(np.asarray(phi)[sel], p, coeffs=coeffs)
    ref = speed_law(tr, p) if m is None else trig_eval(tr, coeffs[0] / 2, coeffs[1],
                                                       coeffs[2], c_.omega)
    return float(np.max(np.abs(n[sel] - ref)) / RPM)


def fmu_cam_parameters(p: DriveParams, m: int, *, compensate: bool = True,
                       sigma: bool = False, tol: float = 1e-7) -> dict:
    """What the drive FMU needs: the phi table and the signal constants (SI).

    Keys: f_rad (rad/rev), U_z (V), r_min (m), k_g (V/m), K ((rev/s)/V), T, tau,
    T_g (s), phi_A0 (m), phi_A, phi_B (lists, m), M, and n_start (rev/s, the
    periodic steady-state speed at t = 0 for this cam)."""
    A0, A, B = cam_profile_phi(p, m, compensate=compensate, sigma=sigma, tol=tol)
    cam = cam_coefficients(p, m, compensate=compensate, sigma=sigma)
    return dict(f_rad=f_rad(p), U_z=U_z(p), r_min=p.r_min, k_g=p.k_g, K=p.K, T=p.T,
                tau=p.tau, T_g=p.T_g, phi_A0=A0, phi_A=A.tolist(), phi_B=B.tolist(),
                M=len(A), n_start=float(simulate_drive_steady(p, cam, 0.0)))


def ideal_radius_at_reversals(p: DriveParams) -> dict:
    """One-sided limits (m) of :func:`cam_radius_ideal` where n0(t + tau) reverses:
    keys "n_min-" (end of layer), "n_min+" (start of interlayer), "n_max-"
    (end of interlayer), "n_max+" (start of layer).  The jumps are
    T (g1 + g2) K_n n_rev/(d_rev K k_g); the extremes of the ideal cam are
    "n_min-" (minimum) and "n_max-" (maximum) for the default values."""
    c_ = law_constants(p)
    out = {}
    for key, n, rate in (("n_min-", p.n_min, -c_.Delta / p.T_c),
                         ("n_min+", p.n_min, c_.Delta / p.T_n),
                         ("n_max-", p.n_max, c_.Delta / p.T_n),
                         ("n_max+", p.n_max, -c_.Delta / p.T_c)):
        slope = rate * n / (n - c_.n1)
        out[key] = p.r_min + (n + p.T * slope - p.n_min) / (p.K * p.k_g)
    return out
