"""Work-precision sweeps: every method over its tolerances (or step sizes) on
one scene, each point's CPU time and achieved error against a tight reference.

Each sweep goes from loose to tight and stops after the first run slower
than ``Plan.cap`` seconds (the point is kept): the tight end of slow methods
is where they are not competitive anyway, and the whole command has to fit
its time budget.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from loomfmu.bench.runners import CasadiModel, Fmu, Run, errors, scipy_run, timed
from loomfmu.bench.scenes import Scene
from loomfmu.declare.model import Model
from loomfmu.declare.solvers import ADAPTIVE_SOLVERS

SCIPY_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
CASADI_PLUGINS = ("cvodes", "idas")
FMU_ADAPTIVE = ADAPTIVE_SOLVERS  # (codegen: the embedded solvers with step control)
RK4_FACTORS = (16.0, 8.0, 4.0, 2.0, 1.0, 0.5)  # rk4 steps: model.h_fixed x these


@dataclass(frozen=True)
class Plan:
    """How fine the sweeps are (``full`` or ``quick``)."""

    fmu_rtols: tuple[float, ...]
    scipy_rtols: tuple[float, ...]
    casadi_rtols: tuple[float, ...]
    rk4_factors: tuple[float, ...]
    repeats: int
    cap: float          # s: a sweep stops after the first run slower than this
    ref_rtol: float

    @staticmethod
    def make(quick: bool) -> "Plan":
        if quick:
            return Plan((1e-3, 1e-6, 1e-9), (1e-3, 1e-6), (1e-4, 1e-8), (4.0, 1.0), 1, 1.5,
                        1e-10)
        return Plan(tuple(10.0 ** -k for k in range(3, 11)),
                    tuple(10.0 ** -k for k in range(3, 10)),
                    tuple(10.0 ** -k for k in range(3, 11)), RK4_FACTORS, 3, 5.0, 1e-11)


@dataclass
class Case:
    """A scene prepared for runs: model, FMU, grid and tight reference."""

    name: str
    scene: Scene
    model: Model
    fmu: Fmu
    stop: float
    interval: float | None
    grid: np.ndarray
    ref: Run
    ref_note: str
    casadi: CasadiModel | None
    casadi_note: str


def prepare(name: str, scene: Scene, model: Model, plan: Plan, quick: bool,
            work: Path, known: tuple | None = None) -> Case:
    """Build the FMU, fix the grid and solve the tight reference (``known``:
    (grid, ref, ref_note) of an earlier prepare of the same scene and plan,
    reused instead of solved again)."""
    fmu = Fmu(model, work / name)
    stop = (scene.quick_stop if quick and scene.quick_stop else scene.stop) or model.stop_time
    interval = scene.interval
    try:
        casadi, casadi_note = CasadiModel(model, scene.values), ""
    except ValueError as exc:
        casadi, casadi_note = None, str(exc)
    if known is not None:
        grid, ref, note = known
        return Case(name, scene, model, fmu, stop, interval, grid, ref, note, casadi,
                    casadi_note)
    grid = fmu.run(solver="dopri5", rtol=1e-4, atol=1e-4 * scene.atol_scale, stop=stop,
                   interval=interval, outputs=scene.outputs[:1], values=scene.values).t
    if scene.reference == "cvodes":
        if casadi is None:
            raise ValueError(f"scene {name}: reference 'cvodes' needs a CasADi model: "
                             f"{casadi_note}")
        rtol = plan.ref_rtol / 10
        ref = casadi.run(grid, plugin="cvodes", rtol=rtol, atol=rtol * scene.atol_scale,
                         outputs=scene.outputs)
        note = f"CasADi cvodes (BDF) at rtol {rtol:.0e}"
    else:
        rtol = plan.ref_rtol
        ref = scipy_run(model, grid, method="DOP853", rtol=rtol, atol=rtol * scene.atol_scale,
                        values=scene.values)
        note = f"scipy DOP853 at rtol {rtol:.0e} (loomfmu.verification.reference)"
    return Case(name, scene, model, fmu, stop, interval, grid, ref, note, casadi, casadi_note)


def point(case: Case, study: str, family: str, method: str, run: Run | None, *,
          rtol=math.nan, h=math.nan, param="", value=math.nan, status="ok", note="") -> dict:
    """One CSV row."""
    if run is not None:
        e_final, e_max = errors(run, case.ref, case.scene.outputs)
        seconds, n_rhs = run.seconds, run.n_rhs
    else:
        e_final = e_max = seconds = math.nan
        n_rhs = None
    return {"model": case.name, "study": study, "family": family, "method": method,
            "rtol": rtol, "h": h, "param": param, "value": value, "seconds": seconds,
            "err_final": e_final, "err_max": e_max,
            "n_rhs": "" if n_rhs is None else n_rhs, "status": status, "note": note}


def _sweep(case, family, method, settings, run_one, key, plan) -> list[dict]:
    rows = []
    for s in settings:
        try:
            run = timed(lambda: run_one(s), plan.repeats)
        except Exception as exc:  # a failed run is a result here
            rows.append(point(case, "wp", family, method, None, status="failed",
                              note=str(exc).splitlines()[0][:120], **{key: s}))
            if family != "fmu" or method != "rk4":
                break
            continue
        rows.append(point(case, "wp", family, method, run, **{key: s}))
        if run.seconds > plan.cap:
            break
    return rows


def methods(case: Case) -> list[tuple[str, str]]:
    """Every (family, method) swept on ``case``, in the charts' order: the unit
    of work of a parallel run, since one method's sweep is sequential (it
    stops at its first run slower than the cap)."""
    found = [("fmu", s) for s in FMU_ADAPTIVE] + [("fmu", "rk4")]
    found += [("scipy", m) for m in SCIPY_METHODS]
    if case.casadi is not None:
        found += [("casadi", p) for p in case.casadi.plugins]
    return found


def method_sweep(case: Case, plan: Plan, family: str, method: str) -> list[dict]:
    """One method's work-precision points on ``case``, loose to tight."""
    sc = case.scene
    if family == "fmu" and method == "rk4":
        steps = [case.model.h_fixed * f for f in plan.rk4_factors]
        return _sweep(case, "fmu", "rk4", steps, lambda h: case.fmu.run(
            solver="rk4", rtol=1e-6, atol=1e-9, stop=case.stop, interval=case.interval,
            outputs=sc.outputs, values={**sc.values, "solver_h_fixed": h}), "h", plan)
    if family == "fmu":
        return _sweep(case, "fmu", method, plan.fmu_rtols, lambda r: case.fmu.run(
            solver=method, rtol=r, atol=r * sc.atol_scale, stop=case.stop,
            interval=case.interval, outputs=sc.outputs, values=sc.values), "rtol", plan)
    if family == "scipy":
        return _sweep(case, "scipy", method, plan.scipy_rtols, lambda r: scipy_run(
            case.model, case.grid, method=method, rtol=r, atol=r * sc.atol_scale,
            values=sc.values), "rtol", plan)
    if family == "casadi" and case.casadi is not None:
        return _sweep(case, "casadi", method, plan.casadi_rtols, lambda r: case.casadi.run(
            case.grid, plugin=method, rtol=r, atol=r * sc.atol_scale,
            outputs=sc.outputs), "rtol", plan)
    raise ValueError(f"family, method = {family!r}, {method!r}; allowed: {methods(case)}")


def work_precision(case: Case, plan: Plan, only=None) -> list[dict]:
    """Every method's work-precision points on ``case`` (``only``: the
    (family, method) pairs to sweep; None: all of :func:`methods`)."""
    rows = []
    for family, method in methods(case):
        if only is None or (family, method) in only:
            rows += method_sweep(case, plan, family, method)
    return rows
