"""Validity conditions (Model.require): a condition expr >= 0 that fails
while the FMU runs ends the step at the last valid time with fmi2Discard,
fmi2Terminated and a log line; the scipy reference stops there too.

Oracle: a mass on a spring, x(t) = cos(2 t), with the condition x + 0.5 >= 0
("string in compression" below -0.5 m): it fails first at t* = acos(-0.5)/2.
"""
from __future__ import annotations

import math

import casadi as ca
import fmpy
import oracles
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated

from loomfmu import build_fmu
from loomfmu.declare.model import Model
from loomfmu.verification.reference import reference

pytestmark = pytest.mark.slow  # builds FMUs

OMEGA = 2.0
T_STAR = math.acos(-0.5) / OMEGA  # x = cos(2 t) reaches -0.5
MESSAGE = "string in compression"


def _spring(require: bool, name: str) -> Model:
    return oracles.spring(name, k=OMEGA**2, require=MESSAGE if require else None)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("validity")
    return {r: build_fmu(_spring(r, f"spring_{'req' if r else 'free'}"), out_dir=out).path
            for r in (True, False)}


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
def test_discard_at_the_crossing(fmus, slave_factory, solver):
    """The step that crosses ends at the crossing (to 1e-9 s with dopri5 and
    rodas4 at rtol 1e-10; rk4 to its fixed step's accuracy), fmi2Discard,
    fmi2Terminated true, state and outputs of that time, the log line."""
    s = slave_factory(fmus[True])
    s.start(solver=solver, solver_rtol=1e-10, solver_atol=1e-12, solver_h_fixed=1e-3)
    t, h = 0.0, 0.1
    with pytest.raises(FMICallException) as e:
        while True:
            s.fmu.doStep(t, h)
            t += h
    assert e.value.status == 2  # fmi2Discard
    assert t < T_STAR < t + h
    t_last = s.fmu.getRealStatus(fmi2LastSuccessfulTime)
    tol = 1e-9 if solver != 3 else 1e-6
    assert t_last == pytest.approx(T_STAR, abs=tol)
    assert t_last <= T_STAR + tol
    assert s.fmu.getBooleanStatus(fmi2Terminated)
    x, x_out = s.get("x", "x_out")
    assert x == x_out and x == pytest.approx(math.cos(OMEGA * t_last), abs=1e-7)
    assert x >= -0.5  # the last valid state
    status, category, message = s.log[-1]
    assert category == "logStatusDiscard" and status == 2
    assert message.startswith(f"taut: {MESSAGE}: value ")
    value = float(message.split("value ")[1].split(" ")[0])
    t_log = float(message.split("at t = ")[1].split(" ")[0])
    assert value < 0 and abs(value) < 1e-6
    assert t_log == pytest.approx(T_STAR, abs=tol)
    # the step cannot be retried from here (terminated): only a restored state goes on
    with pytest.raises(FMICallException):
        s.fmu.doStep(t_last, h)


def test_restored_state_before_the_crossing_discards_again(fmus, slave_factory):
    s = slave_factory(fmus[True])
    s.start(solver_rtol=1e-10, solver_atol=1e-12)
    s.fmu.doStep(0.0, 1.0)
    state = s.fmu.getFMUstate()
    with pytest.raises(FMICallException):
        s.fmu.doStep(1.0, 0.5)
    s.fmu.setFMUstate(state)
    assert not s.fmu.getBooleanStatus(fmi2Terminated)
    s.fmu.doStep(1.0, 0.04)  # up to 1.04 < t*: valid
    with pytest.raises(FMICallException):
        s.fmu.doStep(1.04, 0.04)
    assert s.fmu.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(T_STAR, abs=1e-9)
    s.fmu.freeFMUstate(state)


def test_fmpy_simulate_stops_at_the_crossing(fmus):
    """FMPy's simulate_fmu sees fmi2Terminated and ends its result at the
    last valid time."""
    res = fmpy.simulate_fmu(str(fmus[True]), stop_time=2.0, output_interval=0.01,
                            start_values={"solver_rtol": 1e-10, "solver_atol": 1e-12})
    assert res["time"][-1] == pytest.approx(T_STAR, abs=1e-9)
    assert res["x_out"][-1] == pytest.approx(-0.5, abs=1e-8)
    assert res["time"][-2] < T_STAR


