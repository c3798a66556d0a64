"""FMI 2.0 model exchange (lf_me.c, lf_fmi2_me.c): the importer integrates.

Every FMU here is built as FMI 2.0 "both" (co-simulation and model exchange
in one binary) or "me", validated by FMPy, and run through FMPy's CVode
(fmi_type="ModelExchange") against our own co-simulation run of the same
FMU.  The backrest's stick-slip switch times in model exchange agree with
co-simulation's to FMPy's event location; the drive's delays run when the
importer completes its steps at most tau apart, and are refused (fmi2Discard
with a log) when the history does not reach back far enough; validity
conditions end the simulation (terminateSimulation); misuse gives fmi2Error.

The full matrix of the 11 models (builds take minutes) runs with
``python tests/test_me.py [fraction-of-default-stop-time] [models...]``, the
switch-time gaps per tolerance with ``python tests/test_me.py switches``.
"""
from __future__ import annotations

import ctypes
import re
import sys
import time

import fmpy
import numpy as np
import pytest
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Model,
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2EventInfo,
)
from test_fmi_variants import variant_builds  # FMUs shared by the variant tests
from test_validity import T_STAR, _spring  # the spring x = cos(2 t), fails at T_STAR

from loomfmu import build_fmu, load_model

pytestmark = pytest.mark.slow  # builds FMUs

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("me")
    names = ("two_mass_force", "backrest", "drive")
    built = dict(zip(names, variant_builds(tmp_path_factory, [(n, 2, "both") for n in names])))
    # x'' = -4 x, x(0) = 1, condition x + 0.5 >= 0 (test_validity's oracle)
    built["spring_me"] = build_fmu(_spring(True, "spring_me"), out_dir=out, interface="me")
    return built


class Instance:
    """One FMU instance (ME or CS) driven call by call, its log captured."""

    def __init__(self, path, me=True):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.log: list[tuple[int, str]] = []

        def logger(env, instance, status, category, message):
            self.log.append((status, message.decode()))

        self._cb = fmi2CallbackFunctions()
        self._cb.logger = fmi2CallbackLoggerTYPE(logger)
        self._cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        iface = self.md.modelExchange if me else self.md.coSimulation
        cls = FMU2Model if me else FMU2Slave
        self.fmu = cls(guid=self.md.guid, unzipDirectory=extract(str(path)),
                       modelIdentifier=iface.modelIdentifier, instanceName="inst")
        self.fmu.instantiate(callbacks=self._cb)
        self.nx = self.md.numberOfContinuousStates
        self.ne = self.md.numberOfEventIndicators

    def raw(self, fn, *args):
        """The status of fmi2<fn>(component, *args), no exception."""
        f = self.fmu._functions.get("fmi2" + fn)
        if f is None:  # a function of the other interface: from the library
            f = getattr(self.fmu.dll, "fmi2" + fn)
            f.argtypes = [ctypes.c_void_p] + [type(a) for a in args]
            f.restype = ctypes.c_int
        return f(self.fmu.component, *args)

    def start(self, **reals):
        self.fmu.setupExperiment(startTime=0.0)
        if reals:
            self.fmu.setReal([self.vr[k] for k in reals], list(reals.values()))
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def to_continuous(self):
        info = fmi2EventInfo()
        assert self.raw("NewDiscreteStates", ctypes.byref(info)) == OK
        self.fmu.enterContinuousTimeMode()
        return info

    def states(self):
        x = (ctypes.c_double * max(self.nx, 1))()
        self.fmu.getContinuousStates(x, self.nx)
        return np.array(x[:self.nx])

    def derivatives(self):
        dx = (ctypes.c_double * max(self.nx, 1))()
        self.fmu.getDerivatives(dx, self.nx)
        return np.array(dx[:self.nx])

    def set_states(self, x):
        self.fmu.setContinuousStates((ctypes.c_double * self.nx)(*x), self.nx)

    def euler(self, t0, t1, n):
        """Explicit Euler from t0 to t1 in n steps, each completed."""
        h = (t1 - t0) / n
        for i in range(n):
            self.fmu.setTime(t0 + i * h)
            x = self.states() + h * self.derivatives()
            self.fmu.setTime(t0 + (i + 1) * h)
            self.set_states(x)
            self.fmu.completedIntegratorStep()

    def messages(self, status=None):
        return [m for s, m in self.log if status is None or s == status]

    def close(self):
        self.fmu.freeInstance()


