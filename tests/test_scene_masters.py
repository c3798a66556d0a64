"""Scene masters: port connections by role (kind, unit, direction, driven
twice, no common role), algebraic loops iterated at communication points
(against their analytic solution), and input extrapolation of order 0-2
(against the exact co-simulation map of the two-mass benchmark, including
the first steps, rejected steps and the stability limits)."""
from __future__ import annotations

import math
import re
import zipfile

import numpy as np
import pytest
from scipy.optimize import brentq

from loomfmu.declare.model import Model
from loomfmu.machines import two_mass as tm
from loomfmu.scene import Scene, run
from loomfmu.scene.extrapolation import History, shift, shift_rows, taylor, taylor_many, value
from loomfmu.scene.fmus import build_fmus
from loomfmu.scene.interface import AssumedDependencies, outputs_without_dependencies
from loomfmu.scene.system import FMUError, ModelInvalid

#: these tests run the masters at and past their stability limits on purpose:
#: run()'s warning that the steps do not resolve the coupling is expected
pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("ignore::loomfmu.scene.run.UnresolvedCoupling")]

SRC = "assumption: a test model"


def raises(match: str):
    return pytest.raises(ValueError, match=match)


# -- small declared models ---------------------------------------------------------
def shaft(name: str, *, speed: str | None = "out", torque: str | None = "in",
          speed_unit: str = "rad/s") -> Model:
    """A flywheel with a flange port: its speed out and the torque in, or the
    other way round, or one role only."""
    m = Model(name, description="test flywheel", stop_time=1.0, step_size=1e-2, h_fixed=1e-3)
    J = m.parameter("J", 1.0, unit="kg.m2", description="inertia", source=SRC)
    w = m.state("w", 1.0, unit="rad/s", description="speed")
    roles = {}
    tq = 0.0
    if torque == "in":
        tq = m.input("tq_in", 0.0, unit="N.m", description="torque on the flange")
        roles["torque"] = "tq_in"
    if speed == "in":
        w_in = m.input("w_in", 0.0, unit=speed_unit, description="speed of the far side")
        roles["speed"] = "w_in"
        tq_out = 10.0 * (w_in - w)
    else:
        tq_out = -w
    m.eq(J * m.der(w), tq - w)
    m.output("w_mon", w, unit="rad/s", description="speed (monitor)")
    if speed == "out":
        m.output("w_out", w * (30 / math.pi if speed_unit == "rpm" else 1.0), unit=speed_unit,
                 description="speed")
        roles["speed"] = "w_out"
    if torque == "out":
        m.output("tq_out", tq_out, unit="N.m", description="torque through the flange")
        roles["torque"] = "tq_out"
    m.port("flange", "flange", description="the flywheel's flange", **roles)
    return m


def warp_end(name: str) -> Model:
    m = Model(name, description="test warp end", stop_time=1.0, step_size=1e-2, h_fixed=1e-3)
    x = m.state("x", 0.0, unit="m", description="elongation")
    m.eq(m.der(x), -x)
    m.output("dl", x, unit="m", description="elongation")
    m.port("warp", "warp", elongation="dl", description="warp ends")
    return m


def scene_of(*models: Model) -> Scene:
    s = Scene("ports", stop_time=0.1, step=1e-2)
    for mod in models:
        s.add(mod.name, model=mod)
    return s


def test_ports_connect_the_roles_they_share():
    s = scene_of(shaft("a"), shaft("b", speed="in", torque="out"),
                 shaft("c", speed="out", torque=None))
    new = s.connect("a.flange", "b.flange")
    assert sorted(str(c) for c in new) == ["a.w_out -> b.w_in", "b.tq_out -> a.tq_in"]
    s2 = scene_of(shaft("b", speed="in", torque="out"), shaft("c", speed="out", torque=None))
    (c,) = s2.connect("c.flange", "b.flange")          # c has no torque: speed only
    assert str(c) == "c.w_out -> b.w_in" and c.port.endswith("(speed)")


def test_port_connection_errors_name_the_connection_and_what_is_allowed():
    s = scene_of(shaft("a"), shaft("a2"), shaft("b", speed="in", torque="out"),
                 shaft("s", speed="out", torque=None), shaft("q", speed=None, torque="in"),
                 warp_end("w"))
    # kind
    with raises(r"connection a.flange -> w.warp: port kinds differ \('flange' and 'warp'\); "
                r"allowed: a port of kind 'flange' of w: none"):
        s.connect("a.flange", "w.warp")
    # no common role
    with raises(r"connection s.flange -> q.flange: the ports share no role \(s.flange: "
                r"speed; q.flange: torque\); allowed: ports of kind 'flange' with a role in "
                r"common"):
        s.connect("s.flange", "q.flange")
    # direction: speed out on both ends
    with raises(r"connection a.flange -> s.flange: role 'speed' is a.w_out \(output\) and "
                r"s.w_out \(output\); allowed: an output on one side and an input on the "
                r"other"):
        s.connect("a.flange", "s.flange")
    # driven twice
    s.connect("a.flange", "b.flange")
    with raises(r"connection a2.flange -> b.flange: input b.w_in is already driven by "
                r"a.w_out -> b.w_in; allowed: one connection into each input"):
        s.connect("a2.flange", "b.flange")
    # unit: a speed cannot drive a torque
    with raises(r"connection a2.w_out -> q.tq_in: unit 'rad/s' of a2.w_out cannot be "
                r"converted to 'N.m' of q.tq_in; allowed: units of the same quantity"):
        s.connect("a2.w_out", "q.tq_in")
    assert len(s.connections) == 2     # nothing refused was added


