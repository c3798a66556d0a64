"""The first two benchmarks: ``speed`` (heald frame, FMU vs scipy at equal
error) and ``friction`` (regularized vs event-driven backrest).

    loomfmu bench speed [--model heald_frame] [--repeats 5] [--out docs/results/speed.json]

``speed``: the FMU through FMPy against scipy's ``solve_ivp`` with a Python
right-hand side, compared at equal achieved accuracy.  Each method is run
over a sweep of tolerances; the achieved error is the largest error of any
output relative to its range, over FMPy's communication points, against a
reference solved at rtol = 1e-12.  Times are medians of ``repeats`` runs.
The CPU time of each method at a target error is interpolated log-log on its
work-precision curve, and the ratio scipy / FMU is reported.
"""
from __future__ import annotations

import json
import statistics
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
from fmpy import read_model_description

from loomfmu.fmu.builder import build_fmu
from loomfmu.fmu.platforms import HOST
from loomfmu.registry import load_model
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import compare, simulate

FMU_RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
SCIPY_RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9)


def _median_time(fn, repeats: int):
    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), result


def _worst(errs: dict) -> float:
    return max(e["max_rel_range"] for e in errs.values())


def time_at_error(points: list[tuple[float, float]], target: float) -> float | None:
    """Interpolate log(time) against log(error) at ``target`` error."""
    pts = sorted((e, t) for e, t in points if e > 0)
    for (e0, t0), (e1, t1) in zip(pts, pts[1:]):
        if e0 <= target <= e1:
            w = (np.log(target) - np.log(e0)) / (np.log(e1) - np.log(e0))
            return float(np.exp(np.log(t0) + w * (np.log(t1) - np.log(t0))))
    return None


def _scipy_time(model, grid, rtol, method, repeats):
    first = reference(model, t_end=grid[-1], t_eval=grid, rtol=rtol, atol=rtol * 1e-3,
                      method=method)
    if first.wall_seconds > 1.0:  # long runs: one is enough against the noise
        return first.wall_seconds, first
    more = [reference(model, t_end=grid[-1], t_eval=grid, rtol=rtol, atol=rtol * 1e-3,
                      method=method).wall_seconds for _ in range(repeats - 1)]
    return statistics.median([first.wall_seconds, *more]), first


