"""The drive's named quantities evaluate to what its equations and
its cam table use: the cam series r(phi) is the FMU's r output, the delay
equation is the FMU's n' = (K u(t - tau) - n)/T, the speed law's series (8)
is the law within its truncation, the compensation G_k inverts W W_g, and
the cam radius in time is the cam table at the cam angle."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from loomfmu import build_fmu, load_model
from loomfmu.declare.units import UNITS
from loomfmu.drive import DriveParams
from loomfmu.mechanics.drive_law import fourier, law_constants, speed_law
from loomfmu.mechanics.layer_cam import forward_gain, time_of_angle
from loomfmu.models.drive_derivation import DEFECTS
from loomfmu.verification.verify import simulate


@pytest.fixture(scope="module")
def model():
    return load_model("drive")


@pytest.fixture(scope="module")
def run(model, tmp_path_factory):
    fmu = build_fmu(model, out_dir=tmp_path_factory.mktemp("drive_q"))
    return simulate(fmu.path, solver="dopri5", rtol=1e-9, atol=1e-9, stop_time=6.0,
                    output_interval=0.0025,
                    output=["n_out", "u", "u_delayed", "r", "phi_out"])


def quantity(m, name, *, states=None, delayed=None, p=None, u_ext=0.0) -> np.ndarray:
    """Quantity ``name`` at states (n, phi), the delayed value, parameters
    (default: their starts) and the input, vectorised over the states' columns."""
    q = next(q for q in m.quantities if q.name == name)
    x, d = m.syms("state"), ca.vertcat(*[dl.sym for dl in m.delays])
    f = ca.Function("q", [x, d, m.syms("input"), m.syms("parameter")], [q.expr])
    xs = np.zeros((x.numel(), 1)) if states is None else np.atleast_2d(states)
    ds = np.zeros((1, xs.shape[1])) if delayed is None else np.atleast_2d(delayed)
    p = m.starts("parameter") if p is None else p
    out = [np.array(f(xs[:, k], ds[:, k], [u_ext], p)) for k in range(xs.shape[1])]
    return out[0] if len(out) == 1 else np.hstack(out)


@pytest.mark.slow
def test_cam_series_is_the_fmus_r_output_at_sampled_times(model, run):
    names = [v.name for v in model.of_kind("state")]
    assert names == ["n", "phi"]
    states = np.vstack([run.y["n_out"], run.y["phi_out"]])
    r = quantity(model, "r_cam", states=states).ravel()
    assert np.ptp(run.y["r"]) > 0.01  # the cam turns through its profile
    assert np.max(np.abs(r - run.y["r"])) < 1e-12
    u = quantity(model, "u_in", states=states).ravel()
    assert np.max(np.abs(u - run.y["u"])) < 1e-10
    up = quantity(model, "U_p", states=states).ravel()
    uz = quantity(model, "U_z").item()
    assert np.max(np.abs(uz + up - run.y["u"])) < 1e-10


@pytest.mark.slow
def test_delay_equation_is_the_fmus_speed_derivative(model, run):
    """T n' = K u(t - tau) - n: the quantity at the FMU's (n, u(t - tau)) is T
    times the FMU's dn/dt (central differences on 2.5 ms, away from t = tau and
    2 tau, where the history's start makes the higher derivatives of n jump)."""
    states = np.vstack([run.y["n_out"], run.y["phi_out"]])
    lhs = quantity(model, "T_ndot", states=states, delayed=run.y["u_delayed"]).ravel()
    T, tau = model.var("T").start, model.var("tau").start
    dndt = np.gradient(run.y["n_out"], run.t)
    smooth = (np.min(np.abs(run.t[:, None] - tau * np.arange(3)), axis=1) > 0.025) \
        & (run.t < run.t[-1] - 0.025)
    scale = np.max(np.abs(lhs))
    assert scale > 1.0  # rad/s (10 rpm): the drive is not at rest
    err = np.max(np.abs(T * dndt[smooth] - lhs[smooth]))
    assert err < 1e-3 * scale
    # and not merely close to anything: the lag with the wrong sign of n misses
    assert np.max(np.abs(T * dndt - (lhs + 2 * run.y["n_out"]))) > 1e3 * err
    assert quantity(model, "breakpoint_lag").item() == tau
    # the delayed signal is the signal tau ago (history before t = 0: u(0))
    late = run.t >= tau + 1e-9
    past = np.interp(run.t[late] - tau, run.t, run.y["u"])
    assert np.max(np.abs(run.y["u_delayed"][late] - past)) < 1e-4 * np.ptp(run.y["u"])
    start = quantity(model, "n_start", states=states[:, :1]).item()
    assert start == pytest.approx(run.y["n_out"][0], rel=1e-12)


