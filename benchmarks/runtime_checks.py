"""Measure the runtime's behaviour at input changes, delay breakpoints, zero
delays and touching event indicators, against closed forms and the scipy
reference; its independence of the communication step (backrest switches),
the solvers' errors on a closed-form delay equation, and the wall time of
calls that used to run away; write docs/results/runtime_checks.json.

    python benchmarks/runtime_checks.py

The tests (tests/test_drive_fmu.py, tests/test_backrest.py,
tests/test_events.py, tests/test_comm_step.py, tests/test_delay_convergence.py,
tests/test_runaway.py) assert bounds on the same quantities; this script
prints the measured values quoted in docs/guides/drive.md.
"""
from __future__ import annotations

import json
import math
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from loomfmu import build_fmu, load_model
from loomfmu.declare.model import Model
from loomfmu.models.drive import build as build_drive
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import simulate

ROOT = Path(__file__).resolve().parents[1]
SOLVERS = {1: "dopri5", 2: "rodas4", 3: "rk4"}


class Run:
    """An FMU instance stepped call by call, with its log kept."""

    def __init__(self, path):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.log: list[str] = []
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=extract(str(path)),
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName="run")

        def logger(env, instance, status, category, message):
            self.log.append(message.decode())

        self._cb = fmi2CallbackFunctions()
        self._cb.logger = fmi2CallbackLoggerTYPE(logger)
        self._cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.fmu.instantiate(callbacks=self._cb)
        self.fmu.setDebugLogging(True, ["logEvents"])

    def start(self, **values):
        self.fmu.setupExperiment(startTime=0.0)
        self.set(**values)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def set(self, **values):
        for name, value in values.items():
            if name == "solver":
                self.fmu.setInteger([self.vr[name]], [int(value)])
            else:
                self.fmu.setReal([self.vr[name]], [float(value)])

    def get(self, *names):
        return self.fmu.getReal([self.vr[n] for n in names])


#: the drive's speeds are rad/s; this benchmark reports rpm
RPM_PER_RAD_S = 60.0 / (2 * math.pi)


def drive_late_step(path, solver, tau, t_s, comm, K=1800.0, T=2.0, n_min=12000.0):
    """Max error (rpm) of n_out after a unit step of u_ext at t_s; K (rpm/V) and
    n_min (rpm) are the FMU's defaults in rpm."""
    r = Run(path)
    r.start(solver=solver, tau=tau, solver_rtol=1e-10, solver_atol=1e-8, solver_h_fixed=1e-3)
    t, err = 0.0, 0.0
    for i in range(int(round(4.0 / comm))):
        if abs(t - t_s) < 1e-12:
            r.set(u_ext=1.0)
        r.fmu.doStep(t, comm)
        t = (i + 1) * comm
        lag = t - t_s - tau
        exact = n_min + (K * (1 - math.exp(-lag / T)) if lag > 0 else 0.0)
        err = max(err, abs(r.get("n_out")[0] * RPM_PER_RAD_S - exact))  # rpm
    r.fmu.freeInstance()
    return err


def zero_delay(tmp):
    fast = build_drive(cam="none", harmonics=8, max_delay=2.0)
    path = build_fmu(fast, out_dir=tmp, validate=False).path
    values = {"tau": 0.0, "f_rad": 0.5, "cam_on": 1.0, "cam_A0": 0.06, "cam_A1": 0.02,
              "cam_B3": 0.01, "cam_A8": 0.004}
    out = {}
    for solver in ("dopri5", "rodas4"):
        run = simulate(path, solver=solver, rtol=1e-6, atol=1e-9, stop_time=30.0,
                       output_interval=0.05, output=["n_out"], values=values)
        out[f"{solver}_30s_rtol1e-6_reached_s"] = float(run.t[-1])
    ref = None
    for solver in ("dopri5", "rodas4"):
        run = simulate(path, solver=solver, rtol=1e-9, atol=1e-9, stop_time=5.0,
                       output_interval=0.05, output=["n_out"], values=values)
        if ref is None:
            ref = reference(fast, t_end=5.0, t_eval=run.t, rtol=1e-11, atol=1e-9,
                            values=values)
        out[f"{solver}_5s_rtol1e-9_err_rpm"] = float(np.max(np.abs(
            run.y["n_out"] - ref.y["n_out"])) * RPM_PER_RAD_S)
        out[f"{solver}_5s_rtol1e-9_wall_s"] = run.wall_seconds
    return out