def test_port_roles_in_other_units_are_converted():
    s = scene_of(shaft("r", speed="out", torque=None, speed_unit="rpm"),
                 shaft("b", speed="in", torque="out"))
    (c,) = s.connect("r.flange", "b.flange")
    assert c.gain == pytest.approx(2 * math.pi / 60, rel=1e-15) and c.bias == 0.0


def test_a_declared_model_is_refused_options():
    with raises(r"options = \{'side': 'force'\}: model 'a' is a declaration; allowed: no "
                r"options"):
        Scene("x").add("a", model=shaft("a"), options={"side": "force"})


# -- algebraic loops ---------------------------------------------------------------
G, K, C = 1.5, 2.0, 0.3          # loop gain G K = 3: plain fixed point diverges


def loop_a() -> Model:
    """x' = -x; y = x + G u (direct feedthrough)."""
    m = Model("loop_a", description="test loop side a", stop_time=1.0, step_size=1e-2,
              h_fixed=1e-3)
    g = m.parameter("g", G, description="feedthrough gain", source=SRC)
    u = m.input("u", 0.0, description="input")
    x = m.state("x", 1.0, description="state")
    m.eq(m.der(x), -x)
    m.output("y", x + g * u, description="output (feedthrough)")
    return m


def loop_b(cubic: bool = False) -> Model:
    """z' = 0; y = C - K u (or C - K u^3): direct feedthrough, no dynamics."""
    m = Model("loop_b3" if cubic else "loop_b", description="test loop side b",
              stop_time=1.0, step_size=1e-2, h_fixed=1e-3)
    k = m.parameter("k", K, description="feedthrough gain", source=SRC)
    c = m.parameter("c", C, description="offset", source=SRC)
    u = m.input("u", 0.0, description="input")
    z = m.state("z", 0.0, description="a state that does not move")
    m.eq(m.der(z), 0.0 * z)
    m.output("y", c - k * (u**3 if cubic else u) + z, description="output (feedthrough)")
    return m


def loop_sqrt() -> Model:
    """y = sqrt(u) - 5 + z: NaN (the FMU refuses the read) for u < 0."""
    import casadi as ca
    m = Model("loop_sqrt", description="test loop side b: a square root",
              stop_time=1.0, step_size=1e-2, h_fixed=1e-3)
    u = m.input("u", 0.0, description="input")
    z = m.state("z", 0.0, description="a state that does not move")
    m.eq(m.der(z), 0.0 * z)
    m.output("y", ca.sqrt(u) - 5.0 + z, description="output (feedthrough)")
    return m


#: the validity test model's state reaches zero at this time
T_INVALID = 0.37


def invalid_after() -> Model:
    """x' = -1 from x = T_INVALID, valid while x >= 0."""
    m = Model("invalid_after", description="test: not valid beyond t = T_INVALID",
              stop_time=1.0, step_size=1e-2, h_fixed=1e-3)
    x = m.state("x", T_INVALID, description="time left")
    m.eq(m.der(x), -1.0 + 0.0 * x)
    m.require("x_left", x, "no time left: the test model is not valid here")
    m.output("y", x, description="time left")
    return m


#: the mode test model's state crosses X_MODE at t = 1 - X_MODE
X_MODE = 0.5


def mode_switch() -> Model:
    """x' = -1 from 1; mode q (an Integer output) 0 while x > X_MODE, 1 below."""
    m = Model("mode_switch", description="test: a mode that switches at t = 0.5",
              stop_time=1.0, step_size=1e-2, h_fixed=1e-3)
    x = m.state("x", 1.0, description="falls at rate 1")
    m.eq(m.der(x), -1.0 + 0.0 * x)
    q = m.mode("q", 0, (0, 1), description="0 above x = X_MODE, 1 below")
    m.event("cross", x - X_MODE, description="x passes X_MODE")
    m.mode_rule(q, (1 - 2 * q) * (x - X_MODE), events=["cross"])
    m.output("x_out", x, description="x")
    return m


def taut() -> Model:
    """z' = u; valid while its input u >= 0 (as a warp's tension must be)."""
    m = Model("taut", description="test: not valid for an input below zero",
              stop_time=2.0, step_size=1e-2, h_fixed=1e-3)
    u = m.input("u", 1.0, description="input, valid when >= 0")
    z = m.state("z", 0.0, description="integral of the input")
    m.eq(m.der(z), u)
    m.require("u_taut", u, "input below zero: the test model is not valid here")
    m.output("z_out", z, description="integral of the input")
    return m


