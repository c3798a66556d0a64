"""One run of one method on one scene, timed, with its error.

Methods, all on the same declaration:

* ``fmu``: our FMU through FMPy (``fmpy.simulate_fmu`` on the FMU extracted
  once, its model description parsed once, its library loaded and one
  instance made once: a Python script that runs a model many times keeps
  its instance and resets it, as ``loomfmu sweep`` does).  Time: wall time
  of ``fmi2Reset`` and the whole ``simulate_fmu`` call on that instance
  (start values, initialization, every ``fmi2DoStep`` and output read,
  ``fmi2Terminate``).  Loading the library and binding its functions
  (FMPy's ``FMU2Slave``, about 1.3 ms a run, most of it FMPy's ``inspect``
  of its own methods) is left out as CasADi's is: building the integrator
  (``ca.integrator``) is outside its time.  ``Fmu.run(..., fresh=True)``
  times a new instance instead (load, instantiate, run, free:
  ``loomfmu.verification.verify.simulate``).
* ``scipy``: ``solve_ivp`` with a Python right-hand side, through
  :func:`loomfmu.verification.reference.reference` (events, friction modes and delays
  included).  Time: the integration only (``Reference.wall_seconds``).
* ``casadi``: CasADi's ``cvodes`` / ``idas`` on the symbolic right-hand side
  (:func:`loomfmu.export.dae.dae_form`), outputs on the same grid.  Time: the
  integrator call only.  CasADi's integrators know neither our events nor
  modes nor delays: models with modes or delays are left out; models with
  events (breakpoints) are integrated straight through them.

Error (:func:`errors`): for each key output, relative to the output's range
in the reference (its magnitude if the range is zero), (1) at the final
time and (2) the max over the communication grid; the worst output counts.
Timing (:func:`timed`): the median of ``repeats`` runs; a run longer than
:data:`LONG_RUN` seconds is run once (its noise is small against its length).
"""
from __future__ import annotations

import statistics
import threading
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import fmpy
import numpy as np
from fmpy import read_model_description

from loomfmu.declare.model import Model
from loomfmu.declare.solvers import SOLVERS
from loomfmu.export.dae import dae_form
from loomfmu.fmu.builder import build_fmu
from loomfmu.fmu.platforms import HOST
from loomfmu.verification import fmpy_logger
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import simulate

#: runs longer than this (s) are not repeated
LONG_RUN = 1.0


@dataclass
class Run:
    """A method's result on the grid: outputs by name, seconds, and cost counters."""

    t: np.ndarray
    y: dict[str, np.ndarray]
    seconds: float
    n_rhs: int | None = None


def timed(fn, repeats: int) -> Run:
    """``fn() -> Run``; the median of up to ``repeats`` runs' seconds."""
    first = fn()
    times = [first.seconds]
    if first.seconds < LONG_RUN:
        times += [fn().seconds for _ in range(repeats - 1)]
    first.seconds = statistics.median(times)
    return first


def errors(run: Run, ref: Run, outputs) -> tuple[float, float]:
    """(final-time error, max error over the grid), each the worst output's,
    relative to the output's range in the reference."""
    if len(run.t) != len(ref.t) or not np.allclose(run.t, ref.t, rtol=0, atol=1e-9):
        raise ValueError(f"output times differ: {len(run.t)} vs {len(ref.t)} points")
    final = worst = 0.0
    for name in outputs:
        r, y = np.asarray(ref.y[name]), np.asarray(run.y[name])
        span = float(np.ptp(r)) or float(np.max(np.abs(r))) or 1.0
        if not np.all(np.isfinite(y)):
            return float("inf"), float("inf")
        final = max(final, abs(float(y[-1] - r[-1])) / span)
        worst = max(worst, float(np.max(np.abs(y - r))) / span)
    return final, worst


class Fmu:
    """An FMU built and extracted once into ``out_dir``; one instance of it is
    kept and reset before each run (made again after a run that fails).
    Runs of one ``Fmu`` from several threads take turns on its instance (a
    lock); give each thread its own ``Fmu`` to run them side by side."""

    def __init__(self, model: Model, out_dir: Path):
        out_dir.mkdir(parents=True, exist_ok=True)
        self.path = build_fmu(model, out_dir=out_dir, validate=False, platforms=HOST,
                    reference_results=False).path
        self.dir = out_dir / f"{model.name}_unzipped"
        with zipfile.ZipFile(self.path) as z:
            z.extractall(self.dir)
        self.md = read_model_description(str(self.dir))
        self._log: list[str] = []
        self._instance = None
        self._lock = threading.Lock()

    def _logger(self, *args):  # FMI 2: (env, instance, status, category, message)
        self._log.append(f"[{args[-3]}] {args[-2].decode()}: {args[-1].decode()}")

    def _drop(self):
        if self._instance is not None:
            try:
                self._instance.freeInstance()
            except Exception:  # noqa: BLE001 (an instance in Error may refuse)
                pass
        self._instance = None

    def __del__(self):
        self._drop()

    def run(self, *, solver: str, rtol: float, atol: float, stop: float,
            interval: float | None, outputs, values: dict | None = None,
            fresh: bool = False) -> Run:
        if fresh:
            t0 = time.perf_counter()
            res = simulate(self.dir, solver=solver, rtol=rtol, atol=atol, stop_time=stop,
                           output_interval=interval, output=list(outputs),
                           values=values or {}, model_description=self.md)
            return Run(res.t, res.y, time.perf_counter() - t0)
        start = {"solver": SOLVERS.index(solver) + 1, "solver_atol": atol, **(values or {})}
        with self._lock:  # one instance: one run at a time
            if self._instance is None:  # untimed, as CasADi's ca.integrator
                self._instance = fmpy_logger.instantiate(self.dir, self.md, "CoSimulation",
                                                         self._logger)
            self._log.clear()
            t0 = time.perf_counter()
            try:
                self._instance.reset()
                res = fmpy.simulate_fmu(str(self.dir), validate=False, stop_time=stop,
                                        fmi_type="CoSimulation", relative_tolerance=rtol,
                                        output_interval=interval, start_values=start,
                                        output=list(outputs), model_description=self.md,
                                        fmu_instance=self._instance)
            except Exception as e:  # noqa: BLE001 (FMPy raises bare Exceptions)
                self._drop()
                tail = "; ".join(self._log[-3:]) or "no log"
                raise RuntimeError(f"simulate {self.path.name}: {e} (log: {tail})") from e
            seconds = time.perf_counter() - t0
        return Run(np.asarray(res["time"]), {n: np.asarray(res[n]) for n in outputs}, seconds)