def _simulate(path, kind, stop, interval, rtol, logger=None, **start):
    kw = dict(start_values=start) if start else {}
    if logger is not None:
        kw.update(debug_logging=True, logger=logger)
    return fmpy.simulate_fmu(str(path), stop_time=stop, output_interval=interval,
                             fmi_type=kind, relative_tolerance=rtol, **kw)


def compare(path, stop, interval, rtol=1e-8):
    """Largest difference of any output between FMPy's CVode (model
    exchange) and our co-simulation run, relative to the output's largest
    magnitude."""
    cs = _simulate(path, "CoSimulation", stop, interval, rtol,
                   solver_rtol=rtol, solver_atol=rtol * 1e-2)
    me = _simulate(path, "ModelExchange", stop, interval, rtol)
    worst = (0.0, "")
    for n in cs.dtype.names[1:]:
        diff = np.max(np.abs(np.interp(cs["time"], me["time"], me[n]) - cs[n]))
        worst = max(worst, (diff / (np.max(np.abs(cs[n])) + 1e-12), n))
    return worst


def test_me_fmus_validate(fmus):
    for name, built in fmus.items():
        assert built.problems == [], name
        md = read_model_description(str(built.path))
        assert md.modelExchange is not None, name
        assert md.modelExchange.needsCompletedIntegratorStep, name


@pytest.mark.parametrize("name, stop, interval", [
    ("two_mass_force", 1.0, 0.01),   # inputs held, no events
    ("backrest", 0.5, 0.01),         # stick-slip modes, reinit at events
    ("drive", 1.5, 0.01),            # delay tau = 0.5 s; steps <= interval < tau
])
def test_me_agrees_with_cs(fmus, name, stop, interval):
    worst, which = compare(fmus[name].path, stop, interval)
    assert worst < 1e-4, (which, worst)


def _switches(log):
    return [(float(a), n, int(float(q))) for a, n, q in
            (re.match(r"t = (\S+): mode (\S+): \S+ -> (\S+)", m).groups()
             for m in log if ": mode " in m)]


def switch_gaps(path, rtols=(1e-7, 1e-10)):
    """The backrest's stick-slip switches (mode changes, from the logEvents
    lines) of FMPy's CVode with its root finding at each relative tolerance,
    against co-simulation's located events (solver_rtol 1e-10): the number of
    switches and the largest time gap per tolerance."""
    def switches(kind, rtol, **start):
        log = []
        _simulate(path, kind, 1.0, 0.01, rtol,
                  logger=lambda *a: log.append(a[-1].decode()), **start)  # FMI 2: 5, FMI 3: 4 args
        return _switches(log)

    cs = switches("CoSimulation", 1e-10, solver_rtol=1e-10, solver_atol=1e-12)
    gaps = []
    for rtol in rtols:
        me = switches("ModelExchange", rtol)
        assert [s[1:] for s in me] == [s[1:] for s in cs]
        gaps.append(max(abs(a[0] - b[0]) for a, b in zip(me, cs)))
    return len(cs), gaps


def test_backrest_switch_times_agree_in_me(fmus):
    """Same switches in the same order; the gap shrinks with the tolerance
    (CVode's event location follows its state error)."""
    n, gaps = switch_gaps(fmus["backrest"].path)
    assert n > 10  # genuinely stick-slip
    assert gaps[0] < 1e-5 and gaps[1] < 1e-8 and gaps[1] < gaps[0] / 10, gaps


