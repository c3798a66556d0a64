"""Runtime and code-generation defects found by adversarial testing
(/work/notes/adv: structural_zero_outputs.py, rk4_delay_history_full.py,
breakpoints_dropped.py, deserialize_size_overflow.py, state_cross.py), each
turned into a test on a small user model built for real (gcc, FMPy):

* CasADi writes only an output's structural nonzeros: a structurally zero
  output was never written (the outputs after it shifted into its place),
  and the history's dg/dt of a delayed *input* was garbage, so rk4 filled the
  65536-sample history within 3 communication steps (and its message told
  the user to loosen solver_rtol, for a fixed-step solver);
* pending delay breakpoints past 256 were dropped silently (accuracy lost,
  rodas4 discarded with "step size underflow");
* fmi2DeSerializeFMUstate with a size near SIZE_MAX wrapped the blob's size
  and overran the heap;
* a communication point behind the FMU's time was refused as "does not
  advance time".
"""
from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import textwrap

import casadi as ca
import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException

from loomfmu import build_fmu
from loomfmu.declare.model import Model
from loomfmu.export.codegen import casadi_functions
from loomfmu.export.dae import dae_form

pytestmark = pytest.mark.slow  # builds FMUs

DOPRI5, RODAS4, RK4 = 1, 2, 3


def zeros_model() -> Model:
    """x' = 0 written as a structural zero (the Jacobian of an input with
    respect to a state), an output that is that structural zero, and one
    after it.  The declaration densifies what it is given; the output's
    expression is set back to the bare structural zero afterwards, so that
    code generation meets it on its own (as it meets dg/dt of a delayed
    input, which no declaration sees)."""
    m = Model("zeros", stop_time=1.0, step_size=0.1)
    x = m.state("x", 1.0, description="x")
    u = m.input("u", 2.0, description="input", min=-10, max=10)
    z = ca.jacobian(u, x)  # 1 x 1, no structural nonzero
    assert z.nnz() == 0
    m.eq(m.der(x), z)
    m.output("y0", z, description="a structurally zero output")
    m.output("y1", x + z, description="x")
    next(v for v in m.of_kind("output") if v.name == "y0").expr = z
    return m


def delayed_input_model() -> Model:
    """x' = -x + u(t - tau), u an input: dg/dt of the delayed expression is
    a structural zero."""
    m = Model("ddein", stop_time=4.0, step_size=0.01)
    x = m.state("x", 0.0, description="x")
    u = m.input("u", 0.0, description="input", min=-10, max=10)
    tau = m.parameter("tau", 1.5, unit="s", description="delay", min=0.0, max=2.0,
                      source="test problem")
    ud = m.delay("ud", u, tau, max_delay=2.0, description="u, tau ago")
    m.eq(m.der(x), -x + ud)
    m.output("x_out", x, description="x")
    return m


@pytest.fixture(scope="module")
def zeros_fmu(tmp_path_factory):
    return build_fmu(zeros_model(), out_dir=tmp_path_factory.mktemp("zeros"),
                     validate=False).path


def delayed_fast_model() -> Model:
    """x' = -x + s(t - tau), s a 2 kHz sine: a delayed signal whose samples a
    few microseconds apart are not reproduced by their neighbours' Hermite
    cubic, so the history keeps every one (a slow signal's are thinned)."""
    m = Model("ddfast", stop_time=4.0, step_size=0.01)
    x = m.state("x", 0.0, description="x")
    tau = m.parameter("tau", 1.5, unit="s", description="delay", min=0.0, max=2.0,
                      source="test problem")
    sd = m.delay("sd", ca.sin(2 * math.pi * 2000.0 * m.t), tau, max_delay=2.0,
                 description="a 2 kHz sine, tau ago")
    m.eq(m.der(x), -x + sd)
    m.output("x_out", x, description="x")
    return m


@pytest.fixture(scope="module")
def ddfast_fmu(tmp_path_factory):
    return build_fmu(delayed_fast_model(), out_dir=tmp_path_factory.mktemp("ddfast"),
                     validate=False).path


@pytest.fixture(scope="module")
def ddein_fmu(tmp_path_factory):
    return build_fmu(delayed_input_model(), out_dir=tmp_path_factory.mktemp("ddein"),
                     validate=False).path


def discard_logs(s):
    return [m for status, _, m in s.log if status == 2]


# ---- 1. structural zeros ---------------------------------------------------


@pytest.mark.parametrize("make", [zeros_model, delayed_input_model])
def test_every_output_of_every_generated_function_is_dense(make):
    dae = dae_form(make())
    sparse = [f"{f.name()}:{f.name_out(i)}" for f in casadi_functions(dae)
              for i in range(f.n_out())
              if f.sparsity_out(i).nnz() != f.sparsity_out(i).numel()]
    assert not sparse


