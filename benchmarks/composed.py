"""A scene composed into one FMU against the same scene co-simulated: the
work and precision of every way to run the shipped scenes.

    .venv/bin/python benchmarks/composed.py [--scenes two_mass loom spinning]
        [--quick] [--out docs/results/composed] [--fmu-dir DIR] [--repeats 3]
        [--no-build-times] [--charts-only]

For each scene (two_mass over 2 s, loom over 5 s, spinning over 1 s: its
spindle takes explicit steps of about 5 us, and a second of it costs
seconds; the whole script takes about 9 min on two busy cores):

* reference: the composed FMU (loomfmu.scene.monolithic) at rtol 1e-10,
  atol 1e-13 (rodas4; dopri5 for spinning, where rodas4 costs 5 times more),
  recorded every quarter of the scene's step; its convergence is checked
  against the same solver and the other one at rtol 1e-9;
* monolithic: the composed FMU at dopri5, rodas4, ros34pw2, rtol 1e-4, 1e-6,
  1e-8 (atol = rtol x 1e-3, as loomfmu bench), and rk4 at the composed
  model's fixed step, recorded at the scene's step;
* co-simulation: our master (Jacobi, Gauss-Seidel) with input extrapolation
  of order 0, 1, 2 at communication steps H = 10, 4, 1 and 1/4 times the
  scene's step, and the adaptive step (extrapolation 2, rtol 1e-3 and 1e-5;
  not on spinning, whose outputs oscillate far faster than its adaptive
  steps are long), components at their own solver settings; and libcosim's
  fixed-step master on the exported SSP at the same steps (it holds its
  inputs: order 0; skipped without libcosimpy).

Every run's cost is its CPU seconds (time.process_time around the run, the
FMUs built before: the median of --repeats for runs under a second) per
simulated second.  Its error is the largest, over the scene's recorded
outputs, of max |x - x_ref| / (range of x_ref over the run) at the run's
own communication points (all of them points of the reference's grid; the
adaptive runs' points are not, and the reference is interpolated onto them
by a cubic spline); an output that varies by less than SCALE_FLOOR of its
magnitude is measured against that fraction of its magnitude.  Outputs that
jump (SWITCHING: the loom's friction moments) are also left out in a second
error.  A run that raises or records a value that is not finite is
"failed", with its message.

Also measured: the build (gcc, LOOMFMU_BUILD_CACHE=off, wall and CPU
seconds with the compilers) of the composed FMU against the component FMUs;
the loom's CPU split at 1 ms output interval (the run through FMPy against
the same run by the C driver of ``loomfmu bench limit``, the FMU's own work,
and in that the method's evaluations); the composed loom's real-time factor.

Writes <out>/points.json (every run), <out>/summary.md and
<out>/<scene>_wp.png (work-precision chart); --charts-only redraws the last
two from points.json.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from importlib import metadata
from pathlib import Path

import numpy as np

from loomfmu.scene.fmus import build_fmus
from loomfmu.scene.monolithic import composed_fmu, run_monolithic
from loomfmu.scene.run import run

#: scene -> (stop time of the full run, of --quick) in s
STOPS = {"two_mass": (2.0, 0.5), "loom": (5.0, 0.5), "spinning": (1.0, 0.1)}
SOLVERS = ("dopri5", "rodas4", "ros34pw2")
RTOLS = (1e-4, 1e-6, 1e-8)
#: communication steps as multiples of the scene's step
FACTORS = (10.0, 4.0, 1.0, 0.25)
QUICK_FACTORS = (4.0, 1.0)
MASTERS = ("jacobi", "gauss-seidel")
ORDERS = (0, 1, 2)
#: adaptive co-simulation: (extrapolation, rtol); atol 1e-6, first step the scene's
ADAPTIVE = ((2, 1e-3), (2, 1e-5))
NO_ADAPTIVE = ("spinning",)
#: the reference's solver per scene (rtol 1e-10, atol 1e-13); its checks: the
#: same solver and the other one at rtol 1e-9 (rodas4 at 1e-10 costs the spinning
#: scene 50 CPU s per simulated s, dopri5 11)
REFERENCE = {"two_mass": "rodas4", "loom": "rodas4", "spinning": "dopri5"}
REF_RTOL, CHECK_RTOL = 1e-10, 1e-9
#: an output that varies by less than this fraction of its largest magnitude
#: over the run is measured against that fraction of its magnitude instead of
#: its range (the spindle's orbit radius and bearing forces are constant to
#: 1e-10 while the drive's speed is: its range is rounding)
SCALE_FLOOR = 1e-3
#: outputs that jump (the backrest's friction moments switch sign when a pivot
#: reverses): a run whose switch is a step late is wrong by the jump there,
#: so the scene's error is also given without them ("error_smooth")
SWITCHING = {"loom": ("back.M1f_out", "back.M2f_out")}
#: the error a headline run must reach; the targets of the summary's table
TARGET = 1e-4
TARGETS = (1e-2, 1e-3, 1e-4)
#: runs cheaper than this (CPU s) are repeated --repeats times (median)
REPEAT_BELOW = 1.0


def make_scene(name: str, stop: float):
    """The shipped scene ``name`` with stop time ``stop``."""
    if name == "loom":
        from loomfmu.machines.loom import scene
    elif name == "spinning":
        from loomfmu.machines.spinning import scene
    else:
        from loomfmu.machines.two_mass import scene
    return scene(stop_time=stop)


def timed(fn, repeats: int):
    """(result, median CPU s) of fn(); repeated while each run is cheap."""
    cpu, res = [], None
    for _ in range(repeats):
        c0 = time.process_time()
        res = fn()
        cpu.append(time.process_time() - c0)
        if cpu[-1] > REPEAT_BELOW:
            break
    return res, statistics.median(cpu)


def error(res, ref, names) -> dict:
    """The run's error against the reference (see the module's doc): the
    largest scaled error, its output, every output's and how it was taken."""
    t, t_ref = np.asarray(res["time"]), np.asarray(ref["time"])
    h = t_ref[1] - t_ref[0]
    idx = np.rint(t / h).astype(int)
    on_grid = bool(idx.max() < len(t_ref) and np.allclose(t_ref[idx], t, rtol=0,
                                                          atol=1e-9 * max(1.0, t[-1])))
    per = {}
    for n in names:
        x_ref = np.asarray(ref[n])
        scale = max(float(np.ptp(x_ref)), SCALE_FLOOR * float(np.abs(x_ref).max())) or 1.0
        if on_grid:
            r = x_ref[idx]
        else:
            from scipy.interpolate import CubicSpline
            r = CubicSpline(t_ref, x_ref)(t)
        x = np.asarray(res[n])
        per[n] = float(np.abs(x - r).max() / scale) if np.all(np.isfinite(x)) else math.inf
    worst = max(per, key=per.get)
    return {"error": per[worst], "worst_output": worst, "errors": per,
            "compared_at": "run's points" if on_grid else "run's points, reference by "
                           "cubic spline"}


