"""A scene composed at the equation level into one model and one FMU.

Toy components declared here make each composition rule visible: names under
the component's name, a connection substituted with its unit conversion, a
loop of direct feedthrough turned into algebraic unknowns (closed form, and
Newton where it is nonlinear), events of two components inside one
communication step, a delay kept, validity conditions kept.  Independent
checks: a hand-eliminated ODE (scipy), each component's own reference, the
exact solution of the two-mass benchmark.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from loomfmu import build_fmu
from loomfmu.declare.model import Model
from loomfmu.export.dae import dae_form
from loomfmu.scene.compose import compose
from loomfmu.scene.declare import Scene
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import simulate

RPM = 60.0 / (2.0 * math.pi)   # rad/s -> rpm
K_SIN = 0.8


def _loop_a() -> Model:
    m = Model("loop_a", description="first order lag with a nonlinear feedthrough",
              stop_time=2.0, step_size=0.01)
    u = m.input("ua", 0.0, unit="rad/s", description="speed in")
    x = m.state("xa", 1.0, unit="rad/s", description="lagged speed")
    m.eq(m.der(x), -x + u)
    m.output("ya", x + K_SIN * ca.sin(u), unit="rad/s", description="speed out")
    return m


def _loop_b() -> Model:
    m = Model("loop_b", description="first order lag with a linear feedthrough",
              stop_time=2.0, step_size=0.01)
    u = m.input("ub", 0.0, unit="rpm", description="speed in")
    x = m.state("xb", 5.0, unit="rpm", description="lagged speed")
    m.eq(m.der(x), -2.0 * x + u)
    m.output("yb", x - 0.25 * u, unit="rpm", description="speed out")
    m.require("bounded", 1e4 - x, "the lag runs away")
    return m


def _loop_scene() -> Scene:
    s = Scene("loop", stop_time=2.0, step=0.01)
    s.add("a", model=_loop_a())
    s.add("b", model=_loop_b())
    s.connect("a.ya", "b.ub")      # rad/s -> rpm
    s.connect("b.yb", "a.ua")      # rpm -> rad/s
    return s


def _loop_by_hand(t_eval):
    """The loop eliminated by hand: ua solves ua = (xb - 0.25 RPM ya) / RPM,
    ya = xa + K sin(ua); then xa' = -xa + ua, xb' = -2 xb + RPM ya."""
    def ua_of(xa, xb):
        f = lambda u: u - (xb - 0.25 * RPM * (xa + K_SIN * math.sin(u))) / RPM  # noqa: E731
        return brentq(f, -1e3, 1e3, xtol=1e-15)

    def rhs(t, z):
        xa, xb = z
        ua = ua_of(xa, xb)
        ya = xa + K_SIN * math.sin(ua)
        return [-xa + ua, -2.0 * xb + RPM * ya]
    sol = solve_ivp(rhs, (0.0, t_eval[-1]), [1.0, 5.0], t_eval=t_eval, rtol=1e-11, atol=1e-13)
    ya = [z[0] + K_SIN * math.sin(ua_of(*z)) for z in sol.y.T]
    return sol.y, np.array(ya)


def test_names_are_prefixed_and_a_one_way_connection_is_substituted():
    from loomfmu.machines.two_mass import scene
    m = compose(scene())
    names = {v.name: v.kind for v in m.variables}
    assert names["force.x1"] == names["disp.x2"] == "state"
    assert names["force.kc"] == "parameter" and names["disp.m2"] == "parameter"
    # no loop: the inputs are outputs of the composed model, equal to their sources
    assert names["disp.F_in"] == names["force.x2_in"] == "output"
    assert not m.of_kind("input") and not m.of_kind("algebraic")
    assert ca.is_equal(m.var("disp.F_in").expr, m.var("force.F_c").expr, 20)
    dae = dae_form(m)
    assert not dae.implicit and dae.nx == 4
    # the scene's values are the composed model's defaults
    assert m.var("force.x1").start == 0.1


def test_a_feedthrough_loop_becomes_algebraic_unknowns_with_the_unit_conversion():
    s = _loop_scene()
    assert s.loops(), "the toy scene must close a loop of direct feedthrough"
    m = compose(s)
    assert m.var("a.ua").kind == m.var("b.ub").kind == "algebraic"
    assert dae_form(m).implicit   # sin(ua): nonlinear, solved by Newton in the FMU
    t = np.linspace(0.0, 2.0, 201)
    ref = reference(m, t_end=2.0, t_eval=t, rtol=1e-11, atol=1e-13, method="Radau")
    (xa, xb), ya = _loop_by_hand(t)
    assert np.max(np.abs(ref.y["a.ya"] - ya)) < 1e-7 * np.ptp(ya)
    assert np.max(np.abs(ref.y["b.xb"] - xb)) < 1e-7 * np.ptp(xb)
    assert [c.name for c in m.validity] == ["b_bounded"]
    assert m.validity[0].message.startswith("b: ")


def test_a_component_given_as_an_fmu_file_is_refused_with_the_way_out():
    s = _loop_scene()
    comp = s.components["a"]
    comp.model, comp.declaration, comp.fmu = None, None, Path("a.fmu")
    with pytest.raises(ValueError, match=r"component\(s\) a are given as FMU files.*"
                                         r"co-simulation"):
        compose(s)


def test_a_delay_with_events_in_another_component_is_refused_clearly():
    s = Scene("both", stop_time=1.0, step=0.01)
    s.add("d", model=_delayed())
    s.add("e", model=_switch("e", 2.0))
    with pytest.raises(ValueError, match="delays together with event indicators"):
        dae_form(compose(s))


def _switch(name: str, omega: float) -> Model:
    """An oscillator pushed by 1 N from the time x falls through 0.2 (a mode
    chosen at the event)."""
    m = Model(name, description="oscillator with a switched push", stop_time=1.0,
              step_size=0.1)
    x = m.state("x", 1.0, unit="m", description="position")
    v = m.state("v", 0.0, unit="m/s", description="velocity")
    q = m.mode("q", 0, (0, 1), description="0 above x = 0.2, 1 below")
    m.eq(m.der(x), v)
    m.eq(m.der(v), -omega**2 * x - 1.0 * q)
    m.event("cross", x - 0.2, description="x passes 0.2")
    m.mode_rule(q, (1 - 2 * q) * (x - 0.2), events=["cross"])
    m.output("x_out", x, unit="m", description="position")
    return m


def _delayed() -> Model:
    m = Model("delayed", description="a lag of a delayed ramp", stop_time=1.0, step_size=0.01)
    x = m.state("x", 0.0, unit="m", description="lagged position")
    d = m.delay("ramp", ca.sin(3.0 * m.t), 0.1, max_delay=0.5, description="delayed sine")
    m.eq(m.der(x), -5.0 * x + d)
    m.output("y", x, unit="m", description="position")
    return m


def _follower() -> Model:
    m = Model("follower", description="a lag of its input", stop_time=1.0, step_size=0.01)
    u = m.input("u", 0.0, unit="m", description="position in")
    z = m.state("z", 0.0, unit="m", description="lagged position")
    m.eq(m.der(z), -3.0 * z + u)
    m.output("z_out", z, unit="m", description="position")
    return m


@pytest.mark.slow
def test_the_composed_loop_fmu_solves_the_loop_by_newton(tmp_path):
    m = compose(_loop_scene())
    fmu = build_fmu(m, out_dir=tmp_path)
    assert fmu.problems == []
    t = np.linspace(0.0, 2.0, 201)
    (xa, xb), ya = _loop_by_hand(t)
    for solver in ("dopri5", "rodas4"):
        run = simulate(fmu.path, solver=solver, rtol=1e-8, atol=1e-10, output=["a.ya"])
        assert np.max(np.abs(run.y["a.ya"] - ya)) < 1e-6 * np.ptp(ya), solver


@pytest.mark.slow
def test_events_of_two_components_in_one_step_are_each_located(tmp_path):
    """Two components' events at t = 0.668 s and 0.685 s, inside one
    communication step (0.6 ... 0.7 s): each trajectory equals that
    component's own reference."""
    s = Scene("two_switches", stop_time=1.0, step=0.1)
    s.add("p", model=_switch("p", 2.0))
    s.add("r", model=_switch("r", 2.05))
    m = compose(s)
    assert [e.name for e in m.events] == ["p_cross", "r_cross"]
    fmu = build_fmu(m, out_dir=tmp_path).path
    run = simulate(fmu, rtol=1e-10, atol=1e-12, output=["p.x_out", "r.x_out"])
    for comp, omega in (("p", 2.0), ("r", 2.05)):
        alone = reference(_switch(comp, omega), t_end=1.0, t_eval=run.t, rtol=1e-11,
                          atol=1e-13)
        assert np.max(np.abs(run.y[f"{comp}.x_out"] - alone.y["x_out"])) < 1e-7, comp


