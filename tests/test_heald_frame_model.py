"""The heald-frame declaration against the seed's own formulas and physics."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from loomfmu import load_model
from loomfmu.export.dae import explicit_ode
from loomfmu.models.heald_frame import DEG, influence, motion_law, stiffness


def test_symbolic_inverse_of_delta_equals_the_seed_closed_form():
    d11, d22 = ca.SX.sym("d11"), ca.SX.sym("d22")
    residual = ca.simplify(ca.inv(influence(d11, d22)) - stiffness(d11, d22))
    f = ca.Function("r", [d11, d22], [residual])
    rng = np.random.default_rng(1)
    for a, b in rng.uniform(0.1, 10.0, size=(20, 2)):
        b = b + a / 2 + 0.1  # delta positive definite needs d22 > d11/2
        r = np.array(f(a, b))
        scale = np.abs(np.linalg.inv(np.array(ca.DM(ca.Function("d", [d11, d22], [
            influence(d11, d22)])(a, b))))).max()
        assert np.abs(r).max() < 1e-12 * scale


def _law(k_H, end_dwell="corrected"):
    phi = ca.SX.sym("phi")
    H = motion_law(phi, 1.0, k_H, end_dwell)
    H1 = ca.jacobian(H, phi)
    H2 = ca.jacobian(H1, phi)
    return ca.Function("H", [phi], [H, H1, H2])


def _jumps(f, phi_b, eps=1e-9):
    left = np.array([float(v) for v in f(phi_b - eps)])
    right = np.array([float(v) for v in f(phi_b + eps)])
    return np.abs(right - left)


BOUNDARIES = [40 * DEG, 320 * DEG, 2 * math.pi, 2 * math.pi + 40 * DEG,
              2 * math.pi + 320 * DEG, 4 * math.pi]


def test_corrected_motion_law_is_continuous_to_the_second_derivative():
    f = _law(9 / 7)
    for phi_b in BOUNDARIES:
        assert np.all(_jumps(f, phi_b) < 1e-7), phi_b
    # amplitude: from -h_m to +h_m and back
    assert float(f(0)[0]) == pytest.approx(-1.0)
    assert float(f(330 * DEG)[0]) == pytest.approx(1.0)
    assert float(f(2 * math.pi + 330 * DEG)[0]) == pytest.approx(-1.0)


def test_printed_coefficient_breaks_continuity_as_documented():
    f = _law(1.2)
    j320 = _jumps(f, 320 * DEG)
    assert j320[1] > 0.01 and j320[2] > 0.1  # H' and H'' jump at the top dwell
    j360 = _jumps(f, 2 * math.pi)
    assert j360[0] == pytest.approx(1 - (1.2 * 280 * DEG - math.sin(1.2 * 280 * DEG)) / math.pi
                                    + 1, rel=1e-6)  # H: 0.996 h_m -> h_m


def test_printed_end_dwell_throws_the_frame_back():
    f = _law(9 / 7, "printed")
    assert float(f(330 * DEG)[0]) == pytest.approx(-1.0)
    with pytest.raises(ValueError, match="end_dwell"):
        _law(9 / 7, "other")


def test_ad_derivatives_match_finite_differences():
    f = _law(9 / 7)
    for phi in (0.5, 2.0, 4.0, 8.0):
        h = 1e-6
        fd1 = (float(f(phi + h)[0]) - float(f(phi - h)[0])) / (2 * h)
        fd2 = (float(f(phi + h)[1]) - float(f(phi - h)[1])) / (2 * h)
        assert float(f(phi)[1]) == pytest.approx(fd1, rel=1e-6, abs=1e-9)
        assert float(f(phi)[2]) == pytest.approx(fd2, rel=1e-6, abs=1e-9)


def _evaluate(model, values=None, phi=None):
    ode = explicit_ode(model)
    p = [dict(values or {}).get(v.name, v.start) for v in model.of_kind("parameter")]
    x = model.starts("state")
    if phi is not None:
        x[0] = phi
    f = ca.Function("f", ode.args, [ode.f, ode.y])
    xdot, y = f(0.0, x, model.starts("input"), p)
    names = [v.name for v in model.of_kind("output")]
    return np.array(xdot).ravel(), dict(zip(names, np.array(y).ravel()))


def test_start_is_the_static_equilibrium():
    xdot, _ = _evaluate(load_model("heald_frame"))
    # accelerations of all six coordinates vanish at the start (bottom dwell)
    assert np.abs(xdot[7:10]).max() < 1e-9 and np.abs(xdot[10:13]).max() < 1e-9
    assert np.abs(xdot[4:7]).max() < 1e-9


def test_symmetric_shed_gives_no_horizontal_load():
    model = load_model("heald_frame")
    for phi in (0.3, 1.5, 3.0, 5.0):
        _, y = _evaluate(model, {"k_z": 1.0}, phi)
        assert abs(y["f_x"]) < 1e-9 * abs(y["T"])
        _, y5 = _evaluate(model, {"k_z": 5.0}, phi)
        assert y5["f_x"] > 1e-4 * y5["T"]  # towards the long (back) side


def test_warp_tension_spans_its_range():
    model = load_model("heald_frame")
    _, y_bottom = _evaluate(model, phi=0.0)
    _, y_cross = _evaluate(model, phi=180 * DEG)
    assert y_bottom["T"] == pytest.approx(1000 * 0.8)
    assert y_cross["T"] == pytest.approx(1000 * 0.3, rel=1e-3)


def test_inertia_variants_differ_as_documented():
    corrected = load_model("heald_frame")
    printed = load_model("heald_frame", inertia="printed")
    phi = 60 * DEG  # rising: frame acceleration nonzero
    a, _ = _evaluate(corrected, phi=phi)
    b, _ = _evaluate(printed, phi=phi)
    # vertical accelerations: the frame's inertia enters with opposite sign
    assert np.sign(a[11] - b[11]) != 0
    with pytest.raises(ValueError, match="inertia"):
        load_model("heald_frame", inertia="sideways")


@pytest.mark.parametrize("name", ["heald_frame", "heald_frame_planar"])
def test_a_box_wall_thicker_than_half_the_section_is_refused(name):
    m = load_model(name)
    m.check_constraints({"b1": 0.010, "d1": 0.005, "m_RR": 50.0})  # a solid bar: allowed
    with pytest.raises(ValueError, match=r"box_wall_width: .* \(value -0\.002"):
        m.check_constraints({"b1": 0.010, "d1": 0.006, "m_RR": 50.0})
    with pytest.raises(ValueError, match=r"box_wall_height: .* \(value -0\.002"):
        m.check_constraints({"h1": 0.010, "b1": 0.05, "d1": 0.006, "m_RR": 50.0})