def test_drive_refuses_a_step_longer_than_the_history(fmus):
    """Without completed steps the history ends at the start: a derivative
    at t - tau up to tau / 2 past it takes the history's Taylor line there
    (one warning per instance: FMPy's CVode steps that far past its output
    points); further out it is refused with fmi2Discard and a log saying
    what the importer must do."""
    s = Instance(fmus["drive"].path)
    try:
        s.start()
        s.to_continuous()
        tau = 0.5
        s.fmu.setTime(0.9 * tau)
        s.derivatives()  # t - tau < 0: the history before the start
        s.fmu.setTime(1.4 * tau)
        s.derivatives()  # t - tau = 0.4 tau past the history's end: extrapolated
        s.fmu.setTime(1.45 * tau)
        s.derivatives()
        warned = [m for m in s.messages(1) if "extrapolated" in m]
        assert len(warned) == 1 and "said once per instance" in warned[0]
        s.fmu.setTime(1.6 * tau)
        with pytest.raises(FMICallException) as e:
            s.derivatives()
        assert e.value.status == DISCARD
        msg = s.messages(DISCARD)[-1]
        assert "history ends at t = 0" in msg and "completed integrator step" in msg
        assert "tau = 0.5" in msg and "more than tau / 2 before" in msg
        vr_out = s.vr["u_delayed"]
        with pytest.raises(FMICallException):  # outputs need the delayed value too
            s.fmu.getReal([vr_out])
        with pytest.raises(FMICallException):  # and so does completing that step
            s.fmu.completedIntegratorStep()
    finally:
        s.close()


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_fmpy_with_output_points_further_apart_than_tau_is_refused(fmus):
    """FMPy's CVode completes a step only at output points: 1 s apart, more
    than tau = 0.5 s, the run fails (CVode gives up after the discards)
    where it would need values extrapolated further than tau / 2, and the
    log says why."""
    log = []
    with pytest.raises(Exception):  # noqa: B017 (FMPy raises a bare Exception on Error)
        _simulate(fmus["drive"].path, "ModelExchange", 3.0, 1.0, 1e-7,
                  logger=lambda env, i, st, c, m: log.append((st, m.decode())))
    assert any(st == DISCARD and "history ends at t = " in m and "more than tau / 2" in m
               for st, m in log)


def test_drive_history_from_completed_steps(fmus):
    """With completed steps every 0.05 s (< tau) the delayed output follows
    the signal tau earlier (the history's Hermite interpolation)."""
    s = Instance(fmus["drive"].path)
    try:
        s.start()
        s.to_continuous()
        u = {}
        for i in range(1, 31):  # Euler to 1.5 s, the signal recorded
            s.euler((i - 1) * 0.05, i * 0.05, 5)
            u[i] = s.fmu.getReal([s.vr["u"]])[0]
        # at t = 1.5 the delayed signal is the signal at 1.0 (both from our states)
        assert s.fmu.getReal([s.vr["u_delayed"]])[0] == pytest.approx(u[20], rel=1e-9)
        s.fmu.setTime(1.4)  # back in time without restoring a state: refused
        with pytest.raises(FMICallException) as e:
            s.fmu.completedIntegratorStep()
        assert e.value.status == ERROR and "history already ends at t = 1.5" in s.messages()[-1]
        s.fmu.setTime(1.5)  # the instance goes on from where it was
        s.derivatives()
        s.fmu.setTime(1.2)  # t - tau = 0.7: dropped from the history (it keeps about tau)
        with pytest.raises(FMICallException) as e:
            s.derivatives()
        assert e.value.status == DISCARD and "history kept starts at" in s.messages()[-1]
    finally:
        s.close()


def test_drive_history_jumps_are_time_events_tau_later(fmus):
    """A jump of the history (the start: the history before it is constant;
    an input set in event mode) reaches the equations tau later, announced
    as the next time event; after the last one none is pending."""
    s = Instance(fmus["drive"].path)

    def event(t):
        s.fmu.enterEventMode()
        info = fmi2EventInfo()
        assert s.raw("NewDiscreteStates", ctypes.byref(info)) == OK
        s.fmu.enterContinuousTimeMode()
        return info.nextEventTime if info.nextEventTimeDefined else None

    try:
        s.start()
        info = s.to_continuous()
        assert info.nextEventTimeDefined and info.nextEventTime == pytest.approx(0.5, abs=1e-15)
        s.euler(0.0, 0.2, 10)
        s.fmu.enterEventMode()
        s.fmu.setReal([s.vr["u_ext"]], [1.0])  # a step of the input at 0.2
        info = fmi2EventInfo()
        assert s.raw("NewDiscreteStates", ctypes.byref(info)) == OK
        s.fmu.enterContinuousTimeMode()
        assert info.nextEventTime == pytest.approx(0.5, abs=1e-15)  # the earliest pending
        s.euler(0.2, 0.5, 15)
        assert event(0.5) == pytest.approx(0.7, abs=1e-12)
        s.euler(0.5, 0.7, 10)
        assert event(0.7) is None
    finally:
        s.close()


