"""The declaration layer, the explicit form and the Python front door reject
bad input with ValueError naming the argument and the allowed range."""
from __future__ import annotations

import math

import pytest

from loomfmu import Model, build_fmu, load_model
from loomfmu.export.dae import explicit_ode
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import simulate


def small_model():
    m = Model("tiny", stop_time=1.0, step_size=0.1)
    k = m.parameter("k", 2.0, unit="1/s", description="decay rate", source="assumption: test",
                    min=0.0, max=10.0)
    x = m.state("x", 1.0, unit="m", description="position")
    m.eq(m.der(x), -k * x)
    m.output("x_out", x, unit="m", description="position")
    return m


def test_small_model_resolves_and_matches_exact_solution():
    m = small_model()
    ref = reference(m, rtol=1e-10, atol=1e-12)
    assert ref.y["x"][-1] == pytest.approx(math.exp(-2.0), rel=1e-8)


@pytest.mark.parametrize("call, match", [
    (lambda m: m.parameter("p", 1.0, description="d", source=""), "source"),
    (lambda m: m.parameter("q", 1.0, unit="furlong", description="d", source="s"), "unit"),
    (lambda m: m.parameter("k", 1.0, description="d", source="s"), "declared twice"),
    (lambda m: m.parameter("r", 11.0, description="d", source="s", max=10.0), "range"),
    (lambda m: m.state("1x", 0.0, description="d"), "identifier"),
    (lambda m: m.state("s", 0.0), "description"),
    (lambda m: m.der(m.var("k").sym), "not a declared state"),
    (lambda m: m.var("nope"), "no variable"),
    (lambda m: m.port("p", "flange", speed="nope"), "not a declared variable"),
])
def test_declaration_errors(call, match):
    with pytest.raises(ValueError, match=match):
        call(small_model())


def test_equation_count_must_match_unknowns():
    m = small_model()
    m.state("y", 0.0, description="extra")
    with pytest.raises(ValueError, match="1 equations for 2 unknowns"):
        explicit_ode(m)


def test_nonlinear_in_derivatives_is_rejected():
    m = Model("nl")
    x = m.state("x", 1.0, description="x")
    m.eq(m.der(x) ** 3, -x)
    with pytest.raises(ValueError, match="nonlinear"):
        explicit_ode(m)


@pytest.mark.parametrize("kw, match", [
    ({"t_end": -1.0}, "t_end"), ({"rtol": 0.0}, "rtol"), ({"atol": -1.0}, "atol"),
    ({"values": {"nope": 1.0}}, "not variables"), ({"values": {"k": 99.0}}, "range"),
])
def test_reference_arguments(kw, match):
    with pytest.raises(ValueError, match=match):
        reference(small_model(), **kw)


def test_front_door_arguments(tmp_path):
    with pytest.raises(ValueError, match="fmi_version"):
        build_fmu(small_model(), out_dir=tmp_path, fmi_version=1)
    with pytest.raises(ValueError, match="model"):
        load_model("loom")
    with pytest.raises(ValueError, match="solver"):
        simulate(tmp_path / "x.fmu", solver="euler")
    with pytest.raises(ValueError, match="rtol"):
        simulate(tmp_path / "x.fmu", rtol=-1)


@pytest.mark.slow
def test_small_model_fmu_matches_exact_solution(tmp_path):
    res = build_fmu(small_model(), out_dir=tmp_path)
    assert res.problems == []
    for solver in ("dopri5", "rodas4", "rk4"):
        run = simulate(res.path, solver=solver, rtol=1e-8, atol=1e-12, output=["x_out"],
                       values={"solver_h_fixed": 1e-3})
        exact = [math.exp(-2.0 * t) for t in run.t]
        assert max(abs(a - b) for a, b in zip(run.y["x_out"], exact)) < 1e-7


def test_delay_tau_of_parameters_only():
    m = small_model()
    x = m.var("x").sym
    z = m.algebraic("z", description="an algebraic variable")
    d = m.delay("xd", x, m.var("k").sym, max_delay=1.0, description="x, k ago")
    for bad in (z, m.der(x), d, x, m.t):
        with pytest.raises(ValueError, match="parameters only"):
            m.delay("bad", x, 0.1 + bad, max_delay=1.0)


def test_event_reassigned_to_another_mode_and_mode_without_rule_are_rejected():
    from loomfmu.export.dae import dae_form
    m = small_model()
    x = m.var("x").sym
    a = m.mode("qa", 0, (0, 1), description="mode a")
    b = m.mode("qb", 0, (0, 1), description="mode b")
    m.event("e", x - 0.5, description="x passes 0.5")
    m.mode_rule(a, 1.0, events=["e"])
    with pytest.raises(ValueError, match="one mode per event"):
        m.mode_rule(b, 1.0, events=["e"])
    with pytest.raises(ValueError, match="no mode_rule"):
        dae_form(m)


def test_delays_with_events_are_refused():
    from loomfmu.export.dae import dae_form
    m = small_model()
    x = m.var("x").sym
    m.delay("xd", x, 0.1, max_delay=1.0, description="x, 0.1 s ago")
    m.event("e", x - 0.5, description="x passes 0.5")
    with pytest.raises(ValueError, match="delays together with event"):
        dae_form(m)