@pytest.fixture(scope="module")
def loop_fmus(tmp_path_factory):
    path = tmp_path_factory.mktemp("loop_fmus")
    s = Scene("loops")
    s.add("a", model=loop_a())
    s.add("b", model=loop_b())
    s.add("b3", model=loop_b(cubic=True))
    s.add("bs", model=loop_sqrt())
    s.add("inv", model=invalid_after())
    s.add("sw", model=mode_switch())
    s.add("taut", model=taut())
    return build_fmus(s, path)


def loop_scene(fmus, *, cubic=False) -> tuple[Scene, dict]:
    """The loop scene and its FMUs by component."""
    paths = {"a": fmus["a"], "b": fmus["b3" if cubic else "b"]}
    s = Scene("loop", stop_time=0.5, step=0.05)
    for name, path in paths.items():
        s.add(name, fmu=path)
    s.connect("a.y", "b.u")
    s.connect("b.y", "a.u")
    s.record("a.x", "a.u", "b.u", "a.y", "b.y")
    return s, paths


def solution(x: float, cubic: bool) -> tuple[float, float]:
    """(u_a, u_b) of the loop u_b = x + G u_a, u_a = C - K u_b (or u_b^3)."""
    f = (lambda ub: ub**3) if cubic else (lambda ub: ub)
    ub = brentq(lambda ub: ub - x - G * (C - K * f(ub)), -10.0, 10.0, xtol=1e-15)
    return C - K * f(ub), ub


@pytest.mark.parametrize("cubic", [False, True])
@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_an_algebraic_loop_is_solved_at_each_communication_point(loop_fmus, master, cubic):
    s, fmus = loop_scene(loop_fmus, cubic=cubic)
    assert [str(c) for c in s.loops()[0]] == ["a.y -> b.u", "b.y -> a.u"]
    res = run(s, master=master, fmus=fmus)
    t = res["time"]
    assert np.allclose(res["a.x"], np.exp(-t), rtol=1e-6, atol=0)
    # the inputs held over step n -> n + 1 (recorded at n + 1) solve the loop at t_n
    # (Gauss-Seidel: b steps after a and reads a's output at t_n+1: a.y = x + G u_a)
    for n in range(len(t) - 1):
        ua, ub = solution(float(np.exp(-t[n])), cubic)
        assert res["a.u"][n + 1] == pytest.approx(ua, abs=1e-9)
        if master == "jacobi":
            assert res["b.u"][n + 1] == pytest.approx(ub, abs=1e-9)
        else:
            assert res["b.u"][n + 1] == pytest.approx(float(np.exp(-t[n + 1])) + G * ua,
                                                      abs=1e-7)
    assert res.loop_iterations > 0


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_an_integer_output_a_mode_is_recorded_as_a_number(loop_fmus, master):
    s = Scene("modes", stop_time=1.0, step=0.15)   # no point at the switch itself
    s.add("sw", fmu=loop_fmus["sw"])
    s.record("sw.q", "sw.x_out")
    res = run(s, master=master, fmus={"sw": loop_fmus["sw"]})
    t = res["time"]
    assert np.allclose(res["sw.x_out"], 1.0 - t, atol=1e-9)
    assert list(res["sw.q"]) == [0.0 if x > X_MODE else 1.0 for x in 1.0 - t]
    assert res["sw.q"][0] == 0.0 and res["sw.q"][-1] == 1.0
    # by default every output is recorded, the mode too
    s.recorded.clear()
    res = run(s, master=master, fmus={"sw": loop_fmus["sw"]})
    assert {"sw.q", "sw.x_out"} <= set(res.data.dtype.names)
    with raises(r"record 'sw.nope': no such variable; allowed: a Real, Integer, Boolean or "
                r"enumeration variable of sw \(.*q.*\)"):
        s.record("sw.nope")


@pytest.mark.parametrize("method", ["newton", "fixed-point"])
@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_a_loop_without_a_solution_stops_the_run_naming_it(loop_fmus, master, method):
    """y_a = x + 2 u_a, y_b = 0.6 + 0.5 u_b: loop gain exactly 1, u_a = 0.6 + 0.5 x
    + u_a has no solution.  The run stops at the first communication point
    (t = 0) naming the loop and its residual; the iterate's own size does not
    loosen the convergence test."""
    s, fmus = loop_scene(loop_fmus)
    s.set("a", parameters={"g": 2.0})
    s.set("b", parameters={"k": -0.5, "c": 0.6})
    loop = r"algebraic loop \(a.y -> b.u; b.y -> a.u\)"
    if method == "newton":
        match = (loop + r": singular Jacobian I - dG/du at t = 0 s \(condition number "
                 r"[0-9.e+]+, above 1e\+08; largest \|G\(u\) - u\| = [0-9.e+-]+\): the loop "
                 r"equations have no unique solution")
    else:
        match = (loop + r" did not converge at t = 0 s after 50 fixed-point iterations: "
                 r"largest \|G\(u\) - u\| = [0-9.e+-]+ \(tolerance loop_atol = 1e-12 \+ "
                 r"loop_rtol = 1e-10 \* s, s = [0-9.e+-]+: \|u\| and \|G\(u\)\| before")
    with pytest.raises(FMUError, match=match):
        run(s, master=master, fmus=fmus, loop_options={"loop_method": method})