def attempt(fn, repeats: int) -> dict:
    """Run fn() (a Result) timed; status, message, warnings."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            res, cpu = timed(fn, repeats)
        except Exception as e:  # noqa: BLE001 (a failing run is a result)
            return {"status": "failed", "message": f"{type(e).__name__}: {e}"[:600],
                    "result": None, "cpu_s": None,
                    "warnings": sorted({str(w.message)[:300] for w in caught})}
    return {"status": "ok", "message": "", "result": res, "cpu_s": cpu,
            "warnings": sorted({str(w.message)[:300] for w in caught})}


def record(point: dict, out: dict, ref, names, stop: float) -> dict:
    """point (the run's settings) with its outcome ``out`` and error."""
    res = out.pop("result")
    point.update(out, sim_s=stop)
    if res is not None:
        point["cpu_per_sim_s"] = point["cpu_s"] / stop
        point["comm_steps"] = int(res.accepted)
        point["rejected"] = int(res.rejected)
        point.update(error(res, ref, names))
        if not math.isfinite(point["error"]):
            point["status"] = "failed"
            point["message"] = f"{point['worst_output']} is not finite"
        log = [line for lines in res.log.values() for line in lines]
        if log:
            point["log"] = log[:5]
    return point


def reference(name, scene, path, stop: float, step: float, names) -> tuple:
    """The reference run and its convergence checks."""
    solver, rtol = REFERENCE[name], REF_RTOL
    ref, cpu = timed(lambda: run_monolithic(scene, step=step, stop=stop, solver=solver,
                                            rtol=rtol, atol=rtol * 1e-3, fmu=path), 1)
    checks = []
    other = "dopri5" if solver == "rodas4" else "rodas4"
    for s, r in ((solver, CHECK_RTOL), (other, CHECK_RTOL)):
        other = run_monolithic(scene, step=step, stop=stop, solver=s, rtol=r, atol=r * 1e-3,
                               fmu=path)
        e = error(other, ref, names)
        checks.append({"solver": s, "rtol": r, "error": e["error"],
                       "worst_output": e["worst_output"]})
        print(f"  reference check: {s} rtol {r:g} differs by {e['error']:.2e} "
              f"({e['worst_output']})", flush=True)
    return ref, {"solver": solver, "rtol": rtol, "atol": rtol * 1e-3, "step": step,
                 "cpu_s": cpu, "checks": checks}


def monolithic_points(name, scene, path, model, ref, names, stop, repeats, quick):
    rtols = RTOLS[::2] if quick else RTOLS
    plan = [(s, r) for s in SOLVERS for r in rtols] + [("rk4", None)]
    points = []
    for solver, rtol in plan:
        r = 1e-6 if rtol is None else rtol
        out = attempt(lambda: run_monolithic(scene, step=scene.step, stop=stop,
                                             solver=solver, rtol=r, atol=r * 1e-3,
                                             fmu=path), repeats)
        p = record({"scene": name, "kind": "monolithic", "method": solver, "rtol": rtol,
                    "atol": None if rtol is None else r * 1e-3, "step": scene.step,
                    "h_fixed": model.h_fixed if rtol is None else None}, out, ref, names,
                    stop)
        show(p)
        points.append(p)
    return points


def cosim_points(name, scene, fmus, ref, names, stop, repeats, quick):
    factors = QUICK_FACTORS if quick else FACTORS
    points = []
    for master in MASTERS:
        for order in ORDERS:
            for f in factors:
                h = scene.step * f
                out = attempt(lambda: run(scene, master=master, step=h, stop=stop, fmus=fmus,
                                          extrapolation=order), repeats)
                p = record({"scene": name, "kind": "cosim", "method": master,
                            "extrapolation": order, "step": h, "adaptive": False}, out, ref,
                           names, stop)
                show(p)
                points.append(p)
        if name in NO_ADAPTIVE or quick:
            continue
        for order, rtol in ADAPTIVE:
            out = attempt(lambda: run(scene, master=master, step=scene.step, stop=stop,
                                      fmus=fmus, extrapolation=order, adaptive=True,
                                      rtol=rtol, atol=1e-6), repeats)
            p = record({"scene": name, "kind": "cosim", "method": master,
                        "extrapolation": order, "step": scene.step, "adaptive": True,
                        "rtol": rtol, "atol": 1e-6}, out, ref, names, stop)
            show(p)
            points.append(p)
    return points


def libcosim_points(name, scene, fmus, ref, names, stop, repeats, quick, fmu_dir):
    """libcosim's fixed-step master on the exported SSP (it holds its inputs:
    extrapolation order 0), at the co-simulation's steps."""
    try:
        import libcosimpy  # noqa: F401
    except ImportError:
        print("  libcosim: libcosimpy is not installed (pip install libcosimpy); skipped",
              flush=True)
        return []
    from loomfmu.scene.libcosim import run_ssp
    from loomfmu.scene.run import Result
    from loomfmu.scene.ssp import export_ssp
    ssp = export_ssp(scene, Path(fmu_dir) / f"{name}.ssp", fmus=fmus)
    refs = scene.recorded_variables()
    points = []
    for f in (QUICK_FACTORS if quick else FACTORS):
        h = scene.step * f

        def go(h=h):
            data = run_ssp(ssp, refs, step=h, stop=stop)
            return Result(data, "libcosim", len(data), 0, np.full(len(data), h))
        out = attempt(go, repeats)
        p = record({"scene": name, "kind": "cosim", "method": "libcosim", "extrapolation": 0,
                    "step": h, "adaptive": False}, out, ref, names, stop)
        show(p)
        points.append(p)
    return points


def label(p: dict) -> str:
    if p["kind"] == "monolithic":
        tol = f"rtol {p['rtol']:g}" if p["rtol"] is not None else f"h {p['h_fixed']:g} s"
        return f"composed {p['method']} {tol}"
    how = (f"adaptive rtol {p['rtol']:g}" if p.get("adaptive") else
           f"H {p['step'] * 1e3:g} ms")
    return f"{p['method']} order {p['extrapolation']} {how}"


def show(p: dict) -> None:
    if p["status"] == "ok":
        print(f"  {label(p):44s} {p['cpu_per_sim_s']:9.4f} CPU s/s  error {p['error']:.2e}"
              f" ({p['worst_output']})", flush=True)
    else:
        print(f"  {label(p):44s} failed: {p['message'][:150]}", flush=True)


def build_times(scene) -> dict:
    """Wall and CPU seconds (with the compilers' child processes) of the
    composed FMU's build and of the component FMUs', with the object cache
    off."""
    def clock():
        t = os.times()
        return time.perf_counter(), t.user + t.system + t.children_user + t.children_system

    old = os.environ.get("LOOMFMU_BUILD_CACHE")
    os.environ["LOOMFMU_BUILD_CACHE"] = "off"
    try:
        with tempfile.TemporaryDirectory() as a, tempfile.TemporaryDirectory() as b:
            w0, c0 = clock()
            composed_fmu(scene, a)
            w1, c1 = clock()
            fmus = build_fmus(scene, b)
            w2, c2 = clock()
    finally:
        if old is None:
            del os.environ["LOOMFMU_BUILD_CACHE"]
        else:
            os.environ["LOOMFMU_BUILD_CACHE"] = old
    return {"composed_wall_s": w1 - w0, "composed_cpu_s": c1 - c0,
            "components_wall_s": w2 - w1, "components_cpu_s": c2 - c1,
            "component_fmus": len(set(fmus.values())), "components": len(fmus)}


#: the C driver's Newton counters (-DLF_NEWTON_STATS, lf_newton.c)
NEWTON_STATS = re.compile(r"newton_stats: solves (\d+) hits (\d+) full (\d+) full_it (\d+)")


def loom_split(scene, path, stop: float, solver: str, rtol: float, repeats: int) -> dict:
    """The composed loom at 1 ms output interval, where the CPU time goes:
    run_monolithic (FMPy's instance, its ctypes functions called directly,
    every recorded output read after each step), FMPy's own simulate_fmu
    on the same extracted FMU, and the same run by the C driver of loomfmu
    bench limit (the FMU's own work), in that the right-hand sides and the
    outputs at their best time per call, and the Newton counters of the
    torn loop; the real-time factors."""
    import fmpy

    from loomfmu.bench import limit as L
    from loomfmu.declare.solvers import SOLVERS as EMBEDDED
    step = 1e-3
    atol = rtol * 1e-3
    n = round(stop / step)
    walls = []

    def once(stop=stop):
        w0 = time.perf_counter()
        r = run_monolithic(scene, step=step, stop=stop, solver=solver, rtol=rtol, atol=atol,
                           fmu=path)
        walls.append(time.perf_counter() - w0)
        return r

    _, ours_cpu = timed(once, repeats)
    ours_wall = statistics.median(walls)
    _, fixed_cpu = timed(lambda: once(10 * step), repeats)   # 10 steps: the fixed part
    names = [f"{c}.{v}" for c, v in scene.recorded_variables()]
    md = fmpy.read_model_description(str(path))
    unzipdir = fmpy.extract(str(path))
    try:
        _, fmpy_cpu = timed(lambda: fmpy.simulate_fmu(
            unzipdir, model_description=md, stop_time=stop, output_interval=step,
            relative_tolerance=rtol, output=names,
            start_values={"solver": EMBEDDED.index(solver) + 1, "solver_rtol": rtol,
                          "solver_atol": atol}), repeats)
    finally:
        shutil.rmtree(unzipdir, ignore_errors=True)
    with tempfile.TemporaryDirectory() as work:
        exe = L.compile_driver(Path(path), Path(work))
        c = L.run_driver(exe, stop=stop, step=step, solver=solver, rtol=rtol, atol=atol,
                         repeats=repeats, best_of=5)
        stats_dir = Path(work) / "stats"
        stats_dir.mkdir()
        flags = L.STRICT_FLAGS
        try:
            L.STRICT_FLAGS = (*flags, "-DLF_NEWTON_STATS")
            exe_stats = L.compile_driver(Path(path), stats_dir)
        finally:
            L.STRICT_FLAGS = flags
        proc = subprocess.run([str(exe_stats), repr(stop), repr(step), repr(rtol), repr(atol),
                               solver, "1", "1"], capture_output=True, text=True, check=True)
    m = NEWTON_STATS.search(proc.stderr)
    newton = dict(zip(("solves", "hits", "newton_solves", "newton_iterations"),
                      map(int, m.groups()))) if m else {}
    rhs_s, out_s = c["rhs"] * c["rhs_s"], n * c["out_s"]
    return {"solver": solver, "rtol": rtol, "atol": atol, "step": step, "stop": stop,
            "doSteps": n, "ours_cpu_s": ours_cpu, "ours_wall_s": ours_wall,
            "ours_fixed_cpu_s": fixed_cpu, "fmpy_simulate_cpu_s": fmpy_cpu,
            "c_cpu_s": c["cpu_s"], "c_wall_s": c["wall_s"],
            "evaluations_s": L.limit_seconds(c), "rhs_total_s": rhs_s, "outputs_total_s": out_s,
            "solver_steps": c["steps"], "rhs_calls": c["rhs"], "events": c["events"],
            "newton": newton,
            "python_per_doStep_us": (ours_cpu - fixed_cpu - c["cpu_s"]) / n * 1e6,
            "fmpy_simulate_per_doStep_us": (fmpy_cpu - c["cpu_s"]) / n * 1e6,
            "real_time_factor_cpu": stop / ours_cpu, "real_time_factor_wall": stop / ours_wall,
            "real_time_factor_fmpy_simulate": stop / fmpy_cpu,
            "real_time_factor_c": stop / c["cpu_s"]}


def err(p: dict, key: str) -> float:
    """The run's error: "error" over every recorded output, "error_smooth"
    over those of SWITCHING left out."""
    if key == "error":
        return p["error"]
    skip = SWITCHING.get(p["scene"], ())
    return max(v for n, v in p["errors"].items() if n not in skip)


def chart(name: str, points: list, ref_info: dict, stop: float, path: Path) -> None:
    """CPU s per simulated s against error, log-log: the composed FMU's
    solvers as lines over rtol, each master and extrapolation order as
    markers joined over H (labels: H in ms), failed runs numbered in a band
    at the right and listed beside the chart.  A scene with switching
    outputs gets a second panel without them."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    keys = keys_of(name)
    fig, axes = plt.subplots(len(keys), 1, figsize=(11.5, 5.6 * len(keys) + 0.6),
                             squeeze=False)
    axes = axes[:, 0]
    for ax, key in zip(axes, keys):
        panel(ax, points, key)
        ax.set_xlabel(f"error over {what(name, key)}: max |x - x_ref| / range of x_ref",
                      fontsize=10)
        ax.set_ylabel("CPU s per simulated s", fontsize=10)
    fails = [p for p in points if p["status"] != "ok"]
    if fails:
        text = "failed runs (the band at the right):\n" + "\n".join(
            f"{i + 1}: {label(p)}{where(p)}" for i, p in enumerate(fails))
        axes[-1].text(1.02, 0.0, text, transform=axes[-1].transAxes, fontsize=8.5,
                      va="bottom", ha="left")
    fig.suptitle(f"{name}, {stop:g} s: composed FMU (lines, labels: rtol) against "
                 "co-simulation (markers, labels: H in ms)\nreference: the composed FMU at "
                 f"{ref_info['solver']}, rtol {ref_info['rtol']:g}; lower left is better",
                 fontsize=11)
    axes[0].legend(fontsize=8.5, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def where(p: dict) -> str:
    """", t = ... s" from a failed run's message, if it says when."""
    import re
    m = re.search(r"at t = ([0-9.eE+-]+) s", p.get("message", ""))
    return f" (t = {float(m.group(1)):g} s)" if m else ""


def panel(ax, points: list, key: str) -> None:
    """One work-precision panel of the chart, errors by ``key`` (see err)."""
    ok = [p for p in points if p["status"] == "ok"]
    errs = [max(err(p, key), 1e-16) for p in ok]
    fails = [p for p in points if p["status"] != "ok"]
    fail_x = max(max(errs) * 10, 10.0)
    right = fail_x * 3 if fails else max(errs) * 3
    colours = {"dopri5": "C0", "rodas4": "C1", "ros34pw2": "C2", "rk4": "C7"}
    for solver, colour in colours.items():
        good = sorted((p for p in ok if p["kind"] == "monolithic" and p["method"] == solver),
                      key=lambda p: p["rtol"] or 0, reverse=True)
        if not good:
            continue
        xy = [(max(err(p, key), 1e-16), p["cpu_per_sim_s"]) for p in good]
        ax.plot(*zip(*xy), "-o", color=colour, lw=2, ms=6,
                label=f"composed FMU, {solver}" + (" (its fixed step)" if solver == "rk4"
                                                   else " (rtol 1e-4, 1e-6, 1e-8)"))
        for p, (x, y) in zip(good, xy):
            if p["rtol"] is not None:
                ax.annotate(f"{p['rtol']:.0e}", (x, y), fontsize=8, color=colour,
                            textcoords="offset points", xytext=(5, -12))
    style = {"jacobi": ("C3", "--"), "gauss-seidel": ("C4", ":"), "libcosim": ("k", "-.")}
    marks = {0: "s", 1: "^", 2: "D"}
    for master, (colour, ls) in style.items():
        for order, mk in marks.items():
            good = sorted((p for p in ok if p["kind"] == "cosim" and p["method"] == master
                           and p["extrapolation"] == order and not p["adaptive"]),
                          key=lambda p: -p["step"])
            if not good:
                continue
            xy = [(max(err(p, key), 1e-16), p["cpu_per_sim_s"]) for p in good]
            ax.plot(*zip(*xy), ls=ls, marker=mk, color=colour,
                    mfc="none" if order == 0 else colour, lw=1, ms=7,
                    label=f"co-sim {master}, extrapolation {order}")
            for p, (x, y) in zip(good, xy):
                ax.annotate(f"{p['step'] * 1e3:g}", (x, y), fontsize=8, color=colour,
                            textcoords="offset points", xytext=(5, 3))
        ad = [p for p in ok if p["kind"] == "cosim" and p["method"] == master
              and p["adaptive"]]
        for i, p in enumerate(ad):
            x, y = max(err(p, key), 1e-16), p["cpu_per_sim_s"]
            ax.plot(x, y, "*", color=colour, ms=13,
                    label=f"co-sim {master}, adaptive (extrapolation 2)" if i == 0 else None)
            ax.annotate(f"rtol {p['rtol']:g}", (x, y), fontsize=8, color=colour,
                        textcoords="offset points", xytext=(6, -11))
    ys = [p["cpu_per_sim_s"] for p in ok]
    for i in range(len(fails)):
        y = min(ys) * (max(ys) / min(ys)) ** ((i + 0.5) / max(len(fails), 4))
        ax.plot(fail_x, y, "x", color="k", ms=8)
        ax.annotate(str(i + 1), (fail_x, y), fontsize=8.5, textcoords="offset points",
                    xytext=(6, -3))
    ax.axvline(TARGET, color="grey", lw=0.8, ls="-.")
    ax.set(xscale="log", yscale="log", xlim=(min(errs) / 3, right))
    if fails:
        ax.axvspan(fail_x / 2.5, right, color="0.9", zorder=0)
        ax.text(fail_x, 0.98, "failed", transform=ax.get_xaxis_transform(), ha="center",
                va="top", fontsize=9)
    ax.text(TARGET, 0.02, f" error {TARGET:g}", transform=ax.get_xaxis_transform(),
            fontsize=8, color="grey", rotation=90, va="bottom")
    ax.grid(True, which="major", color="0.85", lw=0.6)


def cheapest(points, kind: str, target: float = TARGET, key: str = "error"):
    ok = [p for p in points if p["kind"] == kind and p["status"] == "ok"
          and err(p, key) <= target]
    return min(ok, key=lambda p: p["cpu_per_sim_s"]) if ok else None


def keys_of(name: str) -> list[str]:
    return ["error"] + (["error_smooth"] if name in SWITCHING else [])


def what(name: str, key: str) -> str:
    return ("every recorded output" if key == "error" else
            "the recorded outputs except " + ", ".join(SWITCHING[name]))


def cheapest_rows(doc: dict) -> list[dict]:
    """Per scene, error definition and target: the cheapest composed and
    co-simulation runs within the target."""
    rows = []
    for name, s in doc["scenes"].items():
        for key in keys_of(name):
            for target in TARGETS:
                m = cheapest(s["points"], "monolithic", target, key)
                c = cheapest(s["points"], "cosim", target, key)
                rows.append({"scene": name, "key": key, "target": target, "composed": m,
                             "cosim": c, "ratio": c["cpu_per_sim_s"] / m["cpu_per_sim_s"]
                             if m and c else None})
    return rows


def summary(doc: dict) -> str:
    lines = [f"# Composed FMU against co-simulation (loomfmu {doc['version']})", "",
             f"`{doc['command']}`: {doc['wall_min']:.1f} min wall, {doc['cpu_min']:.1f} min "
             "CPU (builds included). Error: max over the outputs of max |x - x_ref| / "
             "range of x_ref (see benchmarks/composed.py); cost: CPU s per simulated s.", "",
             "| scene | outputs | error at most | cheapest composed run | CPU s/s | cheapest "
             "co-simulation | CPU s/s | co-sim / composed |", "|" + "---|" * 8]
    for r in cheapest_rows(doc):
        cells = [r["scene"], what(r["scene"], r["key"]), f"{r['target']:g}"]
        for p in (r["composed"], r["cosim"]):
            cells += ([f"{label(p)} ({err(p, r['key']):.1e})", f"{p['cpu_per_sim_s']:.3g}"]
                      if p else ["none", "-"])
        cells.append(f"{r['ratio']:.2f}" if r["ratio"] else "-")
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "| scene | simulated | reference (composed FMU) | every | CPU s | differs "
              "from |", "|---|---|---|---|---|---|"]
    for name, s in doc["scenes"].items():
        ref = s["reference"]
        checks = "; ".join(f"{c['solver']} rtol {c['rtol']:g}: {c['error']:.1e}"
                           for c in ref["checks"])
        lines.append(f"| {name} | {s['stop']:g} s | {ref['solver']} rtol {ref['rtol']:g}, "
                     f"atol {ref['atol']:g} | {ref['step'] * 1e3:g} ms | {ref['cpu_s']:.1f} | "
                     f"{checks} |")
    lines += ["", "Builds (gcc, object cache off; CPU with the compilers):", "",
              "| scene | composed FMU: wall s | CPU s | component FMUs (distinct / "
              "components) | wall s | CPU s |", "|---|---|---|---|---|---|"]
    for name, s in doc["scenes"].items():
        b = s.get("build")
        if b:
            lines.append(f"| {name} | {b['composed_wall_s']:.1f} | {b['composed_cpu_s']:.1f} | "
                         f"{b['component_fmus']} / {b['components']} | "
                         f"{b['components_wall_s']:.1f} | {b['components_cpu_s']:.1f} |")
    split = doc.get("loom_split")
    if split:
        lines += ["", loom_split_text(split)]
    for name, s in doc["scenes"].items():
        smooth = name in SWITCHING
        lines += ["", f"## {name}", "", "| run | CPU s / simulated s | error | worst output | "
                  + ("error without switching outputs | " if smooth else "") + "status |",
                  "|" + "---|" * (6 if smooth else 5)]
        for p in s["points"]:
            if p["status"] == "ok":
                cells = [label(p), f"{p['cpu_per_sim_s']:.4g}", f"{p['error']:.2e}",
                         p["worst_output"]]
                cells += [f"{err(p, 'error_smooth'):.2e}"] if smooth else []
                cells.append("ok" + (" (warned: " + p["warnings"][0][:90] + "...)"
                                     if p["warnings"] else ""))
            else:
                msg = p["message"].replace("|", "/").replace("\n", " ")[:240]
                cells = [label(p), "-", "-", "-"] + (["-"] if smooth else []) + [
                    f"failed: {msg}"]
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def loom_split_text(split: dict) -> str:
    nw = split.get("newton") or {}
    newton = (f" Newton on the torn loop: {nw['newton_solves']} solves, "
              f"{nw['newton_iterations'] / nw['newton_solves']:.2f} iterations each "
              f"({nw['hits']} more answered by the solve cache)."
              if nw.get("newton_solves") else "")
    return (f"Loom, composed FMU at {split['step'] * 1e3:g} ms output interval over "
            f"{split['stop']:g} s ({split['solver']}, rtol {split['rtol']:g}; "
            f"{split['solver_steps']} solver steps, {split['rhs_calls']} right-hand sides, "
            f"{split['events']} events): run_monolithic {split['ours_cpu_s']:.3f} CPU s "
            f"(real-time factor {split['real_time_factor_cpu']:.0f}; wall "
            f"{split['real_time_factor_wall']:.0f}), of which "
            f"{split['ours_fixed_cpu_s']:.3f} s once per run (reading and extracting the FMU, "
            f"instantiating), the FMU's own work {split['c_cpu_s']:.3f} s (the same run by the "
            f"C driver of loomfmu bench limit: real-time factor "
            f"{split['real_time_factor_c']:.0f}; right-hand sides "
            f"{split['rhs_total_s']:.3f} s, outputs {split['outputs_total_s']:.3f} s, the rest "
            "events, validity and step control), and Python "
            f"{split['python_per_doStep_us']:.1f} µs per doStep. FMPy's own simulate_fmu "
            f"on the extracted FMU: {split['fmpy_simulate_cpu_s']:.3f} CPU s (real-time factor "
            f"{split['real_time_factor_fmpy_simulate']:.0f}; "
            f"{split['fmpy_simulate_per_doStep_us']:.1f} µs per doStep besides the FMU's "
            f"work).{newton}")


