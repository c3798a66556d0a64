"""The heald-frame FMU end to end: validation, binary, rebuild from sources,
agreement with the scipy reference per solver, events inside the step,
honest statuses and side-by-side instances."""
from __future__ import annotations

import math
import re
import shutil
import subprocess
import zipfile

import numpy as np
import pytest
from fmpy.build import build_platform_binary
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from loomfmu import load_model
from loomfmu.declare.solvers import SOLVERS
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import compare, simulate

pytestmark = pytest.mark.slow  # builds FMUs

OUTPUTS = ["h", "h_dot", "h_ddot", "x1_out", "x2_out", "y2_out", "T", "dl", "f_x", "f_y"]


@pytest.fixture(scope="module")
def model():
    return load_model("heald_frame")


@pytest.fixture(scope="module")
def ref(model, heald_frame_fmu):
    # two full frame cycles (four revolutions) on FMPy's communication grid
    grid = simulate(heald_frame_fmu.path, output=["h"]).t
    assert grid[-1] == pytest.approx(2 * 4 * math.pi / 60)
    return reference(model, t_end=grid[-1], t_eval=grid, rtol=1e-12, atol=1e-14)


def test_validates_without_problems(heald_frame_fmu):
    assert heald_frame_fmu.problems == []
    assert validate_fmu(str(heald_frame_fmu.path)) == []


def test_binary_needs_only_libc_and_libm(heald_frame_fmu, tmp_path):
    with zipfile.ZipFile(heald_frame_fmu.path) as z:
        z.extract("binaries/linux64/heald_frame.so", tmp_path)
    out = subprocess.run(["ldd", str(tmp_path / "binaries/linux64/heald_frame.so")],
                         capture_output=True, text=True, check=True).stdout
    libs = {line.split()[0] for line in out.splitlines() if line.strip()}
    allowed = {"linux-vdso.so.1", "libc.so.6", "libm.so.6"}
    assert {lib for lib in libs if "ld-linux" not in lib} <= allowed, out


def test_rebuilds_from_sources_with_fmpy(heald_frame_fmu, tmp_path):
    unzipped = tmp_path / "fmu"
    with zipfile.ZipFile(heald_frame_fmu.path) as z:
        z.extractall(unzipped)
    shutil.rmtree(unzipped / "binaries")
    (tmp_path / "build").mkdir()
    build_platform_binary(unzipped, build_dir=tmp_path / "build")
    rebuilt = tmp_path / "rebuilt.fmu"
    shutil.make_archive(str(rebuilt.with_suffix("")), "zip", unzipped)
    rebuilt.with_suffix(".zip").rename(rebuilt)
    a = simulate(heald_frame_fmu.path, output=OUTPUTS)
    b = simulate(rebuilt, output=OUTPUTS)
    for name in OUTPUTS:
        np.testing.assert_allclose(b.y[name], a.y[name], rtol=1e-9, atol=1e-12)


# Bound: the adaptive solvers keep the local error below rtol (atol for small
# states); over two damped frame cycles the global error stays within a
# modest multiple of it.  We assert 20 * rtol relative to each output's range
# at rtol = 1e-6, and that tightening rtol 100x shrinks the error >= 10x.
RTOL = 1e-6
BOUND = 20 * RTOL


@pytest.mark.parametrize("solver", ["dopri5", "rodas4"])
def test_adaptive_solver_agrees_with_reference(heald_frame_fmu, ref, solver):
    run = simulate(heald_frame_fmu.path, solver=solver, rtol=RTOL, atol=1e-10,
                   output=OUTPUTS)
    errs = compare(run, ref, OUTPUTS)
    worst = max(e["max_rel_range"] for e in errs.values())
    assert worst < BOUND, errs
    tight = simulate(heald_frame_fmu.path, solver=solver, rtol=RTOL / 100, atol=1e-12,
                     output=OUTPUTS)
    worst_tight = max(e["max_rel_range"] for e in compare(tight, ref, OUTPUTS).values())
    assert worst_tight < worst / 10


@pytest.mark.parametrize("k_H", [9 / 7, 1.2])
def test_rk4_converges_at_fourth_order_across_the_breakpoints(heald_frame_fmu, model, k_H):
    """RK4 is 4th order only if no step straddles a breakpoint of the motion
    law: with the printed coefficient 1.2 the acceleration jumps there, and
    the FMU must stop at each breakpoint inside its communication steps."""
    values = {"k_H": k_H}
    grid = simulate(heald_frame_fmu.path, output=["h"]).t
    ref = reference(model, t_end=grid[-1], t_eval=grid, values=values, rtol=1e-12,
                    atol=1e-14)
    errs = []
    for h in (8e-5, 4e-5):
        run = simulate(heald_frame_fmu.path, solver="rk4",
                       values={"solver_h_fixed": h, **values}, output=["y2_out"])
        errs.append(compare(run, ref, ["y2_out"])["y2_out"]["max_rel_range"])
    # C h^4 with C from the fastest mode (175 Hz): measured 2e-10 at h = 4e-5
    assert errs[1] < 1e-8
    order = math.log2(errs[0] / errs[1])
    assert 3.6 < order < 4.4, errs