def test_reference_stops_at_the_crossing():
    ref = reference(_spring(True, "spring_ref"), t_end=2.0)
    name, message, t_v, value = ref.violation
    assert (name, message) == ("taut", MESSAGE)
    assert t_v == pytest.approx(T_STAR, abs=1e-9)
    assert abs(value) < 1e-8
    assert ref.t[-1] < T_STAR and len(ref.y["x"]) == len(ref.t)
    assert ref.y["x"][-1] == pytest.approx(math.cos(OMEGA * ref.t[-1]), abs=1e-8)
    free = reference(_spring(False, "spring_free"), t_end=2.0)
    assert free.violation is None and free.t[-1] == 2.0


def test_a_model_without_conditions_runs_through(fmus, slave_factory):
    s = slave_factory(fmus[False])
    s.start(solver_rtol=1e-10, solver_atol=1e-12)
    s.fmu.doStep(0.0, 2.0)
    assert s.get("x")[0] == pytest.approx(math.cos(OMEGA * 2.0), abs=1e-8)
    assert not s.fmu.getBooleanStatus(fmi2Terminated)
    assert not any(c == "logStatusDiscard" for _, c, _ in s.log)


def test_violated_at_the_start_discards_without_progress(fmus, slave_factory):
    s = slave_factory(fmus[True])
    s.start(x=-0.6)
    with pytest.raises(FMICallException):
        s.fmu.doStep(0.0, 0.1)
    assert s.fmu.getRealStatus(fmi2LastSuccessfulTime) == 0.0
    assert s.fmu.getBooleanStatus(fmi2Terminated)
    assert s.log[-1][2].startswith(f"taut: {MESSAGE}: value -0.1 at t = 0 s")


# ---- the located time does not depend on the communication step -----------

W_EVENT = 20.0     # event indicator sin(W_EVENT (t - t_e)): events every pi/20 s


def _spring_with_events(name: str) -> Model:
    """The spring with an event indicator (no mode: the solver restarts at
    each root), one root t_e placed just after t*, so that the internal step
    in which the condition fails ends at an event and is redone up to it."""
    m = _spring(True, name)
    t_e = m.parameter("t_e", T_STAR + 3e-3, unit="s", description="a root of the indicator",
                      source="assumption: test oracle")
    m.event("tick", ca.sin(W_EVENT * (m.t - t_e)), description="a breakpoint")
    return m


X_SWITCH = 0.2    # the mode switches 0 -> 1 where x falls through 0.2
T_SWITCH = math.acos(X_SWITCH) / OMEGA


def _spring_with_a_mode(name: str) -> Model:
    """The spring with a mode q (0 above x = 0.2, 1 below) chosen again at
    the event x = 0.2; the condition 1 - 2 q >= 0 holds before the event and
    jumps to -1 across it."""
    m = Model(name, description="mass on a spring with a mode", stop_time=2.0, step_size=0.01)
    x = m.state("x", 1.0, unit="m", description="position")
    v = m.state("v", 0.0, unit="m/s", description="velocity")
    m.eq(m.der(x), v)
    m.eq(m.der(v), -OMEGA**2 * x)
    q = m.mode("q", 0, (0, 1), description="0 above x = 0.2, 1 below")
    m.event("cross", x - X_SWITCH, description="x passes 0.2")
    m.mode_rule(q, (1 - 2 * q) * (x - X_SWITCH), events=["cross"])
    m.output("x_out", x, unit="m", description="position")
    m.require("above", 1 - 2 * q, "below the switch")
    return m


DIP_EPS = 1e-3     # condition cos(t) + 1 - DIP_EPS >= 0: fails for 0.089 s around pi
T_DIP = math.pi - math.acos(1.0 - DIP_EPS)


