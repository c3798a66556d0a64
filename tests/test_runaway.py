"""Runaway values and runaway calls are refused.

* A state that stops being finite, exceeds 1e150 in magnitude (its square
  would overflow) or leaves a declared range ends the communication step
  with fmi2Discard, at the last accepted point.  Before: u_ext = 1e300 on the
  drive only warned, and 100 steps returned OK with n_out = 4e302.
* One fmi2DoStep does at most solver_max_steps solver steps (a setting,
  default codegen.MAX_STEPS_DEFAULT), then returns fmi2Discard with the
  reason logged.  Before: drive tau = 1e-12 ran 45 s, drive h = 1e9 did not
  return in 400 s, backrest h = 1e4 ran 126 s.
* After a Discard, fmi2GetRealStatus(fmi2LastSuccessfulTime) answers and
  fmi2GetReal gives the outputs at that time.
"""
from __future__ import annotations

import ctypes
import math
import time

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime

from loomfmu import build_fmu, load_model
from loomfmu.declare.solvers import MAX_STEPS_DEFAULT

pytestmark = pytest.mark.slow  # builds FMUs


@pytest.fixture(scope="module")
def drive_path(dist):
    return build_fmu(load_model("drive"), out_dir=dist, validate=False).path


@pytest.fixture(scope="module")
def backrest_path(dist):
    return build_fmu(load_model("backrest"), out_dir=dist, validate=False).path


def last_successful_time(s) -> float:
    value = ctypes.c_double()
    status = s.fmu.fmi2GetRealStatus(s.fmu.component, fmi2LastSuccessfulTime,
                                     ctypes.byref(value))
    assert status == 0
    return value.value


def discarded(s, t0, h):
    """doStep(t0, h) must be discarded; returns its wall time."""
    wall = time.perf_counter()
    with pytest.raises(FMICallException, match="discard"):
        s.fmu.doStep(t0, h)
    return time.perf_counter() - wall


def outputs(s):
    names = [v.name for v in s.md.modelVariables if v.causality == "output"]
    return dict(zip(names, s.get(*names)))


def test_default_budget_is_declared(drive_path, slave_factory):
    s = slave_factory(drive_path)
    s.start()
    assert s.get("solver_max_steps")[0] == MAX_STEPS_DEFAULT


def test_runaway_input_is_discarded_and_the_last_good_outputs_stay_readable(
        drive_path, slave_factory):
    s = slave_factory(drive_path)
    s.start()
    s.set(u_ext=1e300)  # out of range: a warning, as the FMU's inputs have
    t, comm = 0.0, 0.01
    with pytest.raises(FMICallException, match="discard"):
        for _ in range(100):
            s.fmu.doStep(t, comm)
            y = outputs(s)
            assert all(abs(v) < 1e150 for k, v in y.items() if k not in ("u", "u_delayed")), y
            t += comm
    assert any("state n = " in m and "1e+150" in m for _, _, m in s.log), s.log[-2:]
    # the drive declares no state ranges: the message names none
    assert not any("state n = " in m and "range" in m for _, _, m in s.log), s.log[-2:]
    t_ok = last_successful_time(s)
    assert t <= t_ok < t + comm
    y = outputs(s)
    assert all(math.isfinite(v) for v in y.values()), y
    # the same trajectory stepped to t_ok by a fresh instance: the same outputs
    fresh = slave_factory(drive_path)
    fresh.start()
    fresh.set(u_ext=1e300)
    tt = 0.0
    while tt + comm < t_ok - 1e-9:
        fresh.fmu.doStep(tt, comm)
        tt += comm
    fresh.fmu.doStep(tt, t_ok - tt)
    assert fresh.get("n_out")[0] == pytest.approx(y["n_out"], rel=1e-6)
    assert fresh.get("phi_out")[0] == pytest.approx(y["phi_out"], rel=1e-6)


@pytest.mark.parametrize("case", ["drive tau=1e-12", "drive h=1e9", "backrest h=1e4"])
def test_long_calls_stop_at_the_step_budget(case, drive_path, backrest_path, slave_factory):
    """Each case with the default budget returns Discard within seconds (and
    the reason in the log); the outputs at the last accepted time stay
    readable and finite, and a smaller budget stops it sooner."""
    walls = {}
    for budget in (MAX_STEPS_DEFAULT, MAX_STEPS_DEFAULT // 10):
        if case.startswith("drive"):
            s = slave_factory(drive_path)
            s.start(solver_max_steps=budget, **({"tau": 1e-12} if "tau" in case else {}))
            h = 0.01 if "tau" in case else 1e9
        else:
            s = slave_factory(backrest_path)
            s.start(solver_max_steps=budget)
            h = 1e4
        if case == "drive h=1e9" and budget == MAX_STEPS_DEFAULT:
            continue  # about 8 s: the tenth of the budget shows the bound
        walls[budget] = discarded(s, 0.0, h)
        msg = [m for _, _, m in s.log if "solver_max_steps" in m]
        assert msg and f"= {budget} steps" in msg[0], s.log[-2:]
        t_ok = last_successful_time(s)
        assert 0.0 < t_ok < h
        assert all(math.isfinite(v) for v in outputs(s).values())
        assert s.fmu.getReal([s.vr["solver_max_steps"]])[0] == budget
    assert max(walls.values()) < 20.0, walls


def test_state_leaving_its_declared_range_is_discarded(tmp_path, slave_factory):
    """A state with a finite declared range (none of the shipped models has
    one, so the runtime's range check is compiled in only for models that
    do, model_decl.h's LF_X_RANGED): x' = u leaves [-1, 1] at t = 0.1 with
    u = 10; the communication step is discarded at the last accepted point,
    with the state, its value and its range in the log, and the same
    model stepped inside its range runs on."""
    from loomfmu.declare.model import Model

    m = Model("ranged", stop_time=1.0, step_size=0.1)
    x = m.state("x", 0.0, description="a ranged state", min=-1.0, max=1.0)
    u = m.input("u", 10.0, description="its rate", min=-100.0, max=100.0)
    m.eq(m.der(x), u)
    m.output("y", x, description="x")
    path = build_fmu(m, out_dir=tmp_path, validate=False).path
    assert "#define LF_X_RANGED 1" in __import__("zipfile").ZipFile(path).read(
        "sources/model_decl.h").decode()
    s = slave_factory(path)
    s.start()
    discarded(s, 0.0, 0.5)
    assert any("state x = " in msg and "outside its range [-1, 1]" in msg
               for _, _, msg in s.log), s.log[-2:]
    assert 0.0 <= last_successful_time(s) <= 0.1
    assert abs(s.get("y")[0]) <= 1.0
    inside = slave_factory(path)
    inside.start(u=1.0)
    inside.fmu.doStep(0.0, 0.5)
    assert inside.get("y")[0] == pytest.approx(0.5, rel=1e-9)