def test_validity_condition_terminates_me(fmus):
    """The spring's condition fails at T_STAR: the completed step after it
    says terminateSimulation, FMPy stops, the log names the condition."""
    log = []
    res = _simulate(fmus["spring_me"].path, "ModelExchange", 2.0, 0.01, 1e-8,
                    logger=lambda env, i, s, c, m: log.append(m.decode()))
    assert T_STAR - 0.01 - 1e-9 < res["time"][-1] < T_STAR
    assert any("taut: string in compression" in m and "terminateSimulation" in m
               for m in log)


def test_der_x_by_get_real_equals_get_derivatives(fmus):
    s = Instance(fmus["two_mass_force"].path)
    try:
        s.start()
        s.to_continuous()
        s.fmu.setTime(0.3)
        s.set_states([0.01, -0.2])
        der_vrs = [v.valueReference for v in s.md.modelVariables
                   if v.name.startswith("der(")]
        assert len(der_vrs) == s.nx
        assert s.fmu.getReal(der_vrs) == pytest.approx(list(s.derivatives()), rel=1e-15)
        with pytest.raises(FMICallException):
            s.fmu.setReal(der_vrs[:1], [1.0])  # calculated
        assert "cannot be set" in s.messages(ERROR)[-1]
    finally:
        s.close()


def test_me_fmu_state_restores_the_trajectory(fmus):
    """get/set and (de)serialize the FMU state in model exchange: the same
    Euler steps from a restored state give the same states, modes and
    history (backrest: modes; drive: delays)."""
    for name, t1, t2 in (("backrest", 0.05, 0.1), ("drive", 0.6, 1.2)):
        s = Instance(fmus[name].path)
        try:
            s.start()
            s.to_continuous()
            s.euler(0.0, t1, 40)
            state = s.fmu.getFMUstate()
            blob = s.fmu.serializeFMUstate(state)
            s.euler(t1, t2, 40)
            first = s.states()
            s.fmu.setFMUstate(s.fmu.deSerializeFMUstate(blob))
            s.fmu.setTime(t1)
            s.euler(t1, t2, 40)
            assert np.array_equal(s.states(), first), name
            s.fmu.freeFMUstate(state)
        finally:
            s.close()


def _dirder(s, unknowns, knowns, seed):
    n = len(unknowns)
    out = (ctypes.c_double * n)()
    st = s.raw("GetDirectionalDerivative", (ctypes.c_uint * n)(*unknowns), ctypes.c_size_t(n),
               (ctypes.c_uint * len(knowns))(*knowns), ctypes.c_size_t(len(knowns)),
               (ctypes.c_double * len(seed))(*seed), out)
    assert st == OK, s.messages()[-1]
    return np.array(out[:])


