"""The backrest model: derived equations against the seed's, the equilibrium
start, the algebraic loop, and the FMU against its scipy reference."""
from __future__ import annotations

import math
import re

import casadi as ca
import numpy as np
import pytest

from loomfmu import build_fmu, load_model
from loomfmu.export.dae import dae_form
from loomfmu.mechanics.friction import BACKWARD, FORWARD
from loomfmu.verification.reference import _Dae, reference

pytestmark = pytest.mark.slow  # builds FMUs

G = 9.81


@pytest.fixture(scope="module")
def model():
    return load_model("backrest")


def _symbols(model, names):
    return {n: model.var(n).sym for n in names}


def _params(model):
    return {v.name: v.start for v in model.of_kind("parameter")}


def _lagrange_rhs_and_seed(model):
    """The derived generalized forces (from the Lagrange residual with zero
    accelerations) next to the seed's (7) and (10), as functions."""
    dae = dae_form(model)
    s = _symbols(model, ["dphi1", "phi2", "omega1", "omega2", "M1f", "M2f"])
    p = {v.name: v.sym for v in model.of_kind("parameter")}
    # residual rows 2, 3 are Lagrange's: M qdd - Q(q, qdot) = 0 -> at qdd = 0: -Q
    F = dae.F[2:4]
    F0 = ca.substitute(F, dae.w[:4], ca.DM.zeros(4))
    Q_derived = -F0
    phi1 = p["phi_n"] + s["dphi1"]
    w = ca.vertcat(s["omega1"], s["omega2"])
    # the seed's (3)-(10), corrected as documented (r -> r2 in (5), (7))
    S1, S2 = model_tensions(model, dae)
    F_s = ((model_F0(p)) - p["k_s"] * s["dphi1"] * p["r2"] * ca.sin(p["theta"]))
    Q1 = ((S2 - S1) * p["r"] + S2 * p["r1"] * ca.sin(p["alpha2"] + phi1)
          - S1 * p["r1"] * ca.sin(p["alpha1"] + phi1) - p["m_c"] * G * p["r1"] * ca.cos(phi1)
          + F_s * p["r2"] * ca.sin(p["theta"]) + s["M1f"])
    Q2 = p["r"] * (S2 - S1) + s["M2f"]
    args = [dae.t, dae.x, dae.w, dae.u, dae.p, dae.q]
    return ca.Function("q", args, [Q_derived, ca.vertcat(Q1, Q2)]), dae, w


def model_F0(p):
    """Spring preload (8), corrected: m_c g r1 cos(phi_n)."""
    return ((p["m_c"] * G * p["r1"] * ca.cos(p["phi_n"]) + p["r1"] * p["S0"]
             * (ca.sin(p["phi_n"] + p["alpha1"]) - ca.sin(p["phi_n"] + p["alpha2"])))
            / (p["r2"] * ca.sin(p["theta"])))


def model_tensions(model, dae):
    ys = [v.name for v in model.of_kind("output")]
    return dae.y[ys.index("S1")], dae.y[ys.index("S2")]


def _random_points(model, dae, n=10, seed=3):
    rng = np.random.default_rng(seed)
    p = np.array([v.start for v in model.of_kind("parameter")])
    for _ in range(n):
        x = rng.normal(scale=[0.05, 1.0, 0.5, 2.0])
        w = np.concatenate([x[2:], rng.normal(size=2) * 10, rng.normal(size=2) * 5])
        yield rng.uniform(0, 1), x, w, rng.normal(size=2) * 1e-3, p


def test_derived_generalized_forces_equal_the_seed(model):
    f, dae, _ = _lagrange_rhs_and_seed(model)
    for t, x, w, u, p in _random_points(model, dae):
        derived, seed = (np.array(v).ravel() for v in f(t, x, w, u, p, [1, 1]))
        np.testing.assert_allclose(derived, seed, rtol=1e-10, atol=1e-9)


