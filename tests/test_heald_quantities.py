"""The heald frame's derivation quantities: they evaluate to the
numbers the model's equations use, and the seed's closed form of C equals
the inverse of the influence matrix."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from loomfmu import load_model

MODELS = ["heald_frame", "heald_frame_planar", "heald_frame_rigid"]
RNG = np.random.default_rng(14)


class Evaluator:
    """Quantities, outputs and equation residuals of a model as numbers at
    one point: the default parameters with states, inputs and derivatives
    given (random where not given)."""

    def __init__(self, model):
        self.m = model
        self.vars = [v for v in model.variables if v.kind in ("parameter", "state", "input")]
        self.x = ca.vertcat(*[v.sym for v in self.vars])
        self.ders = model.ders()
        self.q = {q.name: q for q in model.quantities}

    def point(self, **given):
        vals = []
        for v in self.vars:
            if v.name in given:
                vals.append(given[v.name])
            elif v.kind == "parameter":
                vals.append(v.start)
            elif v.name == "phi":
                vals.append(RNG.uniform(0, 4 * math.pi))
            elif v.kind == "input":
                vals.append(v.start * RNG.uniform(0.5, 1.5))
            else:
                vals.append(RNG.normal() * (v.nominal or 1.0))
        return np.array(vals, dtype=float), RNG.normal(size=self.ders.shape[0])

    def __call__(self, expr, pt):
        f = ca.Function("f", [self.x, self.ders], [ca.SX(expr)])
        return np.array(f(*pt).full())

    def quantity(self, name, pt):
        return self(self.q[name].expr, pt)

    def output(self, name, pt):
        return float(self(self.m.var(name).expr, pt)[0, 0])

    def residual_blocks(self, pt):
        return [self(e, pt).ravel() for e in self.m.equations]


@pytest.fixture(scope="module", params=[(n, wt) for n in MODELS
                                        for wt in ("geometry", "input")])
def ev(request):
    name, wt = request.param
    return Evaluator(load_model(name, warp_tension=wt))


def test_every_quantity_is_documented_and_in_derivation_order(ev):
    groups = [q.group for q in ev.m.quantities]
    assert groups == sorted(groups, key=lambda g: int(g.split(".")[0])), groups
    for q in ev.m.quantities:
        assert q.description and q.symbol and q.source and q.group, q.name
    names = set(ev.q)
    assert {"phi_a", "H", "H_printed", "dl_shed", "f_y_warp", "f_x_warp"} <= names
    if ev.m.registry_name != "heald_frame_rigid":
        assert {"delta_y", "delta_yf", "C_y", "C_y_inv", "M_y", "J_x"} <= names
    if ev.m.registry_name == "heald_frame":
        assert {"delta_x", "C_x", "C_x_inv", "M_x", "M_x_printed"} <= names


def test_stiffness_is_the_inverse_of_delta_and_the_closed_form(ev):
    if ev.m.registry_name == "heald_frame_rigid":
        pytest.skip("no elastic coordinates")
    for axis in ("y", "x") if ev.m.registry_name == "heald_frame" else ("y",):
        for _ in range(3):
            pt = ev.point(l=RNG.uniform(0.5, 3.0), E=RNG.uniform(5e10, 2e11))
            delta = ev.quantity(f"delta_{axis}", pt)
            C_inv = ev.quantity(f"C_{axis}_inv", pt)
            C = ev.quantity(f"C_{axis}", pt)
            ref = np.linalg.inv(delta)
            scale = np.max(np.abs(ref))
            assert np.max(np.abs(C_inv - ref)) < 1e-10 * scale
            assert np.max(np.abs(C - ref)) < 1e-10 * scale   # the seed's closed form
            assert np.max(np.abs(C @ delta - np.eye(3))) < 1e-10
            d11 = ev.quantity(f"delta_{axis}11", pt)[0, 0]
            assert delta[0, 1] == pytest.approx(d11 / 2) and delta[0, 2] == 0.0


def test_slat_section_by_hand():
    """J_x of the seed's 100 x 10 x 1.4 mm box and m_l of the 1.8 m slat."""
    ev = Evaluator(load_model("heald_frame"))
    pt = ev.point()
    h1, b1, d1 = 0.100, 0.010, 0.0014
    assert ev.quantity("J_x", pt)[0, 0] == pytest.approx(
        (b1 * h1**3 - (b1 - 2 * d1) * (h1 - 2 * d1) ** 3) / 12, rel=1e-12)
    assert ev.quantity("J_y", pt)[0, 0] == pytest.approx(
        (h1 * b1**3 - (h1 - 2 * d1) * (b1 - 2 * d1) ** 3) / 12, rel=1e-12)
    area = h1 * b1 - (h1 - 2 * d1) * (b1 - 2 * d1)
    assert ev.quantity("m_l", pt)[0, 0] == pytest.approx(2700 * area * 1.8, rel=1e-12)
    M_x, M_x_pr = ev.quantity("M_x", pt).ravel(), ev.quantity("M_x_printed", pt).ravel()
    m_B = ev.quantity("m_B", pt)[0, 0]
    assert M_x[0] - M_x_pr[0] == pytest.approx(m_B * (33 / 140 - 33 / 280), rel=1e-12)


