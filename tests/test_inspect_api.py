"""loomfmu.inspect(model): a model's derivation in Python (SymPy and numpy).

The heald frame's stiffness is checked against an independent oracle: the
numpy inverse of its influence matrix equals both the symbolic inverse and
the seed's closed form, at the defaults and at other parameter values.
"""
from __future__ import annotations

import doctest
import inspect as std_inspect
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest
import sympy

import loomfmu
from loomfmu import Model, load_model
from loomfmu.inspection import core as inspection
from loomfmu.inspection import readable


def test_docstring_example_runs():
    result = doctest.testmod(inspection, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 8 and result.failed == 0


def test_the_name_inspect_is_the_function_and_stdlib_inspect_is_intact():
    assert callable(loomfmu.inspect) and loomfmu.inspect is inspection.inspect
    from loomfmu import inspect as fn
    assert fn is inspection.inspect
    # modules of the package that use the standard library's inspect still get it
    from loomfmu import registry
    from loomfmu.fmu import documentation as fmu_doc
    assert fmu_doc.inspect is std_inspect and registry.inspect is std_inspect
    assert "inspect" in loomfmu.__all__


def test_import_loomfmu_does_not_import_sympy():
    code = "import sys, loomfmu; print('sympy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"


def test_cli_subcommand_still_reaches_the_report(capsys, tmp_path):
    from loomfmu.cli.dispatch import main
    out = tmp_path / "r.md"
    assert main(["inspect", "two_mass_force", "--format", "md", "--out", str(out)]) == 0
    assert out.read_text().startswith("# two_mass_force")


def test_heald_frame_stiffness_is_the_inverse_of_the_influence_matrix():
    info = loomfmu.inspect("heald_frame")
    assert {"delta_y", "C_y", "C_y_inv"} <= set(info.names)
    for values in ({}, {"E": 1.5e11, "l_n": 0.3}):
        delta = info.value("delta_y", **values)
        assert delta.shape == (3, 3)
        want = np.linalg.inv(delta)
        for name in ("C_y", "C_y_inv"):
            got = info.value(name, **values)
            assert np.allclose(got, want, rtol=1e-10, atol=0), (name, values)
    # the values change with the parameters (not cached at the defaults)
    assert not np.allclose(info.value("C_y"), info.value("C_y", E=1.5e11))


def test_values_given_at_construction_and_at_the_call():
    model = load_model("heald_frame")
    E = model.var("E").start
    base = loomfmu.inspect(model).value("delta_y11")
    halved = loomfmu.inspect(model, E=2 * E)
    assert halved.value("delta_y11") == pytest.approx(base / 2, rel=1e-12)
    assert halved.value("delta_y11", E=E) == pytest.approx(base, rel=1e-12)
    assert halved.values == {"E": 2 * E}


def test_sympy_forms_match_casadi():
    info = loomfmu.inspect("heald_frame")
    C = info.sympy("C_y")
    assert isinstance(C, sympy.MatrixBase) and C.shape == (3, 3)
    syms = info.symbols
    point = {syms[v.name]: v.start for v in info.variables if v.kind == "parameter"}
    got = np.array(C.subs(point).evalf(), dtype=float)
    assert np.allclose(got, info.value("C_y"), rtol=1e-12)
    d11 = info.sympy("delta_y11")
    assert isinstance(d11, sympy.Expr) and d11.free_symbols <= set(syms.values())
    assert "E" in info.latex("delta_y11")


def test_equations_and_variables():
    model = load_model("heald_frame_rigid")
    info = loomfmu.inspect(model)
    assert len(info.equations) == len(model.equations)
    assert all(isinstance(e, sympy.Eq) for e in info.equations)
    assert [v.name for v in info.variables] == [v.name for v in model.variables]
    assert "heald_frame_rigid" in repr(info)


def _spring() -> Model:
    m = Model("spring", description="a mass on a spring")
    k = m.parameter("k", 100.0, unit="N/m", description="stiffness", min=1.0, max=1e4,
                    source="assumption: test")
    x = m.state("x", 0.1, unit="m", description="position")
    v = m.state("v", 0.0, unit="m/s", description="velocity")
    m.quantity("V", 0.5 * k * x**2, unit="N.m", description="potential energy")
    m.quantity("a", -k * x, unit="N", description="spring force")
    m.quantity("P", m.der(v) * v, description="needs der(v)")
    m.quantity("big", ca.DM.eye(12) * 2.0, description="a numeric matrix")
    m.eq(m.der(x), v)
    m.eq(m.der(v), -k * x)
    return m


def test_states_take_their_start_or_a_given_value():
    info = loomfmu.inspect(_spring())
    assert info.value("V") == pytest.approx(0.5 * 100 * 0.1**2)
    assert info.value("V", x=0.2, k=50.0) == pytest.approx(0.5 * 50 * 0.04)
    big = info.value("big")
    assert big.shape == (12, 12) and np.array_equal(big, 2 * np.eye(12))
    assert info.value("P", **{"der(v)": 3.0, "v": 2.0}) == pytest.approx(6.0)


@pytest.mark.parametrize("call, match", [
    (lambda: loomfmu.inspect("no_such_model"), "model = 'no_such_model'"),
    (lambda: loomfmu.inspect(42), "model = 42"),
    (lambda: loomfmu.inspect(_spring(), q=1.0), "q = 1.0: not a symbol"),
    (lambda: loomfmu.inspect(_spring(), k=0.5), "k = 0.5"),
    (lambda: loomfmu.inspect(_spring(), k=float("nan")), "k = nan"),
    (lambda: loomfmu.inspect(_spring(), k="stiff"), "k = 'stiff'"),
    (lambda: loomfmu.inspect(_spring()).value("nope"), "name = 'nope'.*allowed: V, a, P, big"),
    (lambda: loomfmu.inspect(_spring()).sympy("nope"), "name = 'nope'"),
    (lambda: loomfmu.inspect(_spring()).value("P"),
     r"no value for der\(v\).*\*\*\{'der\(v\)': \.\.\.\}"),
    (lambda: loomfmu.inspect(_spring()).value("V", k=1e9), "k = 1000000000.0"),
])
def test_bad_input_is_refused_naming_the_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_non_finite_quantity_is_refused():
    m = Model("div", description="a quantity that divides by a parameter")
    g = m.parameter("g", 1.0, description="a divisor", min=0.0, source="assumption: test")
    x = m.state("x", 0.0, description="x")
    m.quantity("inv", 1 / g, description="one over g")
    m.eq(m.der(x), g)
    with pytest.raises(ValueError, match="inv is not finite"):
        loomfmu.inspect(m).value("inv", g=0.0)


def test_quantity_symbols_print_their_latex_as_mathml():
    assert readable.symbol_mathml(r"\delta_{11}") == "<msub><mi>\u03b4</mi><mn>11</mn></msub>"
    assert readable.symbol_mathml(r"\mathbf{C}_x") == \
        "<msub><mi>\U0001d402</mi><mi>x</mi></msub>"
    assert "mover" in readable.symbol_mathml(r"\dot{x}")
    with pytest.raises(ValueError, match="symbol"):
        readable.symbol_mathml(r"\frac{a}{b}")
    q = readable.QuantitySymbol("ratio", r"\frac{a}{b}")  # outside the subset: its name
    assert "ratio" in readable.mathml_line(q) and readable.to_latex(q) == r"\frac{a}{b}"
