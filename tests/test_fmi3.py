"""The FMI 3.0 facade (runtime/lf_fmi3*.c): co-simulation with event mode and
early return, model exchange, FMU states, misuse.

Oracles: the FMI 2.0 co-simulation run of the same declaration (the same
runtime behind another facade: co-simulation agrees to rounding; model
exchange, integrated by FMPy's CVode, to the solvers' tolerances), and the
runtime's own event log (logEvents: the located time of every mode switch),
which early returns must reproduce.
"""
from __future__ import annotations

import ctypes
import re

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Model, FMU3Slave, fmi3Boolean, fmi3Float64
from fmpy.validation import validate_fmu
from test_fmi_variants import variant_builds  # FMUs shared by the variant tests

pytestmark = pytest.mark.slow  # builds FMUs

#: events and stick/slip modes (backrest); inputs with direct feedthrough
#: (two_mass_force)
MODELS = ("backrest", "two_mass_force")
OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
STOP = 0.5
COMM = 0.01


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    # FMI 2: "both" serves co-simulation as "cs" does (the same runtime);
    # FMI 3 two_mass_force: co-simulation only (model exchange is refused)
    # drive: a delay (model exchange needs the history of completed steps)
    keys = [(n, 2, "both") for n in MODELS] + [("backrest", 3, "both"),
                                               ("two_mass_force", 3, "cs"), ("drive", 3, "both")]
    return dict(zip([k[:2] for k in keys], variant_builds(tmp_path_factory, keys)))


def _event_times(log):
    """Times of the runtime's mode switches (logEvents lines)."""
    return [float(m.group(1)) for m in
            (re.match(r"t = (\S+): mode .* -> ", msg) for msg in log) if m]


