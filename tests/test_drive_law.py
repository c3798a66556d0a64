"""Speed law, Fourier series and compensating cam of the spindle drive (seed 001).

Oracles: the winding ODE (2) itself, the Lambert-W closed form, scipy quad in
the time domain, solve_ivp on the delayed lag, and the reference numbers of
docs/guides/seed_notes/drive_spec.md section 4, which come from the independent script
docs/guides/seed_notes/drive_check.py.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.special import lambertw

from loomfmu import drive as dr
from loomfmu.drive import RPM, DriveParams

P0 = DriveParams()
C = dr.law_constants(P0)


def test_defaults_are_the_spec_values():
    assert DriveParams.from_rpm(n_min=12000, n_max=15000, K=1800) == P0
    for row in DriveParams.table():
        assert row["unit"] and row["description"]
        assert "seed 001" in row["source"] or row["source"].startswith("assumption")


# ---------------------------------------------------------------- speed law
@pytest.mark.parametrize("t", [0.3, 1.0, 2.5, 4.7, 5.4, 8.0, 12.0, 14.6])
def test_law_satisfies_winding_ode(t):
    """d dd/dt = g n with d = (n - n1)/K_n, g = +g2 (interlayer), -g1 (layer)."""
    h = 1e-4
    d = lambda s: (dr.speed_law(s, P0) - C.n1) / C.K_n
    g = C.g2 if t < P0.T_n else -C.g1
    lhs = d(t) * (d(t + h) - d(t - h)) / (2 * h)
    rhs = g * dr.speed_law(t, P0)
    assert abs(lhs - rhs) <= 1e-7 * abs(rhs)


def test_law_matches_lambert_w_closed_form():
    t = np.linspace(0, C.P, 301, endpoint=False)
    tl = t - P0.T_n
    c = np.where(t < P0.T_n, P0.n_min - C.n1 * np.log(P0.n_min) + C.Delta * t / P0.T_n,
                 P0.n_max - C.n1 * np.log(P0.n_max) - C.Delta * tl / P0.T_c)
    n_lw = np.real(-C.n1 * lambertw(-np.exp(-c / C.n1) / C.n1, -1))   # n1 > 0: branch -1
    assert np.max(np.abs(dr.speed_law(t, P0) - n_lw)) <= 1e-11 * P0.n_max


def test_law_negative_n1_and_zero_n1():
    """n1 < 0 (D_B/D_N > n_min/n_max) and n1 = 0 (n_min/n_max = D_B/D_N: linear in t)."""
    p = DriveParams(D_B=0.036)
    assert dr.law_constants(p).n1 < 0
    c = dr.law_constants(p)
    t = np.linspace(0, c.P, 97)
    n = dr.speed_law(t, p)
    F = n - c.n1 * np.log(n)
    F_exp = np.where(t < p.T_n, p.n_min - c.n1 * np.log(p.n_min) + c.Delta * t / p.T_n,
                     p.n_max - c.n1 * np.log(p.n_max) - c.Delta * (t - p.T_n) / p.T_c)
    assert np.max(np.abs(F - F_exp)) < 1e-10
    p0 = DriveParams(D_B=0.020, D_N=0.025, n_min=200.0, n_max=250.0)
    assert abs(dr.law_constants(p0).n1) < 1e-12
    assert dr.speed_law(2.5, p0) == pytest.approx(225.0, rel=1e-12)


def test_law_continuous_periodic_monotone():
    eps = 1e-9
    assert dr.speed_law(0.0, P0) == pytest.approx(P0.n_min, rel=1e-14)
    assert dr.speed_law(P0.T_n, P0) == pytest.approx(P0.n_max, rel=1e-14)
    assert dr.speed_law(P0.T_n - eps, P0) == pytest.approx(P0.n_max, rel=1e-9)
    assert dr.speed_law(C.P - eps, P0) == pytest.approx(P0.n_min, rel=1e-9)
    t = np.linspace(-20, 20, 1001)
    assert np.allclose(dr.speed_law(t + C.P, P0), dr.speed_law(t, P0), rtol=1e-13)
    ti = np.linspace(0, P0.T_n, 200, endpoint=False)
    tl = np.linspace(P0.T_n, C.P, 200, endpoint=False)
    assert np.all(np.diff(dr.speed_law(ti, P0)) > 0)
    assert np.all(np.diff(dr.speed_law(tl, P0)) < 0)


def test_slope_and_revolutions_exact():
    h = 1e-5
    for t in (1.0, 4.0, 6.0, 13.0):
        fd = (dr.speed_law(t + h, P0) - dr.speed_law(t - h, P0)) / (2 * h)
        assert dr.speed_slope(t, P0) == pytest.approx(fd, rel=1e-7)
    for t in (3.0, 7.3, 14.0, 33.1):
        q = quad(lambda s: dr.speed_law(s, P0), 0, t, points=[5, 15, 20, 30], limit=200)[0]
        assert dr.revolutions(t, P0) == pytest.approx(q, rel=1e-10)
    assert dr.revolutions(C.P, P0) == pytest.approx(C.revs_per_period, rel=1e-13)


# ---------------------------------------------------------------- reference numbers (spec 4)
def test_reference_law_constants():
    assert C.K_n == pytest.approx(2272.7272727272725, rel=1e-12)
    assert C.n1 == pytest.approx(154.54545454545453, rel=1e-12)
    assert C.Delta == pytest.approx(15.514178433258493, rel=1e-10)
    assert C.g1 == pytest.approx(3.0035449446788444e-07, rel=1e-10)
    assert C.g2 == pytest.approx(6.007089889357689e-07, rel=1e-10)
    assert C.n_mean / RPM == pytest.approx(13623.901341145207, rel=1e-10)
    assert dr.f_rad(P0) == pytest.approx(0.0018447536134760148, rel=1e-10)
    assert C.revs_per_period == pytest.approx(3405.9753352863017, rel=1e-10)


def test_reference_samples_and_slopes():
    ref = {1.3: 12944.722886359885, 5.0: 15000.0, 7.7: 14315.687167839538,
           14.9: 12040.723026207095}
    for t, v in ref.items():
        assert dr.speed_law(t, P0) / RPM == pytest.approx(v, rel=1e-10)
    eps = 1e-10
    assert dr.speed_slope(0.0, P0) / RPM == pytest.approx(819.1486212760483, rel=1e-6)
    assert dr.speed_slope(C.P - eps, P0) / RPM == pytest.approx(-409.57431063802414, rel=1e-6)
    assert dr.speed_slope(P0.T_n - eps, P0) / RPM == pytest.approx(487.58846504526684, rel=1e-6)
    assert dr.speed_slope(P0.T_n, P0) / RPM == pytest.approx(-243.79423252263342, rel=1e-6)


def test_reference_fourier_coefficients():
    ref = {1: (-1021.549, 557.559), 2: (-285.693, -99.998), 3: (-36.999, 5.169),
           5: (-47.777, -17.395), 10: (-12.016, 5.070), 20: (-3.028, -1.169)}
    C0, a, b = dr.fourier(P0, 20)
    assert C0 / 2 / RPM == pytest.approx(13623.901341145205, rel=1e-12)
    for k, (ak, bk) in ref.items():        # printed to 3 decimals
        assert a[k - 1] / RPM == pytest.approx(ak, abs=6e-4)
        assert b[k - 1] / RPM == pytest.approx(bk, abs=6e-4)


def test_reference_compensation_gain_and_lead():
    G = dr.inverse_gain(P0, 3) * P0.K * P0.k_g
    assert np.abs(G) == pytest.approx([1.305, 1.951, 2.705], abs=6e-4)
    assert np.angle(G) == pytest.approx([0.9068, 1.4516, 1.8204], abs=6e-5)


def test_reference_cam_radius():
    ri = dr.cam_radius_ideal(np.array([1.0, 3.0, 8.0, 12.0]), P0) * 1e3
    assert ri == pytest.approx([63.08270635972338, 68.35542095503926, 58.65345472023264,
                                51.39584345109815], rel=1e-6)
    cam = dr.cam_coefficients(P0, 40, compensate=True)
    r40 = dr.cam_radius(np.array([1.0, 3.0, 8.0, 12.0]), cam, P0) * 1e3
    assert r40 == pytest.approx([62.96079525330599, 68.33215010308467, 58.55692776030568,
                                 51.39687306294041], rel=1e-9)
    r = dr.cam_radius(np.linspace(0, C.P, 6001), cam, P0) * 1e3
    assert r.min() == pytest.approx(44.680, abs=2e-3)     # spec: 601-point grid
    assert r.max() == pytest.approx(72.323, abs=2e-3)
    lim = dr.ideal_radius_at_reversals(P0)
    assert (lim["n_min+"] - lim["n_min-"]) * 1e3 == pytest.approx(13.652477021267472, rel=1e-9)
    assert (lim["n_max-"] - lim["n_max+"]) * 1e3 == pytest.approx(8.126474417421115, rel=1e-9)
    # the ideal cam is bounded by its one-sided limits at the reversals (defect D10)
    t = np.linspace(0, C.P, 20001)
    ri = dr.cam_radius_ideal(t, P0)
    assert lim["n_min-"] - 1e-12 <= ri.min() < P0.r_min
    assert ri.max() <= lim["n_max-"] + 1e-12


# ---------------------------------------------------------------- Fourier series
def test_fourier_matches_time_domain_quadrature():
    C0, a, b = dr.fourier(P0, 12)
    w = C.omega
    for k in (1, 4, 12):
        f = lambda t, trig: dr.speed_law(t, P0) * trig(k * w * t)
        ak = 2 / C.P * quad(f, 0, C.P, args=(np.cos,), points=[P0.T_n], limit=200,
                            epsabs=1e-10)[0]
        bk = 2 / C.P * quad(f, 0, C.P, args=(np.sin,), points=[P0.T_n], limit=200,
                            epsabs=1e-10)[0]
        assert a[k - 1] == pytest.approx(ak, abs=1e-8)
        assert b[k - 1] == pytest.approx(bk, abs=1e-8)


def test_fourier_converges_first_order_at_the_corners():
    t = np.linspace(0, C.P, 6001)
    n0 = dr.speed_law(t, P0)
    ms = (10, 20, 40, 80)
    C0, a, b = dr.fourier(P0, max(ms))
    err = [np.max(np.abs(dr.series(t, C0, a[:m], b[:m], omega=C.omega) - n0)) for m in ms]
    assert all(e2 < e1 for e1, e2 in zip(err, err[1:]))
    for e1, e2 in zip(err, err[1:]):             # O(1/m): halving per doubling of m
        assert 1.7 < e1 / e2 < 2.3
    k = np.arange(1, 81)
    assert np.max(k**2 * np.hypot(a, b)) < 2 * (P0.n_max - P0.n_min)   # O(1/k^2)


# ---------------------------------------------------------------- compensation
def _steady_response(p, cam, t):
    """Independent: each harmonic of u = U_z + k_g (r - r_min) through
    W(i x) = K e^{-i x tau}/(1 + i x T), in complex exponentials."""
    R0, ar, br = cam
    w = dr.law_constants(p).omega
    n = p.K * (p.n_min / p.K + p.k_g * (R0 - p.r_min)) * np.ones_like(t)
    for k in range(1, len(ar) + 1):
        x = k * w
        W = p.K * np.exp(-1j * x * p.tau) / (1 + 1j * x * p.T)
        ck = p.k_g * (ar[k - 1] - 1j * br[k - 1])      # r_k = Re(ck e^{ixt})
        n += np.real(W * ck * np.exp(1j * x * t))
    return n


def test_compensated_cam_reproduces_series():
    m = 40
    C0, a, b = dr.fourier(P0, m)
    cam = dr.cam_coefficients(P0, m, compensate=True)
    t = np.linspace(0, C.P, 2001)
    ser = dr.series(t, C0, a, b, omega=C.omega)
    n = _steady_response(P0, cam, t)
    assert np.max(np.abs(n - ser)) <= 1e-8 * np.max(ser)
    assert np.max(np.abs(dr.simulate_drive_steady(P0, cam, t) - n)) <= 1e-10 * np.max(ser)
    # truncation only (spec: 23 rpm at m = 40)
    assert np.max(np.abs(n - dr.speed_law(t, P0))) / RPM == pytest.approx(23.05, abs=0.05)


def test_compensated_cam_with_sensor_lag():
    p = DriveParams(T_g=0.02)
    m = 20
    C0, a, b = dr.fourier(p, m)
    cam = dr.cam_coefficients(p, m, compensate=True)
    t = np.linspace(0, C.P, 501)
    # through W and W_g = k_g/(T_g s + 1): harmonic k of the cam scaled by 1/(1 + i k w T_g)
    R0, ar, br = cam
    x = np.arange(1, m + 1) * C.omega
    c = (ar - 1j * br) / (1 + 1j * x * p.T_g)
    cam_g = (R0, c.real, -c.imag)
    ser = dr.series(t, C0, a, b, omega=C.omega)
    assert np.max(np.abs(_steady_response(p, cam_g, t) - ser)) <= 1e-8 * np.max(ser)


def test_compensated_cam_time_domain_delay_ode():
    """T n' + n = K u(t - tau), u = U_z + k_g (r - r_min), solved by solve_ivp
    from the periodic value at t = 0: stays on the m-term series."""
    m = 10
    C0, a, b = dr.fourier(P0, m)
    cam = dr.cam_coefficients(P0, m, compensate=True)
    ser = lambda t: dr.series(t, C0, a, b, omega=C.omega)
    u = lambda t: P0.n_min / P0.K + P0.k_g * (dr.cam_radius(t, cam, P0) - P0.r_min)
    sol = solve_ivp(lambda t, y: (P0.K * u(t - P0.tau) - y) / P0.T, (0, C.P), [ser(0.0)],
                    rtol=1e-11, atol=1e-9, dense_output=True)
    t = np.linspace(0, C.P, 301)
    assert np.max(np.abs(sol.sol(t)[0] - ser(t))) / RPM < 1e-5


def test_uncompensated_cam_misses_by_about_1185_rpm():
    cam = dr.cam_coefficients(P0, 40, compensate=False)
    assert cam[1] == pytest.approx(dr.fourier(P0, 40)[1] / (P0.K * P0.k_g), rel=1e-14)
    t = np.linspace(0, C.P, 3001)
    err = np.max(np.abs(_steady_response(P0, cam, t) - dr.speed_law(t, P0))) / RPM
    assert err == pytest.approx(1184.63, rel=2e-3)   # drive_check.py, true n0 cam


def test_lanczos_cam_stays_within_ideal_range():
    t = np.linspace(0, C.P, 6001)
    lim = dr.ideal_radius_at_reversals(P0)
    r_s = dr.cam_radius(t, dr.cam_coefficients(P0, 40, compensate=True, sigma=True), P0)
    r_p = dr.cam_radius(t, dr.cam_coefficients(P0, 40, compensate=True), P0)
    assert lim["n_min-"] < r_s.min() and r_s.max() < lim["n_max-"]
    assert r_p.min() < lim["n_min-"] and r_p.max() > lim["n_max-"]     # Gibbs overshoot


# ---------------------------------------------------------------- cam angle and phi table
def test_cam_angle_closed_form():
    coeffs = dr.fourier(P0, 10)
    fr = dr.f_rad(P0)
    for t in (2.0, 9.0, 15.0):
        q = quad(lambda s: fr * dr.series(s, *coeffs, omega=C.omega), 0, t, epsabs=1e-12)[0]
        assert dr.cam_angle(t, P0, coeffs=coeffs) == pytest.approx(q, rel=1e-10)
    assert dr.cam_angle(C.P, P0) == pytest.approx(2 * np.pi, rel=1e-13)
    assert dr.cam_angle(C.P, P0, coeffs=coeffs) == pytest.approx(2 * np.pi, rel=1e-13)
    phi = np.array([-1.0, 0.5, 3.0, 6.0, 9.5])
    for cf in (None, coeffs):
        assert dr.cam_angle(dr.time_of_angle(phi, P0, coeffs=cf), P0, coeffs=cf) == \
            pytest.approx(phi, abs=1e-12)


@pytest.mark.parametrize("m,compensate", [(10, True), (40, True), (40, False)])
def test_phi_table_reproduces_cam(m, compensate):
    prof = dr.cam_profile_phi(P0, m, compensate=compensate)
    assert dr.profile_error(P0, m, prof, compensate=compensate) < 1e-6
    # independent of the inversion: r(phi(t)) along time against r(t)
    coeffs = dr.fourier(P0, m)
    cam = dr.cam_from_fourier(P0, *coeffs, compensate=compensate)
    t = np.linspace(0, C.P, 1777)
    r_phi = dr.profile_radius(dr.cam_angle(t, P0, coeffs=coeffs), prof)
    assert np.max(np.abs(r_phi - dr.cam_radius(t, cam, P0))) < 1e-6


def test_fmu_cam_parameters():
    d = dr.fmu_cam_parameters(P0, 40)
    assert d["M"] == len(d["phi_A"]) == len(d["phi_B"])
    assert d["U_z"] * d["K"] == pytest.approx(P0.n_min)
    assert d["n_start"] == pytest.approx(dr.series(0.0, *dr.fourier(P0, 40), omega=C.omega),
                                         rel=1e-10)


# ---------------------------------------------------------------- tracking error helper
def test_tracking_error_helper():
    coeffs = dr.fourier(P0, 20)
    t = np.linspace(0, 100, 20001)
    n = dr.speed_law(t, P0) + 0.5 * RPM
    assert dr.tracking_error(t, n, P0) == pytest.approx(0.5, rel=1e-9)
    # a time-shifted steady state: large error in t, none when aligned by the cam angle
    shift = 0.7
    n_s = dr.series(t + shift, *coeffs, omega=C.omega)
    phi = dr.cam_angle(t + shift, P0, coeffs=coeffs) - dr.cam_angle(shift, P0, coeffs=coeffs)
    assert dr.tracking_error(t, n_s, P0, 20) > 50
    phi_ref = dr.cam_angle(shift, P0, coeffs=coeffs)
    assert dr.tracking_error(t, n_s, P0, 20, phi=phi + phi_ref) < 1e-6
    with pytest.raises(ValueError, match="t_transient"):
        dr.tracking_error(t[:1000], n[:1000], P0)


# ---------------------------------------------------------------- validation
@pytest.mark.parametrize("kw,field", [
    (dict(T=-1.0), "T"), (dict(tau=-0.1), "tau"), (dict(T_c=0.0), "T_c"),
    (dict(T_n=-5.0), "T_n"), (dict(n_max=150.0), "n_max"), (dict(D_N=0.015), "D_N"),
    (dict(D_B=0.0), "D_B"), (dict(K=0.0), "K"), (dict(k_g=-1.0), "k_g"),
    (dict(r_min=float("nan")), "r_min"), (dict(T_g=-0.01), "T_g"),
    (dict(T=0.0), r"T must be in \[1e-06, 100\] s"), (dict(T=101.0), "T"),
    (dict(K=1e-3), r"K must be in \[0.10472, 104720\] rad/\(s.V\) = \[0.0166667, "
                   r"16666.7\]"), (dict(tau=4000.0), "tau"),
    (dict(r_min=2.0), "r_min"), (dict(n_min=1e4), "n_min"), (dict(k_g=1e7), "k_g")])
def test_bad_params_raise(kw, field):
    with pytest.raises(ValueError, match=rf"\b{field}"):
        DriveParams(**kw)


def test_all_problems_reported_and_bad_arguments():
    with pytest.raises(ValueError) as e:
        DriveParams(T=-1.0, tau=-1.0, D_N=0.01)
    assert all(f in str(e.value) for f in ("T must", "tau must", "D_N must"))
    with pytest.raises(ValueError, match=r"K must be > 0 \(\(rev/s\)/V\), got 0"):
        DriveParams(K=0.0)   # the field's unit in the message
    with pytest.raises(ValueError, match="m must"):
        dr.fourier(P0, -1)
    with pytest.raises(ValueError, match="T_g"):
        dr.cam_radius_ideal(1.0, DriveParams(T_g=0.01))
    with pytest.raises(ValueError, match="n_phi"):
        dr.cam_profile_phi(P0, 10, compensate=True, n_phi=7)