def _dip(name: str) -> Model:
    """Constant state, so the adaptive solvers' steps grow to solver_h_max
    (10 s); the condition, driven by time, dips below zero for 0.089 s."""
    m = Model(name, description="a dip driven by time", stop_time=10.0, step_size=0.01)
    x = m.state("x", 1.0, unit="m", description="constant")
    m.eq(m.der(x), 0.0 * x)
    m.output("x_out", x, unit="m", description="x")
    m.require("dip", x * ca.cos(m.t) + 1.0 - DIP_EPS, "a dip")
    return m


@pytest.fixture(scope="module")
def more_fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("validity_more")
    return {"events": build_fmu(_spring_with_events("spring_events"), out_dir=out).path,
            "dip": build_fmu(_dip("dip"), out_dir=out).path,
            "mode": build_fmu(_spring_with_a_mode("spring_mode"), out_dir=out).path}


def _run_to_discard(s, h, t_stop):
    t = 0.0
    with pytest.raises(FMICallException) as e:
        while t < t_stop:
            s.fmu.doStep(t, min(h, t_stop - t))
            t += h
    assert e.value.status == 2  # fmi2Discard
    return s.fmu.getRealStatus(fmi2LastSuccessfulTime)


@pytest.mark.parametrize("solver", [1, 2])
@pytest.mark.parametrize("offset", [1e-4, 3e-3])
def test_failure_in_a_step_that_ends_at_an_event(more_fmus, slave_factory, solver, offset):
    """The condition fails at t* inside an internal step
    that ends at an event (t* + offset).  The time found is t* for every
    communication step from 1e-4 s to the whole run, never the event's time
    (it was the event's time, with the condition already negative, when the
    step ended at the event)."""
    found = {}
    for h in (1e-4, 1e-3, 1e-2, 0.1, 2.0):
        s = slave_factory(more_fmus["events"])
        s.start(solver=solver, solver_rtol=1e-10, solver_atol=1e-12, t_e=T_STAR + offset)
        found[h] = _run_to_discard(s, h, 2.0)
        assert s.fmu.getBooleanStatus(fmi2Terminated)
        assert s.get("x")[0] >= -0.5, h
        assert s.log[-1][2].startswith(f"taut: {MESSAGE}: value "), s.log[-1]
    assert all(abs(t - T_STAR) < 1e-9 for t in found.values()), found


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
def test_a_dip_shorter_than_the_step_is_found(more_fmus, slave_factory, solver):
    """The state is constant (zero error estimate: steps of up to 10 s), the
    condition dips below zero for 0.089 s.  Sampling each step at its
    midpoint and end missed the dip (the FMU ran through to 10 s); scanned
    like an event indicator (halves again where the quadratic through the
    samples comes near zero; steps bounded by the condition's curvature) it
    is found at the same time for every communication step."""
    found = {}
    for h in (1e-2, 0.1, 1.0, 10.0):
        s = slave_factory(more_fmus["dip"])
        s.start(solver=solver, solver_h_fixed=0.05)
        found[h] = _run_to_discard(s, h, 10.0)
        value = float(s.log[-1][2].split("value ")[1].split(" ")[0])
        assert value < 0 and abs(value) < 1e-9, s.log[-1]
    assert all(abs(t - T_DIP) < 1e-9 for t in found.values()), found


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
def test_a_condition_that_fails_across_an_event(more_fmus, slave_factory, solver):
    """The condition jumps from 1 to -1 where the mode changes at an event:
    the step ends at the last point before the event, with the mode and
    state of before (it ended after the event, in the new mode, when the
    restart point was not checked), for every communication step."""
    for h in (1e-3, 0.1, 2.0):
        s = slave_factory(more_fmus["mode"])
        s.start(solver=solver, solver_rtol=1e-10, solver_atol=1e-12, solver_h_fixed=1e-3)
        t_last = _run_to_discard(s, h, 2.0)
        assert abs(t_last - T_SWITCH) < 1e-9, (h, t_last - T_SWITCH)
        assert s.fmu.getInteger([s.vr["q"]]) == [0], h
        assert s.get("x")[0] > X_SWITCH - 1e-9, h  # the old side (to the solution error)
        assert "fails across the event" in s.log[-1][2], s.log[-1]