def study(name: str, args, fmu_dir: Path) -> dict:
    stop = STOPS[name][1 if args.quick else 0]
    scene = make_scene(name, stop)
    names = [f"{c}.{v}" for c, v in scene.recorded_variables()]
    print(f"{name}: {stop:g} s, scene step {scene.step * 1e3:g} ms", flush=True)
    build = build_times(scene) if args.build_times else None
    if build:
        print(f"  build: composed {build['composed_wall_s']:.1f} s wall, components "
              f"{build['components_wall_s']:.1f} s wall", flush=True)
    path, model = composed_fmu(scene, fmu_dir)
    fmus = build_fmus(scene, fmu_dir)
    factors = QUICK_FACTORS if args.quick else FACTORS
    ref_step = scene.step * min(factors)
    ref, ref_info = reference(name, scene, path, stop, ref_step, names)
    points = monolithic_points(name, scene, path, model, ref, names, stop, args.repeats,
                               args.quick)
    points += cosim_points(name, scene, fmus, ref, names, stop, args.repeats, args.quick)
    points += libcosim_points(name, scene, fmus, ref, names, stop, args.repeats, args.quick,
                              fmu_dir)
    out = {"stop": stop, "scene_step": scene.step, "outputs": names, "reference": ref_info,
           "build": build, "points": points}
    chart(name, points, ref_info, stop, args.out / f"{name}_wp.png")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", choices=tuple(STOPS), default=list(STOPS))
    ap.add_argument("--quick", action="store_true",
                    help="short runs, fewer tolerances and steps (a smoke run)")
    ap.add_argument("--out", type=Path, default=Path("docs/results/composed"))
    ap.add_argument("--fmu-dir", type=Path, default=None,
                    help="folder the FMUs are built into and reused from (default: temporary)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-build-times", dest="build_times", action="store_false",
                    help="skip the build-time measurement (the slowest part)")
    ap.add_argument("--charts-only", action="store_true",
                    help="redraw the charts and summary.md from <out>/points.json")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.charts_only:
        doc = json.loads((args.out / "points.json").read_text())
        for name, s in doc["scenes"].items():
            chart(name, s["points"], s["reference"], s["stop"], args.out / f"{name}_wp.png")
        (args.out / "summary.md").write_text(summary(doc))
        headline(doc)
        return 0
    w0, c0 = time.perf_counter(), os.times()
    doc = {"version": metadata.version("loomfmu"),
           # (where the FMUs are kept, --fmu-dir, changes no result)
           "command": " ".join(["python benchmarks/composed.py"] + _without_fmu_dir(sys.argv[1:])),
           "scenes": {}}
    with tempfile.TemporaryDirectory() as tmp:
        fmu_dir = args.fmu_dir or Path(tmp)
        for name in args.scenes:
            doc["scenes"][name] = study(name, args, fmu_dir)
        if "loom" in args.scenes:
            s = doc["scenes"]["loom"]
            best = cheapest(s["points"], "monolithic") or min(
                (p for p in s["points"] if p["kind"] == "monolithic" and p["status"] == "ok"),
                key=lambda p: p["error"])
            scene = make_scene("loom", s["stop"])
            path, _ = composed_fmu(scene, fmu_dir)
            doc["loom_split"] = loom_split(scene, path, s["stop"], best["method"],
                                           best["rtol"] or 1e-6, args.repeats)
    c1 = os.times()
    doc["wall_min"] = (time.perf_counter() - w0) / 60
    doc["cpu_min"] = (c1.user + c1.system + c1.children_user + c1.children_system
                      - c0.user - c0.system - c0.children_user - c0.children_system) / 60
    (args.out / "points.json").write_text(json.dumps(doc, indent=1, default=float) + "\n")
    text = summary(doc)
    (args.out / "summary.md").write_text(text)
    print(text)
    headline(doc)
    return 0


