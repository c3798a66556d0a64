"""The derivation reports as a machine designer reads them: the equations in
the derivation's named quantities, the laws' derivatives as formulas, and the
mesh's figure.

(The round trip, printed form against CasADi, is tests/test_readable.py's, and
so are the report's labels apart from the seeds' numbers and the figures of the
frames and the mesh in the report and on the FMU's page: they need each
model's whole report, whose SymPy forms one process then writes once.)
"""
from __future__ import annotations

import functools
import math
import re

import casadi as ca
import numpy as np
import pytest
import sympy

from loomfmu import MODELS, load_model
from loomfmu.inspection import readable
from loomfmu.inspection.readable.named import named_nodes


@functools.lru_cache(maxsize=None)
def shared_model(name: str):
    """One declaration of ``name`` for the tests of this file that only read it:
    the SymPy forms of its quantities (tens of seconds for the spindles) are
    kept per Model object, so they are computed once per process."""
    return load_model(name)




def _env(model, rng) -> dict[str, float]:
    """A point near the model's start: every variable, der(x), delayed value
    and the time, by name."""
    env = {}
    for v in model.variables:
        if v.kind == "mode":
            env[v.name] = float(v.start)
            continue
        base = v.start if v.start else (v.nominal or 1.0)
        env[v.name] = base * (1 + 0.05 * rng.uniform(-1, 1)) + 1e-3 * rng.uniform(-1, 1)
    for v in model.of_kind("state"):
        env[f"der({v.name})"] = (v.nominal or 1.0) * rng.uniform(-1, 1)
    for d in model.delays:
        env[d.sym.name()] = rng.uniform(0.5, 1.5)
    env[model.t.name()] = 0.37
    return env


def _quantity_values(model, env) -> list[tuple[str, float]]:
    """(symbol name, value) of every named quantity node the reports may use."""
    nodes = named_nodes(model)
    expr = ca.vertcat(*[e for e, _ in nodes])
    syms = ca.symvar(expr)
    f = ca.Function("q", [ca.vertcat(*syms)], [expr])
    vals = np.asarray(f([env[s.name()] for s in syms]).full()).ravel()
    return [(s.name, float(v)) for (_, s), v in zip(nodes, vals)]


def _shared_values(model, lst, env) -> list[tuple[str, float]]:
    """(xi name, value) of the listing's shared subexpressions at ``env``."""
    table = readable.symbols(model)
    names = sorted(env)
    args = [table.get(n) or readable.Var(n) for n in names]
    ren = {s: sympy.Dummy() for s, _ in lst.named}
    defs = [(ren.get(s, s), d.xreplace(ren)) for s, d in lst.named + lst.shared]
    g = sympy.lambdify(args, [s for s, _ in lst.shared], modules="numpy",
                       cse=lambda es: (defs, list(es)))
    with np.errstate(all="ignore"):
        vals = g(*[env[n] for n in names])
    return [(s.name, float(v)) for (s, _), v in zip(lst.shared, vals)]


@pytest.mark.parametrize("name", sorted(MODELS))
@pytest.mark.slow  # every model's listing: seconds each
def test_no_shared_subexpression_stands_for_a_named_quantity(name):
    """Where the derivation names a quantity, the equations use its symbol: no
    xi of the Equations section has the value of a named quantity (checked at
    two random points near the start, so that a coincidence cannot pass).

    Not the spindles: their derivation names element 1 only, and the other
    elements' entries (unnamed) take element 1's values wherever they share
    its length and diameter (two elements below the bolster by default, the
    symmetric entries of one element); there the equations must at least use
    element 1's matrices by name."""
    model = shared_model(name)
    if not model.quantities:
        pytest.skip(f"{name} keeps no derivation")
    lst = readable.listing(model)
    assert lst.named, f"{name}: no named quantity is used in its equations"
    if name.startswith("spindle"):
        used = {s.name.split("[")[0] for s, _ in lst.named}
        assert {"K_e", "M_t", "M_r"} <= used, used
        return
    clashes = None
    for seed in (3, 4):
        env = _env(model, np.random.default_rng(seed))
        qs = _quantity_values(model, env)
        found = {(x, q) for x, xv in _shared_values(model, lst, env) for q, qv in qs
                 if math.isfinite(xv) and abs(xv) > 1e-300
                 and abs(xv - qv) <= 1e-12 * abs(xv)}
        clashes = found if clashes is None else clashes & found
    assert not clashes, f"{name}: shared subexpressions equal to named quantities: " \
        f"{sorted(clashes)[:5]}"