def test_a_diverging_loop_iterate_is_stopped(loop_fmus):
    """Plain fixed point (w = 1) on the loop of gain 3 grows by sqrt(3) per
    iteration: stopped once |u| is a million times its scale."""
    s, fmus = loop_scene(loop_fmus)
    with pytest.raises(FMUError, match=r"algebraic loop \(a.y -> b.u; b.y -> a.u\) "
                       r"diverges at t = 0 s: after \d+ fixed-point iterations \|u\| = "
                       r"[0-9.e+]+ \(more than 1e\+06 times its scale"):
        run(s, fmus=fmus, loop_options={"loop_method": "fixed-point", "relaxation": 1.0})


def without_dependencies(fmu, out) -> str:
    """A copy of the FMU ``fmu`` at ``out`` whose model description lists
    its outputs without the dependencies attribute (valid FMI 2.0: such an
    output depends on every input)."""
    with zipfile.ZipFile(fmu) as z:
        files = {n: z.read(n) for n in z.namelist()}
    xml = files["modelDescription.xml"].decode()
    head, rest = xml.split("<Outputs>", 1)
    outputs, tail = rest.split("</Outputs>", 1)
    outputs = re.sub(r' dependencies(Kind)?="[^"]*"', "", outputs)
    assert "dependencies" not in outputs
    files["modelDescription.xml"] = (head + "<Outputs>" + outputs + "</Outputs>" + tail).encode()
    with zipfile.ZipFile(out, "w") as z:
        for n, data in files.items():
            z.writestr(n, data)
    return str(out)


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_an_output_without_dependencies_depends_on_every_input(loop_fmus, master,
                                                                tmp_path):
    """FMI 2.0 and 3.0: an output whose ModelStructure entry has no
    dependencies depends on all inputs.  The loop a.y -> b.u -> b.y -> a.u is
    found and solved as with the dependencies declared, and the assumption
    is said once per component."""
    fmus = {n: without_dependencies(loop_fmus[n], tmp_path / f"{n}.fmu") for n in "ab"}
    s = Scene("loop", stop_time=0.5, step=0.05)
    for name in "ab":
        with pytest.warns(AssumedDependencies, match=rf"component {name} \(FMU .*\): "
                          r"outputs y declare no dependencies in the model description; "
                          r"taken to depend directly on every input"):
            s.add(name, fmu=fmus[name])
        assert s.components[name].interface.feedthrough["y"] == ("u",)
    s.connect("a.y", "b.u")
    s.connect("b.y", "a.u")
    s.record("a.x", "a.u", "b.u")
    assert [str(c) for c in s.loops()[0]] == ["a.y -> b.u", "b.y -> a.u"]
    res = run(s, master=master, fmus=fmus)
    t = res["time"]
    for n in range(len(t) - 1):
        ua, _ = solution(float(np.exp(-t[n])), False)
        assert res["a.u"][n + 1] == pytest.approx(ua, abs=1e-9)
    assert res.loop_iterations > 0


def test_empty_dependencies_state_no_feedthrough_and_a_missing_attribute_all():
    xml = ('<fmiModelDescription fmiVersion="2.0"><ModelVariables>'
           '<ScalarVariable name="u" causality="input"/>'
           '<ScalarVariable name="y1" causality="output"/>'
           '<ScalarVariable name="y2" causality="output"/>'
           '<ScalarVariable name="y3" causality="output"/></ModelVariables>'
           '<ModelStructure><Outputs><Unknown index="2" dependencies=""/>'
           '<Unknown index="3"/></Outputs></ModelStructure></fmiModelDescription>')
    assert outputs_without_dependencies(xml) == {"y2", "y3"}
    xml3 = ('<fmiModelDescription fmiVersion="3.0"><ModelVariables>'
            '<Float64 name="u" valueReference="1" causality="input"/>'
            '<Float64 name="y1" valueReference="2" causality="output"/>'
            '<Float64 name="y2" valueReference="3" causality="output"/></ModelVariables>'
            '<ModelStructure><Output valueReference="2" dependencies="1"/>'
            '<Output valueReference="3"/></ModelStructure></fmiModelDescription>')
    assert outputs_without_dependencies(xml3) == {"y2"}


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_a_validity_failure_says_how_far_the_coupled_input_moved(loop_fmus, master):
    """x = 1 - t drives the taut model's input, valid while >= 0: at a step of
    0.3 s the input held from t = 1.2 (Gauss-Seidel: 0.9) is -0.2, 0.3 below the
    0.1 of the step before.  The message says so and that a shorter step or extrapolation may
    help; a component without coupled inputs is told a shorter step cannot."""
    s = Scene("taut", stop_time=1.5, step=0.3)
    s.add("sw", fmu=loop_fmus["sw"])
    s.add("taut", fmu=loop_fmus["taut"])
    s.connect("sw.x_out", "taut.u")
    fmus = {"sw": loop_fmus["sw"], "taut": loop_fmus["taut"]}
    # Gauss-Seidel: taut steps after sw and reads x at the step's end, 0.3 s earlier
    at = "1.2" if master == "jacobi" else "0.9"
    with pytest.raises(ModelInvalid, match=rf"taut: fmi2DoStep .* failed at t = {at} s.*"
                       r"input below zero.*\[fmi2Terminated: the model is not valid beyond "
                       r"this point; its coupled inputs at the start of this step of 0.3 s: u "
                       r"moved by -0.3 from 0.1 to -0.2 since the previous communication "
                       r"point, 150 % of its size. An input held or extrapolated over a long "
                       r"step can overshoot: a shorter communication step or input "
                       r"extrapolation may help\]"):
        run(s, master=master, fmus=fmus)
    s = Scene("invalid", stop_time=1.0, step=0.1)
    s.add("inv", fmu=loop_fmus["inv"])
    with pytest.raises(ModelInvalid, match=r"the component has no coupled input: a shorter "
                       r"communication step cannot help"):
        run(s, master=master, fmus={"inv": loop_fmus["inv"]})