def test_events_located_inside_the_step_for_the_printed_motion_law(heald_frame_fmu, model):
    """With the printed coefficient 1.2 the frame velocity and acceleration
    jump at the dwell boundaries; the FMU must find them inside its
    communication steps (large steps here) and restart the solver there."""
    values = {"k_H": 1.2}
    run = simulate(heald_frame_fmu.path, solver="dopri5", rtol=1e-8, atol=1e-12,
                   output_interval=0.01, values=values, output=["y2_out", "h"])
    ref = reference(model, t_end=run.t[-1], t_eval=run.t, values=values, rtol=1e-11,
                    atol=1e-13)
    errs = compare(run, ref, ["y2_out", "h"])
    assert errs["y2_out"]["max_rel_range"] < 1e-5, errs
    # event times from the log against the exact breakpoint times phi_k / omega
    slave_log = _event_log(heald_frame_fmu.path, values)
    omega = 60.0
    expected = sorted((deg * math.pi / 180 + 2 * math.pi * k) / omega
                      for k in range(4) for deg in (0, 40, 320) if (deg, k) != (0, 0))
    expected = [t for t in expected if t < 0.4]
    assert len(slave_log) == len(expected)
    assert max(abs(a - b) for a, b in zip(slave_log, expected)) < 1e-9


def _event_log(path, values):
    from conftest import Slave
    s = Slave(path)
    s.fmu.setDebugLogging(True, ["logEvents"])
    s.start(**values)
    t = 0.0
    while t < 0.4 - 1e-12:
        s.fmu.doStep(t, 0.02)
        t += 0.02
    s.fmu.terminate()
    s.fmu.freeInstance()
    return [float(re.match(r"t = (\S+):", m).group(1)) for st, cat, m in s.log
            if cat == "logEvents"]


def test_solver_failure_returns_discard_not_ok(heald_frame_fmu, slave_factory):
    """RK4 with a step far beyond its stability limit (h |lambda| = 11 > 2.8
    for the 175 Hz mode) grows by ~600x a step until it overflows: the FMU
    must report Discard with the time and cause, keep finite values at the
    last accepted time and refuse to continue."""
    s = slave_factory(heald_frame_fmu.path)
    s.start(solver=SOLVERS.index("rk4") + 1, solver_h_fixed=1e-2)
    t, status = 0.0, None
    while t < 10.0:
        try:
            s.fmu.doStep(t, 0.01)
        except FMICallException as exc:
            status = exc.status
            break
        t += 0.01
    assert status == 2  # fmi2Discard
    messages = [m for st, cat, m in s.log if cat == "logStatusDiscard"]
    assert messages and "rk4" in messages[-1] and "t = " in messages[-1]
    last = s.fmu.getRealStatus(2)  # fmi2LastSuccessfulTime
    assert 0 <= last < t + 0.01
    assert np.all(np.isfinite(s.get("x1", "x2", "y2")))
    with pytest.raises(FMICallException):
        s.fmu.doStep(t, 0.01)


def test_out_of_range_parameter_is_rejected_with_a_log_line(heald_frame_fmu, slave_factory):
    s = slave_factory(heald_frame_fmu.path)
    s.fmu.setupExperiment(startTime=0.0)
    with pytest.raises(FMICallException) as exc:
        s.set(E=-1.0)
    assert exc.value.status == 3  # fmi2Error
    assert any("E = -1" in m and "range" in m for _, _, m in s.log)
    s.fmu.enterInitializationMode()  # values can be read from here on (FMI 2.0, 4.2.4)
    assert s.get("E")[0] == pytest.approx(0.7e11)  # nothing lost
    with pytest.raises(FMICallException):
        s.set(solver_rtol=float("nan"))
    with pytest.raises(FMICallException):
        s.set(solver=7)


def test_parameters_cannot_change_after_initialization(heald_frame_fmu, slave_factory):
    s = slave_factory(heald_frame_fmu.path)
    s.start()
    with pytest.raises(FMICallException):
        s.set(E=1e11)
    assert any("before fmi2ExitInitializationMode" in m for _, _, m in s.log)