def test_directional_derivatives_equal_central_differences(fmus):
    """fmi2GetDirectionalDerivative (exact, CasADi's Jacobians) against
    central differences: model exchange, der(x) and outputs with respect to
    each state (backrest, stuck and slipping joints, algebraic loop);
    co-simulation after a step, outputs and der(x) with respect to each
    input (two_mass_force)."""
    s = Instance(fmus["backrest"].path)
    try:
        s.start()
        s.to_continuous()
        s.euler(0.0, 0.02, 20)
        ders = [u.variable for u in s.md.derivatives]  # in the order of the states
        der = [d.valueReference for d in ders]
        states = [d.derivative.valueReference for d in ders]
        outs = [s.vr[n] for n in ("S1", "N2", "M1f_out")]
        x0 = s.states()
        assert len(states) == s.nx
        for j in range(s.nx):
            seed = np.eye(s.nx)[j]
            exact = _dirder(s, der + outs, states, seed)
            h = 1e-6 * max(1.0, abs(x0[j]))
            f = []
            for sign in (1, -1):
                s.set_states(x0 + sign * h * seed)
                f.append(np.array(s.fmu.getReal(der + outs)))
            s.set_states(x0)
            fd = (f[0] - f[1]) / (2 * h)
            assert np.allclose(exact, fd, rtol=1e-5, atol=1e-6 * np.max(np.abs(fd))), (j, exact, fd)
    finally:
        s.close()
    cs = Instance(fmus["two_mass_force"].path, me=False)
    try:
        cs.start()
        cs.fmu.doStep(0.0, 0.1)
        ins = [cs.vr["x2_in"], cs.vr["v2_in"]]
        unknowns = [cs.vr["F_c"]] + [u.variable.valueReference for u in cs.md.derivatives]
        u0 = np.array(cs.fmu.getReal(ins))
        for j in range(2):
            exact = _dirder(cs, unknowns, ins, np.eye(2)[j])
            h = 1e-6 * max(1.0, abs(u0[j]))
            f = []
            for sign in (1, -1):
                cs.fmu.setReal(ins, list(u0 + sign * h * np.eye(2)[j]))
                f.append(np.array(cs.fmu.getReal(unknowns)))
            fd = (f[0] - f[1]) / (2 * h)
            assert np.any(exact != 0) and np.allclose(exact, fd, rtol=1e-6, atol=1e-9), (j, exact, fd)
    finally:
        cs.close()


def test_an_implicit_importer_uses_the_directional_derivatives(fmus):
    """FMPy 0.3.32's CVode takes no Jacobian (simulate_fmu has no option for
    it; test_fmpy_s_cvode_takes_the_exact_jacobian gives it one), and scipy's
    Radau is another importer: its Jacobian from
    fmi2GetDirectionalDerivative (columns J e_j) gives the trajectory of its
    finite-difference Jacobian (measured: 1.3e-11 apart at the end, 7726 vs
    7798 evaluations of fmi2GetDerivatives)."""
    from scipy.integrate import solve_ivp
    s = Instance(fmus["two_mass_force"].path)
    try:
        s.start()
        s.to_continuous()
        der = [u.variable.valueReference for u in s.md.derivatives]
        states = [u.variable.derivative.valueReference for u in s.md.derivatives]

        def f(t, x):
            s.fmu.setTime(t)
            s.set_states(x)
            return s.derivatives()

        def jac(t, x):
            s.fmu.setTime(t)
            s.set_states(x)
            return np.column_stack([_dirder(s, der, states, e) for e in np.eye(s.nx)])

        x0 = s.states()
        runs = {j is None: solve_ivp(f, (0.0, 1.0), x0, method="Radau", jac=j, rtol=1e-8,
                                     atol=1e-10) for j in (jac, None)}
        exact, fd = runs[False], runs[True]
        assert exact.success and fd.success
        assert np.allclose(exact.y[:, -1], fd.y[:, -1], rtol=1e-6, atol=1e-9)
        assert exact.njev > 0
    finally:
        s.close()