def _without_fmu_dir(args: list[str]) -> list[str]:
    out, skip = [], False
    for a in args:
        if skip:
            skip = False
        elif a == "--fmu-dir":
            skip = True
        elif not a.startswith("--fmu-dir="):
            out.append(a)
    return out


def headline(doc: dict) -> None:
    for r in cheapest_rows(doc):
        if r["target"] != TARGET:
            continue
        text = [f"{r['scene']} ({what(r['scene'], r['key'])}): cheapest at error <= "
                f"{TARGET:g}"]
        for who, p in (("composed", r["composed"]), ("co-simulation", r["cosim"])):
            text.append(f"{who}: {label(p)}, {p['cpu_per_sim_s']:.3g} CPU s/s" if p else
                        f"{who}: none")
        if r["ratio"]:
            text.append(f"ratio {r['ratio']:.2f}")
        print("; ".join(text))
    split = doc.get("loom_split")
    if split:
        print(f"composed loom at 1 ms output interval: real-time factor "
              f"{split['real_time_factor_cpu']:.0f} (CPU, run_monolithic), "
              f"{split['real_time_factor_fmpy_simulate']:.0f} (FMPy's simulate_fmu), "
              f"{split['real_time_factor_c']:.0f} (the FMU alone, C driver)")


if __name__ == "__main__":
    sys.exit(main())
