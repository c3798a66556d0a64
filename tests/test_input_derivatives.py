"""FMI 2.0 input derivatives (fmi2SetRealInputDerivatives, canInterpolateInputs)
and first output derivatives (fmi2GetRealOutputDerivatives).

Oracles: closed forms for small models declared here (an integrator of the
input, of its square, of its delayed value; an implicit one solved by
Newton), the scipy reference with the input as an exact function of time,
and the same FMU fed a fine staircase, for the modal spindle under a speed
ramp (the full spindle takes minutes per run; the modal one has the same
inputs and equations, projected)."""
from __future__ import annotations

import ctypes
import math

import casadi as ca
import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.fmi1 import FMICallException

from loomfmu import build_fmu, load_model
from loomfmu.declare.model import Model
from loomfmu.declare.solvers import SOLVERS
from loomfmu.verification.reference import reference

pytestmark = pytest.mark.slow  # builds FMUs

TAU = 0.1  # delay of the delayed integrator
A, B, U0 = 2.0, 3.0, 0.5  # u(t) = U0 + A t + B t^2 / 2


def _poly_model() -> Model:
    m = Model("poly_in", description="integrators of an input, its square and its delayed "
              "value", stop_time=1.0, step_size=0.1, h_fixed=1e-3)
    u = m.input("u", 0.0, unit="", description="input", min=-100.0, max=100.0)
    x = m.state("x", 0.0, unit="", description="integral of u")
    p = m.state("phi", 0.0, unit="", description="integral of u^2")
    z = m.state("z", 0.0, unit="", description="integral of u(t - tau)")
    ud = m.delay("u_late", u, TAU, max_delay=1.0, description="u, tau ago")
    m.eq(m.der(x), u)
    m.eq(m.der(p), u * u)
    m.eq(m.der(z), ud)
    m.output("y", x + u, unit="", description="x + u")
    m.output("s", ca.sin(p), unit="", description="sin(phi)")
    m.output("late", ud, unit="", description="u, tau ago")
    return m


def _switch_model() -> Model:
    """x' = q, the mode q switching from 0 to 1 where the input crosses 1."""
    m = Model("switch_in", description="a mode switched by the input", stop_time=1.0,
              step_size=0.1)
    u = m.input("u", 0.0, unit="", description="input", min=-100.0, max=100.0)
    x = m.state("x", 0.0, unit="", description="time spent with u >= 1")
    q = m.mode("mode_q", 0, (0, 1), description="1 where u >= 1")
    m.event("cross", u - 1.0, description="u crosses 1")
    m.mode_rule(q, ca.if_else(q == 1, u - 1.0, 1.0 - u), events=["cross"])
    m.eq(m.der(x), q)
    return m


def _implicit_model() -> Model:
    """der(x)^3 + der(x) = u: nonlinear in der(x), solved by Newton in the FMU."""
    m = Model("implicit_in", description="x' from x'^3 + x' = u", stop_time=1.0,
              step_size=0.1)
    u = m.input("u", 0.0, unit="", description="input", min=-100.0, max=100.0)
    x = m.state("x", 0.0, unit="", description="state")
    w = m.der(x)
    m.eq(w**3 + w, u)
    m.output("rate", w, unit="", description="x'")
    return m


def u_exact(t):
    return U0 + A * t + 0.5 * B * t * t


def closed_form(t):
    """x, phi, z, y, s and dy/dt, ds/dt at t for u_exact (u = U0 before 0)."""
    x = U0 * t + A * t**2 / 2 + B * t**3 / 6
    c = [U0, A, B / 2]  # u = sum c_i t^i; u^2 integrated term by term
    phi = sum(c[i] * c[j] * t ** (i + j + 1) / (i + j + 1) for i in range(3) for j in range(3))
    s = t - TAU  # z' = u(t - tau), u = U0 for t < tau's start
    z = U0 * min(t, TAU) + (0.0 if s <= 0 else U0 * s + A * s**2 / 2 + B * s**3 / 6)
    u = u_exact(t)
    return {"x": x, "phi": phi, "z": z, "y": x + u, "s": math.sin(phi),
            "dy": u + A + B * t, "ds": math.cos(phi) * u * u}