def backrest_inputs(path, model, solver, kind):
    comm, t_end = 0.01, 0.6
    schedule = ([(0.1, 0.01)] if kind == "step"
                else [(0.1 + 0.01 * i, 0.001 * (i + 1)) for i in range(20)])
    r = Run(path)
    r.start(solver=solver, solver_rtol=1e-10, solver_atol=1e-12, A_shed=0.0)
    for i in range(int(round(t_end / comm))):
        t = i * comm
        for ts, value in schedule:
            if abs(ts - t) < 1e-9:
                r.set(warp_pull=value)
        r.fmu.doStep(t, comm)
    times = [float(m.group(1)) for m in (re.match(r"t = (\S+): mode", s) for s in r.log) if m]
    r.fmu.freeInstance()
    ref = reference(model, t_end=t_end, rtol=1e-11, atol=1e-13, values={"A_shed": 0.0},
                    input_steps=[(ts, {"warp_pull": v}) for ts, v in schedule])
    same = len(times) == len(ref.switches)
    return {"switches": len(times), "reference_switches": len(ref.switches),
            "max_switch_time_diff_s": (max(abs(a - b[0]) for a, b in zip(times, ref.switches))
                                       if same else None)}


def touch(tmp, solver):
    m = Model("touch", stop_time=2.0, step_size=0.25)
    x = m.state("x", 0.0, unit="m", description="position, moving at 1 m/s")
    m.eq(m.der(x), 1.0)
    m.event("touch", (m.t - 1.0) ** 2, description="touches zero at t = 1")
    m.output("x_out", x, unit="m", description="position")
    path = build_fmu(m, out_dir=tmp, validate=False).path
    r = Run(path)
    r.start(solver=solver, solver_h_fixed=1e-3)
    err = 0.0
    for i in range(8):
        r.fmu.doStep(i * 0.25, 0.25)
        err = max(err, abs(r.get("x_out")[0] - (i + 1) * 0.25))
    r.fmu.freeInstance()
    return err


def backrest_comm_step(path):
    """Mode switches and outputs against the communication step:
    the default scene, one run per (rtol, comm), compared with comm = 1 ms."""
    out = {}
    for rtol in (1e-3, 1e-4, 1e-6, 1e-8):
        fine = None
        for comm in (1e-3, 1e-2, 1e-1, 1.0):
            r = Run(path)
            r.fmu.setupExperiment(startTime=0.0, tolerance=rtol)
            r.fmu.enterInitializationMode()
            r.fmu.exitInitializationMode()
            names = [v.name for v in r.md.modelVariables if v.causality == "output"]
            wall = time.perf_counter()
            ys = []
            for i in range(int(round(1.0 / comm))):
                r.fmu.doStep(i * comm, comm)
                ys.append(r.get(*names))
            wall = time.perf_counter() - wall
            r.fmu.freeInstance()
            ys = np.array(ys)
            switches = sum(1 for m in r.log if re.search(r"mode \S+: \S+ -> ", m))
            if fine is None:
                fine = ys
            every = int(round(comm / 1e-3))
            size = np.maximum(np.ptp(fine, axis=0), np.max(np.abs(fine), axis=0))
            err = float(np.max(np.abs(ys - fine[every - 1::every]) / size))
            out[f"rtol={rtol:g} comm={comm:g}"] = {"switches": switches,
                                                   "max_diff_rel_size": err, "wall_s": wall}
    return out


def dde_model(t_end):
    m = Model("dde", stop_time=t_end, step_size=0.1)
    x = m.state("x", 1.0, description="x' = -x(t - tau), x = 1 before 0")
    tau = m.parameter("tau", 1.0, unit="s", description="the delay", min=0.0, max=2.0,
                      source="test problem")
    m.eq(m.der(x), -m.delay("xd", x, tau, max_delay=2.0, description="x, tau ago"))
    m.output("x_out", x, description="x")
    return m


def dde_exact(t, tau):
    n = int(math.floor(t / tau)) + 1
    return sum((-1) ** k * (t - (k - 1) * tau) ** k / math.factorial(k) for k in range(n + 1))


