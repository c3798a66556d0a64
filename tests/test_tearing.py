"""The block-triangular split of implicit models (loomfmu.export.tearing).

The split is checked against the equations themselves: at points in every
mode, the full system F(w) = 0 is solved by CasADi's Newton on all the
unknowns; the torn form's closed forms must give the same unknowns, and
Newton on the torn unknowns alone (in Python, with the generated residual and
its Jacobian) must reach the same solution.  The FMU-level comparison (the
runtime with and without tearing) is in tests/test_newton_predictor.py.
"""
from __future__ import annotations

import itertools

import casadi as ca
import numpy as np
import pytest

from loomfmu.declare.model import Model
from loomfmu.export.dae import dae_form
from loomfmu.registry import load_model


def _funcs(dae):
    tr = dae.tearing
    args = [dae.t, dae.x, dae.u, dae.p, dae.q, dae.d]
    wh = ca.vertcat(dae.w, tr.h)
    return (ca.Function("full", [dae.w] + args, [dae.F]),
            ca.Function("pre", [dae.w] + args, [tr.pre_expr, tr.h_expr]),
            ca.Function("res", [wh] + args, [tr.res, tr.jac]),
            ca.Function("post", [wh] + args, [tr.post_expr]))


def _point(dae, rng, q):
    """Arguments at the declaration's start values, the states perturbed."""
    m = dae.model

    def start(sym):
        return np.array([m.var(str(s)).start for s in ca.vertsplit(sym)], float)
    x = start(dae.x) * (1 + 0.05 * rng.standard_normal(dae.nx)) + 1e-3 * rng.standard_normal(dae.nx)
    return [0.37, x, start(dae.u), start(dae.p), np.array(q, float), np.zeros(dae.d.numel())]


