"""Verification: run an FMU through FMPy and compare it with the scipy reference.

Error measures (per output, over the communication points):

* ``max_abs``: max |y_fmu - y_ref|;
* ``max_rel_range``: max_abs divided by the output's range (max - min of the
  reference; the magnitude if the range is zero).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import fmpy
import numpy as np

from .codegen import SOLVERS
from .declare import Model
from .reference import Reference, reference


@dataclass
class FmuRun:
    t: np.ndarray
    y: dict[str, np.ndarray]
    wall_seconds: float
    log: list[str] = field(default_factory=list)


def simulate(fmu: Path | str, *, solver: str = "dopri5", rtol: float = 1e-6,
             atol: float = 1e-9, stop_time: float | None = None,
             output_interval: float | None = None, values: dict | None = None,
             output: list[str] | None = None, model_description=None) -> FmuRun:
    """Simulate ``fmu`` with ``fmpy.simulate_fmu`` (co-simulation).

    solver: one of SOLVERS.  rtol, atol: tolerances of the adaptive solvers (> 0).
    output_interval: communication step (default: the FMU's DefaultExperiment).
    values: start values by name (parameters, inputs, states, solver settings).
    model_description: FMPy's parsed description, to skip parsing on repeated runs.
    """
    if solver not in SOLVERS:
        raise ValueError(f"solver = {solver!r}; allowed: {SOLVERS}")
    for name, tol in (("rtol", rtol), ("atol", atol)):
        if not tol > 0:
            raise ValueError(f"{name} = {tol!r}; allowed: > 0")
    log: list[str] = []

    def logger(component, instance, status, category, message):
        log.append(f"[{status}] {category.decode()}: {message.decode()}")

    start = {"solver": SOLVERS.index(solver) + 1, "solver_atol": atol, **(values or {})}
    wall = time.perf_counter()
    res = fmpy.simulate_fmu(str(fmu), validate=False, stop_time=stop_time,
                            relative_tolerance=rtol, output_interval=output_interval,
                            start_values=start, output=output, logger=logger,
                            model_description=model_description)
    wall = time.perf_counter() - wall
    names = [n for n in res.dtype.names if n != "time"]
    return FmuRun(np.asarray(res["time"]), {n: np.asarray(res[n]) for n in names}, wall, log)


def compare(run: FmuRun | Reference, ref: Reference,
            names: list[str]) -> dict[str, dict[str, float]]:
    """Error of each output in ``names`` of ``run`` (an FMU run or another
    reference) at the reference's times."""
    if len(run.t) != len(ref.t) or not np.allclose(run.t, ref.t, rtol=0, atol=1e-9):
        raise ValueError("FMU and reference output times differ")
    errs = {}
    for name in names:
        r, y = ref.y[name], run.y[name]
        span = float(np.ptp(r)) or float(np.max(np.abs(r))) or 1.0
        err = float(np.max(np.abs(y - r)))
        errs[name] = {"max_abs": err, "max_rel_range": err / span}
    return errs


def verify(fmu: Path | str, model: Model, *, solvers=SOLVERS, rtol: float = 1e-6,
           atol: float = 1e-9, ref_rtol: float = 1e-11, ref_atol: float = 1e-13) -> dict:
    """Run ``fmu`` with every solver and compare with a tight scipy reference.

    Returns {"reference_wall_seconds", "solvers": {solver: {"wall_seconds",
    "errors": {output: {"max_abs", "max_rel_range"}}}}}.
    """
    names = [v.name for v in model.of_kind("output")]
    runs = {s: simulate(fmu, solver=s, rtol=rtol, atol=atol, output=names) for s in solvers}
    grid = next(iter(runs.values())).t  # FMPy's communication points
    ref = reference(model, t_end=grid[-1], t_eval=grid, rtol=ref_rtol, atol=ref_atol,
                    method=model.reference_method)
    return {"reference_wall_seconds": ref.wall_seconds, "reference_rhs_calls": ref.n_rhs,
            "solvers": {s: {"wall_seconds": run.wall_seconds, "log": run.log[-5:],
                            "errors": compare(run, ref, names)} for s, run in runs.items()}}