@pytest.mark.parametrize("solver", [DOPRI5, RODAS4, RK4])
def test_structurally_zero_output_is_written(zeros_fmu, solver):
    r = simulate_fmu(str(zeros_fmu), stop_time=1.0, output_interval=0.25,
                     start_values={"solver": solver}, output=["y0", "y1"])
    assert list(r["y0"]) == [0.0] * 5  # was x's value (y1 shifted into y0's place)
    assert list(r["y1"]) == [1.0] * 5  # was leftover memory (4.7e-310)


@pytest.mark.parametrize("solver", [DOPRI5, RODAS4, RK4])
def test_delayed_input_matches_closed_form(ddein_fmu, slave_factory, solver):
    """u = 1 from t = 0 on (0 before): x(4) = 1 - exp(-(4 - tau)).  rk4
    filled its history in 3 steps when dg/dt was garbage."""
    s = slave_factory(ddein_fmu)
    s.start(solver=solver)
    s.set(u=1.0)
    for i in range(400):
        s.fmu.doStep(i * 0.01, 0.01)
    assert s.get("x_out")[0] == pytest.approx(1 - math.exp(-2.5), abs=1e-8)
    assert not discard_logs(s)


def test_rk4_history_full_names_solver_h_fixed(ddfast_fmu, slave_factory):
    """2 s of a fast delayed signal in steps of 1e-5 s needs 200000 samples
    (65536 held): the advice for the fixed-step solver is its step, not only
    tolerances."""
    s = slave_factory(ddfast_fmu)
    s.start(solver=RK4, tau=2.0, solver_h_fixed=1e-5)
    with pytest.raises(FMICallException):
        s.fmu.doStep(0.0, 1.0)
    full = [m for m in discard_logs(s) if "history of delay sd is full" in m]
    assert full, s.log[-3:]
    assert "solver_h_fixed = 1e-05" in full[0] and "rk4 takes fixed steps" in full[0]
    assert f"at least tau / 65536 = {2.0 / 65536:g} s" in full[0]


def test_history_full_by_short_communication_steps_names_them(ddfast_fmu, slave_factory):
    """An adaptive solver ends a step at every communication point: steps
    of 1e-5 s against tau = 2 s fill the 65536 samples of a fast delayed
    signal, and the advice says so (it said only 'loosen solver_rtol /
    solver_atol')."""
    s = slave_factory(ddfast_fmu)
    s.start(solver=DOPRI5, tau=2.0)
    with pytest.raises(FMICallException):
        for i in range(70000):
            s.fmu.doStep(i * 1e-5, 1e-5)
    full = [m for m in discard_logs(s) if "history of delay sd is full" in m]
    assert full, s.log[-3:]
    assert f"communication steps of at least tau / 65536 = {2.0 / 65536:g} s" in full[0]


def test_a_slow_delayed_signal_in_short_steps_is_thinned_not_full(ddein_fmu, slave_factory):
    """The same short steps on a held input: neighbouring samples reproduce
    the ones between them, which are thinned, and the history never fills."""
    s = slave_factory(ddein_fmu)
    s.start(solver=DOPRI5, tau=2.0)
    s.set(u=1.0)
    for i in range(70000):
        s.fmu.doStep(i * 1e-5, 1e-5)
    assert not discard_logs(s), s.log[-3:]
    x = s.fmu.getReal([s.vr["x_out"]])[0]
    assert x == 0.0   # u(t - 2 s) is 0 before t = 2 s


# ---- 2. delay breakpoints ----------------------------------------------------