def test_speed_law_series_is_8_within_its_truncation(model):
    p = DriveParams()
    c = law_constants(p)
    t = np.linspace(0, c.P, 2001)
    a, b = (quantity(model, k).ravel() for k in ("a_k", "b_k"))
    mean = quantity(model, "n0_mean").item()
    w = quantity(model, "omega_P").item()
    assert quantity(model, "P").item() == pytest.approx(p.T_n + p.T_c)
    k = np.arange(1, len(a) + 1)
    series = mean + np.cos(np.outer(t, k) * w) @ a + np.sin(np.outer(t, k) * w) @ b
    err = np.max(np.abs(series - 2 * np.pi * speed_law(t, p))) * 60 / (2 * np.pi)  # rpm
    assert 1.0 < err < 30.0  # docs/guides/drive.md: 23 rpm at m = 40 (the corners of n0)
    C, psi = quantity(model, "C_k").ravel(), quantity(model, "psi_k").ravel()
    polar = mean + np.sin(np.outer(t, k) * w + psi) @ C
    assert np.max(np.abs(polar - series)) < 1e-9 * mean
    printed = mean + np.sin(np.outer(t, k) * w + quantity(model, "psi_k_printed").ravel()) @ C
    assert np.max(np.abs(printed - series)) > 10.0  # rad/s; defect D8: the printed phase


def test_compensation_inverts_the_drive_and_the_cam_table_is_r_of_t(model):
    p = DriveParams()
    m = len(quantity(model, "a_k"))
    G = quantity(model, "alpha_k").ravel() + 1j * quantity(model, "beta_k").ravel()
    # G_k in m per rad/s times (W W_g)(i k w) in rev/s per m (x 2 pi: rad/s per m) is 1
    assert np.max(np.abs(G * forward_gain(p, m) * 2 * np.pi - 1)) < 1e-12
    # r(t) of the time-domain cam equals the table r(phi) at the cam angle phi(t)
    w = law_constants(p).omega
    R0, ar, br = (quantity(model, k).ravel() for k in ("R_0", "ar_k", "br_k"))
    phi = np.linspace(0, 2 * np.pi, 257)
    t = time_of_angle(phi, p, coeffs=fourier(p, m))
    k = np.arange(1, m + 1)
    r_t = R0[0] + np.cos(np.outer(t, k) * w) @ ar + np.sin(np.outer(t, k) * w) @ br
    r_phi = quantity(model, "r_cam", states=np.vstack([np.zeros_like(phi), phi])).ravel()
    assert np.max(np.abs(r_t - r_phi)) < 1e-6  # docs/guides/drive.md: table error 7.6e-8 m
    A, B = quantity(model, "A_j").ravel(), quantity(model, "B_j").ravel()
    j = np.arange(1, len(B) + 1)
    table = A[0] + np.cos(np.outer(phi, j)) @ A[1:] + np.sin(np.outer(phi, j)) @ B
    assert np.max(np.abs(table - r_phi)) < 1e-14


@pytest.mark.parametrize("cam", ["compensated", "uncompensated", "none"])
def test_every_quantity_is_documented_in_derivation_order(cam):
    m = load_model("drive", cam=cam, harmonics=8, m=4)
    groups = []
    for q in m.quantities:
        assert q.unit in UNITS or q.unit == "", q.name
        assert q.description and q.symbol and q.source and q.group, q.name
        if not groups or groups[-1] != q.group:
            assert q.group not in groups, f"group {q.group!r} interleaved at {q.name}"
            groups.append(q.group)
    assert groups[-2:] == ["drive with pure delay (9)", "delay history and breakpoints"]
    assert ("alpha_k" in [q.name for q in m.quantities]) == (cam == "compensated")
    text = " ".join(q.description for q in m.quantities)
    notes = {k for k in DEFECTS if f"print defect {k}: printed {DEFECTS[k][0]}" in text}
    expect = set(DEFECTS) if cam == "compensated" else \
        {"D9", "D10", "D11"} | ({"D3", "D4", "D5", "D6", "D8", "D12"} if cam == "uncompensated"
                                else set())
    assert notes == expect
