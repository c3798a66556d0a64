"""Code generation: clock states and the event indicators whose zeros are
known ahead (codegen.clock_states, event_time_only: the step loop lands
steps on such breaks), and parameter folding (folded functions equal the
unfolded ones; k recomputed when a parameter changes, in a real FMU)."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from fmpy import simulate_fmu

from loomfmu import Model, build_fmu
from loomfmu.export.codegen import (
    FUNCTIONS,
    casadi_functions,
    clock_states,
    declaration_source,
    event_time_only,
    model_guid,
    n_folded,
)
from loomfmu.export.dae import dae_form
from loomfmu.registry import MODELS, load_model


def _timer_model() -> Model:
    m = Model("timer", stop_time=1.0, step_size=0.1)
    period = m.parameter("period", 0.3, unit="s", description="period of the clock",
                         source="assumption: test", min=0.01, max=10.0)
    u = m.input("u", 0.0, description="an input")
    x = m.state("x", 0.0, unit="m", description="position")
    phase = m.state("phase", 0.0, unit="rad", description="advances at a fixed speed")
    drive = m.state("drive", 0.0, unit="rad", description="advances at the input's speed")
    m.eq(m.der(x), u - x)
    m.eq(m.der(phase), 2 * math.pi / period)
    m.eq(m.der(drive), u)
    m.event("clock", ca.sin(math.pi * m.t / period), description="time and parameter only")
    m.event("position", x - 0.5, description="depends on the state")
    m.event("input", u - 0.5 * period, description="depends on an input")
    m.event("rate", m.der(x) - 0.1, description="depends on an unknown")
    m.event("phase", ca.sin(phase + m.t), description="a clock state of level 1")
    m.event("drive", ca.sin(drive) + period, description="a clock state of level 2")
    m.output("x_out", x, unit="m", description="position")
    return m


def test_clock_states_and_known_breaks():
    m = _timer_model()
    dae = dae_form(m)
    assert clock_states(dae) == [0, 1, 2]
    assert event_time_only(dae) == [1, 0, 2, 0, 1, 2]
    src = declaration_source(m, dae, model_guid(m, dae))
    assert "event_time_only[] = {\n    1,\n    0,\n    2,\n    0,\n    1,\n    2\n}" in src
    assert "clock_state[] = {\n    0,\n    1,\n    2\n}" in src


def test_heald_frames_phase_is_a_clock_of_the_held_input():
    """The dwell indicators use the crank angle phi, whose derivative is the
    input omega: known ahead while the input is held."""
    dae = dae_form(load_model("heald_frame_rigid"))
    assert clock_states(dae) == [2]
    assert event_time_only(dae) == [2, 2, 2]


# ---- parameter folding ------------------------------------------------------


def _start(model: Model, kind: str) -> np.ndarray:
    return np.array([v.start if v.start is not None and math.isfinite(v.start) else 0.1
                     for v in model.of_kind(kind)])


def _random_point(model: Model, dae, rng) -> list:
    """(t, x, w, u, p, q, d, u_rate, d_rate) near the model's start."""
    p = _start(model, "parameter") * (1 + 0.01 * rng.standard_normal(dae.p.numel()))
    return [0.37, _start(model, "state") + 0.1 * rng.standard_normal(dae.nx),
            rng.standard_normal(dae.w.numel()), _start(model, "input"), p,
            np.array([v.start for v in model.of_kind("mode")], dtype=float),
            rng.standard_normal(dae.d.numel()), rng.standard_normal(dae.u.numel()),
            rng.standard_normal(dae.d.numel())]


def _worst_difference(unfolded, folded, point, k) -> tuple[float, str]:
    """Largest difference between the functions' outputs, relative to the
    output's largest finite entry (and where)."""
    worst, where = 0.0, ""
    for fa, fb in zip(unfolded, folded):
        if fa.name().endswith("_pre"):
            continue
        pt = list(point)
        extra = fa.size1_in(2) - len(pt[2])  # a torn model's tres, tpost read [w; h]
        if extra > 0:
            pt[2] = np.concatenate([pt[2], np.linspace(0.3, 1.7, extra)])
        ra, rb = fa.call(pt + [np.zeros(0)]), fb.call(pt + [k])
        for i, (a, b) in enumerate(zip(ra, rb)):
            a, b = np.array(a, dtype=float), np.array(b, dtype=float)
            fin = np.isfinite(a)
            assert np.array_equal(fin, np.isfinite(b)), (fa.name(), i)
            scale = np.max(np.abs(a[fin]), initial=1.0)
            err = np.max(np.abs(a - b)[fin], initial=0.0) / scale
            if err > worst:
                worst, where = err, f"{fa.name()}:{fa.name_out(i)}"
    return worst, where


