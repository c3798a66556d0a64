"""The friction state machine against a stick-slip problem with a closed-form
solution: a mass on a spring, dragged by a belt (static > kinetic friction).

m x'' = -k x + F,  v_r = x' - v0 (relative speed of the joint),
stuck while |k x| <= mu_s m g; slipping: F = mu_k m g (backward slip).
Starting stuck at x = x_k - D the limit cycle is immediate:
breakaway after 2 D / v0, restick (2 pi - 2 psi) / omega later, and so on.
"""
from __future__ import annotations

import math
import re

import casadi as ca
import numpy as np
import pytest

from loomfmu import Model, build_fmu
from loomfmu.mechanics.friction import BACKWARD, FORWARD, STUCK, coulomb_joint
from loomfmu.verification.reference import reference

pytestmark = pytest.mark.slow  # builds FMUs

M, K, G, MU_S, MU_K, V0 = 1.0, 100.0, 9.81, 0.4, 0.3, 0.1
OMEGA = math.sqrt(K / M)
X_K = MU_K * M * G / K
DELTA = (MU_S - MU_K) * M * G / K
PSI = math.atan(OMEGA * DELTA / V0)
T_STICK = 2 * DELTA / V0
T_SLIP = (2 * math.pi - 2 * PSI) / OMEGA


def exact_switches(t_end):
    """(time, new mode) of the closed-form limit cycle."""
    out, t = [], 0.0
    while True:
        t += T_STICK
        if t > t_end:
            return out
        out.append((t, BACKWARD))
        t += T_SLIP
        if t > t_end:
            return out
        out.append((t, STUCK))


def belt_model(regularized_eps=None):
    m = Model("belt", description="mass on a spring dragged by a belt (friction test)",
              stop_time=2.0, step_size=0.01)
    k = m.parameter("k", K, unit="N/m", description="spring", source="assumption: test")
    mass = m.parameter("m", M, unit="kg", description="mass", source="assumption: test")
    x = m.state("x", X_K - DELTA, unit="m", description="position")
    vr = m.state("v_r", 0.0, unit="m/s", description="speed relative to the belt")
    F = m.algebraic("F", unit="N", description="friction force on the mass")
    m.eq(m.der(x), vr + V0)
    m.eq(mass * m.der(vr), -k * x + F)
    coulomb_joint(m, "belt", speed=vr, torque=F, normal=mass * G, r_kinetic=MU_K,
                  r_static=MU_S, regularized_eps=regularized_eps)
    m.output("x_out", x, unit="m", description="position")
    m.output("F_out", F, unit="N", description="friction force")
    return m


@pytest.fixture(scope="module")
def belt_fmu(tmp_path_factory):
    return build_fmu(belt_model(), out_dir=tmp_path_factory.mktemp("belt"))


def _switch_log(path, solver, comm_step, t_end=2.0):
    from conftest import Slave
    s = Slave(path)
    s.fmu.setDebugLogging(True, ["logEvents"])
    s.start(solver=solver, solver_rtol=1e-10, solver_atol=1e-12, solver_h_fixed=1e-4)
    t, xs = 0.0, []
    while t < t_end - 1e-12:
        s.fmu.doStep(t, comm_step)
        t += comm_step
        xs.append((t, *s.get("x_out")))
    s.fmu.terminate()
    s.fmu.freeInstance()
    sw = [(float(a), int(float(c))) for a, b, c in
          (re.match(r"t = (\S+): mode \S+: (\S+) -> (\S+)", m).groups()
           for _, cat, m in s.log if "mode" in m)]
    return sw, np.array(xs)


def test_belt_fmu_validates(belt_fmu):
    assert belt_fmu.problems == []


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
@pytest.mark.parametrize("comm_step", [0.1, 0.013])
def test_switch_times_match_the_closed_form(belt_fmu, solver, comm_step):
    exact = exact_switches(2.0)
    sw, xs = _switch_log(belt_fmu.path, solver, comm_step)
    assert [q for _, q in sw] == [q for _, q in exact]
    err = max(abs(a - b) for (a, _), (b, _) in zip(sw, exact))
    assert err < 1e-6, (sw, exact)
    # the stuck phases ride the belt exactly
    x_max = X_K + math.sqrt(DELTA**2 + (V0 / OMEGA) ** 2)
    assert xs[:, 1].max() <= x_max + 1e-7