def dde_errors(tmp):
    """x' = -x(t - tau) against its closed form over 5 s (comm 0.1 s): max
    error against rtol (atol = rtol / 1000), and with steps fixed by
    solver_h_max (tolerances too loose to act) the observed order."""
    path = build_fmu(dde_model(5.0), out_dir=tmp, validate=False).path
    out = {}
    for tau in (1.0, 0.3):
        for solver in ("dopri5", "rodas4"):
            row = {}
            for rtol in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12):
                try:
                    run = simulate(path, solver=solver, rtol=rtol, atol=rtol * 1e-3,
                                   output_interval=0.1, values={"tau": tau}, output=["x_out"])
                    row[f"rtol={rtol:g}"] = max(abs(y - dde_exact(t, tau))
                                                for t, y in zip(run.t, run.y["x_out"]))
                except Exception as e:  # a discarded step (history full): say so
                    row[f"rtol={rtol:g}"] = f"failed: {str(e)[:160]}"
            errs = []
            for h in (0.1, 0.05, 0.025):
                run = simulate(path, solver=solver, rtol=0.1, atol=1.0, output_interval=0.1,
                               values={"tau": tau, "solver_h_max": h}, output=["x_out"])
                errs.append(max(abs(y - dde_exact(t, tau)) for t, y in zip(run.t, run.y["x_out"])))
            row["fixed_step_orders"] = [math.log2(a / b) for a, b in zip(errs, errs[1:])]
            out[f"tau={tau} {solver}"] = row
    return out


def runaway(tmp):
    """Wall time and outcome of one fmi2DoStep that used to run for minutes,
    and of u_ext = 1e300 on the drive (100 steps of 0.01 s)."""
    drive = build_fmu(load_model("drive"), out_dir=tmp, validate=False).path
    backrest = build_fmu(load_model("backrest"), out_dir=tmp, validate=False).path
    out = {}
    for case, path, start, h in (("drive tau=1e-12 h=0.01", drive, {"tau": 1e-12}, 0.01),
                                 ("drive h=1e9", drive, {}, 1e9),
                                 ("backrest h=1e4", backrest, {}, 1e4)):
        r = Run(path)
        r.start(**start)
        wall = time.perf_counter()
        try:
            r.fmu.doStep(0.0, h)
            status = "OK"
        except Exception as e:
            status = str(e)
        out[case] = {"wall_s": time.perf_counter() - wall, "status": status,
                     "log": r.log[-1][:200] if r.log else ""}
        r.fmu.freeInstance()
    r = Run(drive)
    r.start()
    r.set(u_ext=1e300)
    ok, status = 0, "OK"
    for i in range(100):
        try:
            r.fmu.doStep(i * 0.01, 0.01)
            ok += 1
        except Exception as e:
            status = str(e)
            break
    out["drive u_ext=1e300"] = {"steps_ok": ok, "status": status,
                                "n_out_readable": r.get("n_out")[0], "log": r.log[-1][:200]}
    r.fmu.freeInstance()
    return out


def main() -> int:
    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        drive = build_fmu(build_drive(cam="none", harmonics=3, max_delay=2.0),
                          out_dir=tmp / "d", validate=False).path
        out["drive_late_step_max_err_rpm"] = {
            f"tau={tau} t_s={t_s} comm={comm}": {
                SOLVERS[s]: drive_late_step(drive, s, tau, t_s, comm) for s in SOLVERS}
            for tau, t_s, comm in ((0.5, 1.0, 0.01), (0.37, 1.25, 0.05), (0.5, 0.5, 0.1))}
        out["drive_zero_delay_fast_cam"] = zero_delay(tmp / "z")
        model = load_model("backrest")
        br = build_fmu(model, out_dir=tmp / "b", validate=False).path
        out["backrest_warp_pull"] = {f"{kind} {SOLVERS[s]}": backrest_inputs(br, model, s, kind)
                                     for kind in ("step", "ramp") for s in (1, 2)}
        out["touch_x_max_err"] = {SOLVERS[s]: touch(tmp / f"t{s}", s) for s in SOLVERS}
        out["backrest_comm_step"] = backrest_comm_step(br)
        out["dde_errors"] = dde_errors(tmp / "dde")
        out["runaway"] = runaway(tmp / "r")
    text = json.dumps(out, indent=2)
    (ROOT / "docs" / "results" / "runtime_checks.json").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
