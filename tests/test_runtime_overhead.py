"""The runtime's shortcuts on the hot path keep every result.

Where every event indicator is known ahead (lf_breaks.c: a function of time,
the parameters, held inputs and clock states), the events' scan after a
step takes the scan of the prediction's word for "no root in this step"
(c->kb_cert) and skips its own search inside the step (lf_handle_events).
That word must not outlive what it was given for: a restored FMU state, a
reset, an input that changes the clock's rate, another communication step.
One model with a clock driven by an input and two indicators of it (one
crossing twice per turn, one dipping below zero for a tenth of a turn),
and an ordinary state fed by the clock (so the solver takes real steps):
the events come at their closed-form times whatever happens between the
steps, and a run repeated from a restored state or after a reset is the
same bit for bit."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from loomfmu.declare.model import Model
from loomfmu.fmu.builder import build_fmu

pytestmark = pytest.mark.slow  # builds FMUs

OMEGA = 2 * math.pi  # rad/s: one turn per second
A = 0.3  # indicator "cross": sin(th) - A
DIP = 0.1 * math.pi  # indicator "dip": below zero for |th - pi| < DIP (mod 2 pi)


def _model() -> Model:
    m = Model("kb_clock", stop_time=3.0, step_size=0.01)
    w = m.input("w", OMEGA, unit="rad/s", description="clock rate (held)")
    th = m.state("th", 0.0, unit="rad", description="clock: th' = w")
    x = m.state("x", 0.0, unit="m", description="x' = -x + sin(th): not a clock")
    m.eq(m.der(th), w)
    m.eq(m.der(x), -x + ca.sin(th))
    m.event("cross", ca.sin(th) - A, description="crosses zero twice per turn")
    m.event("dip", math.cos(DIP) - ca.cos(th - math.pi),
            description="below zero for a tenth of a turn around th = pi")
    m.output("x_out", x, unit="m", description="x")
    m.output("th_out", th, unit="rad", description="th")
    return m


def _roots(th0: float, th1: float) -> list[float]:
    """The indicators' zeros in th, th0 < th <= th1, in order."""
    base = [math.asin(A), math.pi - math.asin(A), math.pi - DIP, math.pi + DIP]
    out = []
    k = math.floor(th0 / (2 * math.pi)) - 1
    while 2 * math.pi * k <= th1:
        out += [2 * math.pi * k + b for b in base if th0 < 2 * math.pi * k + b <= th1]
        k += 1
    return sorted(out)


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    return build_fmu(_model(), out_dir=tmp_path_factory.mktemp("kb_clock"), validate=False).path


def _events(s) -> list[float]:
    return [float(m.split()[2].rstrip(":")) for _, _, m in s.log
            if " event cross," in m or " event dip," in m]


def _run(s, t0: float, t1: float, comm: float) -> list[tuple]:
    """Steps from t0 to t1; the outputs after each (bit for bit)."""
    out = []
    n = int(round((t1 - t0) / comm))
    for i in range(n):
        t = t0 + i * comm
        s.fmu.doStep(t, (t0 + (i + 1) * comm) - t)
        out.append(tuple(s.get("x_out", "th_out")))
    return out


@pytest.mark.parametrize("solver", [1, 2, 4])
@pytest.mark.parametrize("comm", [0.01, 0.1, 1.0, 3.0])
def test_events_at_closed_form_times(slave_factory, fmu, solver, comm):
    s = slave_factory(fmu)
    s.fmu.setDebugLogging(True, ["logEvents"])
    s.start(solver=solver)
    _run(s, 0.0, 3.0, comm)
    expected = [r / OMEGA for r in _roots(0.0, 3.0 * OMEGA)]
    at = _events(s)
    assert len(at) == len(expected) == 12, at
    assert np.allclose(at, expected, atol=1e-9), (at, expected)


@pytest.mark.parametrize("solver", [1, 2])
def test_restored_state_and_reset_repeat_the_run(slave_factory, fmu, solver):
    s = slave_factory(fmu)
    s.fmu.setDebugLogging(True, ["logEvents"])
    s.start(solver=solver)
    first = _run(s, 0.0, 1.23, 0.01)
    state = s.fmu.getFMUState()
    rest = _run(s, 1.23, 3.0, 0.01)
    events = _events(s)
    # the instance ran on past the state; restored, it repeats the same steps
    s.fmu.setFMUState(state)
    again = _run(s, 1.23, 3.0, 0.01)
    assert again == rest
    assert _events(s)[len(events):] == [t for t in events if t > 1.23]
    s.fmu.freeFMUState(state)
    # reset: the same run from the start, bit for bit
    s.fmu.reset()
    s.start(solver=solver)
    assert _run(s, 0.0, 1.23, 0.01) == first


@pytest.mark.parametrize("solver", [1, 2])
def test_input_change_moves_the_breaks(slave_factory, fmu, solver):
    """The clock's rate doubles at t = 1.005 (inside a turn, between two
    roots): the events before follow the old rate, those after the new one,
    also right after a restored state taken before the change."""
    s = slave_factory(fmu)
    s.fmu.setDebugLogging(True, ["logEvents"])
    s.start(solver=solver)
    t_c = 1.005
    _run(s, 0.0, t_c, 0.005)
    state = s.fmu.getFMUState()
    th_c = s.get("th_out")[0]
    assert th_c == pytest.approx(OMEGA * t_c, rel=1e-12)

    def after_change():
        s.set(w=2 * OMEGA)
        _run(s, t_c, 2.0, 0.005)
        return [t for t in _events(s) if t > t_c]

    n0 = len(_events(s))
    got = after_change()
    expected = [t_c + (r - th_c) / (2 * OMEGA) for r in _roots(th_c, th_c + 2 * OMEGA * (2.0 - t_c))]
    assert len(got) == len(expected) and np.allclose(got, expected, atol=1e-9), (got, expected)
    assert np.allclose(_events(s)[:n0], [r / OMEGA for r in _roots(0.0, OMEGA * t_c)],
                       atol=1e-9)
    # from the state before the change: the old rate's predictions are not reused
    s.fmu.setFMUState(state)
    s.set(w=OMEGA)  # the state's own value, then the change again
    n1 = len(_events(s))
    s.set(w=2 * OMEGA)
    _run(s, t_c, 2.0, 0.005)
    again = [t for t in _events(s)[n1:] if t > t_c]
    assert again == got
    s.fmu.freeFMUState(state)
