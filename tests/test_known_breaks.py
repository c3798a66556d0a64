"""Known breaks (lf_breaks.c): an event indicator that depends
only on time, parameters and clock states (codegen's event_time_only,
clock_state) has zeros the step loop predicts, so the solver's steps land
just before them instead of straddling the discontinuity there.

One small model, x' = 0 before t1 and 1 after it (a jump of x' at the
root: x = max(0, t - t1) exactly), with the break seen four ways: time
itself, a clock state driven by a parameter, one driven by an input (held),
and an ordinary state (not predictable: the control, which pays rejected
steps).  The runtime is driven by tests/c/early_return.c, which prints the
solver's counters."""
from __future__ import annotations

import itertools
import math

import casadi as ca
import pytest
from test_early_return import Run, _driver  # the runtime driver of a built FMU

from loomfmu import load_model
from loomfmu.declare.model import Model

pytestmark = pytest.mark.slow  # builds FMUs

T1 = 0.4372
T_END = 1.0
RATE = 3.0
KINDS = ("time", "clock", "input", "state")


def _break_model(kind: str) -> Model:
    m = Model(f"kb_{kind}", stop_time=T_END, step_size=0.1)
    t1 = m.parameter("t1", T1, unit="s", description="time of the break",
                     source="assumption: test value inside a communication step")
    x = m.state("x", 0.0, unit="m", description="0 before t1, then t - t1")
    if kind == "time":
        ind = m.t - t1
    elif kind in ("clock", "input"):
        rate = (m.parameter("rate", RATE, unit="", description="clock rate",
                            source="assumption: test value") if kind == "clock"
                else m.input("rate", RATE, unit="", description="clock rate (held)"))
        c = m.state("c", 0.0, unit="s", description="clock: c = rate t")
        m.eq(m.der(c), rate)
        ind = c - RATE * t1
    else:
        y = m.state("y", 1.0, unit="", description="exp(t / 2): not a clock")
        m.eq(m.der(y), 0.5 * y)
        ind = y - math.exp(T1 / 2)
    m.eq(m.der(x), ca.if_else(ind > 0, 1.0, 0.0))
    m.event("brk", ind, description="x' jumps from 0 to 1 here")
    m.output("x_out", x, unit="m", description="x")
    return m


def _tol(kind: str) -> float:
    """Where the break is predicted its time is exact to rounding; the
    ordinary state's root is as exact as the solver's y (rtol 1e-8)."""
    return 1e-8 if kind == "state" else 1e-11


@pytest.fixture(scope="module", params=KINDS)
def kb_driver(request, tmp_path_factory):
    kind = request.param
    return kind, _driver(_break_model(kind), tmp_path_factory.mktemp(f"kb_{kind}"))


@pytest.mark.parametrize("solver", [1, 2])
def test_steps_land_on_known_breaks(kb_driver, solver):
    """Predictable breaks: the step ends just before t1 and the event is
    crossed there, with no rejected step; the ordinary state's break costs
    rejected steps (the solver straddles the jump of x' until it is
    located).  Every variant puts the event at t1 and x(1) = 1 - t1."""
    kind, exe = kb_driver
    run = Run(exe, "plain", T_END, 0.1, f"solver={solver}", "solver_rtol=1e-8",
              "solver_atol=1e-10")
    accepted, rejected, rhs, events, known = run.steps
    tol = _tol(kind)
    assert events == 1 and run.events == pytest.approx([T1], abs=tol)
    if kind == "state":
        assert known == 0 and rejected > 0
    else:
        assert known == 1 and rejected == 0, run.steps
    assert any(abs(v - (T_END - T1)) < 10 * tol for v in run.points[-1]), run.points[-1]


def test_known_break_with_early_return(kb_driver):
    """With early return the step ends at the known break (the event
    pending), and the run goes on as the one without early return."""
    kind, exe = kb_driver
    ref = Run(exe, "plain", T_END, 0.1)
    run = Run(exe, "early", T_END, 0.1)
    assert len(run.early) == 1 and run.early[0][0] == pytest.approx(T1, abs=_tol(kind))
    assert run.steps == ref.steps
    assert abs(run.points - ref.points).max() < 1e-12