def scipy_run(model: Model, grid, *, method: str, rtol: float, atol: float,
              values: dict | None = None) -> Run:
    ref = reference(model, t_end=grid[-1], t_eval=grid, rtol=rtol, atol=atol, method=method,
                    values=values or {})
    return Run(ref.t, ref.y, ref.wall_seconds, ref.n_rhs)


class CasadiModel:
    """The model's DaeForm as a CasADi integrator problem with u, p fixed.

    Explicit models: x' = wsol (cvodes and idas).  Models whose unknowns need
    Newton (``wsol`` None): all unknowns w are algebraic, x' = w[:nx],
    0 = F (semi-explicit index 1; idas only).
    """

    def __init__(self, model: Model, values: dict | None = None):
        dae = dae_form(model)
        if model.of_kind("mode") or dae.d.numel():
            raise ValueError(f"model {model.name}: CasADi's integrators support neither "
                             "discrete modes nor delays")
        self.model, self.dae = model, dae
        values = values or {}
        self.pnum = np.array([float(values.get(v.name, v.start)) for kind in
                              ("input", "parameter") for v in model.of_kind(kind)])
        self.P = ca.vertcat(dae.u, dae.p)
        empty = ca.SX(0, 1)
        args = [dae.t, dae.x, dae.w, dae.u, dae.p, empty, empty]
        nx = dae.nx
        x = np.array([float(values.get(v.name, v.start)) for v in model.of_kind("state")])
        init = ca.Function("init", args, [dae.init])
        x_init = np.asarray(init(0.0, x, np.zeros(dae.w.numel()), *self._up(), [], [])).ravel()
        self.x0 = np.array([x[i] if v.name in values else x_init[i]
                            for i, v in enumerate(model.of_kind("state"))])
        if dae.implicit:
            self.plugins = ("idas",)
            self.problem = {"x": dae.x, "z": dae.w, "p": self.P, "t": dae.t,
                            "ode": dae.w[:nx, 0], "alg": dae.F}
            g = ca.Function("g", [dae.w, dae.x, dae.t, self.P], [dae.F])
            newton = ca.rootfinder("w0", "newton", g)
            self.z0 = np.asarray(newton(np.zeros(dae.w.numel()), self.x0, 0.0, self.pnum)
                                 ).ravel()
            w_expr = dae.w
        else:
            self.plugins = ("cvodes", "idas")
            self.problem = {"x": dae.x, "p": self.P, "t": dae.t, "ode": dae.wsol[:nx, 0]}
            self.z0 = None
            w_expr = dae.wsol
        y = ca.substitute(dae.y, dae.w, w_expr) if not dae.implicit else dae.y
        self.out = ca.Function("out", [dae.t, dae.x, dae.w, self.P], [y])
        self.out_names = [v.name for v in model.of_kind("output")]

    def _up(self):
        nu = self.dae.u.numel()
        return self.pnum[:nu], self.pnum[nu:]

    def run(self, grid, *, plugin: str, rtol: float, atol: float, outputs,
            repeats: int = 1) -> Run:
        if plugin not in self.plugins:
            raise ValueError(f"plugin = {plugin!r}; allowed for {self.model.name}: "
                             f"{self.plugins}")
        opts = {"abstol": atol, "reltol": rtol, "max_num_steps": 10**7}
        F = ca.integrator("F", plugin, self.problem, float(grid[0]), list(grid[1:]), opts)
        args = {"x0": self.x0, "p": self.pnum}
        if self.z0 is not None:
            args["z0"] = self.z0
        times, res = [], None
        for _ in range(repeats):
            t0 = time.perf_counter()
            res = F(**args)
            times.append(time.perf_counter() - t0)
            if times[-1] > LONG_RUN:
                break
        xs = np.hstack([self.x0[:, None], np.asarray(res["xf"])])
        nw = self.dae.w.numel()
        if self.z0 is not None:
            ws = np.hstack([self.z0[:, None], np.asarray(res["zf"])])
        else:
            ws = np.zeros((nw, len(grid)))
        n = len(grid)
        ys = np.asarray(self.out.map(n)(np.asarray(grid)[None, :], xs, ws,
                                        np.repeat(self.pnum[:, None], n, axis=1)))
        idx = {name: i for i, name in enumerate(self.out_names)}
        y = {name: ys[idx[name], :] for name in outputs}
        stats = F.stats()
        return Run(np.asarray(grid), y, statistics.median(times), stats.get("nfevals"))