@pytest.fixture(scope="module")
def poly_fmu(tmp_path_factory):
    return build_fmu(_poly_model(), out_dir=tmp_path_factory.mktemp("poly")).path


@pytest.fixture(scope="module")
def switch_fmu(tmp_path_factory):
    return build_fmu(_switch_model(), out_dir=tmp_path_factory.mktemp("switch")).path


@pytest.fixture(scope="module")
def implicit_fmu(tmp_path_factory):
    return build_fmu(_implicit_model(), out_dir=tmp_path_factory.mktemp("impl")).path


SOLVER = {"dopri5": 1, "rodas4": 2, "rk4": 3}


def _run(slave, *, solver, h, t_end=1.0, derivatives=2, rtol=1e-10):
    """Drive u = u_exact through SetReal (+ derivatives up to `derivatives`) at
    each communication point; returns the values at the end."""
    s = slave
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.setInteger([s.vr["solver"]], [SOLVER[solver]])
    s.set(solver_rtol=rtol, solver_atol=1e-12, u=U0)
    s.fmu.enterInitializationMode()
    s.fmu.exitInitializationMode()
    t, n = 0.0, int(round(t_end / h))
    for i in range(n):
        t = i * h
        s.fmu.setReal([s.vr["u"]], [u_exact(t)])
        if derivatives >= 1:
            s.fmu.setRealInputDerivatives([s.vr["u"]], [1], [A + B * t])
        if derivatives >= 2:
            s.fmu.setRealInputDerivatives([s.vr["u"]], [2], [B])
        s.fmu.doStep(t, h)
    return dict(zip(("x", "phi", "z", "y", "s"), s.get("x", "phi", "z", "y", "s")))


@pytest.mark.parametrize("solver", ["dopri5", "rodas4", "rk4"])
def test_quadratic_input_is_integrated_not_staircased(poly_fmu, slave_factory, solver):
    """u(t) = U0 + A t + B t^2/2 given by its value and two derivatives at a
    coarse communication step: every solver integrates the polynomial (the
    delayed one too), while the same FMU fed the staircase misses by O(h)."""
    got = _run(slave_factory(poly_fmu), solver=solver, h=0.25)
    exact = closed_form(1.0)
    tol = 1e-7 if solver == "rk4" else 1e-8
    for k in ("x", "phi", "z", "y", "s"):
        assert got[k] == pytest.approx(exact[k], rel=tol, abs=tol), k
    stair = _run(slave_factory(poly_fmu, "stair"), solver=solver, h=0.25, derivatives=0)
    assert abs(stair["x"] - exact["x"]) > 0.1  # the staircase is far off
    ramp = _run(slave_factory(poly_fmu, "ramp"), solver=solver, h=0.25, derivatives=1)
    assert abs(ramp["x"] - exact["x"]) > 1e-3  # order 1 misses the curvature


@pytest.mark.parametrize("solver", [1, 2])
def test_events_are_located_on_the_input_polynomial(switch_fmu, slave_factory, solver):
    """The event u(t) = 1 falls inside a communication step: located on the
    interpolated input, x(1) = 1 - t*; with the staircase the switch waits
    for the next communication point."""
    t_star = (-A + math.sqrt(A * A - 2 * B * (U0 - 1.0))) / B
    ends = []
    for derivatives in (True, False):
        s = slave_factory(switch_fmu, f"d{derivatives}")
        s.start(u=U0, solver=solver, solver_rtol=1e-10, solver_atol=1e-12)
        for i in range(4):
            t = 0.25 * i
            s.fmu.setReal([s.vr["u"]], [u_exact(t)])
            if derivatives:
                s.fmu.setRealInputDerivatives([s.vr["u"], s.vr["u"]], [1, 2], [A + B * t, B])
            s.fmu.doStep(t, 0.25)
        ends.append(s.get("x")[0])
    assert 0.0 < t_star < 0.25
    assert ends[0] == pytest.approx(1.0 - t_star, abs=1e-8)
    assert ends[1] == pytest.approx(0.75, abs=1e-8)  # switched at t = 0.25


