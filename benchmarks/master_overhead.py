"""What is spent outside the FMU: FMPy's cost per doStep and per run, and
what our scene master adds per communication step beyond the FMUs' doStep.

    python benchmarks/master_overhead.py [--model heald_frame] [--no-fmpy] [--repeats 5]
        [--scene two_mass] [--masters jacobi gauss-seidel] [--extrapolation 0 2]
        [--fmus FILE.json | --fmu-dir DIR] [--out FILE.json]
    python benchmarks/master_overhead.py --reference record|compare FILE --fmu-dir DIR

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
   scene's length and a quarter of it, for each master and extrapolation
   order (``--extrapolation 0 2``).  Every FMI call is timed and counted at
   two levels: FMPy's ctypes functions (``FMU2Slave._functions``, wrapped as
   each FMU2Slave loads them: the FMU's C code and ctypes' argument
   conversion) and FMPy's Python methods (``FMU2Slave.getReal`` etc., which
   build ctypes arrays from lists and call the former).  The wrappers' own
   cost, measured on empty calls, is taken off.  Per communication step
   (slope between the two lengths): the whole run = fmi2DoStep (the FMUs'
   work) + the other FMI functions + FMPy's Python methods + the rest, the
   master's own Python.  A master that calls the ctypes functions directly
   has no FMPy method time.  ``--fmus FILE.json`` (component -> FMU path)
   runs two versions of the master on the same binaries, e.g. the old one
   with ``PYTHONPATH=<old checkout>/src``.  FMPy's cost per FMI call is
   measured on ``getReal`` of one variable (whose C side is a copy).  The
   functions where the master's time goes (cProfile, by own time) are
   printed.

3. Reference runs (``--reference``): 61 runs of the master (two_mass on
   every master with extrapolation 0-2, output derivatives and adaptive
   steps; spinning 0.2 s and loom 0.1 s; algebraic loops by Newton and by
   fixed point; the failing runs) recorded, or compared byte for byte with a
   record: results unchanged by a change of the master.
"""
from __future__ import annotations

import argparse
import cProfile
import json
import pstats
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
from loomfmu.machines.library import SCENES, load_scene
from loomfmu.scene.fmus import build_fmus
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


class _Timed:
    """A ctypes FMI function with a clock around it (keeps the attributes
    FMPy's ``_call`` reads: argtypes, restype, argnames)."""

    def __init__(self, timer: "CallTimer", name: str, fn):
        self._timer, self._name, self._fn = timer, name, fn
        self.argtypes, self.restype = fn.argtypes, fn.restype
        self.argnames = getattr(fn, "argnames", None)

    def __call__(self, *args):
        t = self._timer
        t0 = t.clock()
        try:
            return self._fn(*args)
        finally:
            dt = t.clock() - t0
            t.c_seconds[self._name] = t.c_seconds.get(self._name, 0.0) + dt
            t.c_calls[self._name] = t.c_calls.get(self._name, 0) + 1
            if t.depth:
                t.c_inside += dt
                t.c_inside_calls += 1


