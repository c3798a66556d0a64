"""The drive FMU: first-order lag with pure delay whose history lives in the
FMU.  Against the exact step response, the pure lag for tau = 0, the
method-of-steps scipy reference (state delay: the cam turns with the
spindles), and the interpolation of the history."""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from loomfmu import build_fmu
from loomfmu.models.drive import build
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import compare, simulate

pytestmark = pytest.mark.slow  # builds FMUs

#: rad/s per rpm: the FMU's speeds are rad/s, the seed's values rpm
RPM = 2 * math.pi / 60
K, T, N_MIN = 1800.0 * RPM, 2.0, 12000.0 * RPM   # rad/(s V), s, rad/s
#: a small cam, fast enough that the delayed signal varies within solver steps
CAM = {"cam_on": 1.0, "cam_A0": 0.06, "cam_A1": 0.01, "cam_B2": 0.004, "cam_A3": 0.002,
       "f_rad": 0.02}


@pytest.fixture(scope="module")
def model():
    return build(cam="none", harmonics=3, max_delay=2.0)


@pytest.fixture(scope="module")
def drive_fmu(model, tmp_path_factory):
    return build_fmu(model, out_dir=tmp_path_factory.mktemp("drive"))


def test_drive_fmu_validates(drive_fmu):
    assert drive_fmu.problems == []


def _step_response(path, slave_factory, solver, tau, U=0.5, t_end=5.0, comm=0.01):
    s = slave_factory(path)
    s.start(solver=solver, tau=tau, solver_rtol=1e-10, solver_atol=1e-8)
    s.set(u_ext=U)  # the input steps at t = 0: the history holds 0 before
    t, err = 0.0, 0.0
    for _ in range(int(round(t_end / comm))):
        s.fmu.doStep(t, comm)
        t += comm
        exact = N_MIN + (K * U * (1 - math.exp(-(t - tau) / T)) if t >= tau else 0.0)
        err = max(err, abs(s.get("n_out")[0] - exact))
    return err


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
@pytest.mark.parametrize("tau", [0.5, 0.37, 0.0])
def test_step_response_is_exact(drive_fmu, slave_factory, solver, tau):
    """T n' + n = K u(t - tau): n = n_min + K U (1 - exp(-(t - tau)/T)) after tau;
    tau = 0 is the pure lag.  (tau = 0.37 does not fall on a communication
    point: the jump must be found inside the step.)"""
    assert _step_response(drive_fmu.path, slave_factory, solver, tau) < 1e-6 * RPM


def test_negative_delay_and_time_constant_are_rejected(drive_fmu, slave_factory):
    s = slave_factory(drive_fmu.path)
    s.fmu.setupExperiment(startTime=0.0)
    for name in ("tau", "T"):
        with pytest.raises(FMICallException):
            s.set(**{name: -0.1})
        assert any(f"{name} = -0.1" in m for _, _, m in s.log)


def test_delay_beyond_the_history_is_rejected_at_initialization(model, tmp_path):
    """The FMU's history holds max_delay = 2 s: tau = 3 s is refused at
    initialization with the limit in the message (a larger build needs a
    larger max_delay)."""
    from conftest import Slave
    small = build_fmu(build(cam="none", harmonics=3, max_delay=2.0), out_dir=tmp_path).path
    s = Slave(small)
    s.fmu.setupExperiment(startTime=0.0)
    with pytest.raises(FMICallException):
        s.set(tau=3.0)
    assert any("[0, 2]" in m for _, _, m in s.log)
    s.fmu.freeInstance()
    with pytest.raises(ValueError, match="max_delay"):
        build(cam="none", max_delay=-1.0)


@pytest.fixture(scope="module")
def ref(model, drive_fmu):
    grid = simulate(drive_fmu.path, output=["n_out"], values=CAM, stop_time=10.0).t
    return reference(model, t_end=grid[-1], t_eval=grid, rtol=1e-11, atol=1e-9, values=CAM)


@pytest.mark.parametrize("solver", ["dopri5", "rk4"])
def test_state_delay_matches_method_of_steps_reference(drive_fmu, ref, solver):
    run = simulate(drive_fmu.path, solver=solver, rtol=1e-8, atol=1e-8, stop_time=10.0,
                   output=["n_out", "phi_out", "u_delayed"],
                   values={**CAM, "solver_h_fixed": 2e-3})
    errs = compare(run, ref, ["n_out", "phi_out", "u_delayed"])
    assert errs["n_out"]["max_abs"] < 1e-3 * RPM  # 1e-3 rpm, on a 2300 rpm swing
    assert errs["phi_out"]["max_abs"] < 1e-6