def test_rodas4_uses_the_input_rate_in_df_dt(poly_fmu, slave_factory):
    """At a loose tolerance rodas4 takes long steps; its df/dt must carry
    (df/du) du/dt, or x' = u(t) (no state dependence) loses its order.  With
    the term a polynomial u of degree 2 is integrated to rounding."""
    got = _run(slave_factory(poly_fmu), solver="rodas4", h=0.5, rtol=1e-2)
    assert got["x"] == pytest.approx(closed_form(1.0)["x"], rel=1e-12)


def test_polynomial_continues_until_set_again(poly_fmu, slave_factory):
    """Derivatives set once keep the input on its polynomial over later steps;
    fmi2SetReal of the input resets them (held from there)."""
    s = slave_factory(poly_fmu)
    s.start(u=U0)
    s.fmu.setRealInputDerivatives([s.vr["u"], s.vr["u"]], [1, 2], [A, B])
    t = 0.0
    for _ in range(4):
        s.fmu.doStep(t, 0.125)
        t += 0.125
        assert s.get("u")[0] == pytest.approx(u_exact(t), rel=1e-14)
    assert s.get("x")[0] == pytest.approx(closed_form(t)["x"], rel=1e-9)
    x_half = s.get("x")[0]
    s.fmu.setReal([s.vr["u"]], [1.0])  # held from here: x grows by 1 * 0.5
    for _ in range(4):
        s.fmu.doStep(t, 0.125)
        t += 0.125
    assert s.get("u")[0] == 1.0
    assert s.get("x")[0] == pytest.approx(x_half + 0.5, rel=1e-9)


def test_output_derivatives_are_exact(poly_fmu, implicit_fmu, slave_factory):
    """fmi2GetRealOutputDerivatives order 1 at the end of a step: dy/dt = u +
    du/dt, d sin(phi)/dt = cos(phi) u^2 (closed form), and for the implicit
    model (Newton) d(x')/dt = u' / (3 x'^2 + 1)."""
    s = slave_factory(poly_fmu)
    got = _run(s, solver="dopri5", h=0.25)
    dy, ds, dl = s.fmu.getRealOutputDerivatives([s.vr[k] for k in ("y", "s", "late")],
                                                [1, 1, 1])
    exact = closed_form(1.0)
    assert got["y"] == pytest.approx(exact["y"], rel=1e-9)
    assert dy == pytest.approx(exact["dy"], rel=1e-12)
    assert ds == pytest.approx(exact["ds"], rel=1e-8)
    assert dl == pytest.approx(A + B * (1.0 - TAU), rel=1e-9)  # the history's slope
    s = slave_factory(implicit_fmu, "implicit")
    s.start(u=2.0)  # x'^3 + x' = 2: x' = 1
    s.fmu.setRealInputDerivatives([s.vr["u"]], [1], [3.0])
    s.fmu.doStep(0.0, 0.1)  # u = 2.3 at the end
    w = s.get("rate")[0]
    assert w**3 + w == pytest.approx(2.3, rel=1e-12)
    (dw,) = s.fmu.getRealOutputDerivatives([s.vr["rate"]], [1])
    assert dw == pytest.approx(3.0 / (3 * w * w + 1), rel=1e-12)
    with pytest.raises(FMICallException):
        s.fmu.getRealOutputDerivatives([s.vr["rate"]], [2])
    assert "maxOutputDerivativeOrder = 1" in s.log[-1][2]


def test_state_round_trip_carries_the_derivatives(poly_fmu, slave_factory):
    """An FMU state taken after setting derivatives restores them: the redone
    step (in another instance, through bytes) gives the same bits."""
    a = slave_factory(poly_fmu, "a")
    a.start(u=U0)
    a.fmu.setRealInputDerivatives([a.vr["u"], a.vr["u"]], [1, 2], [A, B])
    a.fmu.doStep(0.0, 0.25)
    state = a.fmu.getFMUstate()
    blob = a.fmu.serializeFMUstate(state)
    a.fmu.doStep(0.25, 0.25)
    first = a.get("x", "phi", "z", "u")
    b = slave_factory(poly_fmu, "b")
    b.start(u=0.0)
    b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
    b.fmu.doStep(0.25, 0.25)
    assert b.get("x", "phi", "z", "u") == first
    a.fmu.setFMUstate(state)
    a.fmu.doStep(0.25, 0.25)
    assert a.get("x", "phi", "z", "u") == first
    a.fmu.freeFMUstate(state)