def _cvode_with_jacobian(exact: bool, runs: list):
    """FMPy's CVodeSolver (SUNDIALS 7.5, the library FMPy ships), given the
    FMU's exact Jacobian (columns J e_j from fmi2GetDirectionalDerivative)
    through CVodeSetJacFn when ``exact``; its counters after every step
    appended to ``runs``.  FMPy 0.3.32 never calls CVodeSetJacFn (its CVode
    builds a difference-quotient Jacobian from fmi2GetDerivatives): this is
    the few lines an importer needs to use ours."""
    from fmpy.sundials import CVodeSolver
    from fmpy.sundials.libraries import sundials_cvode, sundials_sunmatrixdense

    long_p = ctypes.POINTER(ctypes.c_long)
    from fmpy.sundials.sundials_nvector import N_Vector

    jac_fn_t = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_double, N_Vector,
                                ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                                ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)
    set_jac = sundials_cvode.CVodeSetJacFn
    set_jac.argtypes, set_jac.restype = [ctypes.c_void_p, jac_fn_t], ctypes.c_int
    column = sundials_sunmatrixdense.SUNDenseMatrix_Column
    column.argtypes = [ctypes.c_void_p, ctypes.c_long]
    column.restype = ctypes.POINTER(ctypes.c_double)
    counters = {n: getattr(sundials_cvode, "CVodeGetNum" + n) for n in
                ("Steps", "RhsEvals", "JacEvals", "LinRhsEvals")}
    for f in counters.values():
        f.argtypes, f.restype = [ctypes.c_void_p, long_p], ctypes.c_int

    class Solver(CVodeSolver):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            if exact:
                self.jac_ = jac_fn_t(self.jac)
                assert set_jac(self.cvode_mem, self.jac_) == 0

        def jac(self, t, y, fy, J, user_data, tmp1, tmp2, tmp3):
            fmu = Solver.fmu
            self.set_time(t)
            self.set_x(fmpy.sundials.NV_DATA_S(y), self.nx)
            der = [u.variable.valueReference for u in Solver.md.derivatives]
            states = [u.variable.derivative.valueReference for u in Solver.md.derivatives]
            for j in range(self.nx):
                seed = [0.0] * self.nx
                seed[j] = 1.0
                col = fmu.getDirectionalDerivative(der, states, seed)
                c = column(J, j)
                for i in range(self.nx):
                    c[i] = col[i]
            return 0

        def step(self, t, t_next):
            out = super().step(t, t_next)
            n = {}
            for name, f in counters.items():
                v = ctypes.c_long()
                f(self.cvode_mem, ctypes.byref(v))
                n[name] = v.value
            runs.append(n)
            return out

    return Solver


@pytest.mark.parametrize("name, stop", [("backrest", 0.3), ("two_mass_force", 1.0)])
def test_fmpy_s_cvode_takes_the_exact_jacobian(fmus, monkeypatch, name, stop):
    """FMPy's CVode with the FMU's Jacobian (fmi2GetDirectionalDerivative,
    set by CVodeSetJacFn) against its own difference quotients, same run
    otherwise: the same trajectory to the solver's tolerance, no
    right-hand-side evaluation spent on Jacobians (FMPy's own: nx per
    Jacobian) -- backrest: stick-slip events and an algebraic loop.
    Measured (rtol 1e-8): backrest 0.3 s, FMPy's Jacobian 63 steps, 74 RHS +
    4 for 1 Jacobian; ours 73 steps, 95 RHS, 2 Jacobians, 0 RHS for them;
    two_mass_force 1 s, 540 steps, 600 + 20 for 10 against 545 steps, 591 + 0
    for 9."""
    import fmpy.sundials

    path = fmus[name].path
    md = read_model_description(str(path))
    results, counts = {}, {}
    for exact in (False, True):
        runs: list = []
        solver = _cvode_with_jacobian(exact, runs)
        solver.md = md
        fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(str(path)),
                        modelIdentifier=md.modelExchange.modelIdentifier, instanceName="jac")
        fmu.instantiate()
        solver.fmu = fmu  # the instance the Jacobian callback asks
        monkeypatch.setattr(fmpy.sundials, "CVodeSolver", solver)
        try:
            results[exact] = fmpy.simulate_fmu(str(path), fmi_type="ModelExchange",
                                               stop_time=stop, output_interval=stop / 100,
                                               relative_tolerance=1e-8, fmu_instance=fmu)
        finally:
            fmu.freeInstance()
        assert runs
        counts[exact] = runs[-1]
    nx = md.numberOfContinuousStates
    assert counts[True]["JacEvals"] > 0 and counts[True]["LinRhsEvals"] == 0
    assert counts[False]["LinRhsEvals"] == nx * counts[False]["JacEvals"] > 0
    for n in results[True].dtype.names[1:]:
        y, z = results[False][n], results[True][n]
        scale = np.ptp(y) or np.max(np.abs(y)) or 1.0
        assert len(y) == len(z) and np.max(np.abs(y - z)) < 1e-5 * scale, n