@pytest.mark.parametrize("name", list(MODELS))
def test_folded_functions_equal_unfolded(name):
    model = load_model(name)
    dae = dae_form(model)
    unfolded, folded = casadi_functions(dae, fold=False), casadi_functions(dae)
    assert n_folded(unfolded) == 0
    if dae.p.numel() and name != "loom_shaft":  # loom_shaft: nothing parametric to fold
        assert n_folded(folded) > 0
        pre = FUNCTIONS.index("pre")
        assert sum(f.n_instructions() for i, f in enumerate(folded) if i != pre) < \
            sum(f.n_instructions() for i, f in enumerate(unfolded) if i != pre)
    rng = np.random.default_rng(16)
    for _ in range(3):
        point = _random_point(model, dae, rng)
        k = np.array(folded[FUNCTIONS.index("pre")].call(point + [np.zeros(0)])[0]).ravel()
        worst, where = _worst_difference(unfolded, folded, point, k)
        assert worst <= 1e-14, where
        if k.size:  # the folded functions do read k: a wrong k changes them
            worst, _ = _worst_difference(unfolded, folded, point, k * (1 + 1e-6))
            assert worst > 1e-12


# ---- k recomputed when a parameter changes (a real FMU) ---------------------


def _decay_model() -> Model:
    """x' = -(a^2 + 1) x: the rate a^2 + 1 is parameter-only (folded into k)."""
    m = Model("folded_decay", stop_time=1.0, step_size=0.1)
    a = m.parameter("a", 1.0, unit="", description="rate parameter",
                    source="assumption: test", min=0.0, max=5.0)
    x = m.state("x", 1.0, unit="m", description="position")
    m.eq(m.der(x), -(a * a + 1.0) * x)
    m.output("x_out", x, unit="m", description="position")
    return m


@pytest.fixture(scope="module")
def decay_fmu(tmp_path_factory):
    dae = dae_form(_decay_model())
    assert n_folded(casadi_functions(dae)) >= 1  # something to fold, else the test is moot
    return build_fmu(_decay_model(), out_dir=tmp_path_factory.mktemp("fold"),
                     validate=False).path


def _run(s, a: float | None, t_end: float = 0.5) -> float:
    """x(t_end) after outputs were read in initialization mode (k computed
    then), then a set (if given) before initialization ends."""
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.get("x_out")  # evaluates the model: k from the parameters as they are now
    if a is not None:
        s.set(a=a)
    s.fmu.exitInitializationMode()
    t, h = 0.0, 0.05
    while t < t_end - 1e-12:
        s.fmu.doStep(t, h)  # raises on a status other than OK
        t += h
    return s.get("x_out")[0]


@pytest.mark.slow
def test_parameter_set_after_evaluation_recomputes_k(decay_fmu, slave_factory):
    s = slave_factory(decay_fmu)
    x = _run(s, 2.0)
    assert x == pytest.approx(math.exp(-5.0 * 0.5), rel=1e-5)  # not exp(-2 * 0.5)
    s.fmu.reset()  # back to the start values: a = 1
    assert _run(s, None) == pytest.approx(math.exp(-2.0 * 0.5), rel=1e-5)
    s.fmu.reset()
    assert _run(s, 0.5) == pytest.approx(math.exp(-1.25 * 0.5), rel=1e-5)


@pytest.mark.slow
def test_fmpy_start_values_reach_the_folded_terms(decay_fmu):
    for a in (0.0, 3.0):
        r = simulate_fmu(str(decay_fmu), stop_time=0.5, output_interval=0.05,
                         start_values={"a": a}, output=["x_out"])
        assert r["x_out"][-1] == pytest.approx(math.exp(-(a * a + 1) * 0.5), rel=1e-5)


@pytest.mark.slow
def test_fmu_state_from_other_parameters_recomputes_k(decay_fmu, slave_factory):
    """A state serialized by an instance with a = 2, set into one that ran with
    a = 0.5: the restored parameters' folded terms drive the rest of the run."""
    a, b = slave_factory(decay_fmu, "a"), slave_factory(decay_fmu, "b")
    _run(a, 2.0, t_end=0.25)
    blob = a.fmu.serializeFMUstate(a.fmu.getFMUstate())
    _run(b, 0.5, t_end=0.25)  # b evaluated its model: k from a = 0.5
    b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
    for k in range(5):
        b.fmu.doStep(0.25 + 0.05 * k, 0.05)
    assert b.get("x_out")[0] == pytest.approx(math.exp(-5.0 * 0.5), rel=1e-5)