def _check_split(dae, args, w_guess):
    full, pre, res, post = _funcs(dae)
    tr = dae.tearing
    root = ca.rootfinder("root", "newton", full, {"abstol": 1e-13, "max_iter": 100})
    w = np.array(root(w_guess, *args)).ravel()
    assert np.max(np.abs(np.array(full(w, *args)))) < 1e-9
    scale = 1.0 + np.abs(w)
    wp, h = (np.array(v).ravel() for v in pre(w, *args))
    assert np.all(np.abs(wp - w[tr.pre]) <= 1e-12 * scale[tr.pre])
    wh = np.concatenate([w, h])
    assert np.max(np.abs(np.array(res(wh, *args)[0]))) < 1e-9
    assert np.all(np.abs(np.array(post(wh, *args)).ravel() - w[tr.post])
                  <= 1e-10 * scale[tr.post])
    # Newton on the torn unknowns alone, from a start 1 % off, then the rest
    v = np.concatenate([w_guess, h])
    v[tr.pre] = wp
    v[tr.torn] = w[tr.torn] * 1.01 + 1e-3
    for _ in range(30):
        f, jac = (np.array(a) for a in res(v, *args))
        step = np.linalg.solve(np.atleast_2d(jac), f.ravel())
        v[tr.torn] -= step
        if np.max(np.abs(step)) < 1e-14 * (1 + np.max(np.abs(v[tr.torn]))):
            break
    v[tr.post] = np.array(post(v, *args)).ravel()
    np.testing.assert_allclose(v[:len(w)], w, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("name", ["backrest", "backrest_regularized"])
def test_the_backrest_is_newton_on_its_accelerations_only(name):
    dae = dae_form(load_model(name))
    tr = dae.tearing
    assert tr is not None
    # a partition of w: 6 unknowns, of which Newton keeps at most 2
    assert sorted(tr.pre + tr.torn + tr.post) == list(range(dae.w.numel()))
    assert 1 <= len(tr.torn) <= 2 and len(tr.rows) == len(tr.torn)
    names = [str(s) for s in ca.vertsplit(dae.w)]
    assert {names[j] for j in tr.pre} == {"der(dphi1)", "der(phi2)"}
    # every mode of both pivots (stick, slip either way): the same solution
    rng = np.random.default_rng(1)
    values = [dae.model.mode_values[v.name] for v in dae.model.of_kind("mode")]
    for q in itertools.product(*values):
        args = _point(dae, rng, q)
        _check_split(dae, args, np.zeros(dae.w.numel()))


def test_a_mode_switched_coefficient_is_never_divided_by():
    """The backrest's friction rows read der(omega) = 0 while a pivot sticks:
    their coefficient of the friction moment is 0 then, so they may not give
    the moment in closed form (the split must hold in every mode)."""
    dae = dae_form(load_model("backrest"))
    tr = dae.tearing
    names = [str(s) for s in ca.vertsplit(dae.w)]
    assert {names[j] for j in tr.torn} == {"der(omega1)", "der(omega2)"}


def test_the_composed_loom_iterates_on_the_backrest_only():
    from loomfmu.machines.loom import scene
    from loomfmu.scene.compose import compose
    dae = dae_form(compose(scene(stop_time=0.1)))
    tr = dae.tearing
    names = [str(s) for s in ca.vertsplit(dae.w)]
    assert len(tr.torn) == 2 and all(names[j].startswith("der(back.") for j in tr.torn)
    assert all(not names[j].startswith(("der(back.", "back.")) for j in tr.pre[:10])
    assert len(tr.pre) + len(tr.post) == dae.w.numel() - 2
    # hoisting: the residual's subexpressions outside the loop are computed once
    assert tr.h.numel() > 0
    assert not ca.depends_on(tr.h_expr, dae.w)
    rng = np.random.default_rng(2)
    q = [dae.model.var(v.name).start for v in dae.model.of_kind("mode")]
    _check_split(dae, _point(dae, rng, q), np.zeros(dae.w.numel()))


def _lag_loop(nonlinear_in_both: bool) -> Model:
    m = Model("loop", description="two lags closing a loop", stop_time=1.0, step_size=0.1)
    x = m.state("x", 1.0, description="first lag")
    y = m.state("y", 0.5, description="second lag")
    a = m.algebraic("a", description="loop variable a")
    b = m.algebraic("b", description="loop variable b")
    m.eq(m.der(x), -x + a)
    m.eq(m.der(y), -y + b)
    m.eq((a ** 3 + a if nonlinear_in_both else a) - 0.3 * ca.sin(b) - y, 0)
    m.eq((b ** 3 + b if nonlinear_in_both else b) - 0.5 * ca.cos(a) - x, 0)
    return m


def test_a_loop_is_torn_at_one_unknown_and_its_derivatives_follow():
    dae = dae_form(_lag_loop(nonlinear_in_both=False))
    tr = dae.tearing
    assert len(tr.torn) == 1 and len(tr.post) == 3 and tr.pre == []
    rng = np.random.default_rng(3)
    _check_split(dae, _point(dae, rng, []), np.zeros(4))


def test_no_split_where_every_unknown_of_the_loop_is_nonlinear():
    # a and b both enter nonlinearly: no closed form for either, Newton on the
    # loop; the derivatives still follow after it
    dae = dae_form(_lag_loop(nonlinear_in_both=True))
    tr = dae.tearing
    assert tr is not None and len(tr.torn) == 2 and len(tr.post) == 2
    rng = np.random.default_rng(4)
    _check_split(dae, _point(dae, rng, []), np.zeros(4))


def test_explicit_models_and_single_nonlinear_unknowns_are_not_torn():
    assert dae_form(load_model("heald_frame")).tearing is None  # explicit
    m = Model("cubic", description="x' solves a cubic", stop_time=1.0, step_size=0.1)
    x = m.state("x", 1.0, description="state")
    m.eq(m.der(x) ** 3 + m.der(x) + x, 0)
    assert dae_form(m).implicit and dae_form(m).tearing is None