class Inst3:
    """An FMI 3 instance driven call by call: raw calls give the status,
    the log is kept."""

    def __init__(self, path, kind="cs", name="inst", **flags):
        self.md = read_model_description(str(path))
        self.unzipdir = extract(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.log: list[tuple[int, str, str]] = []

        def log(env, status, category, message):
            self.log.append((status, category.decode(), message.decode()))

        cls = FMU3Slave if kind == "cs" else FMU3Model
        ident = (self.md.coSimulation if kind == "cs" else self.md.modelExchange).modelIdentifier
        self.fmu = cls(guid=self.md.instantiationToken, unzipDirectory=self.unzipdir,
                       modelIdentifier=ident, instanceName=name)
        if kind == "cs":
            self.fmu.instantiate(logMessage=log, loggingOn=True, **flags)
        else:
            self.fmu.instantiate(logMessage=log, loggingOn=True)
        self.c = self.fmu.component

    def raw(self, fn, *args):
        return getattr(self.fmu.dll, fn)(self.c, *args)

    def errors(self):
        return [m for s, _, m in self.log if s >= ERROR]

    def do_step(self, t, h):
        flags = [fmi3Boolean() for _ in range(3)]
        last = fmi3Float64()
        st = self.raw("fmi3DoStep", t, h, True, *(ctypes.byref(f) for f in flags),
                      ctypes.byref(last))
        return st, [f.value for f in flags], last.value

    def free(self):
        self.fmu.freeInstance()


@pytest.fixture
def instances():
    made = []

    def make(*args, **kw):
        made.append(Inst3(*args, **kw))
        return made[-1]

    yield make
    for i in made:
        try:
            i.free()
        except Exception:
            pass


@pytest.mark.parametrize("name", MODELS)
def test_fmi3_fmus_validate(fmus, name):
    assert fmus[name, 3].problems == []
    assert list(validate_fmu(str(fmus[name, 3].path))) == []


def _outputs(md):
    return [v.name for v in md.modelVariables if v.causality == "output"]


@pytest.mark.parametrize("event_mode", [False, True], ids=["step-mode", "event-mode"])
@pytest.mark.parametrize("name", MODELS)
def test_cs_equals_fmi2_cs(fmus, name, event_mode):
    """Same runtime, same solver: the FMI 3 co-simulation run through FMPy
    equals the FMI 2 one to rounding at the communication points, also with
    event mode and early return (the importer then stops at every event
    inside a step: extra rows, the same trajectory)."""
    md = read_model_description(str(fmus[name, 2].path))
    names = _outputs(md)
    r2 = simulate_fmu(str(fmus[name, 2].path), stop_time=STOP, output_interval=COMM,
                      output=names)
    r3 = simulate_fmu(str(fmus[name, 3].path), stop_time=STOP, output_interval=COMM,
                      output=names, fmi_type="CoSimulation", use_event_mode=event_mode,
                      early_return_allowed=event_mode)
    t3 = r3["time"]
    at_grid = np.isin(t3, r2["time"]) & np.r_[True, np.diff(t3) > 0]
    assert np.array_equal(t3[at_grid], r2["time"])
    if event_mode and name == "backrest":
        assert len(r3) > len(r2)  # stopped at events inside the steps
    # step mode: bit for bit; early returns: the step after one ends an ulp off
    # the grid point (t_event + (t_next - t_event)), dopri5's result moves by
    # ~1e-11 relative (engineer R's measurement on the runtime)
    tol = 1e-10 if event_mode else 1e-14
    for n in names:
        np.testing.assert_allclose(r3[n][at_grid], r2[n], rtol=tol, atol=tol, err_msg=n)


def test_me_agrees_with_fmi2_cs(fmus):
    """FMPy's CVode (rtol 1e-8) integrates the FMI 3 model exchange FMU: the
    outputs agree with our FMI 2 co-simulation (solver_rtol 1e-6) to the
    tolerances' scale (measured: 3.6e-6 of each output's range), the
    stick/slip switch times to FMPy's event location (measured: 3e-8 s)."""
    name = "backrest"
    names = ["phi1_out", "phi2_out", "omega1_out", "omega2_out", "S1", "S2"]
    log2 = []
    r2 = simulate_fmu(str(fmus[name, 2].path), stop_time=STOP, output_interval=COMM,
                      output=names, debug_logging=True,
                      logger=lambda c, n, s, cat, msg: log2.append(msg.decode()))
    r3 = simulate_fmu(str(fmus[name, 3].path), stop_time=STOP, output_interval=COMM,
                      output=names, fmi_type="ModelExchange", relative_tolerance=1e-8)
    for n in names:
        y3 = np.interp(r2["time"], r3["time"], r3[n])
        assert np.max(np.abs(y3 - r2[n])) < 2e-5 * np.max(np.abs(r2[n])), n
    t3 = r3["time"]
    t_events_me = t3[1:][np.diff(t3) == 0]  # FMPy records every event twice
    t_fmi2 = _event_times(log2)
    assert len(t_fmi2) >= 4
    np.testing.assert_allclose(t_events_me, t_fmi2, rtol=0, atol=1e-6)


def test_early_return_reproduces_the_event_times(fmus, instances):
    """Backrest stick/slip, by hand through fmi3.FMU3Slave with eventModeUsed
    and earlyReturnAllowed: every early return lands on a mode switch the
    FMI 2 run located at the same time (its log), and the outputs at the
    communication points agree with the FMI 2 run."""
    path2, path3 = fmus["backrest", 2].path, fmus["backrest", 3].path
    log2 = []
    r2 = simulate_fmu(str(path2), stop_time=STOP, output_interval=COMM, debug_logging=True,
                      logger=lambda c, n, s, cat, msg: log2.append(msg.decode()),
                      output=["phi1_out", "omega1_out"])
    t_fmi2 = _event_times(log2)
    assert len(t_fmi2) >= 4  # stick/slip switches in the first half second

    s = instances(path3, "cs", eventModeUsed=True, earlyReturnAllowed=True)
    f = s.fmu
    f.enterInitializationMode(startTime=0.0, stopTime=STOP)
    f.exitInitializationMode()
    assert f.updateDiscreteStates()[0] is False
    f.enterStepMode()
    t, early, y = 0.0, [], {}
    k = 1
    while k * COMM <= STOP + 1e-12:
        target = k * COMM
        st, (event, terminate, early_return), last = s.do_step(t, target - t)
        assert st == OK, s.errors()
        assert not terminate
        t = last
        if early_return:
            assert event and last < target
            early.append(last)
        if event:
            f.enterEventMode()
            need, _, _, _, _, _ = f.updateDiscreteStates()
            assert need is False
            f.enterStepMode()
        if not early_return:
            y[k] = f.getFloat64([s.vr["phi1_out"], s.vr["omega1_out"]])
            k += 1
    t_fmi3 = _event_times(m for _, _, m in s.log)
    assert t_fmi3 == pytest.approx(t_fmi2, rel=1e-9, abs=1e-12)
    # one early return per located switch, at its time
    assert early == pytest.approx(t_fmi2, rel=1e-9, abs=1e-12)
    ys = np.array([y[k] for k in sorted(y)])
    np.testing.assert_allclose(ys[:, 0], r2["phi1_out"][1:len(ys) + 1], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(ys[:, 1], r2["omega1_out"][1:len(ys) + 1], rtol=1e-9,
                               atol=1e-9)


def test_fmu_state_round_trip(fmus, instances):
    """Get, serialize, deserialize and set a state: the steps after it are
    taken again with the same results."""
    s = instances(fmus["backrest", 3].path, "cs")
    f = s.fmu
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    for k in range(5):
        f.doStep(k * COMM, COMM)
    state = f.getFMUState()
    blob = f.serializeFMUState(state)
    f.freeFMUState(state)
    vrs = [s.vr["phi1_out"], s.vr["omega2_out"]]
    for k in range(5, 15):
        f.doStep(k * COMM, COMM)
    first = f.getFloat64(vrs)
    state = f.deserializeFMUState(blob)
    f.setFMUState(state)
    for k in range(5, 15):
        f.doStep(k * COMM, COMM)
    assert f.getFloat64(vrs) == first
    f.freeFMUState(state)


def test_states_do_not_cross_fmi_versions(fmus, instances, slave_factory):
    """The FMI 2.0 and 3.0 builds of one model share the GUID and every size,
    not their states (an FMI 3.0 state can hold event mode): each refuses
    the other's serialized state when deserializing it, naming the version,
    and steps on.  (Before: both accepted, set and stepped with OK.)"""
    two = slave_factory(fmus["backrest", 2].path)
    two.start()
    two.fmu.doStep(0.0, COMM)
    blob2 = two.fmu.serializeFMUstate(two.fmu.getFMUstate())
    s = instances(fmus["backrest", 3].path, "cs")
    f = s.fmu
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    f.doStep(0.0, COMM)
    blob3 = f.serializeFMUState(f.getFMUState())
    buf = (ctypes.c_uint8 * len(blob2)).from_buffer_copy(blob2)
    assert s.raw("fmi3DeserializeFMUState", buf, len(blob2),
                 ctypes.byref(ctypes.c_void_p())) == ERROR
    assert any("FMI version of the state = 2" in m for m in s.errors()), s.errors()
    with pytest.raises(FMICallException):
        two.fmu.deSerializeFMUstate(blob3)
    assert any("FMI version of the state = 3" in m for _, _, m in two.log), two.log[-2:]
    # each still takes its own state, and steps on
    f.setFMUState(f.deserializeFMUState(blob3))
    assert s.do_step(COMM, COMM)[0] == OK
    two.fmu.setFMUstate(two.fmu.deSerializeFMUstate(blob2))
    two.fmu.doStep(COMM, COMM)

def test_misuse_is_refused_with_a_log(fmus, instances):
    s = instances(fmus["two_mass_force", 3].path, "cs")
    f = s.fmu
    x1 = s.vr["x1"]
    vr1 = (ctypes.c_uint32 * 1)(x1)
    val = (ctypes.c_double * 1)()
    # step before initialization: state machine
    assert s.do_step(0.0, 0.1)[0] == ERROR
    assert "fmi3DoStep must not be called in state Instantiated" in s.errors()[-1]
    # event mode without eventModeUsed, update discrete states in the wrong state
    f.enterInitializationMode(startTime=0.0, stopTime=1.0)
    f.exitInitializationMode()
    assert s.raw("fmi3EnterEventMode") == ERROR
    assert "eventModeUsed = false" in s.errors()[-1]
    b = [fmi3Boolean() for _ in range(5)]
    assert s.raw("fmi3UpdateDiscreteStates", *(ctypes.byref(x) for x in b),
                 ctypes.byref(fmi3Float64())) == ERROR
    assert "StepMode" in s.errors()[-1]
    # arrays: nValues != nValueReferences, NULL, unknown vr, wrong type
    assert s.raw("fmi3GetFloat64", vr1, 1, val, 2) == ERROR
    assert "nValues = 2" in s.errors()[-1]
    assert s.raw("fmi3GetFloat64", None, 1, val, 1) == ERROR
    assert s.raw("fmi3GetFloat64", (ctypes.c_uint32 * 1)(10 ** 6), 1, val, 1) == ERROR
    assert s.raw("fmi3GetBoolean", vr1, 1, (fmi3Boolean * 1)(), 1) == ERROR
    assert "no variables of type Boolean" in s.errors()[-1]
    assert s.raw("fmi3GetInt32", (ctypes.c_uint32 * 1)(s.vr["solver"]), 1,
                 (ctypes.c_int32 * 1)(), 1) == ERROR
    assert "Enumeration" in s.errors()[-1]
    # a parameter after initialization, NaN input: refused, nothing changed
    assert s.raw("fmi3SetFloat64", (ctypes.c_uint32 * 1)(s.vr["m1"]), 1,
                 (ctypes.c_double * 1)(2.0), 1) == ERROR
    assert s.raw("fmi3SetFloat64", (ctypes.c_uint32 * 1)(s.vr["x2_in"]), 1,
                 (ctypes.c_double * 1)(float("nan")), 1) == ERROR
    # NULL out-arguments, bad steps
    assert s.raw("fmi3DoStep", 0.0, 0.1, True, None, None, None, None) == ERROR
    assert s.do_step(0.5, 0.1)[0] == ERROR      # not at the FMU's time
    assert s.do_step(0.0, -0.1)[0] == ERROR
    assert s.do_step(0.0, float("nan"))[0] == ERROR
    assert s.do_step(0.0, 2.0)[0] == ERROR      # past stopTime
    assert s.do_step(0.0, 0.1)[0] == OK         # still usable
    # model exchange functions on a co-simulation instance; absent features
    assert s.raw("fmi3SetTime", 0.1) == ERROR
    assert s.raw("fmi3GetAdjointDerivative", None, 0, None, 0, None, 0, None, 0) == ERROR
    assert s.raw("fmi3GetClock", None, 0, None) == ERROR
    # FMU states: a pointer not made here, a short buffer
    assert s.raw("fmi3SetFMUState", ctypes.c_void_p(1234)) == ERROR
    state = f.getFMUState()
    assert s.raw("fmi3SerializeFMUState", state, (ctypes.c_uint8 * 8)(), 8) == ERROR
    # bytes that are not a state: refused by the deserialize call itself
    assert s.raw("fmi3DeserializeFMUState", (ctypes.c_uint8 * 64)(), 64,
                 ctypes.byref(ctypes.c_void_p())) == ERROR
    f.freeFMUState(state)
    assert all(str(1e6) not in m for m in s.errors())
    # every refusal logged with the function's name
    assert len(s.errors()) >= 18
    f.terminate()
    assert s.do_step(0.1, 0.1)[0] == ERROR
    assert "state Terminated" in s.errors()[-1]


def test_me_misuse_is_refused_with_a_log(fmus, instances):
    s = instances(fmus["backrest", 3].path, "me")
    f = s.fmu
    nx = sum(1 for v in s.md.modelVariables if v.derivative)
    x = (ctypes.c_double * nx)()
    n = ctypes.c_size_t()
    assert s.raw("fmi3GetNumberOfContinuousStates", ctypes.byref(n)) == OK and n.value == nx
    assert s.raw("fmi3GetNumberOfContinuousStates", None) == ERROR
    assert s.raw("fmi3SetContinuousStates", x, nx) == ERROR
    assert "fmi3SetContinuousStates must not be called in state Instantiated" in s.errors()[-1]
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    flags = [fmi3Boolean() for _ in range(2)]
    assert s.raw("fmi3CompletedIntegratorStep", True, *(ctypes.byref(b) for b in flags)) == ERROR
    assert "state EventMode" in s.errors()[-1]
    assert s.do_step(0.0, 0.01)[0] == ERROR
    assert s.raw("fmi3EnterStepMode") == ERROR
    assert "fmi3InstantiateModelExchange" in s.errors()[-1]
    f.updateDiscreteStates()
    f.enterContinuousTimeMode()
    assert s.raw("fmi3GetContinuousStates", x, nx) == OK
    assert s.raw("fmi3SetContinuousStates", x, nx + 1) == ERROR
    bad = (ctypes.c_double * nx)(*x)
    bad[0] = float("nan")
    assert s.raw("fmi3SetContinuousStates", bad, nx) == ERROR
    assert s.raw("fmi3GetContinuousStateDerivatives", x, nx - 1) == ERROR
    assert s.raw("fmi3GetContinuousStates", None, nx) == ERROR
    assert s.raw("fmi3UpdateDiscreteStates", *(ctypes.byref(fmi3Boolean()) for _ in range(5)),
                 ctypes.byref(fmi3Float64())) == ERROR
    assert "state ContinuousTimeMode" in s.errors()[-1]
    # still usable: time, states, derivatives
    assert s.raw("fmi3SetTime", 0.001) == OK
    assert s.raw("fmi3SetContinuousStates", x, nx) == OK
    assert s.raw("fmi3GetContinuousStateDerivatives", x, nx) == OK
    assert all(np.isfinite(list(x)))


def test_instantiation_refusals(fmus):
    """A wrong token, an empty name, an interface the FMU does not declare:
    NULL with a log."""
    path = fmus["two_mass_force", 3].path
    md = read_model_description(str(path))
    log = []

    def logger(env, status, category, message):
        log.append(message.decode())

    for token, name in (("{not-the-token}", "a"), (md.instantiationToken, ""),
                        (md.instantiationToken, " \t")):
        f = FMU3Slave(guid=token, unzipDirectory=extract(str(path)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        with pytest.raises(Exception, match="Failed to instantiate"):
            f.instantiate(logMessage=logger)
    f = FMU3Model(guid=md.instantiationToken, unzipDirectory=extract(str(path)),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="me")
    with pytest.raises(Exception, match="Failed to instantiate"):
        f.instantiate(logMessage=logger)
    assert "instantiationToken does not match" in log[0]
    assert "instanceName is NULL, empty or only white space" in log[1]
    assert "only white space" in log[2]
    assert "does not declare model exchange" in log[3]


def test_fmi3_only_values(fmus, instances):
    """Values FMI 2 co-simulation does not have, checked against exact
    relations: time, der(x) (der(omega1) is omega1's rate: its finite
    difference over a short step), event indicators (equal to
    fmi3GetEventIndicators), output derivatives (d(phi1_out)/dt = omega1)."""
    s = instances(fmus["backrest", 3].path, "cs")
    f, vr = s.fmu, s.vr
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    f.doStep(0.0, 0.05)
    t, w0, dw = f.getFloat64([vr["time"], vr["omega1"], vr["der(omega1)"]])
    assert t == 0.05
    h = 1e-6
    f.doStep(0.05, h)
    (w1,) = f.getFloat64([vr["omega1"]])
    assert (w1 - w0) / h == pytest.approx(dw, rel=1e-3)
    (dphi,) = f.getOutputDerivatives([vr["phi1_out"]], [1])
    assert dphi == pytest.approx(f.getFloat64([vr["omega1_out"]])[0], rel=1e-12, abs=1e-15)
    evt = [v.name for v in s.md.modelVariables if v.name.startswith("event_indicator.")]
    assert len(evt) == 2
    values = f.getFloat64([vr[n] for n in evt])
    assert all(np.isfinite(values))

    m = instances(fmus["backrest", 3].path, "me")
    m.fmu.enterInitializationMode(startTime=0.0)
    m.fmu.exitInitializationMode()
    m.fmu.updateDiscreteStates()
    m.fmu.enterContinuousTimeMode()
    e = (ctypes.c_double * 2)()
    assert m.raw("fmi3GetEventIndicators", e, 2) == OK
    assert m.fmu.getFloat64([m.vr[n] for n in evt]) == list(e)
    assert (s.raw("fmi3SetFloat64", (ctypes.c_uint32 * 1)(vr["time"]), 1,
                  (ctypes.c_double * 1)(1.0), 1) == ERROR)
    assert "time, the independent variable" in s.errors()[-1]


def test_null_and_freed_instances_are_refused(fmus):
    """A NULL or freed instance: fmi3Error (nothing to log through), never a
    crash; fmi3FreeInstance twice is harmless."""
    s = Inst3(fmus["two_mass_force", 3].path, "cs")
    dll, c = s.fmu.dll, s.c
    dll.fmi3FreeInstance(c)  # (fmpy's freeInstance would unload the library)
    dll.fmi3FreeInstance(c)  # twice: ignored
    for inst in (None, c):
        for fn in ("fmi3EnterStepMode", "fmi3Terminate", "fmi3Reset",
                   "fmi3ExitInitializationMode", "fmi3EnterEventMode",
                   "fmi3EnterContinuousTimeMode"):
            assert getattr(dll, fn)(inst) == ERROR, fn
        assert dll.fmi3DoStep(inst, 0.0, 0.1, True, None, None, None, None) == ERROR
        assert dll.fmi3GetFloat64(inst, None, 0, None, 0) == ERROR
        assert dll.fmi3SetFMUState(inst, None) == ERROR
    assert s.log == []
    s.fmu.freeLibrary()


def _dirder(s, unknowns, knowns, seed):
    n, m = len(unknowns), len(knowns)
    out = (ctypes.c_double * n)()
    st = s.raw("fmi3GetDirectionalDerivative", (ctypes.c_uint32 * n)(*unknowns), n,
               (ctypes.c_uint32 * m)(*knowns), m, (ctypes.c_double * m)(*seed), m, out, n)
    return st, list(out)


def test_directional_derivatives(fmus, instances):
    """Co-simulation: the force's feedthrough is linear, dF_c/dx2_in = -kc and
    dF_c/dv2_in = -dc exactly.  Model exchange (backrest, nonlinear): the
    Jacobian of der(x) with respect to the states, column by column, against
    central finite differences through fmi3SetContinuousStates."""
    s = instances(fmus["two_mass_force", 3].path, "cs")
    f, vr = s.fmu, s.vr
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    f.doStep(0.0, 0.01)
    kc, dc = f.getFloat64([vr["kc"], vr["dc"]])
    for known, expected in (("x2_in", -kc), ("v2_in", -dc)):
        st, (d,) = _dirder(s, [vr["F_c"]], [vr[known]], [1.0])
        assert st == OK and d == pytest.approx(expected, rel=1e-14)
    st, _ = _dirder(s, [vr["F_c"]], [vr["kc"]], [1.0])  # a parameter is no known
    assert st == ERROR
    st = s.raw("fmi3GetDirectionalDerivative", (ctypes.c_uint32 * 1)(vr["F_c"]), 1,
               (ctypes.c_uint32 * 1)(vr["x2_in"]), 1, (ctypes.c_double * 1)(1.0), 1,
               (ctypes.c_double * 2)(), 2)
    assert st == ERROR and "nSensitivity = 2" in s.errors()[-1]

    m = instances(fmus["backrest", 3].path, "me")
    g = m.fmu
    g.enterInitializationMode(startTime=0.0)
    g.exitInitializationMode()
    g.updateDiscreteStates()
    g.enterContinuousTimeMode()
    states = [v for v in m.md.modelVariables if v.derivative is not None]
    x_vr = [v.derivative.valueReference for v in states]
    der_vr = [v.valueReference for v in states]
    nx = len(states)
    x0 = (ctypes.c_double * nx)()
    assert m.raw("fmi3GetContinuousStates", x0, nx) == OK
    x0 = np.array(x0)

    def der(x):
        dx = (ctypes.c_double * nx)()
        assert m.raw("fmi3SetContinuousStates", (ctypes.c_double * nx)(*x), nx) == OK
        assert m.raw("fmi3GetContinuousStateDerivatives", dx, nx) == OK
        return np.array(dx)

    for j in range(nx):
        e = np.zeros(nx)
        e[j] = 1.0
        der(x0)
        st, exact = _dirder(m, der_vr, x_vr, e)
        assert st == OK
        h = 1e-6 * max(1.0, abs(x0[j]))
        fd = (der(x0 + h * e) - der(x0 - h * e)) / (2 * h)
        np.testing.assert_allclose(exact, fd, rtol=1e-5, atol=1e-6 * np.max(np.abs(fd)))


def test_validity_failure_is_a_discard_not_an_early_return(fmus, instances):
    """Backrest with early return: at the first event the importer pulls the
    letoff so far that the warp goes slack (a validity condition of the
    model): the simulation must end with terminateSimulation, and a step
    that fails so is a Discard with earlyReturn = false (FMI 3.0: an early
    return is not an error)."""
    s = instances(fmus["backrest", 3].path, "cs", eventModeUsed=True, earlyReturnAllowed=True)
    f = s.fmu
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    f.updateDiscreteStates()
    f.enterStepMode()
    st, (event, terminate, early), t_event = s.do_step(0.0, 0.05)
    assert st == OK and event and early and t_event < 0.05
    f.enterEventMode()
    f.setFloat64([s.vr["letoff"]], [0.3])
    _, terminate, _, _, _, _ = f.updateDiscreteStates()
    if not terminate:
        f.enterStepMode()
        st, (event, terminate, early), last = s.do_step(t_event, 0.05 - t_event)
        assert st == DISCARD and terminate and not early
        assert t_event <= last < 0.05
    assert any("warp" in m for _, _, m in s.log)


def test_event_mode_settles_the_modes_for_new_inputs(fmus, instances):
    """An importer that sets an input in event mode reads, after
    fmi3UpdateDiscreteStates, the modes and outputs for that input (the
    stuck joint breaks away), as model exchange gives them from the same FMU
    state -- not the old modes until the next step."""
    path = fmus["backrest", 3].path
    s = instances(path, "cs", eventModeUsed=True, earlyReturnAllowed=True)
    f, vr = s.fmu, s.vr
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    f.updateDiscreteStates()
    f.enterStepMode()
    assert s.do_step(0.0, 0.05)[1][2]  # early return at the first switch
    f.enterEventMode()
    f.updateDiscreteStates()
    blob = f.serializeFMUState(f.getFMUState())
    modes = [vr["mode_O1"], vr["mode_O2"]]
    before = f.getInt32(modes)
    outs = [vr["M1f_out"], vr["N1"]]

    f.setFloat64([vr["letoff"]], [0.05])
    need, _, _, changed, _, _ = f.updateDiscreteStates()
    cs = f.getInt32(modes), f.getFloat64(outs)

    m = instances(path, "me")
    m.fmu.enterInitializationMode(startTime=0.0)
    m.fmu.exitInitializationMode()
    m.fmu.setFMUState(m.fmu.deserializeFMUState(blob))
    m.fmu.setFloat64([vr["letoff"]], [0.05])
    m.fmu.updateDiscreteStates()
    me = m.fmu.getInt32(modes), m.fmu.getFloat64(outs)
    assert not need and changed
    assert cs[0] == me[0] != before
    np.testing.assert_allclose(cs[1], me[1], rtol=1e-12)


def test_me_values_at_the_importer_s_point_need_the_delay_s_history(fmus, instances):
    """FMI 3 model exchange with a delay (drive, tau = 0.5 s): an output, der(x)
    by fmi3GetFloat64 and a directional derivative at a time whose delayed
    value lies beyond the history of the completed steps are refused with
    fmi3Discard and a log line, as fmi3GetContinuousStateDerivatives is (they
    gave extrapolated values with fmi3OK before); time needs no history.
    With steps completed 0.05 s apart the delayed output is the signal tau
    earlier, and fmi3GetFloat64's der(x) equals the derivatives' call."""
    s = instances(fmus["drive", 3].path, "me")
    f, vr = s.fmu, s.vr
    f.enterInitializationMode(startTime=0.0)
    f.exitInitializationMode()
    f.updateDiscreteStates()
    f.enterContinuousTimeMode()
    ders = [v for v in s.md.modelVariables if v.derivative is not None]
    nx = len(ders)
    der_vr, x_vr = ders[0].valueReference, ders[0].derivative.valueReference
    one = (ctypes.c_double * 1)()

    def get(v):
        return s.raw("fmi3GetFloat64", (ctypes.c_uint32 * 1)(v), 1, one, 1), one[0]

    assert s.raw("fmi3SetTime", 0.8) == OK   # t - tau: more than tau / 2 past the history
    for v in (vr["u_delayed"], der_vr):
        assert get(v)[0] == DISCARD, v
        assert "history ends at t = 0 (the last completed integrator step)" in s.log[-1][2]
    assert _dirder(s, [der_vr], [x_vr], [1.0])[0] == DISCARD
    assert "fmi3GetDirectionalDerivative" in s.log[-1][2]
    assert get(vr["time"]) == (OK, 0.8)
    dx = (ctypes.c_double * nx)()
    assert s.raw("fmi3GetContinuousStateDerivatives", dx, nx) == DISCARD

    x = (ctypes.c_double * nx)()
    flags = [fmi3Boolean(), fmi3Boolean()]
    u, h = {}, 0.01
    for i in range(1, 76):  # explicit Euler to 0.75 s, a step completed every 0.01 s
        assert s.raw("fmi3SetTime", (i - 1) * h) == OK
        assert s.raw("fmi3GetContinuousStates", x, nx) == OK
        assert s.raw("fmi3GetContinuousStateDerivatives", dx, nx) == OK
        nxt = (ctypes.c_double * nx)(*(x[k] + h * dx[k] for k in range(nx)))
        assert s.raw("fmi3SetTime", i * h) == OK
        assert s.raw("fmi3SetContinuousStates", nxt, nx) == OK
        assert s.raw("fmi3CompletedIntegratorStep", True,
                     *(ctypes.byref(b) for b in flags)) == OK
        u[i] = get(vr["u"])[1]
    st, delayed = get(vr["u_delayed"])
    assert st == OK and delayed == pytest.approx(u[25], rel=1e-9)  # u at 0.75 - tau
    assert s.raw("fmi3GetContinuousStateDerivatives", dx, nx) == OK
    assert get(der_vr) == (OK, dx[0])
    st, d = _dirder(s, [der_vr], [x_vr], [1.0])
    assert st == OK and np.isfinite(d[0])