def test_a_loop_that_does_not_converge_is_named(loop_fmus):
    s, loop_fmus = loop_scene(loop_fmus)
    # relaxed fixed point u <- u + w (G(u) - u): dG/du = [[0, G], [-K, 0]] has eigenvalues
    # +-i sqrt(G K), so the iteration contracts by sqrt((1 - w)^2 + 3 w^2): 1 at w = 0.5
    with pytest.raises(FMUError, match=r"algebraic loop \(a.y -> b.u; b.y -> a.u\) did not "
                       r"converge at t = 0 s after 30 fixed-point iterations: largest "
                       r"\|G\(u\) - u\| = .*loop_atol"):
        run(s, fmus=loop_fmus, loop_options={"loop_method": "fixed-point", "relaxation": 0.5,
                                             "loop_max_iter": 30})
    # and sqrt(0.75) at w = 0.25: converges, slowly (Newton: in 2 iterations)
    res = run(s, fmus=loop_fmus, loop_options={"loop_method": "fixed-point",
                                               "relaxation": 0.25, "loop_max_iter": 300})
    ua, _ = solution(1.0, False)
    assert res["a.u"][1] == pytest.approx(ua, abs=1e-9)
    with raises(r"loop_options: unknown \['tol'\]"):
        run(s, fmus=loop_fmus, loop_options={"tol": 1e-3})
    with raises(r"loop_method = 'secant'; allowed: newton, fixed-point"):
        run(s, fmus=loop_fmus, loop_options={"loop_method": "secant"})
    with raises(r"relaxation = 1.5; allowed: a number in \(0, 1\]"):
        run(s, fmus=loop_fmus, loop_options={"relaxation": 1.5})


@pytest.mark.parametrize("method", ["newton", "fixed-point"])
def test_an_output_that_cannot_be_read_names_component_call_time_and_log(loop_fmus, method,
                                                                          monkeypatch, capsys):
    """b.y = sqrt(u) - 5 drives a.u = -5 + ..., so b reads u = x + G a.u < 0:
    the FMU refuses fmi2GetReal (NaN); the error says who, what, when and the
    FMU's log line, and the command prints it on one line with exit 1."""
    s, _ = loop_scene(loop_fmus)
    paths = {"a": loop_fmus["a"], "b": loop_fmus["bs"]}
    s = Scene("loop_sqrt", stop_time=0.1, step=0.01)
    for name, path in paths.items():
        s.add(name, fmu=path)
    s.connect("a.y", "b.u")
    s.connect("b.y", "a.u")
    s.record("a.y", "b.y")
    with pytest.raises(FMUError, match=r"^b: fmi2GetReal \(y, for b.y -> a.u\) failed at "
                       r"t = 0 s \(.*status 3.*\); its log: .*y") as exc:
        run(s, fmus=paths, loop_options={"loop_method": method})
    assert "NaN" in str(exc.value) or "nan" in str(exc.value)
    import loomfmu.cli.scene as cli
    monkeypatch.setattr(cli, "load_scene", lambda name: s)
    assert cli.main(["run", "loop_sqrt", "--stop", "0.05"]) == 1
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("loomfmu scene run: run failed: b: "
                                               "fmi2GetReal (y, for b.y -> a.u)"), err
    assert "Traceback" not in captured.err


@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_an_adaptive_run_stops_at_once_where_the_model_is_not_valid(loop_fmus, master):
    """fmi2Discard with fmi2Terminated true is not a rejected step: the run
    stops at the first failing step with the FMU's message, not after
    shrinking the step to h_min."""
    s = Scene("invalid", stop_time=1.0, step=0.1)
    s.add("inv", fmu=loop_fmus["inv"])
    s.record("inv.y")
    with pytest.raises(FMUError, match=r"inv: fmi2DoStep \(h = 0.1 s\) failed at t = 0.3 s "
                       r".*no time left: the test model is not valid here.*fmi2Terminated"
                       ) as exc:
        run(s, master=master, fmus={"inv": loop_fmus["inv"]}, adaptive=True, h_min=1e-6)
    assert "h_min" not in str(exc.value)
    # a fixed-step run stops there too
    with pytest.raises(FMUError, match=r"failed at t = 0.3 s .*not valid here"):
        run(s, master=master, fmus={"inv": loop_fmus["inv"]})


