"""The backrest's derivation kept as named quantities (Model.quantity): each
evaluates to what the equations use.  Lagrange's equations formed here from
the quantities T, V, Q reproduce the model's residuals; R2 and R1 give the
outputs N2, N1; T and V equal hand formulas; Q equals the seed's (7), (10);
the friction quantities are the model's event indicators, equations and mode
priority; the print defects B1-B4 are attached to the quantities they
affect, with the same text as the docstring."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from loomfmu import load_model
from loomfmu.mechanics.friction import BACKWARD, FORWARD, STUCK
from loomfmu.models import backrest as backrest_module

G = 9.81


@pytest.fixture(scope="module", params=[{}, {"shedding": False, "fronts": 2}],
            ids=["default", "two_fronts"])
def model(request):
    return load_model("backrest", **request.param)


def _q(model, name):
    hits = [q for q in model.quantities if q.name == name]
    assert len(hits) == 1, name
    return hits[0].expr


def _symbols(model):
    """Every symbol the model's expressions may hold: time, variables, der()."""
    syms = [model.t] + [v.sym for v in model.variables]
    syms += [model.der(v.sym) for v in model.of_kind("state")]
    return ca.vertcat(*syms)


def _points(model, n=8, seed=11):
    """Random values of every symbol (parameters at their starts, modes one of
    their values), as vectors in the order of :func:`_symbols`."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        vals = [rng.uniform(0, 1)]
        for v in model.variables:
            if v.kind == "parameter":
                vals.append(v.start)
            elif v.kind == "mode":
                vals.append(float(rng.choice([STUCK, FORWARD, BACKWARD])))
            elif v.kind == "state":
                vals.append(rng.normal(scale=0.3))
            elif v.kind == "input":
                vals.append(rng.normal(scale=2e-3))
            else:
                vals.append(rng.normal(scale=5.0))
        vals += list(rng.normal(scale=20.0, size=len(model.of_kind("state"))))
        yield np.array(vals)


def _evaluator(model, *exprs):
    f = ca.Function("f", [_symbols(model)], [ca.SX(e) for e in exprs])

    def call(point):
        out = f(point)
        out = out if isinstance(out, (list, tuple)) else [out]
        return [np.array(o, dtype=float).ravel() for o in out]
    return call


def _sym(model, name):
    return model.var(name).sym


def test_lagrange_from_T_V_Q_reproduces_the_model_residuals(model):
    """d/dt dL/dq' - dL/dq - Q, formed here from the quantities (chain rule
    written out in the test), equals the model's equations 3 and 4."""
    q = ca.vertcat(_sym(model, "dphi1"), _sym(model, "phi2"))
    qd = ca.vertcat(_sym(model, "omega1"), _sym(model, "omega2"))
    qdd = ca.vertcat(*[model.der(_sym(model, n)) for n in ("omega1", "omega2")])
    L = _q(model, "T") - _q(model, "V")
    mom = ca.gradient(L, qd)
    ours = ca.jacobian(mom, q) @ qd + ca.jacobian(mom, qd) @ qdd - ca.gradient(L, q) \
        - _q(model, "Q")
    residuals = ca.vertcat(*model.equations)
    ev = _evaluator(model, ours, residuals, _q(model, "lagrange"))
    found = set()
    for point in _points(model):
        a, eqs, declared = ev(point)
        np.testing.assert_allclose(declared, a, rtol=1e-12, atol=1e-9)
        rows = [int(np.argmin(np.abs(eqs - a_i))) for a_i in a]
        np.testing.assert_allclose(eqs[rows], a, rtol=1e-12, atol=1e-9)
        found.add(tuple(rows))
    assert found == {(2, 3)}   # always the same two equations: Lagrange's
    # the mass matrix is the Hessian of T in the rates
    ev = _evaluator(model, _q(model, "M_q"), ca.hessian(_q(model, "T"), qd)[0])
    for point in _points(model, n=2):
        a, b = ev(point)
        np.testing.assert_allclose(a, b, rtol=1e-14)


def test_T_and_V_equal_hand_formulas(model):
    p = {v.name: v.start for v in model.of_kind("parameter")}
    ev = _evaluator(model, _q(model, "T"), _q(model, "V"))
    point = next(_points(model))
    names = ["time"] + [v.name for v in model.variables]
    val = dict(zip(names, point))
    w1, w2 = val["omega1"], val["omega2"]
    phi1 = p["phi_n"] + val["dphi1"]
    T_hand = (0.5 * p["J_1"] * w1**2 + 0.5 * p["m_c"] * (p["r1"] * w1) ** 2
              + 0.5 * p["J_c"] * (w1 + w2) ** 2)
    V_hand = p["m_c"] * G * p["r1"] * math.sin(phi1)
    T, V = ev(point)
    assert T[0] == pytest.approx(T_hand, rel=1e-13)
    assert V[0] == pytest.approx(V_hand, rel=1e-13)