def test_reference_switch_times_match_the_closed_form():
    ref = reference(belt_model(), t_end=2.0, rtol=1e-11, atol=1e-13)
    exact = exact_switches(2.0)
    assert [q for _, _, _, q in ref.switches] == [q for _, q in exact]
    assert max(abs(s[0] - e[0]) for s, e in zip(ref.switches, exact)) < 1e-7


# -- a block on a fixed floor under a harmonic force (mu_s = mu_k = mu) ------
# m x'' = F0 sin(w t) + F; sticks while |F0 sin w t| <= mu m g.  With
# eta = mu m g / F0 and tau = w t: breakaway at tau1 = asin(eta), stop at the
# first root tau2 > tau1 of cos(tau1) - cos(tau2) = eta (tau2 - tau1) (it
# sticks there when |sin tau2| <= eta), breakaway backwards at pi + tau1, stop
# at tau2 + pi; period 2 pi.
F0, W, ETA = 10.0, 2 * math.pi, 0.6
MU = ETA * F0 / (M * G)


def harmonic_model(regularized_eps=None):
    m = Model("harmonic", description="block under a harmonic force (friction test)",
              stop_time=2.0, step_size=0.01)
    x = m.state("x", 0.0, unit="m", description="position")
    v = m.state("v", 0.0, unit="m/s", description="speed")
    F = m.algebraic("F", unit="N", description="friction force")
    m.eq(m.der(x), v)
    m.eq(M * m.der(v), F0 * ca.sin(W * m.t) + F)
    coulomb_joint(m, "floor", speed=v, torque=F, normal=M * G, r_kinetic=MU, r_static=MU,
                  regularized_eps=regularized_eps)
    m.output("x_out", x, unit="m", description="position")
    return m


def harmonic_exact(t_end):
    from scipy.optimize import brentq
    tau1 = math.asin(ETA)
    tau2 = brentq(lambda s: math.cos(tau1) - math.cos(s) - ETA * (s - tau1), tau1 + 1e-3,
                  2 * math.pi)
    assert abs(math.sin(tau2)) <= ETA  # it sticks (the seed-spec case)
    out = []
    for k in range(4):
        base = k * math.pi
        out += [((base + tau1) / W, FORWARD if k % 2 == 0 else BACKWARD),
                ((base + tau2) / W, STUCK)]
    return [(t, q) for t, q in out if t <= t_end]


def test_harmonic_switch_times_fmu_and_reference(tmp_path):
    exact = harmonic_exact(2.0)
    ref = reference(harmonic_model(), t_end=2.0, rtol=1e-11, atol=1e-13)
    assert [q for *_, q in ref.switches] == [q for _, q in exact]
    assert max(abs(s[0] - e[0]) for s, e in zip(ref.switches, exact)) < 1e-7
    fmu = build_fmu(harmonic_model(), out_dir=tmp_path).path
    for solver in (1, 2):
        sw, _ = _switch_log(fmu, solver, 0.05)
        assert [q for _, q in sw] == [q for _, q in exact]
        assert max(abs(a - b) for (a, _), (b, _) in zip(sw, exact)) < 1e-6


def test_regularized_friction_approaches_the_event_driven_solution():
    exact = reference(harmonic_model(), t_end=1.0, rtol=1e-11, atol=1e-13)
    errs = []
    for eps in (1e-3, 1e-4):
        reg = reference(harmonic_model(eps), t_end=1.0, rtol=1e-9, atol=1e-12,
                        method="Radau")
        errs.append(np.abs(reg.y["x"] - exact.y["x"]).max())
    assert errs[1] < errs[0] / 3  # converges as eps -> 0