# -- extrapolation: the polynomial ------------------------------------------------
def test_taylor_coefficients_of_the_extrapolation():
    q = lambda t: 2.0 - 3.0 * t + 0.7 * t * t          # noqa: E731
    taus = [-2e-3, -1e-3, 0.0]
    c = taylor(taus, [q(x) for x in taus], 2)
    assert np.allclose(c, [2.0, -3.0, 1.4], rtol=1e-9, atol=1e-9)
    assert value(c, 5e-3) == pytest.approx(q(5e-3), rel=1e-12)
    # expanded elsewhere and moved back
    c1 = taylor([t - 1e-3 for t in taus], [q(x) for x in taus], 2)
    assert np.allclose(shift(c1, -1e-3), c, rtol=1e-9, atol=1e-9)
    # fewer samples: lower degree, zero rows
    assert np.allclose(taylor([0.0], [4.0], 2), [4.0, 0.0, 0.0])
    with raises(r"taylor: 3 samples for order 1"):
        taylor(taus, [1, 2, 3], 1)
    # a rejected step leaves no sample
    hist = History(1)
    hist.coefficients(0, 0.0, 1.0, 0.0, 1)
    hist.commit()
    hist.coefficients(0, 0.1, 5.0, 0.1, 1)
    hist.discard()
    c = hist.coefficients(0, 0.05, 2.0, 0.05, 1)
    assert np.allclose(c, [2.0, 20.0])


def test_the_masters_row_at_a_time_polynomials_are_those_of_taylor_and_shift_bit_for_bit():
    """The master fits all connections sampled at the same times in one call
    (taylor_many) and moves their polynomials together (shift_rows): the
    numbers must be those of taylor and shift exactly, not to rounding."""
    rng = np.random.default_rng(7)
    for order in (1, 2):
        for n_samples in range(1, order + 2):
            for _ in range(50):
                h = 10.0 ** rng.uniform(-6, 0)
                t = rng.uniform(0, 10)
                taus = [((j - n_samples + 1) * h + t) - t for j in range(n_samples)]
                rows = rng.normal(size=(4, n_samples)) * 10.0 ** rng.uniform(-3, 3)
                many = taylor_many(taus, rows.tolist(), order)
                for row, got in zip(rows, many):
                    want = taylor(taus, row, order)
                    assert np.array_equal(np.array(got), want), (got, want)
                s = rng.uniform(0, 2) * h
                for row, got in zip(many, shift_rows(many, s)):
                    assert np.array_equal(np.array(got), shift(row, s))
                    assert got[0] == value(row, s)
    with raises(r"taylor_many: 3 samples for order 1"):
        taylor_many([-2.0, -1.0, 0.0], [[1.0, 2.0, 3.0]], 1)


def test_a_step_makes_one_fmi_call_per_component_and_direction(loop_fmus, monkeypatch):
    """FMI calls counted at FMPy's ctypes functions (the FMUs' own): a loop-free
    scene of two FMUs, three connections, moves its values with one
    fmi2GetReal per source component and one fmi2SetReal per receiving
    component per stage, and reads every source and recorded variable once
    per component after the step."""
    from fmpy.fmi2 import FMU2Slave
    counts: dict[str, int] = {}
    load = FMU2Slave._loadFunctions

    def counting(slave):
        load(slave)
        for name, fn in list(slave._functions.items()):
            def call(*args, _fn=fn, _name=name):
                counts[_name] = counts.get(_name, 0) + 1
                return _fn(*args)
            call.argtypes, call.restype = fn.argtypes, fn.restype
            call.argnames = getattr(fn, "argnames", None)
            slave._functions[name] = call
    monkeypatch.setattr(FMU2Slave, "_loadFunctions", counting)
    s = Scene("chain", stop_time=0.3, step=0.05)      # z is valid up to 0.37 s
    s.add("a", fmu=loop_fmus["a"])          # y = x + G u (feedthrough)
    s.add("z", fmu=loop_fmus["inv"])        # y = time left (no input)
    s.connect("z.y", "a.u")
    s.record("a.x", "a.y", "z.y")
    res = {}
    for stop in (0.1, 0.3):
        counts.clear()
        run(s, fmus={"a": loop_fmus["a"], "z": loop_fmus["inv"]}, stop=stop)
        res[stop] = dict(counts)
    per_step = {k: (res[0.3].get(k, 0) - res[0.1].get(k, 0)) / 4 for k in res[0.3]}
    # z.y -> a.u: one read of z, one set of a; after the step one read of each
    assert per_step["fmi2GetReal"] == 3 and per_step["fmi2SetReal"] == 1, per_step
    assert per_step["fmi2DoStep"] == 2, per_step