def test_reactions_equal_the_seed_11_12(model):
    dae = dae_form(model)
    names = [v.name for v in model.of_kind("output")]
    p = {v.name: v.sym for v in model.of_kind("parameter")}
    s = _symbols(model, ["dphi1", "omega1"])
    phi1, w1, a1 = p["phi_n"] + s["dphi1"], s["omega1"], dae.w[2]
    S1, S2 = model_tensions(model, dae)
    ny = names.index
    F_s = dae.y[ny("F_spring")]
    R2x = (S1 * ca.cos(p["alpha1"]) - S2 * ca.cos(p["alpha2"]) + p["m_c"] * a1 * p["r1"]
           * ca.sin(phi1) + p["m_c"] * w1**2 * p["r1"] * ca.cos(phi1))
    R2y = (S1 * ca.sin(p["alpha1"]) - S2 * ca.sin(p["alpha2"]) + p["m_c"] * G + p["m_c"] * a1
           * p["r1"] * ca.cos(phi1) - p["m_c"] * w1**2 * p["r1"] * ca.sin(phi1))
    psi = phi1 + p["gamma"] + p["theta"]
    R1x, R1y = R2x - F_s * ca.cos(psi), R2y + F_s * ca.sin(psi)
    f = ca.Function("r", [dae.t, dae.x, dae.w, dae.u, dae.p, dae.q],
                    [ca.vertcat(dae.y[ny("N1")], dae.y[ny("N2")]),
                     ca.vertcat(ca.sqrt(R1x**2 + R1y**2), ca.sqrt(R2x**2 + R2y**2))])
    for t, x, w, u, pv in _random_points(model, dae):
        a, b = (np.array(v).ravel() for v in f(t, x, w, u, pv, [0, 0]))
        np.testing.assert_allclose(a, b, rtol=1e-12)


def test_start_is_the_equilibrium_of_8(model):
    d = _Dae(dae_form(model), np.zeros(2), np.array([v.start for v in model.of_kind(
        "parameter")]), np.zeros(2))
    w = d.solve(0.0, np.array(model.starts("state")))
    # rates, accelerations and both friction torques vanish at t = 0
    assert np.abs(w).max() < 1e-9


def test_algebraic_loop_release_matches_closed_form(model):
    """Spec 6.3: warp and spring removed (S0 = c = 0, phi_n = 90 deg so that
    the preload (8) vanishes), lever released horizontal (phi1 = 0): both
    pins slip, the normal force depends on the acceleration it produces."""
    pv = _params(model)
    pv.update(S0=0.0, c1=0.0, c2=0.0, b1=0.0, b2=0.0, A_shed=0.0, k_s=0.0,
              phi_n=math.pi / 2)
    names = [v.name for v in model.of_kind("parameter")]
    d = _Dae(dae_form(model), np.zeros(2), np.array([pv[n] for n in names]),
             np.array([BACKWARD, FORWARD], dtype=float))
    w = d.solve(0.0, np.array([-math.pi / 2, 0.0, 0.0, 0.0]))
    r1f = pv["rho1"] * pv["mu1"] / math.sqrt(1 + pv["mu1"] ** 2)
    r2f = pv["rho2"] * pv["mu2"] / math.sqrt(1 + pv["mu2"] ** 2)
    m_c, r1 = pv["m_c"], pv["r1"]
    a1 = -m_c * G * (r1 - r1f - r2f) / (pv["J_1"] + m_c * r1**2 - (r1f + r2f) * m_c * r1)
    a2 = -a1 - r2f * m_c * (G + r1 * a1) / pv["J_c"]
    assert w[2] == pytest.approx(a1, rel=1e-10)
    assert w[3] == pytest.approx(a2, rel=1e-10)


@pytest.fixture(scope="module")
def backrest_fmu(tmp_path_factory):
    return build_fmu(load_model("backrest"), out_dir=tmp_path_factory.mktemp("backrest"))


@pytest.fixture(scope="module")
def ref(model):
    return reference(model, t_end=1.0, rtol=1e-11, atol=1e-13)


def test_backrest_fmu_validates(backrest_fmu):
    assert backrest_fmu.problems == []


