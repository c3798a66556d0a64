"""``loomfmu bench limit``: each model's verification run at C level, against
the limit of its method, with FMPy's time of the same run beside it.

    loomfmu bench limit [--models heald_frame drive ...] [--solvers dopri5 rodas4]
        [--repeats 5] [--best-of 5] [--fmpy-repeats 5]
        [--out docs/results/limit.json] [--page docs/guides/limit.md]

For every model (:data:`loomfmu.registry.MODELS`) the FMU is built, its own
``sources/`` and ``limit_driver.c`` (next to this file) are compiled with gcc
into one program, which runs the model's verification experiment (the
FMU's default experiment: stop time, communication step; rtol 1e-6, atol
1e-9, as :func:`loomfmu.verification.verify.verify`) through the FMI 2.0 functions without
Python and reads the solver's counters from the instance.  The limit
(:func:`limit_seconds`) is the fewest evaluations the method needs for the
steps it took: accepted steps x new stages per step x the best time of one
right-hand side (+ one Jacobian per step for rodas4; + one history sample
per step for a model that keeps a delay history).  Definitions and the
table: docs/guides/limit.md (written by the command).
"""
from __future__ import annotations

import json
import os
import statistics
import subprocess
import tempfile
import time
import zipfile
from importlib import metadata
from pathlib import Path

from loomfmu.declare.checks import check_int, check_name_list
from loomfmu.declare.solvers import SOLVERS
from loomfmu.fmu.builder import GENERATED_FLAGS, STRICT_FLAGS, build_fmu, fmi_headers_dir
from loomfmu.fmu.platforms import HOST
from loomfmu.registry import MODELS, load_model

DRIVER = Path(__file__).with_name("limit_driver.c")

#: per method: (new right-hand-side evaluations per accepted step, Jacobians
#: per accepted step) of the method itself: dopri5 has 7 stages of which the
#: first is the previous step's last (FSAL); rodas4 evaluates f(t, x) and 5
#: more stages and a fresh Jacobian at each step; rk4 has 4 stages;
#: ros34pw2 (a W-method) 4, its first f(t, x) the previous step's last, and
#: reuses its Jacobian over steps (None: the Jacobians the run evaluated).
STAGES = {"dopri5": (6, 0), "rodas4": (6, 1), "rk4": (4, 0), "ros34pw2": (4, None)}
#: the verification run's tolerances (loomfmu.verification.verify.verify's defaults)
RTOL, ATOL = 1e-6, 1e-9


def compile_driver(fmu: Path, work: Path, cc: str = "gcc") -> Path:
    """The FMU's ``sources/`` plus the driver, compiled (our code with the
    builder's strict flags, CasADi's with its own) into ``work/limit_driver``."""
    if not DRIVER.is_file():
        raise RuntimeError(f"{DRIVER} is missing: this installation does not ship the C "
                           "driver (package data loomfmu/bench/*.c)")
    src = work / "sources"
    with zipfile.ZipFile(fmu) as z:
        for name in z.namelist():
            if name.startswith("sources/") and not name.endswith("/"):
                z.extract(name, work)
    include = ["-I", str(src), "-I", str(fmi_headers_dir())]
    objs = []
    for c_file in sorted(src.glob("*.c")) + [DRIVER]:
        flags = GENERATED_FLAGS if c_file.name.endswith("_casadi.c") else STRICT_FLAGS
        obj = work / f"{c_file.stem}.o"
        _gcc([cc, *flags, *include, "-c", str(c_file), "-o", str(obj)])
        objs.append(str(obj))
    exe = work / "limit_driver"
    _gcc([cc, "-o", str(exe), *objs, "-lm"])
    return exe


def _gcc(cmd: list[str]) -> None:
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"gcc failed ({proc.returncode}): {' '.join(cmd)}\n"
                           f"{proc.stderr[-3000:]}")


def run_driver(exe: Path, *, stop: float, step: float, solver: str, rtol: float = RTOL,
               atol: float = ATOL, repeats: int = 5, best_of: int = 5,
               values: dict | None = None) -> dict:
    """One driver run: the counters, the median CPU/wall seconds of ``repeats``
    runs, the best seconds per right-hand side / Jacobian call, the outputs
    at the end.  values: start values of Real variables by name."""
    cmd = [str(exe), repr(stop), repr(step), repr(rtol), repr(atol), solver, str(repeats),
           str(best_of), *(f"{k}={float(v)!r}" for k, v in (values or {}).items())]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}): "
                           f"{proc.stderr[-2000:]}")
    return json.loads(proc.stdout)


