"""Declaration checks that a table row cannot show (the bad calls themselves
are rows of benchmarks/api_misuse.py, run by tests/test_api_validation.py):
the reserved names are exactly the names a built FMU adds, good texts and
column equations still build and run, the refused calls leave the model as
it was, and good values for settings still reach the FMU."""
from __future__ import annotations

import math

import casadi as ca
import fmpy
import numpy as np
import pytest

from loomfmu import build_fmu
from loomfmu.declare.checks import check_text
from loomfmu.declare.model import Model, reserved_names
from loomfmu.declare.solvers import SETTINGS, SOLVERS
from loomfmu.verification.verify import simulate

#: texts that XML and C handle with escaping: they must still build
GOOD_TEXT = 'Drehzahl ü 1/min — ≤ <&> "q" */ %s \\ line1\nline2\ttab'


def _decay(description: str = "x") -> Model:
    """x' = -k x, x(0) = 1 (exact: exp(-k t)), with a delayed copy of x."""
    m = Model("decay", stop_time=1.0, step_size=0.5, description=description)
    x = m.state("x", 1.0, description=description)
    k = m.parameter("k", 2.0, description=description, source=description, min=0.0, max=10.0)
    d = m.delay("x_old", x, 0.1, max_delay=1.0, description=description)
    m.eq(m.der(x), -k * x)
    m.output("y", x, description=description)
    m.output("y_old", d, description=description)
    return m


@pytest.fixture(scope="module")
def decay_fmu(tmp_path_factory):
    return build_fmu(_decay(GOOD_TEXT), out_dir=tmp_path_factory.mktemp("decay"))


@pytest.mark.slow
def test_reserved_names_are_the_names_every_fmu_adds(decay_fmu):
    """The names a built FMU has beyond the declared variables are reserved,
    and every solver setting of codegen is among them."""
    md = fmpy.read_model_description(str(decay_fmu.path))
    declared = {v.name for v in _decay().variables}
    added = {v.name for v in md.modelVariables} - declared
    assert added and added <= set(reserved_names())
    assert {s.name for s in SETTINGS} <= set(reserved_names())
    assert "time" in reserved_names()  # FMPy's result column


@pytest.mark.slow
def test_texts_xml_and_c_can_hold_still_build_and_run(decay_fmu):
    assert decay_fmu.problems == []
    md = fmpy.read_model_description(str(decay_fmu.path))
    assert md.description == GOOD_TEXT
    run = simulate(decay_fmu.path, output=["y"], rtol=1e-9, atol=1e-12)
    assert np.allclose(run.y["y"], np.exp(-2.0 * run.t), rtol=1e-6, atol=0)


@pytest.mark.slow
def test_settings_values_in_their_range_reach_the_fmu(decay_fmu):
    """values={'solver': 3} (rk4) is accepted and used: rk4 with a coarse
    fixed step is far less accurate than dopri5 at a tight tolerance."""
    exact = lambda run: float(np.max(np.abs(run.y["y"] - np.exp(-2.0 * run.t))))  # noqa: E731
    fine = simulate(decay_fmu.path, output=["y"], rtol=1e-10, atol=1e-13)
    rk4 = simulate(decay_fmu.path, output=["y"], values={"solver": 3, "solver_h_fixed": 0.1})
    assert exact(rk4) > 100 * exact(fine)
    with pytest.raises(ValueError, match=rf"values\['solver'\] = {len(SOLVERS) + 1}; allowed: "
                       r"1 \(dopri5\)"):
        simulate(decay_fmu.path, values={"solver": len(SOLVERS) + 1})
    with pytest.raises(ValueError, match=r"values\['k'\] = 11.*\[0, 10\]"):
        simulate(decay_fmu.path, values={"k": 11.0})


def test_column_equations_still_declare_one_equation_per_row():
    m = Model("col")
    x = m.state("x", 1.0, description="x")
    z = m.algebraic("z", description="z")
    m.eq(ca.vertcat(m.der(x), z), ca.vertcat(-x, 2 * x))
    m.eq(z - 2 * x)
    assert [e.shape for e in m.equations] == [(2, 1), (1, 1)]


@pytest.mark.parametrize("call", [
    lambda m, x: m.output("y", ca.vertcat(x, x), description="y"),
    lambda m, x: m.output("y", ca.SX(0, 1), description="y"),
    lambda m, x: m.delay("d", ca.vertcat(x, x), 0.1, max_delay=1.0, description="d"),
    lambda m, x: m.event("e", ca.horzcat(x, x)),
    lambda m, x: m.state("solver_h_max", 0.0, description="s"),
    lambda m, x: m.state("z", 0.0, description="a\x00b"),
])
def test_a_refused_declaration_leaves_the_model_unchanged(call):
    m = Model("m")
    x = m.state("x", 1.0, description="x")
    before = ([v.name for v in m.variables], len(m.delays), len(m.events))
    with pytest.raises(ValueError):
        call(m, x)
    assert ([v.name for v in m.variables], len(m.delays), len(m.events)) == before


@pytest.mark.slow
def test_a_vector_output_is_refused_before_any_build(tmp_path):
    """The adversarial case: a 2-vector output built an FMU whose fmi2DoStep
    overran a stack buffer.  Now the declaration names the output."""
    m = Model("vec", stop_time=1.0, step_size=0.5)
    x = m.state("x", 1.0, description="x")
    m.eq(m.der(x), -x)
    with pytest.raises(ValueError, match=r"output 'y': expr: a 2x1 expression; allowed: "
                                         r"a scalar \(1x1\)"):
        m.output("y", ca.vertcat(2 * x, 3 * x), description="a 2-vector")
    m.output("z", 5 * x, description="5 x")
    run = simulate(build_fmu(m, out_dir=tmp_path, validate=False).path, output=["z"],
                   rtol=1e-10, atol=1e-12)
    assert np.allclose(run.y["z"], 5 * np.exp(-run.t), rtol=1e-8)


def test_check_text():
    assert check_text("d", GOOD_TEXT) == GOOD_TEXT
    for bad in ("a\x00b", "\x1b", "\ud800", "\ufffe", 3, None):
        with pytest.raises(ValueError, match="^d"):
            check_text("d", bad)
    assert check_text("m", "ok: 5 %") == "ok: 5 %"
    for bad in ("two\nlines", "tab\there", "trigraph ??/"):
        with pytest.raises(ValueError, match="^m = .*allowed: printable text on one line"):
            check_text("m", bad, c_string=True)


@pytest.mark.slow
def test_build_fmu_makes_a_missing_nested_out_dir_and_refuses_a_file(tmp_path):
    m = Model("tiny", stop_time=1.0, step_size=0.5)
    x = m.state("x", 1.0, description="x")
    m.eq(m.der(x), -x)
    m.output("y", x, description="y")
    out = tmp_path / "a" / "b"
    assert build_fmu(m, out_dir=out, validate=False).path == out / "tiny.fmu"
    with pytest.raises(ValueError, match=r"^out_dir = .*tiny.fmu' is an existing file"):
        build_fmu(m, out_dir=out / "tiny.fmu", validate=False)
    assert math.isfinite(simulate(out / "tiny.fmu").y["y"][-1])