def test_instances_side_by_side(heald_frame_fmu, slave_factory):
    """Two instances in one process, interleaved, with different parameters,
    give the same results as each run alone."""
    def run(slaves, steps=40):
        out = {id(s): [] for s in slaves}
        t = 0.0
        for _ in range(steps):
            for s in slaves:
                s.fmu.doStep(t, 0.005)
                out[id(s)].append(s.get("x2_out", "y2_out"))
            t += 0.005
        return [np.array(out[id(s)]) for s in slaves]

    a, b = slave_factory(heald_frame_fmu.path, "a"), slave_factory(heald_frame_fmu.path, "b")
    a.start()
    b.start(k_z=2.0, omega=50.0)
    ya, yb = run([a, b])
    alone = slave_factory(heald_frame_fmu.path, "alone")
    alone.start(k_z=2.0, omega=50.0)
    (y_alone,) = run([alone])
    np.testing.assert_array_equal(yb, y_alone)
    assert not np.allclose(ya, yb)


def test_start_follows_parameters_set_at_run_time(heald_frame_fmu, model, slave_factory):
    """The static-equilibrium start is recomputed from the parameters set
    before initialization (not frozen at the build-time values), unless the
    state itself is set."""
    ref = reference(model, t_end=1e-3, values={"k_z": 2.0})
    s = slave_factory(heald_frame_fmu.path)
    s.start(k_z=2.0)
    x2 = s.get("x2")[0]
    assert x2 == pytest.approx(ref.y["x2"][0], rel=1e-12)
    assert x2 != pytest.approx(model.var("x2").start, rel=1e-3)
    s2 = slave_factory(heald_frame_fmu.path)
    s2.start(k_z=2.0, x2=0.0)
    assert s2.get("x2")[0] == 0.0


def test_cross_parameter_constraint_is_checked(heald_frame_fmu, model, slave_factory):
    """The slats' reduced masses must fit in the frame mass m_RR: no single
    range can say so; the FMU refuses to initialize, Python raises."""
    s = slave_factory(heald_frame_fmu.path)
    s.fmu.setupExperiment(startTime=0.0)
    s.set(m_RR=0.5)  # in range, but lighter than the slats
    s.fmu.enterInitializationMode()
    with pytest.raises(FMICallException):
        s.fmu.exitInitializationMode()
    assert any("reduced_mass_in_frame" in m for _, _, m in s.log)
    with pytest.raises(ValueError, match="reduced_mass_in_frame"):
        reference(model, t_end=0.01, values={"m_RR": 0.5})


def test_outputs_in_initialization_mode_are_those_initialization_starts_from(
        heald_frame_fmu, slave_factory):
    s = slave_factory(heald_frame_fmu.path)
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.set(k_z=2.0)
    before = s.get("x2", "x2_out", "f_x")
    s.fmu.exitInitializationMode()
    assert s.get("x2", "x2_out", "f_x") == pytest.approx(before, rel=1e-14)


def test_call_errors_change_nothing(heald_frame_fmu, slave_factory):
    """A refused call (bad communication point, step past stopTime) returns
    fmi2Error and the co-simulation can go on (FMI 2.0: the importer may
    correct the call)."""
    s = slave_factory(heald_frame_fmu.path)
    s.fmu.setupExperiment(startTime=0.0, stopTime=0.05)
    s.fmu.enterInitializationMode()
    s.fmu.exitInitializationMode()
    for t, h in ((0.01, 0.01), (0.0, -0.01), (0.0, 0.06)):
        with pytest.raises(FMICallException):
            s.fmu.doStep(t, h)
    assert any("stopTime" in m for _, _, m in s.log)
    s.fmu.doStep(0.0, 0.05)  # the valid call still works
    assert s.get("h")[0] == pytest.approx(-0.029 + 0.0, abs=0.03)


def test_importer_tolerance_is_clamped_not_refused(heald_frame_fmu):
    import fmpy
    res = fmpy.simulate_fmu(str(heald_frame_fmu.path), relative_tolerance=0.5, stop_time=0.01,
                            output=["h"], logger=lambda *a: None)
    assert np.all(np.isfinite(res["h"]))


def test_input_outside_its_range_is_a_warning_and_log_messages_are_escaped(
        heald_frame_fmu, slave_factory):
    s = slave_factory(heald_frame_fmu.path)
    s.start()
    s.fmu.setReal([s.vr["omega"]], [600.0])  # fmi2Warning: FMPy does not raise
    assert s.get("omega")[0] == 600.0
    assert any(st == 1 and "omega = 600" in m for st, _, m in s.log)
    with pytest.raises(FMICallException):
        s.fmu.setDebugLogging(True, ["50%#"])
    assert any("50%%##" in m for _, _, m in s.log)  # a printf format, '#' doubled


def test_values_cannot_be_read_before_initialization_mode(heald_frame_fmu, slave_factory):
    s = slave_factory(heald_frame_fmu.path)
    with pytest.raises(FMICallException):
        s.get("E")