def limit_seconds(c: dict) -> float | None:
    """The limit of the run ``c`` (a driver result): accepted steps x
    (new stages x best RHS seconds + Jacobians per step x best Jacobian
    seconds + best seconds of one history sample); None for a method
    without a STAGES entry.

    A model with a delay keeps a history of its delayed expressions g; each
    accepted step must add at least the sample at its end (g and dg/dt
    there: the unknowns w and the generated history function), whatever the
    method: ``hist_s``, reported by the driver for a model whose history is
    kept (0 or absent: no history).  The right-hand side's own time already
    holds the delayed values' lookup (every generated function but the
    history's reads them at t - tau)."""
    if c["solver"] not in STAGES:
        return None
    stages, jacs = STAGES[c["solver"]]
    jac_calls = c["jac"] if jacs is None else jacs * c["steps"]
    return c["steps"] * (stages * c["rhs_s"] + c.get("hist_s", 0.0)) + jac_calls * c["jac_s"]


def fmpy_run(path: Path, md, *, stop: float, step: float, solver: str, rtol: float = RTOL,
             atol: float = ATOL, repeats: int = 5) -> dict:
    """``fmpy.simulate_fmu`` of the same experiment on the unzipped FMU (its
    model description parsed once): median wall and CPU seconds, and the
    outputs at the end."""
    import fmpy
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    wall, cpu, res = [], [], None
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        res = fmpy.simulate_fmu(str(path), model_description=md, validate=False,
                                stop_time=stop, output_interval=step,
                                relative_tolerance=rtol, output=outputs,
                                start_values={"solver": SOLVERS.index(solver) + 1,
                                              "solver_atol": atol})
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return {"wall_s": statistics.median(wall), "cpu_s": statistics.median(cpu),
            "y_end": {n: float(res[n][-1]) for n in outputs}, "points": len(res)}


def measure_model(name: str, solvers, work: Path, *, repeats: int, best_of: int,
                  fmpy_repeats: int) -> list[dict]:
    """Every solver's row for model ``name`` (built and compiled in ``work``)."""
    import fmpy
    model = load_model(name)
    work.mkdir(parents=True, exist_ok=True)
    fmu = build_fmu(model, out_dir=work, validate=False, platforms=HOST,
                    reference_results=False).path
    exe = compile_driver(fmu, work)
    unzipped = work / "unzipped"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unzipped)
    md = fmpy.read_model_description(str(unzipped), validate=False)
    rows = []
    for solver in solvers:
        c = run_driver(exe, stop=model.stop_time, step=model.step_size, solver=solver,
                       repeats=repeats, best_of=best_of)
        f = fmpy_run(unzipped, md, stop=model.stop_time, step=model.step_size,
                     solver=solver, repeats=fmpy_repeats)
        rows.append(row(c, f))
    return rows


def row(c: dict, f: dict | None) -> dict:
    """A table row from a driver result ``c`` and an FMPy result ``f``."""
    lim = limit_seconds(c)
    n_comm = round(c["stop"] / c["step"])
    r = {**c, "limit_s": lim, "ratio": c["cpu_s"] / lim if lim else None,
         "comm_steps": n_comm, "realtime_x": c["stop"] / c["cpu_s"],
         # where the run's CPU time goes, from the counters and the per-call times
         "rhs_share": c["rhs"] * c["rhs_s"] / c["cpu_s"],
         "jac_share": c["jac"] * c["jac_s"] / c["cpu_s"],
         "out_share": n_comm * c["out_s"] / c["cpu_s"]}
    if f is not None:
        r["fmpy"] = f
        r["fmpy_ratio"] = f["cpu_s"] / c["cpu_s"]
        r["fmpy_per_step_us"] = (f["cpu_s"] - c["cpu_s"]) / n_comm * 1e6
    return r