def test_Q_equals_the_seed_7_and_10_corrected(model):
    """Q from virtual work, with the weight's -dV/dq, against the seed's (7),
    (10) with B1 (r2 as the spring's arm), using the model's tension outputs
    (the seed counts the weight among the forces; here it is in V)."""
    p = {v.name: v.sym for v in model.of_kind("parameter")}
    outs = {v.name: v for v in model.of_kind("output")}
    S1, S2, F_s = outs["S1"].expr, outs["S2"].expr, outs["F_spring"].expr
    phi1 = p["phi_n"] + _sym(model, "dphi1")
    Q1 = ((S2 - S1) * p["r"] + S2 * p["r1"] * ca.sin(p["alpha2"] + phi1)
          - S1 * p["r1"] * ca.sin(p["alpha1"] + phi1) - p["m_c"] * G * p["r1"] * ca.cos(phi1)
          + F_s * p["r2"] * ca.sin(p["theta"]) + _sym(model, "M1f"))
    Q2 = p["r"] * (S2 - S1) + _sym(model, "M2f")
    q = ca.vertcat(_sym(model, "dphi1"), _sym(model, "phi2"))
    ev = _evaluator(model, _q(model, "Q") - ca.gradient(_q(model, "V"), q), ca.vertcat(Q1, Q2))
    for point in _points(model):
        a, b = ev(point)
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-9)


def test_reactions_give_the_normal_force_outputs(model):
    outs = {v.name: v.expr for v in model.of_kind("output")}
    ev = _evaluator(model, ca.norm_2(_q(model, "R_2")), outs["N2"],
                    ca.norm_2(_q(model, "R_1")), outs["N1"], _q(model, "N_1"),
                    _q(model, "N_2"))
    for point in _points(model):
        r2, n2, r1, n1, qn1, qn2 = ev(point)
        np.testing.assert_allclose(r2, n2, rtol=1e-13)
        np.testing.assert_allclose(r1, n1, rtol=1e-13)
        np.testing.assert_allclose([qn1[0], qn2[0]], [n1[0], n2[0]], rtol=1e-13)


def test_tension_quantities_are_the_outputs(model):
    outs = {v.name: v.expr for v in model.of_kind("output")}
    fronts = [q.name for q in model.quantities if q.name.startswith("S_2")]
    ev = _evaluator(model, _q(model, "S_1"), outs["S1"], sum(_q(model, n) for n in fronts),
                    outs["S2"], *[outs[n.replace("S_2_", "S2")] for n in fronts
                                  if n != "S_2"], *[_q(model, n) for n in fronts
                                                    if n != "S_2"])
    for point in _points(model):
        vals = ev(point)
        np.testing.assert_allclose(vals[0], vals[1], rtol=1e-13)
        np.testing.assert_allclose(vals[2], vals[3], rtol=1e-13)
        k = (len(vals) - 4) // 2
        for a, b in zip(vals[4:4 + k], vals[4 + k:]):
            np.testing.assert_allclose(a, b, rtol=1e-13)


def test_friction_quantities_are_the_model_events_equations_and_priority():
    model = load_model("backrest")
    p = {v.name: v.start for v in model.of_kind("parameter")}
    events = {e.name: e.expr for e in model.events}
    for i, joint in ((1, "O1"), (2, "O2")):
        r_f = p[f"rho{i}"] * p[f"mu{i}"] / math.sqrt(1 + p[f"mu{i}"] ** 2)
        assert float(ca.evalf(ca.substitute(
            _q(model, f"r_{i}f"), ca.vertcat(*[v.sym for v in model.of_kind("parameter")]),
            ca.DM([v.start for v in model.of_kind("parameter")])))) == pytest.approx(r_f)
        prio = np.array(ca.DM(_q(model, f"{joint}_mode_priority"))).ravel().tolist()
        assert prio == list(model.mode_values[f"mode_{joint}"])
        assert prio == [STUCK, FORWARD, BACKWARD]
        ev = _evaluator(model, _q(model, f"{joint}_event_indicator"),
                        events[f"switch_{joint}"], _q(model, f"{joint}_law"),
                        ca.vertcat(*model.equations), _q(model, f"{joint}_static_limit"),
                        _q(model, f"{joint}_kinetic_limit"),
                        model.mode_valid[f"mode_{joint}"], _q(model, f"{joint}_stick_margin"),
                        _q(model, f"{joint}_slip_condition"))
        for point in _points(model):
            ind, ev_expr, law, eqs, st, kin, valid, margin, slip = ev(point)
            np.testing.assert_array_equal(ind, ev_expr)
            assert np.min(np.abs(eqs - law[0])) == 0.0   # one of the model's equations
            assert st[0] == pytest.approx(p["k_static"] * kin[0], rel=1e-14)
            names = ["time"] + [v.name for v in model.variables]
            mode = dict(zip(names, point))[f"mode_{joint}"]
            np.testing.assert_array_equal(valid, margin if mode == STUCK else slip)


def test_every_quantity_is_documented_and_in_derivation_order(model):
    for q in model.quantities:
        assert q.description and q.symbol and q.source and q.group, q.name
    groups = list(dict.fromkeys(q.group for q in model.quantities))
    order = ["coordinates and kinematics", "energies", "warp branches", "spring",
             "generalized forces (virtual work)", "Lagrange's equations", "reactions",
             "friction laws", "stick/slip in joint O1", "stick/slip in joint O2"]
    assert groups == order