def test_linear_history_is_not_accurate_enough(drive_fmu, ref):
    """The cam signal varies within the solver's steps: the history sampled
    on the dense output converges with the tolerance; linear interpolation
    between accepted steps does not."""
    errs = {}
    for interp in (1, 2):
        for rtol in (1e-6, 1e-9):
            run = simulate(drive_fmu.path, solver="dopri5", rtol=rtol, atol=1e-8,
                           stop_time=10.0, output=["n_out"],
                           values={**CAM, "delay_interpolation": interp})
            errs[interp, rtol] = compare(run, ref, ["n_out"])["n_out"]["max_abs"]
    assert errs[1, 1e-9] < errs[1, 1e-6] / 5 and errs[1, 1e-9] < 1e-3 * RPM
    assert errs[2, 1e-9] > 0.01 * RPM and errs[2, 1e-9] > 100 * errs[1, 1e-9]


def test_compensated_cam_removes_lag_and_delay_up_to_truncation(tmp_path):
    """The point of seed 001: through the FMU, the compensated cam (m = 12)
    reproduces its m-term series of n0 after the transient; the uncompensated
    cam misses n0 by hundreds of rpm."""
    import dataclasses

    from loomfmu import load_model
    from loomfmu.drive import DriveParams, tracking_error
    from loomfmu.drive.tracking import cam_values
    from loomfmu.mechanics.drive_law import law_constants
    model = load_model("drive", harmonics=48, m=12)
    fmu = build_fmu(model, out_dir=tmp_path, validate=False).path
    p = dataclasses.replace(DriveParams(), tau=0.25, T=1.0)
    t_end = 30 * p.T + p.tau + law_constants(p).P
    errs = {}
    for comp in (True, False):
        run = simulate(fmu, solver="dopri5", rtol=1e-8, atol=1e-6, stop_time=t_end,
                       output_interval=0.01, output=["n_out", "phi_out"],
                       values=cam_values(p, 12, comp, 48))
        errs[comp] = tracking_error(run.t, run.y["n_out"] / (2 * math.pi), p, 12,
                                    phi=run.y["phi_out"])  # rev/s in, rpm out
    assert errs[True] < 1e-2  # rpm
    assert errs[False] > 300


def _late_step(path, slave_factory, solver, tau, t_s, comm, h_fixed=1e-3, U=1.0,
               t_end=4.0):
    """u_ext steps from 0 to U at t_s > 0 (a communication point), after
    the history has run at 0 for t_s seconds: max |n - exact| after t_s."""
    s = slave_factory(path)
    s.start(solver=solver, tau=tau, solver_rtol=1e-10, solver_atol=1e-8,
            solver_h_fixed=h_fixed)
    t, err, n_steps = 0.0, 0.0, int(round(t_end / comm))
    for i in range(n_steps):
        if abs(t - t_s) < 1e-12:
            s.set(u_ext=U)
        s.fmu.doStep(t, comm)
        t = (i + 1) * comm
        lag = t - t_s - tau
        exact = N_MIN + (K * U * (1 - math.exp(-lag / T)) if lag > 0 else 0.0)
        err = max(err, abs(s.get("n_out")[0] - exact))
    return err


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
@pytest.mark.parametrize("tau,t_s,comm", [(0.5, 1.0, 0.01), (0.37, 1.25, 0.05),
                                          (0.5, 0.5, 0.1)])
def test_input_step_after_the_start_reaches_the_lag_tau_later(drive_fmu, slave_factory,
                                                             solver, tau, t_s, comm):
    """A step of u_ext at t_s > 0: two history samples at t_s (before, after).
    The steps that end at the breakpoint t_s + tau must read the value before
    the jump in all their stages (a last stage reading the new value makes
    rk4 first order: error h/6 K U / T = 0.15 rpm at h = 1e-3), and the
    solver restarts there.  (0.5, 0.5, 0.1): the breakpoint 1.0 falls on a
    communication point.)"""
    err = _late_step(drive_fmu.path, slave_factory, solver, tau, t_s, comm)
    assert err < 1e-6 * RPM, err


