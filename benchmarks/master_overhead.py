"""What is spent outside the FMU: FMPy's cost per doStep and per run, and
what our scene master adds per communication step beyond the FMUs' doStep.

    python benchmarks/master_overhead.py [--model heald_frame] [--repeats 5]
        [--scene two_mass] [--masters jacobi gauss-seidel] [--out FILE.json]

1. FMPy.  The model's verification run (its default experiment, dopri5,
   rtol 1e-6) over fractions 1/8, 1/4, 1/2, 1 of its length, each run both
   by ``fmpy.simulate_fmu`` (unzipped FMU, model description parsed once)
   and by the C driver of ``loomfmu bench limit`` (the same FMI calls in C:
   the FMU's own work).  CPU seconds, medians of ``--repeats``.  A straight
   line through (communication steps, FMPy - C) gives FMPy's Python-side
   cost per doStep (slope) and per run (intercept: loading the binary,
   instantiation, set-up, the result array); one through (steps, C) the
   FMU's own work per doStep.

2. Our master.  The scene (default two_mass: two FMUs, force-displacement
   coupling) run by ``loomfmu.scene.run.run`` at its default step, over the
   scene's length and a quarter of it; every FMI call FMPy makes for it is
   timed and counted (the methods of fmpy.fmi2.FMU2Slave wrapped; the
   wrapper's own cost, measured on an empty wrapped call, is taken off).
   Per communication step (slope between the two lengths): the whole run,
   the time inside fmi2DoStep calls (the FMUs' work plus FMPy's call
   wrapping), inside the other FMI calls (values in and out), and the rest:
   the master's own Python.  FMPy's cost per FMI call is measured on
   ``getReal`` of one variable (whose C side is a copy).  The functions
   where the master's time goes (cProfile, by own time) are printed.
"""
from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import statistics
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import fmpy
import numpy as np
from fmpy.fmi2 import FMU2Slave

from loomfmu import build_fmu, load_model
from loomfmu.bench import limit as L
from loomfmu.scene.fmus import build_fmus
from loomfmu.scene.library import SCENES, load_scene
from loomfmu.scene.run import run as run_scene

FRACTIONS = (0.125, 0.25, 0.5, 1.0)
#: the FMPy methods a master calls (timed in part 2)
FMI_METHODS = ("doStep", "getReal", "setReal", "setRealInputDerivatives",
               "getRealOutputDerivatives", "getFMUState", "setFMUState", "freeFMUState",
               "getBooleanStatus", "setupExperiment", "enterInitializationMode",
               "exitInitializationMode", "instantiate", "terminate", "freeInstance")


def fit(n, y) -> tuple[float, float]:
    """(slope, intercept) of the least-squares line through (n, y)."""
    slope, intercept = np.polyfit(np.asarray(n, float), np.asarray(y, float), 1)
    return float(slope), float(intercept)


def fmpy_cost(model_name: str, repeats: int, work: Path) -> dict:
    model = load_model(model_name)
    fmu = build_fmu(model, out_dir=work, validate=False).path
    exe = L.compile_driver(fmu, work / "driver")
    unzipped = work / "unzipped"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unzipped)
    md = fmpy.read_model_description(str(unzipped), validate=False)
    rows = []
    for frac in FRACTIONS:
        n = round(frac * model.stop_time / model.step_size)
        stop = n * model.step_size
        c = L.run_driver(exe, stop=stop, step=model.step_size, solver="dopri5",
                         repeats=repeats, best_of=1)
        f = L.fmpy_run(unzipped, md, stop=stop, step=model.step_size, solver="dopri5",
                       repeats=repeats)
        rows.append({"comm_steps": n, "c_cpu_s": c["cpu_s"], "fmpy_cpu_s": f["cpu_s"],
                     "fmpy_wall_s": f["wall_s"]})
        print(f"  {model_name}: {n:6d} steps: C {c['cpu_s'] * 1e3:8.3f} ms, FMPy "
              f"{f['cpu_s'] * 1e3:8.3f} ms CPU", flush=True)
    n = [r["comm_steps"] for r in rows]
    py_step, py_setup = fit(n, [r["fmpy_cpu_s"] - r["c_cpu_s"] for r in rows])
    c_step, c_setup = fit(n, [r["c_cpu_s"] for r in rows])
    full = rows[-1]
    return {"model": model_name, "rows": rows, "python_per_step_us": py_step * 1e6,
            "python_setup_ms": py_setup * 1e3, "fmu_per_step_us": c_step * 1e6,
            "fmu_setup_ms": c_setup * 1e3,
            "python_share_full_run": 1 - full["c_cpu_s"] / full["fmpy_cpu_s"]}