class CallTimer:
    """CPU seconds and calls of every FMI function at two levels: the ctypes
    functions of the FMU's binary (``c_seconds``, ``c_calls``: the C side and
    ctypes' argument conversion; FMPy's ``_functions``, wrapped as each
    FMU2Slave loads them), and FMPy's Python methods (``seconds``, ``calls``:
    FMU2Slave.getReal etc., which build ctypes arrays from lists and call
    the former).  A master that calls the ctypes functions directly shows
    C time without method time."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self.c_seconds: dict[str, float] = {}
        self.c_calls: dict[str, int] = {}
        self.c_inside = 0.0        # C seconds inside FMPy's methods
        self.c_inside_calls = 0
        self.depth = 0
        self.clock = time.process_time
        self._orig = {}

    def __enter__(self):
        for name in FMI_METHODS:
            orig = getattr(FMU2Slave, name, None)
            if orig is None:
                continue
            self._orig[name] = orig
            setattr(FMU2Slave, name, self._wrap(name, orig))
        load = FMU2Slave._loadFunctions
        self._orig["_loadFunctions"] = load
        timer = self

        def loaded(slave):
            load(slave)
            for name, fn in list(slave._functions.items()):
                slave._functions[name] = _Timed(timer, name, fn)
        FMU2Slave._loadFunctions = loaded
        return self

    def _wrap(self, name, orig):
        seconds, calls, clock = self.seconds, self.calls, time.process_time
        timer = self

        def wrapped(*args, **kw):
            timer.depth += 1
            t0 = clock()
            try:
                return orig(*args, **kw)
            finally:
                seconds[name] = seconds.get(name, 0.0) + clock() - t0
                calls[name] = calls.get(name, 0) + 1
                timer.depth -= 1
        return wrapped

    def __exit__(self, *exc):
        for name, orig in self._orig.items():
            setattr(FMU2Slave, name, orig)
        self._orig.clear()


def wrapper_cost(n: int = 200_000) -> dict:
    """What the CallTimer's two wrappers cost, in CPU seconds per call:
    ``method_w``, ``c_w``: added to the caller (taken off the run's time);
    ``method_b``, ``c_b``: inside the interval each one measures (taken off
    the measured time), both measured around an empty call."""
    class Dummy:
        def f(self):
            return None

    class Fn:
        argtypes, restype = [], None

        def __call__(self):
            return None
    timer = CallTimer()
    w = timer._wrap("f", Dummy.f)
    fn = Fn()
    c = _Timed(timer, "f", fn)
    d = Dummy()

    def per_call(call, bare):
        t0 = time.process_time()
        for _ in range(n):
            bare()
        b = time.process_time() - t0
        t0 = time.process_time()
        for _ in range(n):
            call()
        return max(0.0, (time.process_time() - t0 - b) / n)
    out = {"method_w": per_call(lambda: w(d), lambda: Dummy.f(d)), "c_w": per_call(c, fn)}
    out["method_b"] = timer.seconds["f"] / timer.calls["f"]
    out["c_b"] = timer.c_seconds["f"] / timer.c_calls["f"]
    return out


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


def master_cost(scene_name: str, master: str, fmus: dict, repeats: int,
                wrap_s: dict, **run_kw) -> dict:
    """Per communication step (slope between a quarter and the whole run):
    the run's CPU time split into fmi2DoStep (the C function: the FMUs'
    work), the other FMI functions (C), FMPy's Python methods around them,
    and the rest: the master's own Python."""
    scene = load_scene(scene_name)
    stops = (scene.stop_time / 4, scene.stop_time)
    per_stop = []
    for stop in stops:
        totals, timers = [], []
        for _ in range(repeats):
            with CallTimer() as timer:
                t0 = time.process_time()
                res = run_scene(scene, master=master, stop=stop, fmus=fmus, **run_kw)
                totals.append(time.process_time() - t0)
            timers.append(timer)
        k = int(np.argsort(totals)[len(totals) // 2])  # the median run's call times
        timer = timers[k]
        n_m, n_c = sum(timer.calls.values()), sum(timer.c_calls.values())
        cpu = totals[k] - n_m * wrap_s["method_w"] - n_c * wrap_s["c_w"]
        do_step = (timer.c_seconds.get("fmi2DoStep", 0.0)
                   - timer.c_calls.get("fmi2DoStep", 0) * wrap_s["c_b"])
        c_all = sum(timer.c_seconds.values()) - n_c * wrap_s["c_b"]
        fmpy_py = (sum(timer.seconds.values()) - n_m * wrap_s["method_b"] - timer.c_inside
                   - timer.c_inside_calls * (wrap_s["c_w"] - wrap_s["c_b"]))
        per_stop.append({"stop": stop, "steps": res.accepted + res.rejected, "cpu_s": cpu,
                         "do_step_s": do_step, "other_fmi_s": c_all - do_step,
                         "fmpy_python_s": fmpy_py,
                         "master_python_s": cpu - c_all - fmpy_py,
                         "c_calls": dict(timer.c_calls), "method_calls": dict(timer.calls)})
    a, b = per_stop
    dn = b["steps"] - a["steps"]

    def slope(key):
        return (b[key] - a[key]) / dn * 1e6

    calls_per_step = {m: (b["c_calls"].get(m, 0) - a["c_calls"].get(m, 0)) / dn
                      for m in b["c_calls"]}
    return {"scene": scene_name, "master": master, "options": run_kw, "runs": per_stop,
            "per_step_us": slope("cpu_s"),
            "do_step_per_step_us": slope("do_step_s"),
            "other_fmi_per_step_us": slope("other_fmi_s"),
            "fmpy_python_per_step_us": slope("fmpy_python_s"),
            "master_python_per_step_us": slope("master_python_s"),
            "fmi_calls_per_step": {m: round(v, 3) for m, v in calls_per_step.items() if v},
            "setup_ms": (a["cpu_s"] - slope("cpu_s") * 1e-6 * a["steps"]) * 1e3}


def profile_master(scene_name: str, master: str, fmus: dict, top: int = 12, **run_kw
                   ) -> list[str]:
    scene = load_scene(scene_name)
    prof = cProfile.Profile()
    prof.enable()
    run_scene(scene, master=master, fmus=fmus, **run_kw)
    prof.disable()
    stats = pstats.Stats(prof)
    rows = sorted(stats.stats.items(), key=lambda kv: kv[1][2], reverse=True)[:top]
    total = sum(v[2] for v in stats.stats.values())
    out = []
    for (file, line, fn), (_cc, nc, tt, _ct, _) in rows:
        out.append(f"{tt / total * 100:5.1f} %  {nc:8d} calls  {Path(file).name}:{line} {fn}")
    return out


def scene_fmus(scene, args, tmp: Path) -> dict:
    """--fmus FILE.json (component -> FMU path: the same binaries for runs
    of two versions of the master), or the scene's FMUs built into --fmu-dir
    (default a temporary folder)."""
    if args.fmus is not None:
        return {k: Path(v) for k, v in json.loads(args.fmus.read_text()).items()}
    return build_fmus(scene, args.fmu_dir if args.fmu_dir is not None else tmp / "scene")


# -- reference runs: results unchanged by a change of the master --------------------
class _LoopModels:
    """The small models of tests/test_scene_masters.py (copied: an older
    version of the master must be able to run them): an algebraic loop of
    gain 3 (linear or cubic), a square root that fails for u < 0, a model
    not valid after 0.37 s."""
    SRC = "assumption: a test model"

    @staticmethod
    def loop_a():
        from loomfmu.declare.model import Model
        m = Model("loop_a", description="test loop side a", stop_time=1.0, step_size=1e-2,
                  h_fixed=1e-3)
        g = m.parameter("g", 1.5, description="feedthrough gain", source=_LoopModels.SRC)
        u = m.input("u", 0.0, description="input")
        x = m.state("x", 1.0, description="state")
        m.eq(m.der(x), -x)
        m.output("y", x + g * u, description="output (feedthrough)")
        return m

    @staticmethod
    def loop_b(cubic: bool = False):
        from loomfmu.declare.model import Model
        m = Model("loop_b3" if cubic else "loop_b", description="test loop side b",
                  stop_time=1.0, step_size=1e-2, h_fixed=1e-3)
        k = m.parameter("k", 2.0, description="feedthrough gain", source=_LoopModels.SRC)
        c = m.parameter("c", 0.3, description="offset", source=_LoopModels.SRC)
        u = m.input("u", 0.0, description="input")
        z = m.state("z", 0.0, description="a state that does not move")
        m.eq(m.der(z), 0.0 * z)
        m.output("y", c - k * (u**3 if cubic else u) + z, description="output (feedthrough)")
        return m

    @staticmethod
    def loop_sqrt():
        import casadi as ca

        from loomfmu.declare.model import Model
        m = Model("loop_sqrt", description="test loop side b: a square root",
                  stop_time=1.0, step_size=1e-2, h_fixed=1e-3)
        u = m.input("u", 0.0, description="input")
        z = m.state("z", 0.0, description="a state that does not move")
        m.eq(m.der(z), 0.0 * z)
        m.output("y", ca.sqrt(u) - 5.0 + z, description="output (feedthrough)")
        return m

    @staticmethod
    def invalid_after():
        from loomfmu.declare.model import Model
        m = Model("invalid_after", description="test: not valid beyond t = T_INVALID",
                  stop_time=1.0, step_size=1e-2, h_fixed=1e-3)
        x = m.state("x", 0.37, description="time left")
        m.eq(m.der(x), -1.0 + 0.0 * x)
        m.require("x_left", x, "no time left: the test model is not valid here")
        m.output("y", x, description="time left")
        return m

    @staticmethod
    def loop_scene(fmus, *, cubic=False):
        from loomfmu.scene import Scene
        paths = {"a": fmus["a"], "b": fmus["b3" if cubic else "b"]}
        s = Scene("loop", stop_time=0.5, step=0.05)
        for name, path in paths.items():
            s.add(name, fmu=path)
        s.connect("a.y", "b.u")
        s.connect("b.y", "a.u")
        s.record("a.x", "a.u", "b.u", "a.y", "b.y")
        return s, paths


def fmus_of(scene, key, fmu_dir: Path):
    idx = fmu_dir / f"{key}.json"
    if idx.exists():
        return {k: Path(v) for k, v in json.loads(idx.read_text()).items()}
    f = build_fmus(scene, fmu_dir / key)
    idx.write_text(json.dumps({k: str(v) for k, v in f.items()}))
    return f


def cases(fmu_dir: Path):
    """(name, scene, run options): the reference runs (two_mass on every master,
    extrapolation 0-2, output derivatives, adaptive; spinning 0.2 s, loom 0.1 s;
    loops by Newton and fixed point; failing runs)."""
    from loomfmu.scene import Scene
    tm = load_scene("two_mass")
    f = fmus_of(tm, "two_mass", fmu_dir)
    for master in ("jacobi", "gauss-seidel"):
        for k in (0, 1, 2):
            yield f"tm-{master}-k{k}", tm, dict(master=master, extrapolation=k, fmus=f)
            yield f"tm-{master}-k{k}-ad", tm, dict(master=master, extrapolation=k, fmus=f,
                                                   adaptive=True, rtol=1e-2, atol=1e-4)
        yield f"tm-{master}-k0-ad-loose", tm, dict(master=master, fmus=f, adaptive=True,
                                                   rtol=0.1, atol=1e-4, stop=0.5)
        yield f"tm-{master}-k1-od", tm, dict(master=master, extrapolation=1, fmus=f,
                                             master_options={"output_derivatives": True})
        yield f"tm-{master}-k1-od-ad", tm, dict(master=master, extrapolation=1, fmus=f,
                                                adaptive=True, rtol=1e-3, atol=1e-4,
                                                master_options={"output_derivatives": True})
    for k in (0, 1, 2):
        yield f"tm-gs-dispfirst-k{k}", tm, dict(master="gauss-seidel", extrapolation=k,
                                                fmus=f,
                                                master_options={"order": ["disp", "force"]})
    yield "tm-jacobi-libcosim", tm, dict(master="jacobi", fmus=f,
                                         master_options={"resolve_feedthrough": False})
    yield "tm-jacobi-h6ms-k2", tm, dict(master="jacobi", fmus=f, step=6e-3, extrapolation=2)
    sp = load_scene("spinning")
    f = fmus_of(sp, "spinning", fmu_dir)
    for master in ("jacobi", "gauss-seidel"):
        yield f"spin-{master}", sp, dict(master=master, fmus=f, stop=0.2)
        yield f"spin-{master}-k1", sp, dict(master=master, fmus=f, stop=0.2, extrapolation=1)
    yield "spin-gs-k2-ad", sp, dict(master="gauss-seidel", fmus=f, stop=0.2, extrapolation=2,
                                    adaptive=True, rtol=1e-3)
    lo = load_scene("loom")
    f = fmus_of(lo, "loom", fmu_dir)
    for master in ("jacobi", "gauss-seidel"):
        yield f"loom-{master}", lo, dict(master=master, fmus=f, stop=0.1)
        yield f"loom-{master}-k2", lo, dict(master=master, fmus=f, stop=0.1, extrapolation=2)
        yield f"loom-{master}-k1-ad", lo, dict(master=master, fmus=f, stop=0.1,
                                               extrapolation=1, adaptive=True, rtol=1e-3)
    # loops, failures
    T = _LoopModels
    s = Scene("loops")
    s.add("a", model=T.loop_a())
    s.add("b", model=T.loop_b())
    s.add("b3", model=T.loop_b(cubic=True))
    s.add("bs", model=T.loop_sqrt())
    s.add("inv", model=T.invalid_after())
    lf = fmus_of(s, "loops", fmu_dir)
    for cubic in (False, True):
        ls, lp = T.loop_scene(lf, cubic=cubic)
        for master in ("jacobi", "gauss-seidel"):
            for k in (0, 1, 2):
                yield f"loop-{cubic}-{master}-k{k}", ls, dict(master=master, fmus=lp,
                                                              extrapolation=k)
            yield f"loop-{cubic}-{master}-ad", ls, dict(master=master, fmus=lp, adaptive=True,
                                                        rtol=1e-4, extrapolation=1)
            yield f"loop-{cubic}-{master}-fp", ls, dict(
                master=master, fmus=lp, loop_options={"loop_method": "fixed-point",
                                                      "relaxation": 0.25,
                                                      "loop_max_iter": 300})
    ls, lp = T.loop_scene(lf)
    yield "loop-diverge", ls, dict(fmus=lp, loop_options={"loop_method": "fixed-point",
                                                          "relaxation": 0.5,
                                                          "loop_max_iter": 30})
    paths = {"a": lf["a"], "b": lf["bs"]}
    sq = Scene("loop_sqrt", stop_time=0.1, step=0.01)
    for name, path in paths.items():
        sq.add(name, fmu=path)
    sq.connect("a.y", "b.u")
    sq.connect("b.y", "a.u")
    sq.record("a.y", "b.y")
    for method in ("newton", "fixed-point"):
        yield f"sqrt-{method}", sq, dict(fmus=paths, loop_options={"loop_method": method})
    iv = Scene("invalid", stop_time=1.0, step=0.1)
    iv.add("inv", fmu=lf["inv"])
    iv.record("inv.y")
    for master in ("jacobi", "gauss-seidel"):
        yield f"inv-{master}-ad", iv, dict(master=master, fmus={"inv": lf["inv"]},
                                           adaptive=True, h_min=1e-6)
        yield f"inv-{master}", iv, dict(master=master, fmus={"inv": lf["inv"]})


def one(scene, kw):
    from loomfmu.scene import run
    from loomfmu.scene.system import FMUError
    try:
        r = run(scene, **kw)
    except (FMUError, RuntimeError) as exc:
        return {"error": f"{type(exc).__name__}: {exc}"}
    return {"data": r.data, "h": r.h, "accepted": r.accepted, "rejected": r.rejected,
            "loop_iterations": r.loop_iterations, "notes": r.notes, "log": r.log}


def same(a, b):
    if set(a) != set(b):
        return f"keys {sorted(a)} != {sorted(b)}"
    for k in a:
        x, y = a[k], b[k]
        if isinstance(x, np.ndarray):
            if x.dtype != y.dtype or x.shape != y.shape:
                return f"{k}: shape/dtype"
            if x.dtype.names:
                for n in x.dtype.names:
                    if x[n].tobytes() != y[n].tobytes():
                        d = np.nanmax(np.abs(x[n] - y[n]))
                        return f"{k}[{n}] differs (max {d:.3g})"
            elif x.tobytes() != y.tobytes():
                return f"{k} differs"
        elif x != y:
            return f"{k}: {str(x)[:200]} != {str(y)[:200]}"
    return None


def reference(mode: str, path: Path, fmu_dir: Path, only: str = "") -> int:
    """Record (mode "record") the reference runs into ``path`` (pickle), or
    compare (mode "compare") them with it byte for byte: data, step sizes,
    counts, loop iterations, notes, logs and error messages.  The FMUs are
    built once into ``fmu_dir`` and listed there (<scene>.json), so two
    versions of the master run the same binaries (build them with the older
    version's code: e.g. PYTHONPATH=<old checkout>/src)."""
    import pickle
    fmu_dir.mkdir(parents=True, exist_ok=True)
    ref = pickle.loads(path.read_bytes()) if mode == "compare" else {}
    out, bad = {}, 0
    for name, scene, kw in cases(fmu_dir):
        if only and only not in name:
            continue
        t1 = time.perf_counter()
        out[name] = one(scene, kw)
        msg = ""
        if mode == "compare":
            diff = same(ref[name], out[name]) if name in ref else "not in the reference"
            bad += diff is not None
            msg = "identical" if diff is None else f"DIFFERS: {diff}"
        print(f"{name:34s} {time.perf_counter() - t1:6.2f} s {msg}", flush=True)
    if mode == "record":
        path.write_bytes(pickle.dumps(out))
    print(f"{len(out)} reference runs, {bad} differ")
    return 1 if bad else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", default="heald_frame", help="part 1: the model")
    ap.add_argument("--no-fmpy", action="store_true", help="skip part 1 (FMPy's own cost)")
    ap.add_argument("--scene", default="two_mass", choices=sorted(SCENES),
                    help="part 2: the scene")
    ap.add_argument("--masters", nargs="+", default=["jacobi", "gauss-seidel"],
                    choices=["jacobi", "gauss-seidel"])
    ap.add_argument("--extrapolation", nargs="+", type=int, default=[0], choices=[0, 1, 2],
                    help="part 2: the input extrapolation orders to measure")
    ap.add_argument("--fmus", type=Path, default=None,
                    help="part 2: JSON file component -> FMU path (skip the build)")
    ap.add_argument("--fmu-dir", type=Path, default=None, help="part 2: build the FMUs here")
    ap.add_argument("--repeats", type=int, default=5, help="runs per point, median (>= 1)")
    ap.add_argument("--out", type=Path, default=None, help="also write the numbers as JSON")
    ap.add_argument("--reference", nargs=2, metavar=("record|compare", "FILE"), default=None,
                    help="instead of timing: record the reference runs into FILE, or compare "
                         "them with FILE byte for byte (FMUs built once into --fmu-dir)")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error(f"--repeats {args.repeats}: allowed >= 1")
    if args.reference is not None:
        mode, path = args.reference
        if mode not in ("record", "compare") or args.fmu_dir is None:
            ap.error("--reference record|compare FILE needs --fmu-dir DIR")
        return reference(mode, Path(path), args.fmu_dir)
    t_start = time.perf_counter()
    out = {"command": "python benchmarks/master_overhead.py " + " ".join(argv or sys.argv[1:])}
    f = None
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if not args.no_fmpy:
            print(f"1. FMPy's own cost ({args.model}, verification run, dopri5):", flush=True)
            f = fmpy_cost(args.model, args.repeats, tmp / args.model)
            out["fmpy"] = f
            print(f"   Python side: {f['python_per_step_us']:.2f} µs per doStep + "
                  f"{f['python_setup_ms']:.2f} ms per run; the FMU's own work "
                  f"{f['fmu_per_step_us']:.2f} µs per doStep; Python's share of the full "
                  f"run {f['python_share_full_run'] * 100:.0f} %")
        scene = load_scene(args.scene)
        fmus = scene_fmus(scene, args, tmp)
        wrap_s = wrapper_cost()
        call_s = fmpy_call_cost(next(iter(fmus.values())))
        out["fmpy_call_us"] = call_s * 1e6
        out["wrapper_us"] = {k: v * 1e6 for k, v in wrap_s.items()}
        print(f"\n2. Our master on scene {args.scene} ({len(fmus)} FMUs, step "
              f"{scene.step:g} s): FMPy's cost of one FMI call (getReal of one variable) "
              f"{call_s * 1e6:.2f} µs; timing wrappers {wrap_s['method_w'] * 1e6:.2f} "
              f"(method), {wrap_s['c_w'] * 1e6:.2f} (ctypes function) µs per call, of "
              f"which {wrap_s['method_b'] * 1e6:.2f} and {wrap_s['c_b'] * 1e6:.2f} inside "
              "what they measure (all taken off)")
        out["masters"] = []
        for master in args.masters:
            for k in args.extrapolation:
                m = master_cost(args.scene, master, fmus, args.repeats, wrap_s,
                                extrapolation=k)
                m["profile"] = profile_master(args.scene, master, fmus, extrapolation=k)
                out["masters"].append(m)
                print(f"   {master}, extrapolation {k}: {m['per_step_us']:.1f} µs per "
                      f"communication step = fmi2DoStep {m['do_step_per_step_us']:.1f} + other "
                      f"FMI functions {m['other_fmi_per_step_us']:.1f} + FMPy's Python "
                      f"methods {m['fmpy_python_per_step_us']:.1f} + the master's Python "
                      f"{m['master_python_per_step_us']:.1f}; setup {m['setup_ms']:.1f} ms")
                print(f"     FMI calls per step: {m['fmi_calls_per_step']}")
                print("     own time by function (cProfile, one full run):")
                for line in m["profile"]:
                    print(f"       {line}")
        if f is not None:
            fmpy_per_fmu = f["python_per_step_us"]
            print(f"\n   FMPy's own Python cost per doStep ({args.model}): {fmpy_per_fmu:.2f} "
                  f"µs, x {len(fmus)} FMUs = {fmpy_per_fmu * len(fmus):.2f} µs per step")
    out["wall_seconds"] = time.perf_counter() - t_start
    print(f"master_overhead.py took {out['wall_seconds']:.0f} s")
    if args.out:
        args.out.write_text(json.dumps(out, indent=1))
        print(f"written: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