def limit(models=None, solvers=SOLVERS, *, repeats: int = 5, best_of: int = 5,
          fmpy_repeats: int = 5, work_dir: Path | None = None, on_model=None) -> dict:
    """The C-level benchmark for ``models`` (names in the registry; default:
    all) and ``solvers``: {"rows": [...], "wall_seconds"}.

    repeats: driver runs per row, the median kept (1 ... 64); best_of:
    timing batches of one RHS/Jacobian call, the best kept (1 ... 64);
    fmpy_repeats: FMPy runs per row, the median kept (0: no FMPy column;
    at most 64).  on_model: called with each model's name and rows."""
    models = list(MODELS) if models is None else models
    models = check_name_list("models", models, list(MODELS), what="models")
    solvers = check_name_list("solvers", solvers, list(SOLVERS), what="solvers")
    if not models or not solvers:
        raise ValueError("models, solvers: allowed: non-empty lists")
    repeats = check_int("repeats", repeats, lo=1, hi=64)
    best_of = check_int("best_of", best_of, lo=1, hi=64)
    fmpy_repeats = check_int("fmpy_repeats", fmpy_repeats, lo=0, hi=64)
    t0 = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(work_dir) if work_dir is not None else Path(tmp)
        for name in models:
            got = measure_model(name, solvers, base / name, repeats=repeats, best_of=best_of,
                                fmpy_repeats=fmpy_repeats) if fmpy_repeats else \
                _measure_c_only(name, solvers, base / name, repeats, best_of)
            rows += got
            if on_model:
                on_model(name, got)
    return {"rows": rows, "wall_seconds": time.perf_counter() - t0, "repeats": repeats,
            "best_of": best_of, "fmpy_repeats": fmpy_repeats, "cpus": os.cpu_count(),
            "version": _version()}


def _version() -> str:
    """The loomfmu version measured (figures say the version, not a commit)."""
    from importlib import metadata
    return metadata.version("loomfmu")


def _measure_c_only(name, solvers, work: Path, repeats, best_of) -> list[dict]:
    model = load_model(name)
    work.mkdir(parents=True, exist_ok=True)
    exe = compile_driver(build_fmu(model, out_dir=work, validate=False, platforms=HOST,
                    reference_results=False).path, work)
    return [row(run_driver(exe, stop=model.stop_time, step=model.step_size, solver=s,
                           repeats=repeats, best_of=best_of), None) for s in solvers]



DEFINITION = """\
**What is measured.** Each model's verification run (its default experiment:
stop time and communication step; rtol 1e-6, atol 1e-9; the same settings as
`loomfmu build`'s verification and `fmpy.simulate_fmu`) is driven through the
FMU's FMI 2.0 functions by a C program (`src/loomfmu/bench/limit_driver.c`)
compiled with gcc together with the FMU's own `sources/` (the builder's
flags, -O2), without Python: instantiate, set up, step at the communication
step reading the outputs after each step, as FMPy does. The program's final
outputs equal FMPy's bit for bit (`tests/test_bench_limit.py`).

* **C run**: CPU time of the run (instantiate to the last `fmi2DoStep`),
  median of the repeats.
* **steps, rej., RHS, Jac, LU, events**: the solver's counters read from the
  instance after the run (`LfSolver.n_steps`, `n_rejected`, `n_rhs`, `n_jac`,
  `n_lu`; `LfInstance.n_events`). RHS counts the solver's calls of the
  right-hand side only (not the outputs, event indicators or event location).
* **RHS µs, Jac µs**: CPU time of one call of the right-hand side the solver
  integrates (`lf_ode_of(c).rhs`: the generated `wsol`, or for implicit
  models the torn form, `tpre`, Newton on the torn unknowns with `tres` and
  `tpost`, here converging in one iteration from the solution; models whose
  loop is not torn, `res` with Newton on the exact dF/dw, from a predictor
  inside a step, `lf_newton_mem.h`) and of its Jacobian (`.jac`), at the run's
  last accepted point, in a tight loop: the best of the batches. For a model
  with delays the right-hand side includes the lookup of the delayed values
  in the history (at t − τ, cubic Hermite), which every call needs.
* **hist µs** (models that keep a delay history, the drive): CPU time of one
  history sample (`lf_hist_sample`: the unknowns w and the generated history
  function, g and dg/dt of the delayed expressions) at the same point, timed
  the same way.
* **limit** = accepted steps × (new stages per step × RHS µs + Jacobians per
  step × Jac µs + hist µs), with dopri5: 6 stages (7, the first reused from
  the previous step: FSAL), 0 Jacobians; rodas4: 6 (f(t, x) and 5 stages), 1
  Jacobian; rk4: 4, 0; ros34pw2 (Rosenbrock-W, Jacobian reused over steps): 4
  (FSAL), and the Jacobians the run evaluated. The history term (models with
  a delay τ > 0; the driver reports no hist µs for the others): the history
  must gain at least the sample at each accepted step's end (value and slope,
  for the Hermite the stages read), whatever the method; where the delayed
  expression is costly (the drive's cam series of 96 harmonics) this sample,
  not the right-hand side, is most of the work a step needs. Samples inside
  a step (where the history's estimated error asks for them) are above the
  limit. The accepted steps are the run's own (the fewest the method took
  at this tolerance with this communication grid); rejected steps, restarts
  after events and input changes, the LU factorizations and solves, event
  location, outputs and the step loop are all above the limit.
* **ratio** = C run ÷ limit (the issue's target: ≤ 2).
* **× real time** = simulated time ÷ C run (above 1: faster than real time).
* **RHS, Jac, out share**: RHS × RHS µs ÷ C run, the part of the run spent
  in the right-hand side; Jac × Jac µs ÷ C run; communication steps × the
  time of one evaluation of the outputs (`lf_update_outputs`, which ends
  every `fmi2DoStep`: the unknowns w and the generated output function) ÷
  C run. The rest: the LU factorizations and solves, event indicators and
  event location, the step loop and the FMI calls.
* **FMPy**: CPU time of `fmpy.simulate_fmu` of the same run on the unzipped
  FMU, the model description parsed once (median); FMPy ÷ C: how many times
  the C run; the Python side's cost per communication step is
  (FMPy − C run) ÷ communication steps."""


