"""The heald frame with the warp tension as an input (build option
warp_tension='input'): the three levels build with it, the warp
port connects both ways to a backrest's front, the input-tension FMU fed the
geometry model's tension reproduces its slat motion, it agrees with scipy at
communication steps from tiny to large, and a second frame in opposition is
the same FMU started one revolution later."""
from __future__ import annotations

import math
import re

import casadi as ca
import numpy as np
import pytest
from fmpy.validation import validate_fmu

from loomfmu import build_fmu, load_model
from loomfmu.declare.ports import PORT_KINDS
from loomfmu.declare.units import same_quantity
from loomfmu.heald.tension_input import lockstep
from loomfmu.registry import build_options
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import simulate

pytestmark = pytest.mark.slow  # builds FMUs

LEVELS = ["heald_frame", "heald_frame_planar", "heald_frame_rigid"]
SLATS = ["x2_out", "y2_out", "N_rem"]


@pytest.fixture(scope="module")
def dist_input(tmp_path_factory):
    return tmp_path_factory.mktemp("dist_warp_input")


@pytest.fixture(scope="module")
def spatial_input_fmu(dist_input):
    return build_fmu(load_model("heald_frame", warp_tension="input"), out_dir=dist_input)


@pytest.fixture(scope="module")
def planar_input_fmu(dist_input):
    return build_fmu(load_model("heald_frame_planar", warp_tension="input"),
                     out_dir=dist_input)


@pytest.fixture(scope="module")
def rigid_input_fmu(dist_input):
    return build_fmu(load_model("heald_frame_rigid", warp_tension="input"), out_dir=dist_input)


# -- declarations -------------------------------------------------------------------------
@pytest.mark.parametrize("name", LEVELS)
def test_levels_build_with_the_tension_as_an_input(name):
    geo, inp = load_model(name), load_model(name, warp_tension="input")
    assert geo.var("T").kind == "output" and [p.variables for p in geo.ports
                                               if p.name == "warp"] == [{"elongation": "dl"}]
    assert inp.var("T").kind == "input" and inp.var("dl").kind == "output"
    (port,) = [p for p in inp.ports if p.name == "warp"]
    assert port.kind == "warp" and port.variables == {"elongation": "dl", "tension": "T"}
    for role, var in port.variables.items():
        assert same_quantity(inp.var(var).unit, PORT_KINDS["warp"].roles[role].unit)
    assert [c.name for c in inp.validity] == ["warp_taut"] and geo.validity == []
    # T_min/T_max only describe the geometry tension
    assert {"T_min", "T_max"} <= {v.name for v in geo.of_kind("parameter")}
    assert not {"T_min", "T_max"} & {v.name for v in inp.of_kind("parameter")}
    assert inp.options["warp_tension"] == "input"
    assert "warp_tension" in build_options(name)
    with pytest.raises(ValueError, match="warp_tension.*geometry.*input"):
        load_model(name, warp_tension="backrest")


def test_presets_apply_with_the_tension_as_an_input():
    m = load_model("heald_frame", warp_tension="input", preset="STB-180 Elitex")
    assert m.var("n_n").start == load_model("heald_frame", preset="STB-180 Elitex").var(
        "n_n").start


def _backrest_fronts():
    """Every warp port of the backrest's builds (one front, and two if the
    model has that option)."""
    builds = [load_model("backrest")]
    if "fronts" in build_options("backrest"):
        builds.append(load_model("backrest", fronts=2))
    return [(b, p) for b in builds for p in b.ports
            if p.kind == "warp" and p.name.startswith("warp_front")]


@pytest.mark.parametrize("name", LEVELS)
def test_warp_port_connects_both_ways_to_a_backrest_front(name):
    frame = load_model(name, warp_tension="input")
    (fp,) = [p for p in frame.ports if p.name == "warp"]
    fronts = _backrest_fronts()
    assert fronts
    for back, bp in fronts:
        assert set(bp.variables) == set(fp.variables), bp
        for role in fp.variables:
            a, b = frame.var(fp.variables[role]), back.var(bp.variables[role])
            assert {a.kind, b.kind} == {"input", "output"}, (bp.name, role)
            assert same_quantity(a.unit, b.unit)
    # the geometry-mode frame gives the elongation only: it can drive a front's
    # elongation but takes no tension back
    geo = load_model(name)
    (gp,) = [p for p in geo.ports if p.name == "warp"]
    assert geo.var(gp.variables["elongation"]).kind == "output" and "tension" not in gp.variables


def test_port_refuses_a_tension_output_beside_the_elongation_output():
    """Model.port's alternation rule applied to the geometry frame: its T is an
    output like dl, so they cannot form one warp port."""
    m = load_model("heald_frame_rigid")
    with pytest.raises(ValueError, match="alternate"):
        m.port("warp2", "warp", elongation="dl", tension="T")