def test_input_step_against_reference_with_input_steps(model, drive_fmu, slave_factory):
    """The reference's input_steps reproduce the same late step (its own
    left/right rule at the jump), and agree with the FMU and the closed form."""
    ref = reference(model, t_end=3.0, t_eval=np.linspace(0, 3.0, 31), rtol=1e-11,
                    atol=1e-9, values={"tau": 0.37}, input_steps=[(1.0, {"u_ext": 1.0})])
    lag = np.maximum(ref.t - 1.0 - 0.37, 0.0)
    exact = N_MIN + K * (1 - np.exp(-lag / T))
    assert np.max(np.abs(ref.y["n_out"] - exact)) < 1e-6 * RPM
    with pytest.raises(ValueError, match="input_steps"):
        reference(model, t_end=3.0, input_steps=[(5.0, {"u_ext": 1.0})])
    with pytest.raises(ValueError, match="input_steps"):
        reference(model, t_end=3.0, input_steps=[(1.0, {"tau": 1.0})])


def test_zero_delay_keeps_no_history_on_long_fast_runs(tmp_path):
    """tau = 0 reads the value now and stores nothing.  An 8 s run with a
    fast cam (8th harmonic near 190 Hz) at rtol 1e-6 runs through (refined
    history samples filled the 65536-sample ring in about 2 s when they
    were kept; docs/guides/drive.md says 30 s, measured by
    benchmarks/runtime_checks.py), and at
    rtol 1e-9 both adaptive solvers match the reference (tau = 0: the
    delayed value is g(t, x) now) over the first 5 s."""
    fast = build(cam="none", harmonics=8, max_delay=2.0)
    path = build_fmu(fast, out_dir=tmp_path, validate=False).path
    values = {"tau": 0.0, "f_rad": 0.5, "cam_on": 1.0, "cam_A0": 0.06, "cam_A1": 0.02,
              "cam_B3": 0.01, "cam_A8": 0.004}
    for solver in ("dopri5", "rodas4"):
        run = simulate(path, solver=solver, rtol=1e-6, atol=1e-9, stop_time=8.0,
                       output_interval=0.05, output=["n_out"], values=values)
        assert not any("full" in m for m in run.log), run.log[-3:]
        assert run.t[-1] == pytest.approx(8.0)
    ref = None
    for solver in ("dopri5", "rodas4"):
        run = simulate(path, solver=solver, rtol=1e-9, atol=1e-9, stop_time=5.0,
                       output_interval=0.05, output=["n_out"], values=values)
        if ref is None:
            ref = reference(fast, t_end=5.0, t_eval=run.t, rtol=1e-11, atol=1e-9,
                            values=values)
        assert np.max(np.abs(run.y["n_out"] - ref.y["n_out"])) < 2e-3 * RPM, solver


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
@pytest.mark.parametrize("tau", [0.37, 0.0])
def test_outputs_kept_by_the_history_sample_equal_a_separate_evaluation(
        drive_fmu, slave_factory, solver, tau):
    """The outputs after a step come from the history sample at the step's end
    (the combined function histout, lf_hist_outputs) where its point matches;
    a restored FMU state drops them, so the outputs read again are a separate
    evaluation of the output function: equal bit for bit, at every step,
    with the cam on and the input changing (restarts, breakpoints tau later)."""
    s = slave_factory(drive_fmu.path)
    s.start(solver=solver, tau=tau, **CAM)
    names = ["n_out", "u", "u_delayed", "r", "phi_out"]
    t, comm = 0.0, 0.01
    for i in range(150):
        if i % 40 == 0:
            s.set(u_ext=0.2 + 0.001 * i)
        s.fmu.doStep(t, comm)
        t += comm
        kept = s.get(*names)
        state = s.fmu.getFMUstate()
        s.fmu.setFMUstate(state)
        s.fmu.freeFMUstate(state)
        again = s.get(*names)
        assert np.array_equal(np.asarray(kept).view(np.int64),
                              np.asarray(again).view(np.int64)), (t, kept, again)


def test_a_cam_on_a_drive_it_was_not_made_for_loses_part_of_its_gain():
    """mismatch_rows: the assumed drive's compensated cam tracks within the
    truncation (about 22 rpm) on that drive, several times worse where T is
    20 % off, and still better than the uncompensated cam everywhere."""
    from loomfmu.drive.tracking import mismatch_rows
    with pytest.raises(ValueError, match="factors"):
        mismatch_rows(factors=(0.0,))
    rows = {(r["tau_s"], r["T_s"]): r for r in mismatch_rows(factors=(1.0, 1.2))}
    matched = rows[(0.5, 2.0)]["compensated_vs_law_rpm"]
    assert matched < 30
    assert rows[(0.5, 2.4)]["compensated_vs_law_rpm"] > 3 * matched
    for r in rows.values():
        assert r["compensated_vs_law_rpm"] < 0.5 * r["uncompensated_vs_law_rpm"], r