@pytest.mark.slow
def test_a_delay_is_kept_with_its_history(tmp_path):
    s = Scene("delayed_pair", stop_time=1.0, step=0.01)
    s.add("d", model=_delayed())
    s.add("f", model=_follower())
    s.connect("d.y", "f.u")
    m = compose(s)
    assert [d.name for d in m.delays] == ["d_ramp"]
    fmu = build_fmu(m, out_dir=tmp_path).path
    run = simulate(fmu, rtol=1e-10, atol=1e-12, output=["d.y", "f.z_out"])
    ref = reference(m, t_end=1.0, t_eval=run.t, rtol=1e-11, atol=1e-13)
    alone = reference(_delayed(), t_end=1.0, t_eval=run.t, rtol=1e-11, atol=1e-13)
    assert np.max(np.abs(run.y["d.y"] - alone.y["y"])) < 1e-8
    assert np.max(np.abs(run.y["f.z_out"] - ref.y["f.z_out"])) < 1e-6 * np.ptp(ref.y["f.z_out"])


@pytest.mark.slow
def test_the_composed_two_mass_fmu_is_the_exact_solution_in_every_interface(tmp_path):
    from loomfmu.machines import two_mass as tm
    m = compose(tm.scene())
    for version, interface in ((2, "cs"), (2, "both"), (3, "both")):
        res = build_fmu(m, out_dir=tmp_path, fmi_version=version, interface=interface)
        assert res.problems == [], (version, interface, res.problems)
    fmu = tmp_path / "two_mass.fmu"
    names = ["force.x1_out", "force.v1_out", "disp.x2_out", "disp.v2_out"]
    run = simulate(fmu, rtol=1e-12, atol=1e-14, output=names)
    exact = tm.exact_solution(tm.Params.declared(), run.t, [0.1, 0.0, 0.0, 0.0])
    got = np.column_stack([run.y[n] for n in names])
    assert np.max(np.abs(got - exact)) < 1e-9