# -- FMUs ---------------------------------------------------------------------------------
def test_fed_the_geometry_tension_it_reproduces_the_slat_motion(
        heald_frame_fmu, spatial_input_fmu, slave_factory):
    """Over one frame cycle the input FMU, fed the geometry FMU's tension at
    each communication point, follows its slats; the difference is that of
    the held input and shrinks about linearly with the communication step."""
    assert spatial_input_fmu.problems == [] and validate_fmu(str(spatial_input_fmu.path)) == []
    names = ["h", "dl", "f_y", *SLATS]
    t_end = 4 * math.pi / 60
    err = {}
    for dt in (1e-3, 1e-4):
        rg, ri = lockstep(heald_frame_fmu.path, spatial_input_fmu.path, dt, t_end, names,
                          make=slave_factory)
        np.testing.assert_allclose(ri[:, :2], rg[:, :2], rtol=0, atol=1e-12)  # h, dl
        err[dt] = {n: np.max(np.abs(rg[:, k] - ri[:, k])) / np.ptp(rg[:, k])
                   for k, n in enumerate(names) if n in SLATS}
    for n in SLATS:
        assert err[1e-4][n] < 0.01, err
        assert err[1e-4][n] < err[1e-3][n] / 5, err


@pytest.mark.parametrize("level, outputs", [
    ("heald_frame", ["x2_out", "y2_out", "f_x", "f_y", "N_rem"]),
    ("heald_frame_planar", ["y2_out", "f_y", "N_rem"]),
    ("heald_frame_rigid", ["f_x", "f_y", "N_rem"])])
def test_each_level_equals_the_geometry_model_in_the_bottom_dwell(request, level, outputs):
    """In the bottom dwell (0..40 deg) the shed is open and still, so the
    geometry tension is n_n T_max = 800 N, the input's start: the two FMUs of
    each level agree there to solver tolerance, and part ways once the
    frame moves and the geometry tension falls."""
    suffix = {"heald_frame": "", "heald_frame_planar": "_planar",
              "heald_frame_rigid": "_rigid"}[level]
    geo = request.getfixturevalue(f"heald_frame{suffix}_fmu")
    inp = request.getfixturevalue({"heald_frame": "spatial_input_fmu",
                                   "heald_frame_planar": "planar_input_fmu",
                                   "heald_frame_rigid": "rigid_input_fmu"}[level])
    assert inp.problems == [] and validate_fmu(str(inp.path)) == []
    dwell = 40 * math.pi / 180 / 60.0
    kw = dict(rtol=1e-10, atol=1e-14, output_interval=dwell / 50, output=outputs)
    a = simulate(geo.path, stop_time=dwell, **kw)
    b = simulate(inp.path, stop_time=dwell, **kw)
    later_a = simulate(geo.path, stop_time=4 * dwell, **kw)
    later_b = simulate(inp.path, stop_time=4 * dwell, **kw)
    for o in outputs:
        scale = np.ptp(later_a.y[o])
        assert np.max(np.abs(a.y[o] - b.y[o])) < 1e-7 * scale, o
        assert np.max(np.abs(later_a.y[o] - later_b.y[o])) > 1e-3 * scale, o


def test_staircase_tension_agrees_with_scipy(spatial_input_fmu, slave_factory):
    """The input FMU under a tension that changes at every communication point
    (the geometry tension, held) against scipy with the same input steps."""
    model = load_model("heald_frame", warp_tension="input")
    geo = load_model("heald_frame")
    phi = geo.var("phi").sym
    T_of_phi = ca.Function("T", [phi], [ca.substitute(
        geo.var("T").expr, ca.vertcat(*[v.sym for v in geo.of_kind("parameter")]),
        ca.DM([v.start for v in geo.of_kind("parameter")]))])
    dt, n = 2e-3, 105
    t = np.arange(n + 1) * dt
    Tk = [float(T_of_phi(60.0 * tk)) for tk in t]
    s = slave_factory(spatial_input_fmu.path)
    s.start(T=Tk[0], solver_rtol=1e-9, solver_atol=1e-13)
    rec = [s.get(*SLATS)]
    for k in range(n):
        s.set(T=Tk[k])
        s.fmu.doStep(t[k], dt)
        rec.append(s.get(*SLATS))
    rec = np.array(rec)
    ref = reference(model, t_end=t[-1], t_eval=t, rtol=1e-11, atol=1e-13,
                    values={"T": Tk[0]},
                    input_steps=[(t[k], {"T": Tk[k]}) for k in range(1, n)])
    for j, o in enumerate(SLATS):
        assert np.max(np.abs(rec[:, j] - ref.y[o])) < 1e-5 * np.ptp(ref.y[o]), o


@pytest.mark.parametrize("stop, dt", [(2e-3, 1e-6), (0.02, 1e-5), (0.21, 1e-3),
                                      (0.21, 0.021), (0.21, 0.105), (0.21, 0.21)])