def _f(v, fmt: str, scale: float = 1.0) -> str:
    return "–" if v is None else format(v * scale, fmt)


def _x(v: float) -> str:
    """A factor: 3 significant digits, whole numbers from 1000 on."""
    return f"{v:.0f}" if v >= 1000 else f"{v:.3g}"


def table_md(rows) -> str:
    head = ("| model | solver | nx | comm. steps | steps (rej.) | RHS | Jac | LU | events | "
            "RHS µs | Jac µs | hist µs | C run ms | limit ms | ratio | RHS / Jac / out share | "
            "× real time | FMPy ms | FMPy ÷ C |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
            "---|---|---|---|---|---|---|\n")
    lines = []
    for r in rows:
        f = r.get("fmpy")
        lines.append(
            f"| {r['model']} | {r['solver']} | {r['nx']} | {r['comm_steps']} | "
            f"{r['steps']} ({r['rejected']}) | {r['rhs']} | {r['jac']} | {r['lu']} | "
            f"{r['events']} | {r['rhs_s'] * 1e6:.3g} | {r['jac_s'] * 1e6:.3g} | "
            f"{_f(r.get('hist_s') or None, '.3g', 1e6)} | {r['cpu_s'] * 1e3:.3g} | "
            f"{_f(r['limit_s'], '.3g', 1e3)} | "
            f"{_f(r['ratio'], '.2f')} | {r['rhs_share'] * 100:.0f} / "
            f"{r['jac_share'] * 100:.0f} / {r['out_share'] * 100:.0f} % | "
            f"{_x(r['realtime_x'])} | "
            f"{_f(f and f['cpu_s'], '.3g', 1e3)} | {_f(r.get('fmpy_ratio'), '.1f')} |")
    return head + "\n".join(lines) + "\n"


def summary_md(rows) -> str:
    """Per model: the ratio to the limit of each solver, the fastest C run
    (its solver), its speed against real time and FMPy's time of that run."""
    solvers = list(dict.fromkeys(r["solver"] for r in rows))
    head = ("| model | " + " | ".join(f"ratio {s}" for s in solvers)
            + " | fastest C run ms (solver) | × real time | FMPy ms |\n|---|"
            + "---|" * (len(solvers) + 3) + "\n")
    lines = []
    for model in dict.fromkeys(r["model"] for r in rows):
        mine = {r["solver"]: r for r in rows if r["model"] == model}
        best = min(mine.values(), key=lambda r: r["cpu_s"])
        f = best.get("fmpy")
        lines.append(f"| {model} | " + " | ".join(
            _f(mine[s]["ratio"], ".2f") if s in mine else "–" for s in solvers)
            + f" | {best['cpu_s'] * 1e3:.3g} ({best['solver']}) | {_x(best['realtime_x'])} | "
            f"{_f(f and f['cpu_s'], '.3g', 1e3)} |")
    return head + "\n".join(lines) + "\n"