def _raw(slave, name):
    f = getattr(slave.fmu.dll, name)
    f.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint), ctypes.c_size_t,
                  ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_double)]
    f.restype = ctypes.c_int

    def call(vr, order, value, n=None):
        arr = (lambda t, v: None if v is None else (t * len(v))(*v))
        n = len(vr or order or value or []) if n is None else n
        return f(slave.fmu.component, arr(ctypes.c_uint, vr), n, arr(ctypes.c_int, order),
                 arr(ctypes.c_double, value))
    return call


def test_bad_input_derivative_calls_are_refused(poly_fmu, slave_factory):
    """Every bad call returns fmi2Error with a log line naming the problem and
    sets nothing (one bad entry refuses the whole call); the run then goes on
    exactly as an untouched one."""
    s = slave_factory(poly_fmu)
    s.start(u=U0)
    call = _raw(s, "fmi2SetRealInputDerivatives")
    u, x = s.vr["u"], s.vr["x"]
    cases = [
        (([x], [1], [1.0]), "is not a Real input"),
        (([10**6], [1], [1.0]), "not a variable of this type"),
        (([u], [0], [1.0]), "0 is not allowed"),
        (([u], [3], [1.0]), "order = 3"),
        (([u], [-1], [1.0]), "order = -1"),
        (([u], [1], [math.nan]), "expected a finite value"),
        (([u], [2], [math.inf]), "expected a finite value"),
        (([u, x], [1, 1], [1.0, 1.0]), "is not a Real input"),  # first entry good
        ((None, [1], [1.0]), "vr (with nvr > 0) is NULL"),
        (([u], None, [1.0]), "order (with nvr > 0) is NULL"),
        (([u], [1], None), "value (with nvr > 0) is NULL"),
    ]
    for args, expected in cases:
        n_log = len(s.log)
        assert call(*args, n=1 if args[0] is None or args[1] is None or args[2] is None
                    else None) == 3, args
        assert any(expected in m for _, _, m in s.log[n_log:]), (args, s.log[n_log:])
    assert call([], [], [], n=0) == 0  # nothing to set
    s.fmu.doStep(0.0, 0.5)
    assert s.get("x")[0] == pytest.approx(U0 * 0.5, rel=1e-12)  # u stayed held
    s.fmu.terminate()
    n_log = len(s.log)
    assert call([u], [1], [1.0]) == 3
    # the states by FMI's names, not a bit mask
    assert ("fmi2SetRealInputDerivatives must not be called in state Terminated; allowed "
            "in: Instantiated, InitializationMode, StepComplete") in s.log[n_log][2], s.log[n_log]


def test_model_description_declares_interpolation(poly_fmu):
    cs = read_model_description(str(poly_fmu)).coSimulation
    assert cs.canInterpolateInputs is True
    assert cs.maxOutputDerivativeOrder == 1


# ---- the spindle under a speed ramp ------------------------------------------

# Omega(t) = N0 + RAMP t (rad/s): 3000 -> 7000 rpm over 0.02 s
N0, RAMP = 3000.0 * 2 * math.pi / 60, 2.0e5 * 2 * math.pi / 60
T_END, H_COARSE, H_FINE = 0.02, 2e-3, 2e-5
OUT = ("x_top", "y_top", "F_upper_x")


@pytest.fixture(scope="module")
def spindle(tmp_path_factory):
    model = load_model("spindle_modal", n_modes=2)
    return model, build_fmu(model, out_dir=tmp_path_factory.mktemp("spm")).path


def _spindle_run(slave, h, derivatives):
    s = slave
    s.start(Omega=N0, solver_rtol=1e-9, solver_atol=1e-13)
    n = int(round(T_END / h))
    got = []
    for i in range(n):
        t = i * h
        s.fmu.setReal([s.vr["Omega"]], [N0 + RAMP * t])
        if derivatives:
            s.fmu.setRealInputDerivatives([s.vr["Omega"]], [1], [RAMP])
        s.fmu.doStep(t, h)
        if abs((t + h) / H_COARSE - round((t + h) / H_COARSE)) < 1e-9:
            got.append(s.get(*OUT))
    return np.array(got)