def _run(path, solver, comm):
    from conftest import Slave
    s = Slave(path)
    s.fmu.setDebugLogging(True, ["logEvents"])
    s.start(solver=solver, solver_rtol=1e-10, solver_atol=1e-12, solver_h_fixed=1e-5)
    n = int(round(1.0 / comm))
    ys = []
    for i in range(n):
        s.fmu.doStep(i * comm, comm)
        ys.append(s.get("phi1_out", "omega1_out", "omega2_out", "S2", "M1f_out"))
    sw = [(float(a), b, int(float(c))) for a, b, c in
          (re.match(r"t = (\S+): mode (\S+): \S+ -> (\S+)", msg).groups()
           for _, _, msg in s.log if ": mode " in msg)]
    s.fmu.terminate()
    s.fmu.freeInstance()
    return sw, np.array(ys)


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
@pytest.mark.parametrize("comm", [0.1, 0.01])
def test_fmu_matches_reference_switches_and_trajectories(backrest_fmu, ref, solver, comm):
    assert len(ref.switches) > 10  # the scene is genuinely stick-slip
    sw, ys = _run(backrest_fmu.path, solver, comm)
    assert [(n, q) for _, n, q in sw] == [(n, q) for _, n, _, q in ref.switches]
    assert max(abs(a[0] - b[0]) for a, b in zip(sw, ref.switches)) < 1e-6
    idx = np.searchsorted(ref.t, np.arange(1, len(ys) + 1) * comm - 1e-12)
    for j, name in enumerate(["phi1_out", "omega1_out", "omega2_out", "S2", "M1f_out"]):
        r = ref.y[name][idx]
        assert np.abs(ys[:, j] - r).max() < 1e-6 * (np.ptp(ref.y[name]) + 1e-3), name


def test_bad_options_are_rejected():
    with pytest.raises(ValueError, match="friction"):
        load_model("backrest", friction="viscous")
    with pytest.raises(ValueError, match="eps"):
        load_model("backrest", friction="regularized", eps=0.0)


def _run_inputs(path, solver, comm, t_end, schedule):
    """Step the backrest FMU with warp_pull set from ``schedule`` (time ->
    value) at the communication points; outputs after every step."""
    from conftest import Slave
    s = Slave(path)
    s.fmu.setDebugLogging(True, ["logEvents"])
    s.start(solver=solver, solver_rtol=1e-10, solver_atol=1e-12, solver_h_fixed=1e-5,
            A_shed=0.0)
    names = ["phi1_out", "omega1_out", "omega2_out", "M1f_out", "M2f_out", "N1", "N2"]
    ys, qs = [], []
    for i in range(int(round(t_end / comm))):
        t = i * comm
        for ts, value in schedule:
            if abs(ts - t) < 1e-9:
                s.set(warp_pull=value)
        s.fmu.doStep(t, comm)
        ys.append(s.get(*names))
        qs.append(s.fmu.getInteger([s.vr["mode_O1"], s.vr["mode_O2"]]))
    log = [msg for _, _, msg in s.log if ": mode " in msg]
    s.fmu.terminate()
    s.fmu.freeInstance()
    return dict(zip(names, np.array(ys).T)), np.array(qs), log


@pytest.mark.parametrize("kind", ["step", "ramp"])
@pytest.mark.parametrize("solver", [1, 2])
def test_input_change_makes_stuck_joints_break_away(model, backrest_fmu, solver, kind):
    """A master pulls the warp through the input warp_pull (built-in shedding
    off).  At the communication point where the input changes, a stuck
    joint loaded beyond its static limit must break away (the mode is chosen
    again there).  Checked against the stick/slip conditions at every
    communication point (stuck: |M_f| <= r_static N) and against the
    reference, which changes its inputs at the same times."""
    from loomfmu.models.backrest import friction_radius
    comm, t_end = 0.01, 0.6
    if kind == "step":
        schedule = [(0.1, 0.01)]
    else:
        schedule = [(0.1 + 0.01 * i, 0.001 * (i + 1)) for i in range(20)]
    ys, qs, log = _run_inputs(backrest_fmu.path, solver, comm, t_end, schedule)
    assert log, "no joint broke away"
    p = _params(model)
    limits = [p["k_static"] * float(friction_radius(p["rho1"], p["mu1"])),
              p["k_static"] * float(friction_radius(p["rho2"], p["mu2"]))]
    for j, (M, N) in enumerate((("M1f_out", "N1"), ("M2f_out", "N2"))):
        stuck = qs[:, j] == 0
        assert np.all(np.abs(ys[M][stuck]) <= limits[j] * ys[N][stuck] * (1 + 1e-9)), M
    ref = reference(model, t_end=t_end, t_eval=np.linspace(0, t_end, 61), rtol=1e-11,
                    atol=1e-13, values={"A_shed": 0.0},
                    input_steps=[(ts, {"warp_pull": v}) for ts, v in schedule])
    assert len(ref.switches) == len(log)
    for name in ("phi1_out", "omega1_out", "omega2_out"):
        span = np.ptp(ref.y[name]) + 1e-3
        assert np.abs(ys[name] - ref.y[name][1:]).max() < 1e-6 * span, name