# ---- a break at a communication point: landed once, not again and again ----
#
# A break whose root lies at (or within the landing margin of) a
# communication point is landed a margin before it; the crossing is left to
# the next step (lf_cross_known_break).  The step loop then predicts the
# root again from the solver's own clock states, which differ from the
# first prediction by rounding: the root can come out a few ulps later.
# Landing a margin before that was a step of one ulp, after which the same
# happened again, through the whole margin (1e-12 s / 5.6e-17 s: 18 000
# steps on heald_frame with rodas4 after a change of its rounding, and
# the event at the stop time lost).

GRID_CLOCKS = [(0.37, 1.0), (0.37, 12.0), (3.0, 12.0), (7.3, 12.0), (30.0, 12.0)]


def _grid_model() -> Model:
    """A clock c' = rate from c(0) and the break where c reaches c1 (rate
    and c(0) change the rounding of the clock state the solver reaches)."""
    m = Model("kb_grid", stop_time=T_END, step_size=0.1)
    c1 = m.parameter("c1", 1.0, unit="", description="clock value at the break",
                     source="assumption: test value")
    rate = m.parameter("rate", RATE, unit="", description="clock rate",
                       source="assumption: test value")
    c = m.state("c", 0.0, unit="", description="clock")
    x = m.state("x", 0.0, unit="m", description="0 before the break, then t - t1")
    m.eq(m.der(c), rate)
    ind = c - c1
    m.eq(m.der(x), ca.if_else(ind > 0, 1.0, 0.0))
    m.event("brk", ind, description="x' jumps from 0 to 1 here")
    m.output("x_out", x, unit="m", description="x")
    return m


@pytest.fixture(scope="module")
def grid_driver(tmp_path_factory):
    return _driver(_grid_model(), tmp_path_factory.mktemp("kb_grid"))


@pytest.mark.parametrize("solver", [1, 2, 4])
def test_break_at_a_communication_point_is_not_landed_again(grid_driver, solver):
    """The break on the communication grid (t1 = 0.1 k): one event at t1
    and a handful of steps for every clock, never a crawl of ulp-long steps
    up to the grid point (before the fix 2 000 - 36 000 steps for some of
    these clocks with each of the three solvers)."""
    for (rate, c0), k in itertools.product(GRID_CLOCKS, range(1, 10)):
        t1 = 0.1 * k
        run = Run(grid_driver, "plain", T_END, 0.1, f"solver={solver}", f"rate={rate!r}",
                  f"c={c0!r}", f"c1={c0 + rate * t1!r}")
        accepted, rejected, rhs, events, known = run.steps
        where = (rate, c0, t1, run.steps)
        assert events == 1 and run.events == pytest.approx([t1], abs=1e-11), where
        assert accepted < 60, where


HEALD_STEPS = {1: 1311, 2: 2404, 3: 20957, 4: 8147}  # measured before known breaks existed


@pytest.fixture(scope="module")
def heald_driver(tmp_path_factory):
    return _driver("heald_frame", tmp_path_factory.mktemp("kb_heald_frame"))


def test_heald_frame_solvers_locate_the_same_dwell_events(heald_driver):
    """heald_frame's verification run (two frame cycles; the stop time is
    the twelfth dwell event, the root of sin(phi / 2) at phi = 4 pi): every
    solver locates the same eleven dwell events before the stop time, with
    the steps measured before known breaks existed (HEALD_STEPS) to within
    a few percent.  (Whether the
    root at the stop time itself shows a sign change there is decided by
    the last ulp of phi: it is left out.)"""
    model = load_model("heald_frame")
    stop = model.stop_time
    before = {}
    for solver, steps in HEALD_STEPS.items():
        run = Run(heald_driver, "plain", stop, model.step_size, f"solver={solver}")
        accepted, rejected, rhs, events, known = run.steps
        assert accepted < 1.1 * steps, (solver, run.steps)
        assert events in (11, 12) and len(run.events) == events, (solver, run.events)
        before[solver] = [t for t in run.events if t < stop - 1e-9]
    assert len(before[1]) == 11
    for solver in (2, 3, 4):
        assert before[solver] == pytest.approx(before[1], abs=1e-9), solver
