"""Code generation: which event indicators depend on time and parameters only
(codegen.event_time_only, read by the step loop to land steps on known
breaks), and parameter folding (tests added with it)."""
from __future__ import annotations

import math

import casadi as ca

from loomfmu import Model
from loomfmu.codegen import declaration_source, event_time_only, model_guid
from loomfmu.ode import dae_form


def _timer_model() -> Model:
    m = Model("timer", stop_time=1.0, step_size=0.1)
    period = m.parameter("period", 0.3, unit="s", description="period of the clock",
                         source="assumption: test", min=0.01, max=10.0)
    u = m.input("u", 0.0, description="an input")
    x = m.state("x", 0.0, unit="m", description="position")
    m.eq(m.der(x), u - x)
    m.event("clock", ca.sin(math.pi * m.t / period), description="time and parameter only")
    m.event("position", x - 0.5, description="depends on the state")
    m.event("input", u - 0.5 * period, description="depends on an input")
    m.event("rate", m.der(x) - 0.1, description="depends on an unknown")
    m.output("x_out", x, unit="m", description="position")
    return m


def test_event_time_only_marks_indicators_of_time_and_parameters():
    m = _timer_model()
    dae = dae_form(m)
    assert event_time_only(dae) == [1, 0, 0, 0]
    src = declaration_source(m, dae, model_guid(m, dae))
    assert "event_time_only[] = {\n    1,\n    0,\n    0,\n    0\n}" in src