class CallTimer:
    """Wraps FMU2Slave's methods: CPU seconds and calls per method."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self._orig = {}

    def __enter__(self):
        for name in FMI_METHODS:
            orig = getattr(FMU2Slave, name, None)
            if orig is None:
                continue
            self._orig[name] = orig
            setattr(FMU2Slave, name, self._wrap(name, orig))
        return self

    def _wrap(self, name, orig):
        seconds, calls, clock = self.seconds, self.calls, time.process_time

        def wrapped(*args, **kw):
            t0 = clock()
            try:
                return orig(*args, **kw)
            finally:
                seconds[name] = seconds.get(name, 0.0) + clock() - t0
                calls[name] = calls.get(name, 0) + 1
        return wrapped

    def __exit__(self, *exc):
        for name, orig in self._orig.items():
            setattr(FMU2Slave, name, orig)
        self._orig.clear()


def wrapper_cost(n: int = 200_000) -> float:
    """CPU seconds the CallTimer's wrapper adds to one call."""
    class Dummy:
        def f(self):
            return None
    timer = CallTimer()
    w = timer._wrap("f", Dummy.f)
    d = Dummy()
    t0 = time.process_time()
    for _ in range(n):
        Dummy.f(d)
    bare = time.process_time() - t0
    t0 = time.process_time()
    for _ in range(n):
        w(d)
    return max(0.0, (time.process_time() - t0 - bare) / n)


def fmpy_call_cost(fmu_path: Path, n: int = 20_000) -> float:
    """CPU seconds of one FMPy getReal([vr]) call (the C side copies a double)."""
    md = fmpy.read_model_description(str(fmu_path), validate=False)
    unzipped = fmpy.extract(str(fmu_path))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    vr = [md.modelVariables[0].valueReference]
    t0 = time.process_time()
    for _ in range(n):
        slave.getReal(vr)
    per = (time.process_time() - t0) / n
    slave.terminate()
    slave.freeInstance()
    return per


