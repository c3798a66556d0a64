"""Validity conditions (Model.require): a condition expr >= 0 that fails
while the FMU runs ends the step at the last valid time with fmi2Discard,
fmi2Terminated and a log line; the scipy reference stops there too.

Oracle: a mass on a spring, x(t) = cos(2 t), with the condition x + 0.5 >= 0
("string in compression" below -0.5 m): it fails first at t* = acos(-0.5)/2.
"""
from __future__ import annotations

import math

import fmpy
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2LastSuccessfulTime, fmi2Terminated

from loomfmu import build_fmu
from loomfmu.declare import Model
from loomfmu.reference import reference

OMEGA = 2.0
T_STAR = math.acos(-0.5) / OMEGA  # x = cos(2 t) reaches -0.5
MESSAGE = "string in compression"


def _spring(require: bool, name: str) -> Model:
    m = Model(name, description="mass on a spring", stop_time=2.0, step_size=0.01)
    k = m.parameter("k", OMEGA**2, unit="N/m", description="stiffness per unit mass",
                    source="assumption: test oracle")
    x = m.state("x", 1.0, unit="m", description="position")
    v = m.state("v", 0.0, unit="m/s", description="velocity")
    m.eq(m.der(x), v)
    m.eq(m.der(v), -k * x)
    xo = m.output("x_out", x, unit="m", description="position")
    if require:
        m.require("taut", xo + 0.5, MESSAGE)  # through an output's symbol
    return m


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("validity")
    return {r: build_fmu(_spring(r, f"spring_{'req' if r else 'free'}"), out_dir=out).path
            for r in (True, False)}


@pytest.mark.parametrize("solver", [1, 2, 3])
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
