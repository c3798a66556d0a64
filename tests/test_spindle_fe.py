"""The FE rotor against analytic beam and rotor results, and the seed's
analyses (15), (18)-(21) against direct solutions."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
import scipy.integrate as si

from loomfmu.mechanics.rotor import (
    Rotor,
    band_ldl_solve,
    equivalent_support,
    film_damping,
    film_integral_C,
    film_integral_K,
    spring_radii,
)
from loomfmu.spindle.analysis import (
    RPM,
    direct_compliance,
    dynamic_compliance,
    unbalance_response,
    undamped_frequencies,
    whirl_modes,
)
from loomfmu.spindle.study import Spindle

E, RHO, G, KAPPA = 2.1e11, 7800.0, 8.1e10, 0.9


def numeric(rotor):
    return [np.array(ca.DM(ca.evalf(a))) for a in rotor.assemble()]


def pinned_plane(rotor, mats):
    """x-plane DOF of a beam pinned at both ends (end translations removed)."""
    names = rotor.dof_names()
    last = rotor.n_nodes - 1
    keep = [i for i, s in enumerate(names) if s.endswith((".x", ".ax"))
            and s not in ("n0.x", f"n{last}.x")]
    return [a[np.ix_(keep, keep)] for a in mats]


def uniform(n, L, d, timoshenko=False):
    r = Rotor(E, RHO, G, KAPPA, timoshenko=timoshenko)
    for _ in range(n):
        r.element(L / n, d)
    return r


@pytest.mark.parametrize("timoshenko", [False, True])
def test_pinned_beam_frequencies_match_the_analytic_ones(timoshenko):
    """Rayleigh beam (rotary inertia, Euler-Bernoulli element):
    w^2 = EI k^4 / (rho A + rho I k^2); Timoshenko beam: the lower root of
    (rho A w^2 - kGA k^2)(rho I w^2 - EI k^2 - kGA) = (kGA k)^2, k = n pi / L.
    A stubby shaft (L/d = 10) makes shear matter (5 % on mode 3)."""
    L, d = 0.5, 0.05
    r = uniform(24, L, d, timoshenko)
    M, _, _, K = pinned_plane(r, numeric(r))
    w = undamped_frequencies(M, K)[:3]
    A, I = math.pi * d**2 / 4, math.pi * d**4 / 64
    exact = []
    for n in (1, 2, 3):
        k = n * math.pi / L
        if timoshenko:
            a, kga = RHO**2 * A * I, KAPPA * G * A
            b = -(RHO * A * (E * I * k**2 + kga) + RHO * I * kga * k**2)
            c = kga * E * I * k**4
            exact.append(math.sqrt((-b - math.sqrt(b * b - 4 * a * c)) / (2 * a)))
        else:
            exact.append(math.sqrt(E * I * k**4 / (RHO * A + RHO * I * k**2)))
    np.testing.assert_allclose(w, exact, rtol=1e-3 if timoshenko else 2e-4)
    if timoshenko:  # the option changes the answer where it should
        M0, _, _, K0 = pinned_plane(uniform(24, L, d), numeric(uniform(24, L, d)))
        assert undamped_frequencies(M0, K0)[2] / w[2] > 1.03


@pytest.mark.parametrize("rpm", [500.0, 3000.0, 20000.0])
def test_disk_on_massless_cantilever_whirls_as_the_analytic_rotor(rpm):
    """Overhung rigid disk on a massless clamped shaft: forward (+) and
    backward (-) whirl w solve (k11 - m w^2)(k22 - Id w^2 +- Ip Omega w) = k12^2
    with the tip stiffness of the cantilever."""
    L, d, m, Id, Ip = 0.3, 0.03, 5.0, 0.05, 0.1
    r = Rotor(E, RHO * 1e-10)
    for _ in range(4):
        r.element(L / 4, d)
    r.disk(4, m, Id, Ip)
    M, C, Gy, K = numeric(r)
    keep = [i for i, s in enumerate(r.dof_names()) if not s.startswith("n0.")]
    M, Gy, K = (a[np.ix_(keep, keep)] for a in (M, Gy, K))
    names = [r.dof_names()[i] for i in keep]
    xi = [i for i, s in enumerate(names) if s.endswith((".x", ".ax"))]
    yi = [i for i, s in enumerate(names) if s.endswith((".y", ".ay"))]
    Om = rpm * RPM
    modes = [md for md in whirl_modes(M, Om * Gy, K, xi, yi) if md.freq < 1e4]
    I = math.pi * d**4 / 64
    k11, k12, k22 = 12 * E * I / L**3, -6 * E * I / L**2, 4 * E * I / L
    for forward, sign in ((True, 1), (False, -1)):
        p = np.polymul([-m, 0, k11], [-Id, sign * Ip * Om, k22])
        p[-1] -= k12**2
        exact = sorted(x.real for x in np.roots(p) if abs(x.imag) < 1e-6 and x.real > 0)
        got = sorted(md.freq for md in modes if md.forward == forward)
        np.testing.assert_allclose(got, exact, rtol=1e-6)


def test_banded_ldl_solve_equals_a_dense_solve():
    rng = np.random.default_rng(1)
    n, bw = 12, 3
    B = rng.normal(size=(n, n))
    A = B @ B.T + n * np.eye(n)
    A[np.abs(np.subtract.outer(range(n), range(n))) > bw] = 0
    A += 10 * n * np.eye(n)  # still SPD after cutting the band
    b = rng.normal(size=n)
    x = np.array(ca.evalf(band_ldl_solve(ca.sparsify(ca.SX(A)), ca.SX(b)))).ravel()
    np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-12)


@pytest.mark.parametrize("eps", [-0.5, 0.0, 0.4, 0.9])
def test_film_integrals_match_adaptive_quadrature(eps):
    for fun, ours in ((lambda t: math.cos(t) ** 2 * math.sin(t) / (1 - eps * math.cos(t))
                       ** 2.28, film_integral_K),
                      (lambda t: math.sin(t) * math.cos(t) / (1 - eps * math.cos(t)) ** 1.28,
                       film_integral_C)):
        exact = si.quad(fun, 0, math.pi / 2, epsabs=1e-14, epsrel=1e-13)[0]
        assert ours(eps) == pytest.approx(exact, rel=1e-8)


def test_printed_film_damping_differs_by_the_missing_length():
    """(5) as printed lacks a length (unit Pa s): with equal radii r the
    printed and corrected forms differ exactly by the factor r."""
    radii = [0.01] * 4
    printed = film_damping(0.02, radii, 0.02, 5e-4, 0.0, form="printed")
    corrected = film_damping(0.02, radii, 0.02, 5e-4, 0.0, form="corrected")
    assert corrected / printed == pytest.approx(0.01, rel=1e-12)
    with pytest.raises(ValueError):
        spring_radii(0.01, 1e-3, 1)


@pytest.fixture(scope="module")
def spindle():
    return Spindle({})


def test_housing_dofs_equal_the_equivalent_support_of_fig4(spindle):
    """Condensing the housing's DOF out of the FE model at frequency w gives
    the equivalent 8-coefficient support Z = Z1 (Z1 + Z2)^-1 Z2."""
    w = 9000 * RPM
    v = spindle.values(k_f_xy=2e4, c_f_xy=3.0)
    M, C, G, K = spindle.matrices(w, v)
    Z = K + 1j * w * C - w**2 * M
    h = [spindle.sp.idx("h0.x"), spindle.sp.idx("h0.y")]
    s = [spindle.sp.idx("n0.x"), spindle.sp.idx("n0.y")]
    Z1 = np.array([[v["k_f"], v["k_f_xy"]], [-v["k_f_xy"], v["k_f"]]]) \
        + 1j * w * np.array([[v["c_f"], v["c_f_xy"]], [-v["c_f_xy"], v["c_f"]]])
    # what the housing DOF add at the footstep when condensed out at frequency w
    support = Z1 - Z[np.ix_(s, h)] @ np.linalg.solve(Z[np.ix_(h, h)], Z[np.ix_(h, s)])
    np.testing.assert_allclose(Z[np.ix_(s, h)], -Z1, rtol=1e-12)
    Zh2 = Z[np.ix_(h, h)] - Z1 + w**2 * v["m_p"] * np.eye(2)  # K2 + i w C2
    Keq, Ceq = equivalent_support(Z1.real, Z1.imag / w, Zh2.real, Zh2.imag / w,
                                  v["m_p"], w)
    np.testing.assert_allclose(support, Keq + 1j * w * Ceq, rtol=1e-9)
    assert abs(Keq[0, 1]) > 0  # the cross terms took part


def test_unbalance_response_15_equals_the_complex_solution(spindle):
    w = 16000 * RPM
    M, C, G, K = spindle.matrices(w)
    n = M.shape[0]
    rng = np.random.default_rng(2)
    P1, P2 = rng.normal(size=n), rng.normal(size=n)
    A1, A2 = unbalance_response(M, C + w * G, K, w, P1, P2)
    # F = P1 sin + P2 cos = Re((P2 - i P1) e^{iwt}); q = Re(Q e^{iwt}), Q = A2 - i A1
    Q = np.linalg.solve(K + 1j * w * (C + w * G) - w**2 * M, P2 - 1j * P1)
    np.testing.assert_allclose(A2 - 1j * A1, Q, rtol=1e-8, atol=1e-12 * np.abs(Q).max())


def test_dynamic_compliance_21_equals_the_direct_inverse(spindle):
    w = 16000 * RPM
    M, C, G, K = spindle.matrices(w)
    Ct = C + w * G
    a = np.zeros(M.shape[0])
    a[spindle.sp.idx(f"n{spindle.sp.nodes['top']}.x")] = 1.0
    for freq in (500 * RPM, 16000 * RPM, 30000 * RPM):
        got = dynamic_compliance(M, Ct, K, freq, a)
        assert got == pytest.approx(direct_compliance(M, Ct, K, freq, a), rel=1e-6)


def test_default_mesh_is_converged_for_the_calibrated_frequencies(spindle):
    fine = Spindle({"n_low": 4, "n_cone": 8})
    for fill in (0.0, 1.0):
        coarse = spindle.forward_freqs_rpm(spindle.values(fill=fill))
        ref = fine.forward_freqs_rpm(fine.values(fill=fill))
        np.testing.assert_allclose(coarse, ref, rtol=0.02)


def test_forward_whirl_stiffens_and_backward_softens_with_speed(spindle):
    lo = spindle.forward_freqs_rpm(speed_rpm=1000.0)
    hi = spindle.forward_freqs_rpm(speed_rpm=30000.0)
    assert np.all(hi >= lo * (1 - 1e-9))


def test_model_defaults_reproduce_the_seeds_six_frequencies(spindle):
    """The calibrated defaults give the seed's natural frequencies at 16 000 rpm
    (section V(一)1) within 5 % (docs/results/spindle_calibration.md: within 3 %)."""
    from loomfmu.spindle.study import SEED_FREQS
    for fill, case in ((0.0, "empty"), (1.0, "full")):
        got = spindle.forward_freqs_rpm(spindle.values(fill=fill))
        np.testing.assert_allclose(got, SEED_FREQS[case], rtol=0.05)


def test_critical_speeds_are_where_the_forward_whirl_meets_the_spin_speed(spindle):
    sp = spindle
    """Each critical speed is a spin speed at which one of the lowest forward
    whirl frequencies equals it (to the refinement's 1e-3 rpm, here checked
    to 0.01 rpm); the full bobbin's are lower than the empty one's."""
    crit = sp.critical_speeds({"fill": 1.0})
    assert len(crit) >= 2 and crit == sorted(crit)
    for c in crit:
        f = sp.forward_freqs_rpm({"fill": 1.0}, speed_rpm=c, n=3)
        assert np.min(np.abs(f - c)) < 0.01, (c, f)
    assert min(crit) < min(sp.critical_speeds({"fill": 0.0}))
    with pytest.raises(ValueError, match="max_rpm"):
        sp.critical_speeds(max_rpm=-1.0)


def test_rotor_critical_flags_a_critical_speed_near_the_working_speed(capsys):
    """loomfmu rotor critical: with the blade's diameter factor k_d = 0.8 the
    full bobbin has a critical speed near 16 000 rpm: a warning on stderr."""
    from loomfmu.spindle.__main__ import main
    assert main(["critical"]) == 0
    out, err = capsys.readouterr()
    assert "full bobbin" in out and "warning" not in err
    assert main(["critical", "--set", "k_d=0.8"]) == 0
    out, err = capsys.readouterr()
    assert "within 10 % of the working speed 16000 rpm" in err, (out, err)
    with pytest.raises(SystemExit) as exc:
        main(["critical", "--set", "fill=1"])
    assert exc.value.code == 2 and "both bobbins" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["charts", "--set", "k_d=1"])
    assert exc.value.code == 2