def test_spindle_ramp_through_input_derivatives(spindle, slave_factory):
    """Omega ramped through input derivatives at a coarse communication step
    (10 steps) agrees with the scipy reference fed the exact ramp n(t) to the
    solver's tolerance, and with a 100x finer staircase to that staircase's
    own O(h) error; the coarse staircase is far off."""
    model, fmu = spindle
    t_cp = np.arange(1, int(round(T_END / H_COARSE)) + 1) * H_COARSE
    ref = reference(model, t_end=T_END, t_eval=t_cp, rtol=1e-11, atol=1e-14,
                    values={"Omega": N0}, input_functions={"Omega": lambda t: N0 + RAMP * t})
    exact = np.column_stack([ref.y[k] for k in OUT])
    scale = np.max(np.abs(exact), axis=0)

    def err(run):
        return float(np.max(np.abs(run - exact) / scale))

    e_deriv = err(_spindle_run(slave_factory(fmu, "deriv"), H_COARSE, True))
    e_stair = err(_spindle_run(slave_factory(fmu, "stair"), H_COARSE, False))
    e_fine = err(_spindle_run(slave_factory(fmu, "fine"), H_FINE, False))
    assert e_deriv < 1e-6, e_deriv
    assert e_stair > 100 * e_deriv and e_stair > 1e-3, (e_stair, e_deriv)
    assert e_fine < e_stair / 30, (e_fine, e_stair)  # the staircase converges to it
    assert e_deriv < e_fine, (e_deriv, e_fine)


def test_solver_index_chooses_the_solver_as_an_integer(poly_fmu, slave_factory):
    """`solver_index` (Integer: libcosim cannot set the `solver` Enumeration)
    wins over `solver` when > 0: the same bits as choosing by `solver`."""
    md = read_model_description(str(poly_fmu))
    var = next(v for v in md.modelVariables if v.name == "solver_index")
    assert (var.type, var.causality, var.start) == ("Integer", "parameter", "0")

    def run(name, **ints):
        s = slave_factory(poly_fmu, name)
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.setReal([s.vr["solver_h_fixed"], s.vr["u"]], [0.05, U0])
        s.fmu.setRealInputDerivatives([s.vr["u"], s.vr["u"]], [1, 2], [A, B])
        for k, v in ints.items():
            s.fmu.setInteger([s.vr[k]], [v])
        s.fmu.enterInitializationMode()
        s.fmu.exitInitializationMode()
        s.fmu.doStep(0.0, 1.0)
        return s, s.get("phi")[0]

    _, rk4 = run("rk4", solver=3)
    s, alias = run("alias", solver=1, solver_index=3)
    _, dopri5 = run("dopri5", solver=1)
    assert alias == rk4 != dopri5
    assert s.fmu.getInteger([s.vr["solver"], s.vr["solver_index"]]) == [3, 3]
    bad = slave_factory(poly_fmu, "bad")
    listed = ", ".join(f"{i} {name}" for i, name in enumerate(SOLVERS, 1))
    assert listed.startswith("1 dopri5, 2 rodas4, 3 rk4, 4 ros34pw2")
    for value in (7, len(SOLVERS) + 1, -1):  # the variable set and its range are named
        with pytest.raises(FMICallException):
            bad.fmu.setInteger([bad.vr["solver_index"]], [value])
        assert (f"solver_index = {value} is not a solver: allowed 0..{len(SOLVERS)} (0 leaves "
                f"solver in charge, {listed})") in bad.log[-1][2], bad.log[-1]
    with pytest.raises(FMICallException):
        bad.fmu.setInteger([bad.vr["solver"]], [0])
    assert f"solver = 0 is not a solver: allowed 1..{len(SOLVERS)} (1 dopri5," in bad.log[-1][2]
    bad.fmu.setupExperiment(startTime=0.0)
    bad.fmu.enterInitializationMode()  # nothing refused was set
    assert bad.fmu.getInteger([bad.vr["solver"], bad.vr["solver_index"]]) == [1, 0]