#: The page's text from this line on is kept when the page is written again
#: (notes measured by hand, e.g. instruction counts with callgrind)
NOTES_MARKER = "<!-- notes below this line are kept by loomfmu bench limit -->"


def page_md(result: dict, cmd: str) -> str:
    rows = result["rows"]
    over = [r for r in rows if r["ratio"] is not None and r["ratio"] > 2]
    lines = ["# The C-level benchmark: how far each run is from its limit", "",
             DEFINITION, "",
             f"**Table** (from `{cmd}`"
             + f" at loomfmu {metadata.version('loomfmu')}"
             + f", {result['wall_seconds'] / 60:.1f} min on this "
             f"machine, {result['cpus']} cores shared with other work: medians of "
             f"{result['repeats']} C runs and {result['fmpy_repeats']} FMPy runs, per-call "
             f"times the best of {result['best_of']} batches).", "",
             "Summary: C run ÷ limit per solver, and the fastest run:", "", summary_md(rows),
             "", "Every run:", "", table_md(rows),
             f"{len(rows) - len(over)} of {len(rows)} runs are within 2× of their limit.",
             "", f"Every number is in `docs/results/limit.json`. Regenerate: `{cmd}`.", ""]
    return "\n".join(lines)


def write(result: dict, json_path: Path | None, page: Path | None, cmd: str) -> None:
    """docs/results/limit.json and docs/guides/limit.md (either may be None: not written)."""
    if json_path is not None:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(json.dumps({"command": cmd, **result}, indent=1, default=str))
    if page is not None:
        page.parent.mkdir(parents=True, exist_ok=True)
        notes = ""
        if page.is_file():  # written notes below NOTES_MARKER stay (measured by hand)
            old = page.read_text()
            if NOTES_MARKER in old:
                notes = "\n" + old[old.index(NOTES_MARKER):]
        page.write_text(page_md(result, cmd) + notes)


# -- the speed table at C level ------------------------------------------------------
def speed_points(name: str, rows: list[dict], *, quick: bool, work: Path,
                 repeats: int = 3) -> list[dict]:
    """Our FMU's work-precision points of scene ``name`` (``rows``: the charts'
    CSV rows, family "fmu") timed again at C level: the same FMU, settings and
    communication grid driven by the C driver (median CPU seconds of
    ``repeats``).  The trajectory is the same (same code, same calls; the
    final outputs are compared with FMPy's, tests/test_bench_limit.py), so
    each point keeps the FMPy point's errors.  Family "fmu-c"."""
    from loomfmu.bench.scenes import BENCH, load_scene_model
    scene, model = BENCH[name], load_scene_model(name)
    mine = [r for r in rows if r["model"] == name and r["family"] == "fmu"
            and r["study"] == "wp" and r["status"] == "ok"]
    if model is None or not mine:
        return []
    work.mkdir(parents=True, exist_ok=True)
    exe = compile_driver(build_fmu(model, out_dir=work, validate=False, platforms=HOST,
                    reference_results=False).path, work)
    stop = (scene.quick_stop if quick and scene.quick_stop else scene.stop) or model.stop_time
    step = scene.interval or model.step_size
    out = []
    for r in mine:
        values = dict(scene.values)
        if r["method"] == "rk4":
            values["solver_h_fixed"] = r["h"]
            rtol, atol = 1e-6, 1e-9
        else:
            rtol = r["rtol"]
            atol = rtol * scene.atol_scale
        c = run_driver(exe, stop=stop, step=step, solver=r["method"], rtol=rtol, atol=atol,
                       repeats=repeats, best_of=1, values=values)
        out.append({**r, "family": "fmu-c", "seconds": c["cpu_s"], "n_rhs": c["rhs"],
                    "note": f"C driver; {c['steps']} steps, {c['rejected']} rejected"})
    return out