def test_backrest_equations_are_written_in_its_quantities():
    """The backrest's equations need no xi: (7) reads with M_1, the friction
    laws with the normal forces N_1, N_2 and the friction radii."""
    lst = readable.listing(shared_model("backrest"))
    assert not lst.shared
    names = {s.name for s, _ in lst.named}
    assert {"M_1", "N_1", "N_2", "r_1f", "r_2f", "r_O2[0,0]"} <= names, names
    lhs, rhs = lst.equations[2]
    assert rhs == readable.QuantitySymbol("M_1", next(
        q.symbol for q in load_model("backrest").quantities if q.name == "M_1"))


def test_motion_law_derivatives_are_formulas_equal_to_ad():
    """H'(phi), H''(phi) are written out (no AD of the clamp: no floor's or
    fmax's derivative in them) and equal AD of H away from the dwell
    boundaries, for the corrected and the printed law."""
    from loomfmu.models.heald_common import motion_law, shaft_angle, stroke_derivatives
    phi = ca.SX.sym("phi")
    xs = np.random.default_rng(7).uniform(-15.0, 30.0, 3000)
    for k_H in (9 / 7, 1.2):
        for end_dwell in ("corrected", "printed"):
            H = motion_law(phi, 0.029, k_H, end_dwell)
            ad1 = ca.jacobian(H, phi)
            ad2 = ca.jacobian(ad1, phi)
            _, _, phi_a, sign = shaft_angle(phi, end_dwell)
            H1, H2 = stroke_derivatives(phi_a, sign, 0.029, k_H)
            f = ca.Function("f", [phi], [ad1 - H1, ad2 - H2, H2])
            got = np.array([np.asarray(f(x)).ravel() for x in xs], dtype=float)
            assert np.abs(got[:, 0]).max() < 1e-12 and np.abs(got[:, 1]).max() < 1e-12
            assert np.abs(got[:, 2]).max() > 0.01  # not trivially zero
    m = load_model("heald_frame_rigid")
    forms = {q.name: f for q, _, f in readable.quantities_written(m)}
    for name in ("dH_dphi", "d2H_dphi2"):
        text = str(forms[name])
        assert "floor" not in text and ">=" not in text, text


@pytest.mark.slow  # the listing opens T with the derivation's forms: seconds
def test_heald_frame_outputs_and_equations_use_the_motion_law_and_stiffness():
    model = shared_model("heald_frame")
    lst = readable.listing(model)
    outs = {y.name: e for y, e in lst.outputs}
    dH = next(s for s, _ in lst.named if s.name == "dH_dphi")
    assert outs["h_dot"] == dH * readable.Var("omega")
    used = {s.name for s, _ in lst.named}
    assert {f"C_y[{i},{j}]" for i in range(3) for j in range(3) if (i, j) != (1, 1)} <= used
    assert {f"C_x[{i},{j}]" for i in range(3) for j in range(3) if (i, j) != (1, 1)} <= used


def _mesh(model) -> str:
    return next(f.svg for f in model.figures if f.name == "mesh")


@pytest.mark.parametrize("options", [{}, {"n_low": 3, "n_cone": 6}, {"n_cone": 1}])
def test_spindle_mesh_figure_has_the_models_nodes(options):
    """The mesh is drawn from the model's own mesh: as many nodes as the model
    has (n0, n1, ... in its states), one element fewer, for any build options."""
    model = load_model("spindle", **options)
    svg = _mesh(model)
    nodes = {v.name.split(".")[0] for v in model.of_kind("state")
             if re.fullmatch(r"n\d+\.\w+", v.name)}
    assert svg.count('class="node"') == len(nodes)
    assert svg.count('class="element"') == len(nodes) - 1
    for k in range(len(nodes)):
        assert f">n{k}<" in svg
    modal = load_model("spindle_modal", **options)
    assert _mesh(modal).count('class="node"') == len(nodes)