def jumpy_input(i: int) -> float:
    """An input that changes at every communication point."""
    return math.sin(7.0 * i * 0.001) + (1.0 if (i // 3) % 2 else -1.0)


def exact_x(us, comm, tau):
    """x' = -x + u(t - tau), x(0) = 0, u piecewise constant (us[j] on
    [j comm, (j + 1) comm)), 0 before 0: x at each communication point."""
    xs, x, t = [], 0.0, 0.0
    pieces = [(0.0, tau, 0.0)] + [(j * comm + tau, (j + 1) * comm + tau, u)
                                  for j, u in enumerate(us)]
    for i in range(len(us)):
        te = (i + 1) * comm
        for a, b, f in pieces:
            lo, hi = max(a, t), min(b, te)
            if hi > lo:
                x = f + (x - f) * math.exp(-(hi - lo))
        t = te
        xs.append(x)
    return np.array(xs)


@pytest.mark.parametrize("solver", [DOPRI5, RODAS4])
def test_1500_pending_input_jumps_keep_accuracy(ddein_fmu, slave_factory, solver):
    """tau = 1.5 s, an input change every 1 ms: 1500 breakpoints pending.
    Before, those past 256 were dropped: dopri5's error grew to 1e-10 at
    rtol 1e-12 and rodas4 discarded (step size underflow) at t = 2.226.
    Also a state taken with 1500 pending breakpoints continues identically
    in another instance (they are part of the state)."""
    comm, tau, n, k_state = 0.001, 1.5, 2300, 1600
    a = slave_factory(ddein_fmu, "A")
    a.fmu.setupExperiment(startTime=0.0, tolerance=1e-12)
    a.set(solver=solver, solver_atol=1e-15, tau=tau)
    a.fmu.enterInitializationMode()
    a.fmu.exitInitializationMode()
    us = [jumpy_input(i) for i in range(n)]
    xs, blob = [], None
    for i, u in enumerate(us):
        if i == k_state:
            blob = a.fmu.serializeFMUstate(a.fmu.getFMUstate())
        a.set(u=u)
        a.fmu.doStep(i * comm, comm)
        xs.append(a.get("x_out")[0])
    err = np.max(np.abs(np.array(xs) - exact_x(us, comm, tau)))
    assert err < 1e-12, err

    b = slave_factory(ddein_fmu, "B")
    b.start(solver=solver)
    b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
    ys = []
    for i in range(k_state, n):
        b.set(u=us[i])
        b.fmu.doStep(i * comm, comm)
        ys.append(b.get("x_out")[0])
    assert np.array_equal(np.array(ys), np.array(xs[k_state:]))


def test_breakpoints_beyond_capacity_discard_with_the_cause(ddein_fmu, slave_factory):
    """tau = 2 s, an input change every 2/9000 s: 9000 would be pending, past
    the 8192 the FMU holds.  The step whose input change does not fit is
    discarded with the cause (none dropped silently); the state there, with
    8192 breakpoints and its history, still serializes and deserializes."""
    comm, tau = 2.0 / 9000, 2.0
    s = slave_factory(ddein_fmu)
    s.start(solver=DOPRI5, tau=tau)
    stopped = None
    for i in range(9000):
        s.set(u=jumpy_input(i))
        try:
            s.fmu.doStep(i * comm, comm)
        except FMICallException as e:
            assert e.status == 2  # fmi2Discard
            stopped = i
            break
    assert stopped is not None and 8100 <= stopped <= 8192, stopped
    msg = discard_logs(s)
    assert msg and "too many input changes within one delay time" in msg[0], s.log[-2:]
    assert "8192 jumps of delayed values are pending" in msg[0]
    apart = float(re.search(r"came about (\S+) s apart", msg[0]).group(1))
    assert apart == pytest.approx(comm, rel=0.01)
    assert msg[0].startswith(f"t = {stopped * comm:.6}")
    assert s.fmu.getRealStatus(2) == pytest.approx(stopped * comm)  # LastSuccessfulTime
    blob = s.fmu.serializeFMUstate(s.fmu.getFMUstate())
    assert len(blob) > 8192 * 8
    s.fmu.setFMUstate(s.fmu.deSerializeFMUstate(blob))


# ---- 3. fmi2DeSerializeFMUstate sizes ----------------------------------------

CHILD = textwrap.dedent("""
    import ctypes, json, re, sys
    from fmpy import extract, read_model_description, calloc, free
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                           fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2FMUstate)
    path = sys.argv[1]
    md = read_model_description(path)
    logs = []
    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(lambda e, i, st, c, m: logs.append(m.decode()))
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(path),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="a")
    f.instantiate(callbacks=cb, loggingOn=True)
    f.setupExperiment(startTime=0.0); f.enterInitializationMode(); f.exitInitializationMode()
    buf = (ctypes.c_char * 64)()
    def deserialize(n):
        st = fmi2FMUstate()
        try:
            f.fmi2DeSerializeFMUstate(f.component, buf, n, ctypes.byref(st))
            return "ok"
        except FMICallException as e:
            return e.status
    out = {}
    for name, n in (("size_max", ctypes.c_size_t(-1).value),
                    ("size_max_minus_16", ctypes.c_size_t(-16).value)):
        out[name] = [deserialize(n), logs[-1] if logs else ""]
    bound = int(re.search(r"expected \\d+ \\.\\.\\. (\\d+)", logs[-1]).group(1))
    out["bound"] = bound
    out["state_size"] = len(f.serializeFMUstate(f.getFMUstate()))
    out["above_bound"] = deserialize(bound + 1)
    f.doStep(0.0, 0.01)  # the instance still works
    print(json.dumps(out))
""")


def test_deserialize_size_near_size_max_is_refused(ddein_fmu, tmp_path):
    """In a child process: before, the blob's size wrapped and memcpy overran
    the heap (abort 'malloc(): invalid size', SIGSEGV, or OK on a corrupted
    heap)."""
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    r = subprocess.run([sys.executable, str(script), str(ddein_fmu)], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, (r.returncode, r.stderr[-500:])
    out = json.loads(r.stdout.strip().splitlines()[-1])
    for case in ("size_max", "size_max_minus_16"):
        status, log = out[case]
        assert status == 3, out  # fmi2Error
        assert "fmi2DeSerializeFMUstate: size = " in log and "nothing done" in log
    assert out["above_bound"] == 3
    # the bound holds the largest state: 3 x 65536 history doubles, 8192 breakpoints
    assert out["state_size"] < (3 * 65536 + 8192) * 8 < out["bound"]


# ---- 4. communication point behind the FMU's time ---------------------------


def test_communication_point_behind_says_what_was_expected(ddein_fmu, slave_factory):
    s = slave_factory(ddein_fmu)
    s.start()
    for i in range(5):
        s.fmu.doStep(i * 0.01, 0.01)
    with pytest.raises(FMICallException):
        s.fmu.doStep(0.02, 0.01)  # behind: ends at 0.03 < 0.05
    msg = s.log[-1][2]
    assert "expected currentCommunicationPoint = t = 0.05" in msg and "got 0.02" in msg
    assert "behind" in msg and "does not advance time" not in msg
    with pytest.raises(FMICallException):
        s.fmu.doStep(0.05, 1e-20)  # at the FMU's time, below the resolution of time
    assert "does not advance time" in s.log[-1][2]
    s.fmu.doStep(0.05, 0.01)  # nothing was changed by the refused calls


# ---- runaway inputs on a model with modes -----------------------------------


@pytest.fixture(scope="module")
def backrest_fmu(tmp_path_factory):
    from loomfmu import load_model
    return build_fmu(load_model("backrest"), out_dir=tmp_path_factory.mktemp("backrest"),
                     validate=False).path


def test_runaway_input_with_no_consistent_mode_is_a_discard(backrest_fmu, slave_factory):
    """letoff = 1e300 (its range is [-0.5, 0.5]: setting it only warns) in
    the middle of a run leaves no friction mode consistent: the step is not
    done (Discard at the last successful time, the modes as they were), not
    an Error that leaves the instance only to be freed; the master rolls
    back with fmi2SetFMUstate (allowed after a Discard) and goes on."""
    s = slave_factory(backrest_fmu)
    s.start(solver=DOPRI5)
    t, h = 0.0, 0.0107
    for _ in range(30):
        s.fmu.doStep(t, h)
        t += h
    state = s.fmu.getFMUstate()
    s.fmu.doStep(t, h)
    ref = s.get("phi1_out", "omega2_out")
    s.fmu.setFMUstate(state)
    s.set(letoff=1e300)
    with pytest.raises(FMICallException) as exc:
        s.fmu.doStep(t, h)
    assert exc.value.status == 2, s.log[-3:]  # fmi2Discard
    assert any("no value of mode" in m for m in discard_logs(s)), s.log[-3:]
    assert not [m for status, _, m in s.log if status >= 3], s.log[-3:]
    assert s.fmu.getRealStatus(2) == t  # fmi2LastSuccessfulTime
    s.fmu.setFMUstate(state)  # letoff back to its value then
    s.fmu.doStep(t, h)
    np.testing.assert_array_equal(s.get("phi1_out", "omega2_out"), ref)
    s.fmu.freeFMUstate(state)


def test_step_size_underflow_at_t0_names_the_cause(slave_factory, tmp_path_factory):
    """x2_in = 1e300 (no declared range) at t = 0: the step size falls to 0,
    where the relative bound is 0 too; the message said 'h=0 < 0' and
    blamed only a blow-up or a singularity."""
    from loomfmu import load_model
    path = build_fmu(load_model("two_mass_force"), out_dir=tmp_path_factory.mktemp("tmf"),
                     validate=False).path
    s = slave_factory(path)
    s.start(solver=DOPRI5)
    s.set(x2_in=1e300)
    with pytest.raises(FMICallException) as exc:
        s.fmu.doStep(0.0, 0.01)
    assert exc.value.status == 2
    msg = discard_logs(s)[-1]
    assert "h=0 no longer moves t" in msg and "< 0)" not in msg, msg
    assert "input or parameter far outside its range" in msg, msg