# -- extrapolation on the two-mass benchmark ----------------------------------------
Z = ("force.x1_out", "force.v1_out", "disp.x2_out", "disp.v2_out")
Z0 = [0.1, 0.0, 0.0, 0.0]
#: master name and options for each algorithm of the theory
MASTERS = {"jacobi": ("jacobi", {}),
           "gauss-seidel:force-first": ("gauss-seidel", {}),
           "gauss-seidel:disp-first": ("gauss-seidel", {"order": ["disp", "force"]})}


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    scene = tm.scene(stop_time=1.0)
    fmus = build_fmus(scene, tmp_path_factory.mktemp("two_mass"))
    return scene, fmus, tm.Params.declared()


def states(res) -> np.ndarray:
    return np.column_stack([res[n] for n in Z])


def ours(bench, algorithm, h, n, order, **kw):
    scene, fmus, _ = bench
    master, opts = MASTERS[algorithm]
    return run(scene, master=master, step=h, stop=n * h, fmus=fmus, extrapolation=order,
               master_options=opts, **kw)


def identified_radius(z: np.ndarray, depth: int) -> float:
    """Spectral radius of z_{n+1} = sum_j K_j z_{n-j} (j < depth) fitted by least
    squares to a run: the extrapolated map acts on the last ``depth`` states."""
    X = np.hstack([z[depth - 1 - j:len(z) - 1 - j] for j in range(depth)])
    K, *_ = np.linalg.lstsq(X, z[depth:], rcond=None)
    M = np.zeros((4 * depth, 4 * depth))
    M[:4] = K.T
    M[4:, :-4] = np.eye(4 * (depth - 1))
    return float(max(abs(np.linalg.eigvals(M))))


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("algorithm", list(MASTERS))
def test_extrapolating_master_reproduces_the_exact_map(bench, algorithm, order):
    """From the first step (a shorter history: lower order), at a step well
    inside and one past the stability limit."""
    p = bench[2]
    lim = tm.stability_limit(p, algorithm, order=order)
    for h in (1e-3, 1.2 * lim):
        n = 100
        z = states(ours(bench, algorithm, h, n, order))
        ref = tm.extrapolated_trajectory(p, h, n, Z0, algorithm, order)
        assert np.abs(z - ref).max() < 1e-9 * np.abs(ref).max(), (h, np.abs(z - ref).max())
    # the map differs from the zero-order hold's: the test can fail
    ref0 = tm.extrapolated_trajectory(p, 1e-3, 100, Z0, algorithm, 0)
    assert np.abs(ref0 - tm.extrapolated_trajectory(p, 1e-3, 100, Z0, algorithm,
                                                    order)).max() > 1e-4


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("algorithm", ["jacobi", "gauss-seidel:force-first"])
def test_extrapolated_stability_is_lost_where_the_theory_says(bench, algorithm, order):
    p = bench[2]
    lim = tm.stability_limit(p, algorithm, order=order)
    for f, below in ((0.999, True), (1.001, False)):
        h = f * lim
        rho = tm.spectral_radius(p, h, algorithm, order)
        assert (rho < 1) == below
        z = states(ours(bench, algorithm, h, 60, order))
        measured = identified_radius(z[2 * order + 2:], order + 1)
        assert measured == pytest.approx(rho, abs=1e-7)
    # a long run decays below the limit and grows above it
    for f, grows in ((0.8, False), (1.25, True)):
        z = states(ours(bench, algorithm, f * lim, 600, order))
        late = np.abs(z[-100:]).max() / np.abs(z[:100]).max()
        assert (late > 1.5) if grows else (late < 0.5), (f, late)


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("master", ["jacobi", "gauss-seidel"])
def test_adaptive_extrapolated_run_keeps_no_sample_of_a_rejected_step(bench, master, order):
    """The run equals the theory over its accepted steps, whose polynomials go
    through samples at the accepted communication points only."""
    scene, fmus, p = bench
    res = run(scene, master=master, step=1e-3, adaptive=True, rtol=1e-2, atol=1e-4,
              fmus=fmus, stop=0.3, extrapolation=order)
    assert res.rejected > 0 and res.accepted == len(res.h)
    assert len(set(np.round(res.h, 12))) > 10
    algorithm = "jacobi" if master == "jacobi" else "gauss-seidel:force-first"
    z = states(res)
    ref = tm.extrapolated_run(p, res.h, Z0, algorithm, order)
    assert np.abs(z - ref).max() < 1e-9 * np.abs(ref).max()