def test_a_discarded_co_simulation_state_goes_on_in_model_exchange(fmus):
    """An FMU state of a co-simulation instance whose step was discarded (a
    validity condition fails at once) set in a model-exchange instance: no
    co-simulation-only state (StepFailed) there; it goes on from the last
    accepted time and states."""
    path = fmus["backrest"].path
    cs = Instance(path, me=False)
    me = Instance(path)
    try:
        cs.start()
        cs.fmu.setReal([cs.vr["letoff"], cs.vr["warp_pull"]], [0.01, -0.02])
        assert cs.raw("DoStep", ctypes.c_double(0.0), ctypes.c_double(0.1),
                      ctypes.c_int(1)) == DISCARD
        blob = cs.fmu.serializeFMUstate(cs.fmu.getFMUstate())
        me.start()
        me.to_continuous()
        me.fmu.setFMUstate(me.fmu.deSerializeFMUstate(blob))
        me.fmu.setTime(0.0)
        assert np.all(np.isfinite(me.derivatives()))
        me.fmu.enterEventMode()
    finally:
        cs.close()
        me.close()


def test_setup_and_names_refused(fmus):
    """A tolerance that is not a finite positive number, and an instance
    name of white space only, are refused (nothing set / NULL)."""
    s = Instance(fmus["two_mass_force"].path)
    try:
        setup = s.fmu._functions["fmi2SetupExperiment"]
        for tol in (float("nan"), -1.0, 0.0, float("inf")):
            assert setup(s.fmu.component, 1, tol, 0.0, 0, 0.0) == ERROR
            assert "expected a finite value > 0" in s.messages()[-1]
        assert setup(s.fmu.component, 1, 0.5, 0.0, 0, 0.0) == WARNING  # limited to the range
        comp = s.fmu._functions["fmi2Instantiate"](
            b" \t ", 0, s.md.guid.encode(), b"", ctypes.byref(s._cb), 0, 0)
        assert comp is None and "white space only" in s.messages()[-1]
    finally:
        s.close()


def test_me_misuse_is_refused(fmus):
    """Calls out of order, on the wrong interface, NULL arrays, a wrong
    number of states, non-finite states or time: fmi2Error and a log line,
    nothing changed, never a crash."""
    path = fmus["backrest"].path
    s = Instance(path)
    dbl = ctypes.c_double
    try:
        x = (dbl * s.nx)()
        info = fmi2EventInfo()
        # instantiated: no continuous-time calls yet
        assert s.raw("SetTime", dbl(0.1)) == ERROR
        assert "fmi2SetTime must not be called in state Instantiated" in s.messages()[-1]
        s.fmu.setupExperiment(startTime=0.0)
        s.fmu.enterInitializationMode()
        vr = (ctypes.c_uint * 1)(s.vr["warp_pull"])
        assert s.raw("SetRealInputDerivatives", vr, ctypes.c_size_t(1),
                     (ctypes.c_int * 1)(1), (dbl * 1)(1.0)) == ERROR
        assert "is a co-simulation function" in s.messages()[-1]
        s.fmu.exitInitializationMode()
        # event mode after initialization: states are set in continuous-time mode only
        assert s.raw("SetContinuousStates", x, s.nx) == ERROR
        assert "state EventMode" in s.messages()[-1]
        assert s.raw("CompletedIntegratorStep", 1, None, None) == ERROR
        assert s.raw("DoStep", dbl(0.0), dbl(0.1), ctypes.c_int(1)) == ERROR  # a co-simulation call
        assert s.raw("NewDiscreteStates", None) == ERROR
        s.to_continuous()
        assert s.raw("NewDiscreteStates", ctypes.byref(info)) == ERROR
        assert "ContinuousTimeMode" in s.messages()[-1]
        x0 = s.states()
        # arrays: NULL, wrong size, non-finite
        assert s.raw("SetContinuousStates", None, s.nx) == ERROR
        assert s.raw("SetContinuousStates", x, s.nx + 1) == ERROR
        assert "nx = %d, expected %d" % (s.nx + 1, s.nx) in s.messages()[-1]
        assert s.raw("GetDerivatives", x, s.nx - 1) == ERROR
        assert s.raw("GetEventIndicators", None, s.ne) == ERROR
        assert s.raw("GetEventIndicators", x, s.ne + 3) == ERROR
        assert s.raw("GetNominalsOfContinuousStates", None, s.nx) == ERROR
        bad = (dbl * s.nx)(*([float("nan")] + [0.0] * (s.nx - 1)))
        assert s.raw("SetContinuousStates", bad, s.nx) == ERROR
        assert "is not finite" in s.messages()[-1]
        for t in (float("nan"), float("inf"), -1.0):
            assert s.raw("SetTime", dbl(t)) == ERROR
        assert np.array_equal(s.states(), x0)  # nothing changed
        assert s.raw("CompletedIntegratorStep", 1, None, None) == ERROR
        s.fmu.terminate()
        assert s.raw("EnterEventMode") == ERROR
    finally:
        s.close()
    # a model-exchange call on a co-simulation instance
    cs = Instance(path, me=False)
    try:
        x = (dbl * cs.nx)()
        cs.fmu.setupExperiment(startTime=0.0)
        cs.fmu.enterInitializationMode()
        assert cs.raw("GetDerivatives", x, ctypes.c_size_t(cs.nx)) == ERROR
        assert "is a model-exchange function" in cs.messages()[-1]
        cs.fmu.exitInitializationMode()
        assert cs.raw("GetDerivatives", x, ctypes.c_size_t(cs.nx)) == ERROR
        assert "state StepComplete" in cs.messages()[-1]
    finally:
        cs.close()