def test_print_defects_are_next_to_the_quantities_they_affect():
    model = load_model("backrest")
    src = {q.name: q.source + " " + q.description for q in model.quantities}
    where = {"B1": ["M_s", "Q", "M_1"], "B2": ["F_0"], "B3": ["F_0"], "B4": ["R_2"]}
    for key, names in where.items():
        text = backrest_module.defect(key)
        printed, corrected = backrest_module.DEFECTS[key][1:3]
        assert f"printed {printed}, corrected {corrected}" in text
        assert text in backrest_module.__doc__, key
        for name in names:
            assert text in src[name], (key, name)
        others = [n for n, s in src.items() if f"defect {key} " in s and n not in names]
        assert others == [], (key, others)


def test_the_corrections_matter_B2_cosine_is_the_equilibrium():
    """B2: the printed m_c g r1 phi_n in (8) would not be the equilibrium; the
    corrected cosine makes Q_1 vanish at the start (no friction, S = S0)."""
    model = load_model("backrest")
    p = {v.name: v.start for v in model.of_kind("parameter")}
    psyms = ca.vertcat(*[v.sym for v in model.of_kind("parameter")])
    rest = ca.vertcat(_sym(model, "dphi1"), _sym(model, "phi2"), _sym(model, "omega1"),
                      _sym(model, "omega2"), _sym(model, "M1f"), _sym(model, "M2f"),
                      _sym(model, "letoff"), _sym(model, "warp_pull"), model.t)
    q = ca.vertcat(_sym(model, "dphi1"), _sym(model, "phi2"))
    Q = _q(model, "Q") - ca.gradient(_q(model, "V"), q)   # the weight as a force
    Q = ca.substitute(Q, rest, ca.DM.zeros(rest.numel()))
    Q = np.array(ca.evalf(ca.substitute(Q, psyms, ca.DM([v.start for v in
                                                             model.of_kind("parameter")]))))
    assert np.abs(Q).max() < 1e-9
    F0 = float(ca.evalf(ca.substitute(_q(model, "F_0"), psyms, ca.DM(
        [v.start for v in model.of_kind("parameter")]))))
    printed = F0 + p["m_c"] * G * p["r1"] * (p["phi_n"] - math.cos(p["phi_n"])) / (
        p["r2"] * math.sin(p["theta"]))
    # with the printed preload the lever would carry an unbalanced moment
    assert abs((printed - F0) * p["r2"] * math.sin(p["theta"])) > 10.0


def test_regularized_friction_law_is_the_model_equation():
    model = load_model("backrest_regularized")
    names = [q.name for q in model.quantities]
    assert "O1_mode_priority" not in names and "O1_event_indicator" not in names
    for joint in ("O1", "O2"):
        torque = _sym(model, f"M{joint[1]}f")
        ev = _evaluator(model, _q(model, f"{joint}_law") - torque,
                        ca.vertcat(*model.equations), _q(model, f"{joint}_kinetic_limit"))
        for point in _points(model, n=4):
            law, eqs, kin = ev(point)
            # the model's equation torque = law, written as torque - law = 0
            assert np.min(np.abs(eqs + law[0])) < 1e-12 * (1 + abs(law[0]))
            assert abs(law[0] + point[1 + [v.name for v in model.variables].index(
                f"M{joint[1]}f")]) <= kin[0] * (1 + 1e-12)


def test_energies_carry_the_unit_joule(model):
    """An energy is measured in J (the same base units as N.m, which reads as
    a moment)."""
    from loomfmu.declare.units import same_quantity
    energies = [q for q in model.quantities if "energy" in q.description.split(":")[0]]
    assert {q.name for q in energies} == {"T", "V"}
    assert [q.unit for q in energies] == ["J", "J"]
    assert same_quantity("J", "N.m")


def test_moment_about_O1_with_the_weight_vanishes_at_the_static_equilibrium(model):
    """Q leaves the roller's weight to V: Q_1 alone is a sizeable moment at
    the static equilibrium.  The quantity M_1 = Q_1 - dV/dphi1 (the seed's
    (7)) is printed beside it and is zero there."""
    from loomfmu.inspection.core import evaluate
    at_rest = {"M1f": 0.0, "M2f": 0.0, "time": 0.0}
    q1 = evaluate(model, _q(model, "Q")[0], at_rest).item()
    m1 = evaluate(model, _q(model, "M_1"), at_rest).item()
    assert abs(q1) > 1.0
    assert abs(m1) < 1e-9 * abs(q1)
    q = ca.vertcat(_sym(model, "dphi1"), _sym(model, "phi2"))
    ev = _evaluator(model, _q(model, "M_1"),
                    _q(model, "Q")[0] - ca.gradient(_q(model, "V"), q)[0])
    for point in _points(model, n=3):
        a, b = ev(point)
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-9)
    names = [q.name for q in model.quantities]
    assert names.index("M_1") == names.index("Q") + 1