def speed(model_name: str = "heald_frame", repeats: int = 5, scale: float = 1.0,
          targets=(1e-4, 1e-6, 1e-8)) -> dict:
    """Work-precision of the FMU and of scipy over ``scale`` x the model's
    default experiment; speed-up at each target error."""
    model = load_model(model_name)
    names = [v.name for v in model.of_kind("output")]
    stop = model.stop_time * scale
    curves: dict[str, list[dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_fmu(model, out_dir=tmp, validate=False, platforms=HOST,
                    reference_results=False).path
        unzipped = Path(tmp) / "unzipped"
        with zipfile.ZipFile(fmu) as z:
            z.extractall(unzipped)
        md = read_model_description(str(unzipped))
        grid = simulate(unzipped, output=["h"], stop_time=stop).t
        ref = reference(model, t_end=grid[-1], t_eval=grid, rtol=1e-12, atol=1e-14)
        for solver in ("dopri5", "rodas4"):
            for rtol in FMU_RTOLS:
                wall, run = _median_time(lambda: simulate(
                    unzipped, solver=solver, rtol=rtol, atol=rtol * 1e-3, output=names,
                    stop_time=stop, model_description=md), repeats)
                curves.setdefault(f"fmu_{solver}", []).append(
                    {"rtol": rtol, "seconds": wall, "error": _worst(compare(run, ref, names))})
    for method in ("RK45", "DOP853"):
        for rtol in SCIPY_RTOLS:
            wall, run = _scipy_time(model, grid, rtol, method, repeats)
            curves.setdefault(f"scipy_{method}", []).append(
                {"rtol": rtol, "seconds": wall, "error": _worst(compare(run, ref, names)),
                 "rhs_calls": run.n_rhs})
    table = []
    for target in targets:
        at = {k: time_at_error([(p["error"], p["seconds"]) for p in v], target)
              for k, v in curves.items()}
        fmu_times = [v for k, v in at.items() if k.startswith("fmu_") and v]
        best = min(fmu_times) if fmu_times else None
        table.append({"target_error": target, "seconds": at,
                      "speedup": {k: v / best for k, v in at.items()
                                  if k.startswith("scipy_") and v and best}})
    return {"model": model_name, "t_end": float(grid[-1]), "repeats": repeats,
            "error_measure": "max over outputs of max |y - y_ref| / range(y_ref), on "
                             "the communication grid; reference: scipy DOP853 rtol 1e-12",
            "fmu_timing": "fmpy.simulate_fmu on the extracted FMU with its model "
                          "description read once; median of repeats",
            "curves": curves, "at_target": table}


def friction(repeats: int = 3, eps_values=(1e-1, 1e-2, 1e-3, 1e-4, 1e-5),
             k_static_values=(1.3, 1.0)) -> dict:
    """Backrest: the regularized friction model (torque ~ tanh(speed / eps))
    against the event-driven one, error and cost as eps shrinks, with static
    friction above kinetic (k_static = 1.3, the default) and equal (1.0).

    Error: max over phi1, omega1, omega2, S2 of max |y - y_ref| / range(y_ref)
    on the 1 ms grid; y_ref: the event-driven model by scipy at rtol 1e-11.
    Each FMU runs with rtol 1e-8 (dopri5, rodas4) through FMPy; median wall time.
    """
    names = ["phi1_out", "omega1_out", "omega2_out", "S2"]
    event_model = load_model("backrest")
    rows, switches = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        ev_fmu = build_fmu(event_model, out_dir=tmp, validate=False, platforms=HOST,
                    reference_results=False).path
        reg_fmu = build_fmu(load_model("backrest", friction="regularized"), out_dir=tmp,
                            validate=False, platforms=HOST,
                    reference_results=False).path
        grid = simulate(ev_fmu, output=["phi1_out"]).t
        for k_static in k_static_values:
            ref = reference(event_model, t_end=grid[-1], t_eval=grid, rtol=1e-11,
                            atol=1e-13, values={"k_static": k_static})
            switches[k_static] = len(ref.switches)
            for solver in ("dopri5", "rodas4"):
                wall, run = _median_time(lambda: simulate(
                    ev_fmu, solver=solver, rtol=1e-8, atol=1e-11, output=names,
                    values={"k_static": k_static}), repeats)
                rows.append({"k_static": k_static, "model": "event-driven", "eps": None,
                             "solver": solver, "seconds": wall,
                             "error": _worst(compare(run, ref, names))})
                for eps in eps_values:
                    try:
                        wall, run = _median_time(lambda: simulate(
                            reg_fmu, solver=solver, rtol=1e-8, atol=1e-11, output=names,
                            values={"eps": eps, "k_static": k_static}), repeats)
                        err = _worst(compare(run, ref, names))
                    except Exception as exc:  # a failed run is a result here
                        wall, err = None, f"failed: {exc}"
                    rows.append({"k_static": k_static, "model": "regularized", "eps": eps,
                                 "solver": solver, "seconds": wall, "error": err})
    return {"scene": "backrest, 1 s, built-in shedding at 240 rpm",
            "error_measure": friction.__doc__.split("Error: ", 1)[1].split("\n\n")[0],
            "n_switches_reference": switches, "rows": rows}


def main_speed(args) -> int:
    results = [speed(args.model, args.repeats, scale) for scale in args.scales]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2))
    print(f"{'model':<14}{'t_end s':>9}{'error':>9}{'FMU ms':>10}{'RK45 ms':>10}"
          f"{'DOP853 ms':>11}{'vs RK45':>9}{'vs DOP853':>11}")
    for res in results:
        for row in res["at_target"]:
            sec, sp = row["seconds"], row["speedup"]
            fmu = min((v for k, v in sec.items() if k.startswith("fmu_") and v), default=None)

            def ms(v):
                return f"{v * 1e3:.1f}" if v else "-"

            def x(v):
                return f"{v:.0f}x" if v else "-"

            print(f"{res['model']:<14}{res['t_end']:>9.3f}{row['target_error']:>9.0e}"
                  f"{ms(fmu):>10}{ms(sec.get('scipy_RK45')):>10}{ms(sec.get('scipy_DOP853')):>11}"
                  f"{x(sp.get('scipy_RK45')):>9}{x(sp.get('scipy_DOP853')):>11}")
    print(f"written: {args.out}")
    return 0


def main_friction(args) -> int:
    res = friction(args.repeats)
    out = args.out
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=2))
    print(f"{res['scene']}; mode switches in the reference by k_static: "
          f"{res['n_switches_reference']}")
    print(f"{'k_static':>8}  {'model':<14}{'eps rad/s':>11}{'solver':>8}{'FMU ms':>10}"
          f"{'error':>12}")
    for r in res["rows"]:
        eps = "-" if r["eps"] is None else f"{r['eps']:.0e}"
        sec = "-" if r["seconds"] is None else f"{r['seconds'] * 1e3:.1f}"
        err = r["error"] if isinstance(r["error"], str) else f"{r['error']:.2e}"
        print(f"{r['k_static']:>8}  {r['model']:<14}{eps:>11}{r['solver']:>8}{sec:>10}"
              f"{err:>12}")
    print(f"written: {out}")
    return 0