def test_communication_steps_tiny_to_large(spatial_input_fmu, stop, dt):
    """A constant tension input: the FMU's outputs at every communication
    point agree with scipy whatever the step (one step over the whole cycle
    included)."""
    model = load_model("heald_frame", warp_tension="input")
    values = {"T": 700.0}
    run = simulate(spatial_input_fmu.path, rtol=1e-8, atol=1e-12, stop_time=stop,
                   output_interval=dt, values=values, output=SLATS)
    ref = reference(model, t_end=run.t[-1], t_eval=run.t, rtol=1e-11, atol=1e-13,
                    values=values)
    assert run.t[-1] == pytest.approx(stop)
    full = reference(model, t_end=0.21, rtol=1e-10, atol=1e-13, values=values)
    for o in SLATS:
        assert np.all(np.isfinite(run.y[o]))
        assert np.max(np.abs(run.y[o] - ref.y[o])) < 1e-5 * np.ptp(full.y[o]), o


def test_second_frame_in_opposition_starts_one_revolution_later(
        rigid_input_fmu, heald_frame_fmu):
    """phi settable at the start: phi = 2 pi gives the opposite frame of a
    plain weave, h(t) = -h_0(t) with the same shed elongation; phi = pi is a
    frame half-way up, not one in opposition."""
    out = ["h", "dl", "f_y"]
    a = simulate(rigid_input_fmu.path, rtol=1e-9, output=out)
    b = simulate(rigid_input_fmu.path, rtol=1e-9, output=out,
                 values={"phi": 2 * math.pi})
    assert np.max(np.abs(a.y["h"] + b.y["h"])) < 1e-12
    assert np.max(np.abs(a.y["dl"] - b.y["dl"])) < 1e-12 * np.ptp(a.y["dl"])
    assert np.max(np.abs(a.y["f_y"] + b.y["f_y"])) < 1e-9 * np.ptp(a.y["f_y"])
    half = simulate(rigid_input_fmu.path, rtol=1e-9, output=["h"], values={"phi": math.pi})
    assert abs(half.y["h"][0]) < 1e-12 and np.max(np.abs(half.y["h"] + a.y["h"])) > 0.02
    # the elastic frame started at 2 pi starts at its static deflection at the top
    sp = simulate(heald_frame_fmu.path, rtol=1e-9, output=["h", "y2_out", "f_y"],
                  values={"phi": 2 * math.pi})
    m = load_model("heald_frame")
    y2_static = _quantity_at(m, "Y_static", {"phi": 2 * math.pi})[1]
    assert sp.y["h"][0] == pytest.approx(0.029, abs=1e-12)
    assert sp.y["y2_out"][0] == pytest.approx(y2_static, rel=1e-9)


def _quantity_at(model, name, values):
    known = [v for v in model.variables if v.kind in ("parameter", "state", "input")]
    (q,) = [q for q in model.quantities if q.name == name]
    f = ca.Function("q", [ca.vertcat(*[v.sym for v in known])], [q.expr])
    return np.array(f(ca.DM([values.get(v.name, v.start) for v in known]))).ravel()


def test_negative_tension_is_refused_with_the_time(rigid_input_fmu, slave_factory):
    """A warp that pushes is outside the model: the step with a negative
    tension input ends with fmi2Discard and a log line saying what and when;
    the FMU's time stays where the tension was last valid."""
    from fmpy.fmi1 import FMICallException
    s = slave_factory(rigid_input_fmu.path)
    s.start()
    dt = 1e-3
    for k in range(10):
        s.fmu.doStep(k * dt, dt)
    assert s.get("f_y")[0] < 0      # bottom dwell: the warp pulls the frame up
    s.set(T=-50.0)
    with pytest.raises(FMICallException) as e:
        s.fmu.doStep(10 * dt, dt)
    assert e.value.status == 2      # fmi2Discard
    lines = [m for status, _, m in s.log if "warp in compression" in m]
    assert lines, s.log[-3:]
    assert "value -50 " in lines[0], lines[0]
    assert float(re.search(r"at t = (\S+) s", lines[0]).group(1)) == pytest.approx(0.01)
    for name in ("h", "f_y", "N_rem"):
        assert np.isfinite(s.get(name)[0])


def test_defaults_agree_with_the_backrest():
    """The backrest's static sheet tension is two frames' ends at the closed
    shed (dl = 0, T_min per end), and its upper-branch stiffness is the one
    the heald frame's tension law implies for two frames' ends (rounded)."""
    from loomfmu.heald.tension_input import defaults
    d = defaults()
    back = load_model("backrest")
    assert back.var("S0").start == pytest.approx(2 * d["n_n"] * d["T_min"])
    assert back.var("c2").start == pytest.approx(2 * d["k_ends"], rel=0.01)
    assert d["dl_max"] == pytest.approx(math.hypot(0.05, 0.029) + math.hypot(0.25, 0.029) - 0.3)
    assert d["T_min"] < (d["T_min"] + d["T_max"]) / 2 < d["T_end_mean"] < d["T_max"]