def test_extrapolation_order_raises_the_accuracy(bench):
    """Error against the monolithic solution over 1 s at H = 1 ms: the order
    k extrapolation's error falls by more than 10x per order; the output
    derivatives (order 1) do as well as the history's line."""
    p = bench[2]
    errs = {}
    for k, od in ((0, False), (1, False), (2, False), (1, True)):
        res = ours(bench, "gauss-seidel:force-first", 1e-3, 1000, k,
                   ) if not od else run(bench[0], master="gauss-seidel", step=1e-3,
                                        stop=1.0, fmus=bench[1], extrapolation=1,
                                        master_options={"output_derivatives": True})
        z = states(res)
        exact = tm.exact_solution(p, res["time"], z[0])
        errs[(k, od)] = np.abs(z - exact).max() / np.abs(exact).max()
    assert errs[(1, False)] < errs[(0, False)] / 10
    assert errs[(2, False)] < errs[(1, False)] / 10
    assert errs[(1, True)] < errs[(1, False)]


def test_extrapolation_is_refused_where_an_fmu_cannot_interpolate(bench, tmp_path):
    scene, fmus, _ = bench
    # the displacement side's FMU, its model description saying it cannot interpolate
    plain = tmp_path / "disp_plain.fmu"
    with zipfile.ZipFile(fmus["disp"]) as src, zipfile.ZipFile(plain, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                assert 'canInterpolateInputs="true"' in text
                data = text.replace('canInterpolateInputs="true"',
                                    'canInterpolateInputs="false"').replace(
                    'maxOutputDerivativeOrder="1"', 'maxOutputDerivativeOrder="0"').encode()
            dst.writestr(item, data)
    s = Scene("plain", stop_time=0.01, step=1e-3)
    s.add("force", fmu=fmus["force"], start={"x1": 0.1})
    s.add("disp", fmu=plain)
    s.connect("force.F_c", "disp.F_in")
    s.connect("disp.x2_out", "force.x2_in")
    s.connect("disp.v2_out", "force.v2_in")
    with raises(r"extrapolation = 1: component disp cannot interpolate inputs \(its FMU "
                r"declares canInterpolateInputs = false\); allowed: extrapolation = 0"):
        run(s, extrapolation=1)
    # its outputs have no derivatives: the force side cannot take them
    s2 = Scene("plain2", stop_time=0.01, step=1e-3)
    s2.add("force", fmu=fmus["force"], start={"x1": 0.1})
    s2.add("disp", fmu=fmus["disp"])
    s2.add("mon", fmu=plain)
    s2.connect("mon.x2_out", "force.x2_in")
    with raises(r"output_derivatives = True: component mon declares "
                r"maxOutputDerivativeOrder = 0 < extrapolation = 1"):
        run(s2, extrapolation=1, master_options={"output_derivatives": True})
    with raises(r"extrapolation = 3; allowed: one of 0, 1, 2"):
        run(s2, extrapolation=3)
    with raises(r"resolve_feedthrough = False with extrapolation = 1"):
        run(s2, extrapolation=1, master_options={"resolve_feedthrough": False})
    assert run(s, extrapolation=0).accepted == 10      # order 0 needs nothing


def test_scene_command_takes_the_extrapolation_and_the_order(bench, capsys):
    from loomfmu.cli.scene import main
    fmu_dir = str(bench[1]["force"].parent)
    assert main(["run", "two_mass", "--master", "gauss-seidel", "--extrapolation", "2",
                 "--order", "disp,force", "--stop", "0.01", "--fmu-dir", fmu_dir]) == 0
    out = capsys.readouterr().out
    assert ("master gauss-seidel, extrapolation 2 (step: the scene's recommendation): "
            "10 steps accepted") in out
    assert main(["run", "two_mass", "--master", "jacobi", "--order", "disp,force",
                 "--stop", "0.01"]) == 2
    assert "--order disp,force: applies to --master gauss-seidel only (the master is " \
        "jacobi)" in capsys.readouterr().err


def test_output_derivatives_that_fail_fall_back_to_the_samples(bench, tmp_path):
    """FMUs that declare more output derivatives than they give (ours saying 2
    where the runtime gives order 1): the master notes it and extrapolates
    those connections from their samples, which is the exact map of the
    samples' polynomial."""
    scene, fmus, p = bench
    liars = {}
    for name in ("force", "disp"):
        liars[name] = tmp_path / f"{name}_liar.fmu"
        with zipfile.ZipFile(fmus[name]) as src, zipfile.ZipFile(liars[name], "w") as dst:
            for item in src.infolist():
                data = src.read(item.filename)
                if item.filename == "modelDescription.xml":
                    text = data.decode()
                    assert 'maxOutputDerivativeOrder="1"' in text
                    data = text.replace('maxOutputDerivativeOrder="1"',
                                        'maxOutputDerivativeOrder="2"').encode()
                dst.writestr(item, data)
    res = run(scene, master="gauss-seidel", extrapolation=2, stop=0.1, step=1e-3,
              fmus=liars, master_options={"output_derivatives": True})
    assert len(res.notes) == 3 and all("output derivatives unavailable" in n
                                       for n in res.notes), res.notes
    assert "disp.x2_out -> force.x2_in" in " ".join(res.notes)
    ref = tm.extrapolated_trajectory(p, 1e-3, 100, Z0, "gauss-seidel:force-first", 2)
    assert np.abs(states(res) - ref).max() < 1e-9 * np.abs(ref).max()