def seed_motion_law(phi, h_m=0.029, k=9 / 7, printed=False):
    """Seed 000's motion law written out again: k_f = [1 + phi/2pi],
    phi_r = phi - 2pi(k_f - 1), the three cases of phi_a."""
    k_f = math.floor(1 + phi / (2 * math.pi))
    phi_r = phi - 2 * math.pi * (k_f - 1)
    a, b = 40 * math.pi / 180, 320 * math.pi / 180
    if phi_r <= a:
        phi_a = 0.0
    elif phi_r <= b:
        phi_a = phi_r - a
    else:
        phi_a = 0.0 if printed else b - a
    return h_m * ((k * phi_a - math.sin(k * phi_a)) / math.pi - 1) * (-1) ** (k_f + 1)


def test_motion_law_corrected_and_printed_match_the_seed_and_the_output(ev):
    for _ in range(20):
        phi = RNG.uniform(0, 8 * math.pi)
        pt = ev.point(phi=phi)
        H = ev.quantity("H", pt)[0, 0]
        assert H == pytest.approx(seed_motion_law(phi), abs=1e-14)
        assert H == pytest.approx(ev.output("h", pt), abs=1e-15)
        assert ev.quantity("H_printed", pt)[0, 0] == pytest.approx(
            seed_motion_law(phi, k=1.2, printed=True), abs=1e-14)
        omega = ev.point()[0][[v.name for v in ev.vars].index("omega")]
        pt = ev.point(phi=phi, omega=omega)
        assert ev.quantity("d2H_dphi2", pt)[0, 0] * omega**2 == pytest.approx(
            ev.output("h_ddot", pt), rel=1e-12, abs=1e-12)
    # the printed law differs where D1/D2 say: after 320 deg it is back at -h_m
    phi = 330 * math.pi / 180
    pt = ev.point(phi=phi)
    assert ev.quantity("H_printed", pt)[0, 0] == pytest.approx(-0.029)
    assert ev.quantity("H", pt)[0, 0] == pytest.approx(0.029)


def test_warp_quantities_are_the_outputs(ev):
    for _ in range(10):
        pt = ev.point()
        assert ev.quantity("dl_shed", pt)[0, 0] == pytest.approx(ev.output("dl", pt), abs=1e-15)
        assert ev.quantity("f_y_warp", pt)[0, 0] == pytest.approx(ev.output("f_y", pt))
        assert ev.quantity("f_x_warp", pt)[0, 0] == pytest.approx(ev.output("f_x", pt))
        H = ev.quantity("H", pt)[0, 0]
        L1, L2 = math.hypot(0.05, H), math.hypot(0.25, H)
        assert ev.quantity("sin_sum", pt)[0, 0] == pytest.approx(H / L1 + H / L2)
        if "T_shed" in ev.q:
            T = ev.quantity("T_shed", pt)[0, 0]
            assert T == pytest.approx(ev.output("T", pt))
            dl_max = math.hypot(0.05, 0.029) + math.hypot(0.25, 0.029) - 0.3
            assert T == pytest.approx(1000 * (0.3 + 0.5 * (L1 + L2 - 0.3) / dl_max))
        else:
            T = pt[0][[v.name for v in ev.vars].index("T")]
            assert ev.quantity("T_input", pt)[0, 0] == T
            assert ev.quantity("f_y_warp", pt)[0, 0] == pytest.approx(T * (H / L1 + H / L2))


def test_equations_of_motion_from_the_quantities(ev):
    """M Y'' + C (Y - Y_static) + mu Y' - F_inertia is a residual block of
    the model's equations at random points (and the same for x)."""
    if ev.m.registry_name == "heald_frame_rigid":
        pytest.skip("no elastic coordinates")
    names = [v.name for v in ev.vars]
    der_names = [s.name() for s in ca.vertsplit(ev.ders)]
    for _ in range(5):
        pt = ev.point()
        x, d = pt
        blocks = ev.residual_blocks(pt)
        mu = x[names.index("mu")]
        for ax in ("y", "x") if ev.m.registry_name == "heald_frame" else ("y",):
            pos = np.array([x[names.index(f"{ax}{i}")] for i in (1, 2, 3)])
            vel = np.array([x[names.index(f"v{ax}{i}")] for i in (1, 2, 3)])
            acc = np.array([d[k] for k, n in enumerate(der_names) if n in
                            (f"der(v{ax}{i})" for i in (1, 2, 3))])
            assert acc.size == 3, der_names
            M = ev.quantity(f"M_{ax}", pt).ravel()
            C = ev.quantity(f"C_{ax}", pt)
            r = M * acc + C @ (pos - ev.quantity(f"{ax.upper()}_static", pt).ravel()) + mu * vel
            if ax == "y":
                r = r - ev.quantity("F_inertia_y", pt).ravel()
            match = [b for b in blocks if b.size == 3 and
                     np.max(np.abs(b - r)) < 1e-9 * np.max(np.abs(r))]
            assert match, (ax, r, blocks)


def test_print_defects_come_from_one_source():
    """D1-D4 (heald_common.DEFECTS) appear word for word in the model's
    docstring and next to the quantities they touch."""
    from loomfmu.models import heald_frame
    from loomfmu.models.heald_common import DEFECTS, defect
    q = {x.name: x for x in load_model("heald_frame").quantities}
    touched = {"D1": ["H", "H_printed"], "D2": ["phi_a", "H_printed"],
               "D3": ["F_inertia_y", "F_inertia_y_printed"], "D4": ["M_x", "M_x_printed"]}
    assert set(touched) == set(DEFECTS)
    for key, names in touched.items():
        assert defect(key) in heald_frame.__doc__
        for name in names:
            assert defect(key) in q[name].description, (key, name)