@pytest.mark.slow
def test_the_composed_loom_fmu_matches_the_reference_of_the_composed_dae(tmp_path):
    from loomfmu.machines.loom import scene
    m = compose(scene(stop_time=0.5))
    for version in (2, 3):
        res = build_fmu(m, out_dir=tmp_path, fmi_version=version, interface="both")
        assert res.problems == [], (version, res.problems)
    names = ["frame_a.h", "frame_a.T", "back.S2a", "back.phi2_out", "frame_b.x2_out"]
    run = simulate(res.path, rtol=1e-8, atol=1e-10, output=names, stop_time=0.5,
                   output_interval=2e-3)
    ref = reference(m, t_end=0.5, t_eval=run.t, rtol=1e-11, atol=1e-13,
                    method=m.reference_method)
    for n in names:
        span = np.ptp(ref.y[n]) or 1.0
        assert np.max(np.abs(run.y[n] - ref.y[n])) < 1e-6 * span, n


@pytest.mark.slow
def test_the_command_line_builds_the_scene_and_runs_it_either_way(tmp_path, capsys):
    from loomfmu.cli.scene import main
    assert main(["build", "two_mass", "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert f"written: {tmp_path / 'two_mass.fmu'}" in out and "0 problem(s)" in out
    csv = {c: tmp_path / f"{c}.csv" for c in ("monolithic", "cosim")}
    for coupling, path in csv.items():
        assert main(["run", "two_mass", "--coupling", coupling, "--stop", "0.5",
                     "--fmu-dir", str(tmp_path), "--csv", str(path)]) == 0
    mono, cosim = (np.genfromtxt(p, delimiter=",", names=True) for p in csv.values())
    assert mono.dtype.names == cosim.dtype.names and len(mono) == len(cosim) == 501
    x = mono["forcex1_out"]   # genfromtxt drops the dot
    assert np.max(np.abs(x - cosim["forcex1_out"])) < 1e-3 * np.ptp(x)
    capsys.readouterr()
    assert main(["run", "two_mass", "--coupling", "monolithic", "--master", "jacobi"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--master: options of the co-simulation master" in err
    assert main(["build", "two_mass", "--platforms", "foo", "--out-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--platforms: unknown platform 'foo'" in err
    for bad in (["--rtol", "1e-5"], ["--rtol", "nan"]):   # the adaptive master's, not the FMU's
        assert main(["run", "two_mass", "--coupling", "monolithic", *bad]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--rtol: options of the co-simulation master" in err


def _square_plus_one() -> Model:
    m = Model("sq", description="y = 1 + u^2", stop_time=1.0, step_size=0.1)
    u = m.input("u", 0.0, unit="m", description="in")
    x = m.state("x", 1.0, unit="m", description="a decaying state")
    m.eq(m.der(x), -x)
    m.output("y", 1.0 + u * u, unit="m", description="out")
    return m


def _echo() -> Model:
    m = Model("echo", description="y = u", stop_time=1.0, step_size=0.1)
    u = m.input("u", 0.0, unit="m", description="in")
    x = m.state("x", 1.0, unit="m", description="a decaying state")
    m.eq(m.der(x), -x)
    m.output("y", u, unit="m", description="out")
    return m


@pytest.mark.slow
def test_a_loop_without_a_solution_fails_initialization_naming_the_loop(tmp_path):
    """u = 1 + u^2 has no real solution: the FMU refuses to initialize, its
    log naming the loop's unknowns, the time and the residual left."""
    s = Scene("no_solution", stop_time=1.0, step=0.1)
    s.add("a", model=_square_plus_one())
    s.add("b", model=_echo())
    s.connect("a.y", "b.u")
    s.connect("b.y", "a.u")
    fmu = build_fmu(compose(s), out_dir=tmp_path).path
    with pytest.raises(RuntimeError, match=r"ExitInitializationMode failed.*t = 0: algebraic "
                                           r"loop \(unknowns: der\(x\), a\.u, b\.u\): Newton did "
                                           r"not converge in \d+ iterations; largest residual"):
        simulate(fmu, output=["a.y"])


def test_a_study_takes_a_declared_model_and_refuses_a_mismatch():
    from loomfmu.sweep.figures import Figure
    from loomfmu.sweep.space import grid
    from loomfmu.sweep.study import Study
    m = _loop_a()
    Study("loop_a", declaration=m, cases=grid(ua=[0.0]), figures=[Figure("max", "ya")],
          stop_time=1.0, output_interval=0.1)
    for kw, what in (({"model": "other"}, "model = 'other'"),
                     ({"options": {"side": "force"}}, "no options"),
                     ({"declaration": "loop_a"}, "declaration = 'loop_a'")):
        args = {"model": "loop_a", "declaration": m, **kw}
        with pytest.raises(ValueError, match=re.escape(what)):
            Study(args.pop("model"), cases=grid(ua=[0.0]), figures=[Figure("max", "ya")],
                  stop_time=1.0, output_interval=0.1, **args)


@pytest.mark.slow
def test_the_loom_study_runs_on_the_composed_fmu(tmp_path):
    """Two cases of the loom study (picks/min x preload) on the composed FMU:
    the stick share is a share, the hinge load grows with the preload (a
    higher static warp tension loads the frames more)."""
    from loomfmu.machines.studies import loom_stick
    from loomfmu.sweep.run import run_serial
    study = loom_stick(ppm=[240.0], preload=[0.7, 1.3], stop_time=0.5)
    rows = run_serial(study)
    assert [r["status"] for r in rows] == ["ok", "ok"], rows
    assert all(0.0 <= r["stick_share"] <= 1.0 for r in rows)
    assert rows[0]["max_abs_frame_a.N_rem"] < rows[1]["max_abs_frame_a.N_rem"]


@pytest.mark.parametrize("name", ["two_mass", "loom", "spinning"])
def test_the_ssp_export_and_the_composed_model_describe_the_same_machine(name):
    """Every connector of the scene's SSD is a variable of the composed model
    under its component's name, every connection's conversion is the
    composed equation's, and every parameter value the SSD binds is the
    composed model's default (but the components' solver settings: the
    composed FMU has one solver, and says which it ignored)."""
    import xml.etree.ElementTree as ET

    from loomfmu.machines.library import load_scene
    from loomfmu.scene.ssp import ssd_text
    s = load_scene(name)
    m = compose(s)
    root = ET.fromstring(ssd_text(s))
    ns = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
    comps = root.findall(f".//{ns}Component")
    assert {c.get("name") for c in comps} == set(s.components)
    for c in comps:
        ignored = m.options.get("ignored", {}).get(c.get("name"), [])
        for conn in c.iter(f"{ns}Connector"):
            if conn.get("name") not in ignored:   # a component's own solver settings
                m.var(f"{c.get('name')}.{conn.get('name')}")   # ValueError if absent
        for p in c.iter():
            if p.tag.endswith("}Parameter") and p.get("name") not in ignored:
                value = float(next(iter(p)).get("value"))
                var = m.var(f"{c.get('name')}.{p.get('name')}")
                assert var.start == pytest.approx(value, rel=1e-12), var.name
    for e in root.iter(f"{ns}Connection"):
        src = m.var(f"{e.get('startElement')}.{e.get('startConnector')}")
        dst = m.var(f"{e.get('endElement')}.{e.get('endConnector')}")
        lt = next(iter(e), None)
        gain = float(lt.get("factor")) if lt is not None else 1.0
        bias = float(lt.get("offset")) if lt is not None else 0.0
        if dst.kind == "output":     # a substituted input: its expression is the source's
            assert ca.is_equal(ca.simplify(dst.expr - (gain * src.expr + bias)), ca.SX(0), 5)


def _slow_delayed() -> Model:
    m = Model("slow_delayed", description="a lag of a sine delayed by 0.5 s", stop_time=0.8,
              step_size=0.01)
    x = m.state("x", 0.0, unit="m", description="lagged position")
    d = m.delay("s", ca.sin(2.0 * m.t), 0.5, max_delay=1.0, description="delayed sine")
    m.eq(m.der(x), -5.0 * x + d)
    m.output("y", x, unit="m", description="position")
    return m


def _fast_oscillator() -> Model:
    m = Model("fast", description="an undamped 3 kHz oscillator", stop_time=0.8,
              step_size=0.01)
    x = m.state("q", 1e-3, unit="m", description="position")
    v = m.state("v", 0.0, unit="m/s", description="velocity")
    w = 2 * math.pi * 3000.0
    m.eq(m.der(x), v)
    m.eq(m.der(v), -w * w * x)
    m.output("q_out", x, unit="m", description="position")
    return m


@pytest.mark.slow
def test_a_slow_delay_beside_a_fast_part_keeps_its_history_within_capacity(tmp_path):
    """Composed with a 3 kHz oscillator the solver steps every few
    microseconds, far more steps within the 0.5 s delay than the history
    holds (65 536 samples): the history samples the slow delayed signal as
    densely as its error estimate needs, not at every step, the run
    completes and the lag equals the slow part's own reference."""
    s = Scene("slow_fast", stop_time=0.8, step=0.01)
    s.add("d", model=_slow_delayed())
    s.add("f", model=_fast_oscillator())
    fmu = build_fmu(compose(s), out_dir=tmp_path).path
    run = simulate(fmu, rtol=1e-9, atol=1e-12, output=["d.y", "f.q_out"])
    alone = reference(_slow_delayed(), t_end=0.8, t_eval=run.t, rtol=1e-11, atol=1e-13)
    assert np.max(np.abs(run.y["d.y"] - alone.y["y"])) < 1e-7
    # the history samples the slow signal, not every step of the fast part:
    # the same run by the C driver with the skipping on and off
    import json
    import subprocess

    from loomfmu.bench import limit as L
    got = {}
    for name, flags in (("skip", ()), ("every", ("-DLF_HIST_SKIPPING=0",))):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(L, "STRICT_FLAGS", (*L.STRICT_FLAGS, "-DLF_HIST_STATS", *flags))
            (tmp_path / name).mkdir()
            exe = L.compile_driver(fmu, tmp_path / name)
        proc = subprocess.run([str(exe), "0.8", "0.01", "1e-9", "1e-12", "dopri5", "1", "1"],
                              capture_output=True, text=True, check=True)
        sampled, skipped = map(int, re.search(r"hist_stats: sampled (\d+) skipped (\d+)",
                                              proc.stderr).groups())
        got[name] = (json.loads(proc.stdout), sampled, skipped)
    (skip, sampled, skipped), (every, sampled0, skipped0) = got["skip"], got["every"]
    assert sampled0 >= 0.99 * every["steps"]   # off: every accepted step sampled
    assert skipped0 == 0 and skip["steps"] == every["steps"]
    assert skipped > 20 * sampled   # 3 kHz steps against a 2 rad/s signal
    assert skip["y_end"]["d.y"] == pytest.approx(every["y_end"]["d.y"], rel=1e-8, abs=1e-12)


def test_the_composed_scene_is_inspected_like_a_model(tmp_path, capsys):
    from loomfmu.cli.scene import main
    out = tmp_path / "two_mass.md"
    assert main(["inspect", "two_mass", "--format", "md", "--out", str(out)]) == 0
    text = out.read_text()
    assert "composed into one model from components force (two_mass_force)" in text
    assert "`force.x1`" in text and "`disp.F_in`" in text   # a substituted input: an output
    assert "(from force.F_c -> disp.F_in)" in text


@pytest.mark.slow
@pytest.mark.parametrize("master, order", [("jacobi", 0), ("gauss-seidel", 2)])
def test_the_cosimulation_converges_to_the_composed_fmu_at_its_order(tmp_path, master, order):
    """two_mass co-simulated at H, H/2, H/4 against its composed FMU (exact to
    1e-9): the error at the end shrinks as H^(order + 1), the input
    extrapolation's order plus one (fitted exponent within 0.35)."""
    from loomfmu.machines import two_mass as tm
    from loomfmu.scene.monolithic import run_monolithic
    from loomfmu.scene.run import run
    s = tm.scene(stop_time=0.5)
    one = run_monolithic(s, step=2e-3, rtol=1e-12, atol=1e-14, fmu_dir=tmp_path)
    errs = []
    steps = (2e-3, 1e-3, 5e-4)
    for h in steps:
        res = run(s, master=master, extrapolation=order, step=h, fmu_dir=tmp_path)
        k = np.searchsorted(res["time"], one["time"])
        errs.append(max(np.max(np.abs(res[n][k] - one[n])) for n in
                        ("force.x1_out", "disp.x2_out")))
    slope = np.polyfit(np.log(steps), np.log(errs), 1)[0]
    assert abs(slope - (order + 1)) < 0.35, (errs, slope)


@pytest.mark.slow
def test_a_refused_composed_run_raises_with_the_fmus_log(tmp_path):
    from loomfmu.scene.monolithic import run_monolithic
    s = Scene("no_solution", stop_time=1.0, step=0.1)
    s.add("a", model=_square_plus_one())
    s.add("b", model=_echo())
    s.connect("a.y", "b.u")
    s.connect("b.y", "a.u")
    with pytest.raises(RuntimeError, match=r"scene no_solution composed: .*log: .*Newton did "
                                           r"not converge"):
        run_monolithic(s, fmu_dir=tmp_path)


def _gain_lag(k: float | None) -> Model:
    """y = k u + x (k a parameter; None: the constant 1), x' = -x."""
    m = Model("gain_lag", description="a lag plus a feedthrough gain", stop_time=0.5,
              step_size=0.1)
    gain = 1.0 if k is None else m.parameter("k", k, description="feedthrough gain",
                                             source="test")
    u = m.input("u", 0.0, unit="m", description="input")
    x = m.state("x", 1.0, unit="m", description="lag")
    m.eq(m.der(x), -x)
    m.output("y", gain * u + x, unit="m", description="output")
    return m


def _linear_loop(k: float | None) -> Scene:
    s = Scene("linear_loop", stop_time=0.5, step=0.1)
    s.add("a", model=_gain_lag(k))
    s.add("b", model=_echo())
    s.connect("a.y", "b.u")
    s.connect("b.y", "a.u")
    return s


def test_a_linear_loop_gets_a_regularity_condition():
    """u = k u + x has the unique solution x / (1 - k) unless k = 1: solved in
    closed form, the loop is checked by a constraint on k (the FMU refuses
    to initialize where it fails); with constant gains it is decided here."""
    m = compose(_linear_loop(0.5))
    (c,) = [c for c in m.constraints if c.name.startswith("loop_")]
    assert "algebraic loop (" in c.message and "singular" in c.message
    f = ca.Function("f", [m.syms("parameter")], [c.expr])
    k_index = [v.name for v in m.of_kind("parameter")].index("a.k")
    p = np.array([v.start for v in m.of_kind("parameter")], float)
    assert float(f(p)) > 0
    p[k_index] = 1.0
    assert float(f(p)) < 0
    with pytest.raises(ValueError, match="singular.*for every parameter value"):
        compose(_linear_loop(None))


@pytest.mark.slow
def test_a_singular_linear_loop_is_refused_at_initialization(tmp_path):
    from loomfmu.scene.monolithic import run_monolithic
    s = _linear_loop(0.5)
    ok = run_monolithic(s, fmu_dir=tmp_path)
    t = ok["time"]
    assert np.allclose(ok["a.y"], np.exp(-t) / 0.5, rtol=1e-6)   # x / (1 - k)
    s.set("a", parameters={"k": 1.0})
    with pytest.raises(RuntimeError, match=r"algebraic loop \(.*\) is singular"):
        run_monolithic(s, fmu_dir=tmp_path)


@pytest.mark.slow
def test_a_composed_fmu_built_before_runs_the_scene_as_declared_now(tmp_path):
    """fmu= skips the build; the scene's parameter and start values are set
    on the instance, so a changed value is not silently the old default."""
    from loomfmu.machines.two_mass import scene
    from loomfmu.scene.monolithic import composed_fmu, run_monolithic
    path, _ = composed_fmu(scene(stop_time=0.5), tmp_path / "default")
    s = scene(stop_time=0.5)
    s.set("force", parameters={"m1": 5.0})
    reused = run_monolithic(s, stop=0.5, step=0.1, fmu=path)
    built = run_monolithic(s, stop=0.5, step=0.1, fmu_dir=tmp_path / "heavy")
    np.testing.assert_allclose(reused["force.x1_out"], built["force.x1_out"], rtol=1e-12,
                               atol=1e-15)
    default = run_monolithic(scene(stop_time=0.5), stop=0.5, step=0.1, fmu=path)
    assert np.max(np.abs(default["force.x1_out"] - built["force.x1_out"])) > 1e-3
    with pytest.raises(ValueError, match=r"fmu_dir = 5; allowed: a directory"):
        run_monolithic(s, fmu_dir=5)


@pytest.mark.slow
def test_a_composed_fmu_of_another_scene_is_refused_naming_it(tmp_path):
    from loomfmu.scene.monolithic import composed_fmu, run_monolithic
    other, _ = composed_fmu(_loop_scene(), tmp_path)
    from loomfmu.machines.two_mass import scene
    with pytest.raises(ValueError, match=r"fmu = .*: it has no force\.x1_out.*allowed: the "
                                         r"composed FMU of scene 'two_mass'"):
        run_monolithic(scene(), fmu=other)
    (tmp_path / "junk.fmu").write_text("not a zip")
    with pytest.raises(ValueError, match="not a readable FMU"):
        run_monolithic(scene(), fmu=tmp_path / "junk.fmu")