def test_an_undeclared_interface_is_not_instantiated(fmus):
    """spring_me declares model exchange only: a co-simulation instance is
    refused (NULL) with a log line."""
    md = read_model_description(str(fmus["spring_me"].path))
    assert md.coSimulation is None
    s = Instance(fmus["spring_me"].path)
    try:
        comp = s.fmu._functions["fmi2Instantiate"](
            b"cs", 1, md.guid.encode(), b"", ctypes.byref(s._cb), 0, 0)
        assert comp is None
        assert "declares model exchange only" in s.messages()[-1]
    finally:
        s.close()


def matrix(frac: float, names: list[str]) -> None:
    """Every model as FMI 2.0 "both": CVode (ME) against our CS run over
    `frac` of the default stop time; prints one line per model."""
    import tempfile

    from loomfmu.registry import MODELS
    out = tempfile.mkdtemp()
    for name in names or list(MODELS):
        t0 = time.perf_counter()
        built = build_fmu(load_model(name), out_dir=out, interface="both")
        md = read_model_description(str(built.path))
        stop = float(md.defaultExperiment.stopTime) * frac
        t1 = time.perf_counter()
        try:
            worst, which = compare(built.path, stop, stop / 100)
            print(f"{name}: nx={md.numberOfContinuousStates} "
                  f"ne={md.numberOfEventIndicators} problems={len(built.problems)} "
                  f"stop={stop:g} s worst={worst:.2e} ({which}) build={t1 - t0:.1f} s "
                  f"runs={time.perf_counter() - t1:.2f} s", flush=True)
        except Exception as e:  # report and go on with the next model
            print(f"{name}: FAILED {type(e).__name__}: {str(e)[:300]}", flush=True)


if __name__ == "__main__":
    if sys.argv[1:2] == ["switches"]:  # python tests/test_me.py switches
        import tempfile
        rtols = (1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
        for version in (2, 3):  # each version's ME against its own CS
            built = build_fmu(load_model("backrest"), out_dir=tempfile.mkdtemp(),
                              fmi_version=version, interface="both")
            n, gaps = switch_gaps(built.path, rtols)
            print(f"backrest FMI {version}.0: {n} switches in 1 s; largest |t_ME - t_CS| "
                  "per CVode rtol:")
            for rtol, gap in zip(rtols, gaps):
                print(f"  rtol {rtol:g}: {gap:.2e} s")
    else:
        matrix(float(sys.argv[1]) if len(sys.argv) > 1 else 0.1, sys.argv[2:])