def master_cost(scene_name: str, master: str, fmus: dict, repeats: int, wrap_s: float
                ) -> dict:
    scene = load_scene(scene_name)
    stops = (scene.stop_time / 4, scene.stop_time)
    per_stop = []
    for stop in stops:
        totals, timers = [], []
        for _ in range(repeats):
            with CallTimer() as timer:
                t0 = time.process_time()
                res = run_scene(scene, master=master, stop=stop, fmus=fmus)
                totals.append(time.process_time() - t0)
            timers.append(timer)
        k = int(np.argsort(totals)[len(totals) // 2])  # the median run's call times
        timer = timers[k]
        calls = sum(timer.calls.values())
        fmi = sum(timer.seconds.values()) - calls * wrap_s
        do_step = timer.seconds.get("doStep", 0.0) - timer.calls.get("doStep", 0) * wrap_s
        per_stop.append({"stop": stop, "steps": res.accepted, "cpu_s": totals[k],
                         "fmi_s": fmi, "do_step_s": do_step, "calls": dict(timer.calls),
                         "seconds": dict(timer.seconds)})
    a, b = per_stop
    dn = b["steps"] - a["steps"]

    def slope(key):
        return (b[key] - a[key]) / dn

    calls_per_step = {m: (b["calls"].get(m, 0) - a["calls"].get(m, 0)) / dn
                      for m in b["calls"]}
    return {"scene": scene_name, "master": master, "runs": per_stop,
            "per_step_us": slope("cpu_s") * 1e6,
            "do_step_per_step_us": slope("do_step_s") * 1e6,
            "other_fmi_per_step_us": (slope("fmi_s") - slope("do_step_s")) * 1e6,
            "master_python_per_step_us": (slope("cpu_s") - slope("fmi_s")) * 1e6,
            "fmi_calls_per_step": {m: round(v, 3) for m, v in calls_per_step.items() if v},
            "setup_ms": (a["cpu_s"] - slope("cpu_s") * a["steps"]) * 1e3}


def profile_master(scene_name: str, master: str, fmus: dict, top: int = 12) -> list[str]:
    scene = load_scene(scene_name)
    prof = cProfile.Profile()
    prof.enable()
    run_scene(scene, master=master, fmus=fmus)
    prof.disable()
    stats = pstats.Stats(prof)
    rows = sorted(stats.stats.items(), key=lambda kv: kv[1][2], reverse=True)[:top]
    total = sum(v[2] for v in stats.stats.values())
    out = []
    for (file, line, fn), (cc, nc, tt, ct, _) in rows:
        out.append(f"{tt / total * 100:5.1f} %  {nc:8d} calls  {Path(file).name}:{line} {fn}")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", default="heald_frame", help="part 1: the model")
    ap.add_argument("--scene", default="two_mass", choices=sorted(SCENES),
                    help="part 2: the scene")
    ap.add_argument("--masters", nargs="+", default=["jacobi", "gauss-seidel"],
                    choices=["jacobi", "gauss-seidel"])
    ap.add_argument("--repeats", type=int, default=5, help="runs per point, median (>= 1)")
    ap.add_argument("--out", type=Path, default=None, help="also write the numbers as JSON")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error(f"--repeats {args.repeats}: allowed >= 1")
    t_start = time.perf_counter()
    out = {"command": "python benchmarks/master_overhead.py " + " ".join(argv or sys.argv[1:])}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        print(f"1. FMPy's own cost ({args.model}, verification run, dopri5):", flush=True)
        f = fmpy_cost(args.model, args.repeats, tmp / args.model)
        out["fmpy"] = f
        print(f"   Python side: {f['python_per_step_us']:.2f} µs per doStep + "
              f"{f['python_setup_ms']:.2f} ms per run; the FMU's own work "
              f"{f['fmu_per_step_us']:.2f} µs per doStep; Python's share of the full run "
              f"{f['python_share_full_run'] * 100:.0f} %")
        scene = load_scene(args.scene)
        fmus = build_fmus(scene, tmp / "scene")
        wrap_s = wrapper_cost()
        call_s = fmpy_call_cost(next(iter(fmus.values())))
        out["fmpy_call_us"], out["wrapper_us"] = call_s * 1e6, wrap_s * 1e6
        print(f"\n2. Our master on scene {args.scene} ({len(fmus)} FMUs, step "
              f"{scene.step:g} s): FMPy's cost of one FMI call (getReal of one variable) "
              f"{call_s * 1e6:.2f} µs; timing wrapper {wrap_s * 1e6:.2f} µs per call "
              "(taken off)")
        out["masters"] = []
        for master in args.masters:
            m = master_cost(args.scene, master, fmus, args.repeats, wrap_s)
            m["profile"] = profile_master(args.scene, master, fmus)
            out["masters"].append(m)
            print(f"   {master}: {m['per_step_us']:.1f} µs per communication step = "
                  f"doStep calls {m['do_step_per_step_us']:.1f} + other FMI calls "
                  f"{m['other_fmi_per_step_us']:.1f} + the master's Python "
                  f"{m['master_python_per_step_us']:.1f}; setup {m['setup_ms']:.1f} ms")
            print(f"     FMI calls per step: {m['fmi_calls_per_step']}")
            print("     own time by function (cProfile, one full run):")
            for line in m["profile"]:
                print(f"       {line}")
        fmpy_per_fmu = f["python_per_step_us"]
        print(f"\n   FMPy's own Python cost per doStep ({args.model}): {fmpy_per_fmu:.2f} µs, "
              f"x {len(fmus)} FMUs = {fmpy_per_fmu * len(fmus):.2f} µs per step")
    out["wall_seconds"] = time.perf_counter() - t_start
    print(f"master_overhead.py took {out['wall_seconds']:.0f} s")
    if args.out:
        args.out.write_text(json.dumps(out, indent=1))
        print(f"written: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
