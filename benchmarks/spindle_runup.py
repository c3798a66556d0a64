"""Run-up of the spindle through its first critical speed to 16 000 rpm:
the full FE FMU against the modal FMUs, and the real-time factor of each.

    python benchmarks/spindle_runup.py [--modes 1 2 3 4 5 6] [--solver rodas4]
        [--out docs/results/spindle_runup.json]

Scene: the spin speed (the FMU's input Omega, rad/s) ramps linearly from 0 to 16 000 rpm in ``RAMP`` seconds and is
held for ``HOLD`` seconds, set at every communication step (``DT``) as the
drive would; bobbin and whorl eccentricity 5 um each.  The error of a
reduced model is max_t |r_top,red - r_top,full| / max_t r_top,full (r_top:
radial displacement of the top of the blade).  Real-time factor: wall time /
simulated time (below 1: faster than real time), median of ``--repeats``.

    python benchmarks/spindle_runup.py --interp [--interp-steps 1 5 25 125]
        [--model spindle] [--out docs/results/spindle_runup_interp.json]

Input derivatives (FMI 2.0 fmi2SetRealInputDerivatives): the same ramp given
at each communication point by its value and slope, so that the FMU
integrates the ramp instead of a staircase, at communication steps
``DT`` x each of ``--interp-steps``; against the staircase at ``DT`` (the
scene above).  Oracle: the interpolated run at ``DT`` (the exact ramp to the
solver's tolerance); error: max over the common communication points of
|r_top - r_top,oracle| / max r_top,oracle.

    python benchmarks/spindle_runup.py --counters [--model spindle]
        [--solvers rodas4 ros34pw2] [--repeats 3]
        [--out docs/results/spindle_runup_counters.json]

The same scene at ``DT`` driven without Python: the FMU's own sources plus
benchmarks/spindle_runup_driver.c, compiled with gcc into one program that
calls the FMI 2.0 functions and reads the solver's counters (accepted and
rejected steps, RHS and Jacobian calls, factorizations) from the instance;
CPU time (median of ``--repeats``) / simulated time, with the staircase and
with input derivatives, and max r_top of each run.

Each mode reports its progress on stderr (loomfmu.progress), prints its table
and ``written: <path>`` for the JSON it writes: by default into this
repository's docs/ (wherever the script is run from), else ``--out``.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import tempfile
import time
import zipfile
from pathlib import Path

import fmpy
import numpy as np

from loomfmu import build_fmu, load_model
from loomfmu.declare.solvers import SOLVERS
from loomfmu.fmu.builder import fmi_headers_dir
from loomfmu.progress import Progress

RAMP, HOLD, DT, TOP_RPM, ECC = 1.0, 0.25, 2e-4, 16000.0, 5e-6
RAD_S_PER_RPM = 2 * np.pi / 60  # the FMU's input Omega is rad/s
ROOT = Path(__file__).resolve().parents[1]


def table(header: list[str], rows: list[list[str]], left: int = 1) -> str:
    """``rows`` of formatted cells under ``header``, each column as wide as
    its widest cell and two spaces apart; the first ``left`` columns
    left-aligned, the others right-aligned."""
    widths = [max(len(c) for c in col) for col in zip(header, *rows)]
    return "\n".join("  ".join(c.ljust(w) if i < left else c.rjust(w)
                               for i, (c, w) in enumerate(zip(line, widths))).rstrip()
                     for line in [header, *rows])


def write_json(path: Path, result: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=1))
    print(f"written: {path}")


def scene(t_end: float = RAMP + HOLD) -> np.ndarray:
    t = np.arange(0.0, t_end + DT / 2, DT)
    sig = np.zeros(len(t), dtype=[("time", float), ("Omega", float), ("e_b", float),
                                  ("e_w", float)])
    sig["time"], sig["Omega"] = t, TOP_RPM * RAD_S_PER_RPM * np.clip(t / RAMP, 0, 1)
    sig["e_b"], sig["e_w"] = ECC, ECC
    return sig


def run(fmu: Path, solver: str, rtol: float, repeats: int):
    sig = scene()
    md = fmpy.read_model_description(str(fmu))
    times, res = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = fmpy.simulate_fmu(str(fmu), model_description=md, stop_time=sig["time"][-1],
                                output_interval=DT, input=sig, relative_tolerance=rtol,
                                start_values={"solver": SOLVERS.index(solver) + 1,
                                              "solver_atol": 1e-12},
                                output=["r_top", "r_footstep"])
        times.append(time.perf_counter() - t0)
    return res, statistics.median(times)


def ramp_rpm(t: float) -> tuple[float, float]:
    """The spin speed (rpm) of the scene at t and its slope (the slope after the ramp: 0)."""
    if t < RAMP - 1e-12:
        return TOP_RPM * t / RAMP, TOP_RPM / RAMP
    return TOP_RPM, 0.0


def run_driven(fmu: Path, solver: str, rtol: float, h: float, interp: bool):
    """The scene driven call by call at communication step h:
    Omega set at each communication point (held: a staircase), with its
    slope as an input derivative if ``interp``.  (times, r_top), wall s."""
    md = fmpy.read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = fmpy.extract(str(fmu))
    slave = fmpy.fmi2.FMU2Slave(guid=md.guid, unzipDirectory=unzip,
                                modelIdentifier=md.coSimulation.modelIdentifier,
                                instanceName="runup")
    n = int(round((RAMP + HOLD) / h))
    t0 = time.perf_counter()
    slave.instantiate()
    slave.setupExperiment(tolerance=rtol, startTime=0.0)
    slave.setInteger([vr["solver"]], [SOLVERS.index(solver) + 1])
    slave.setReal([vr["solver_atol"], vr["e_b"], vr["e_w"], vr["Omega"]], [1e-12, ECC, ECC, 0.0])
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    times, r_top = [], []
    for i in range(n):
        t = i * h
        rpm, slope = ramp_rpm(t)
        slave.setReal([vr["Omega"]], [rpm * RAD_S_PER_RPM])
        if interp and slope:
            slave.setRealInputDerivatives([vr["Omega"]], [1], [slope * RAD_S_PER_RPM])
        slave.doStep(t, h)
        times.append((i + 1) * h)
        r_top.append(slave.getReal([vr["r_top"]])[0])
    wall = time.perf_counter() - t0
    slave.terminate()
    slave.freeInstance()
    return np.array(times), np.array(r_top), wall


def main_interp(args) -> int:
    runs = [(DT / k, False) for k in args.stair_refine] + \
        [(DT * k, True) for k in args.interp_steps]
    with tempfile.TemporaryDirectory() as tmp, \
            Progress(total=len(runs) + 1, desc="spindle run-up interp") as bar:
        opts = {"n_modes": args.n_modes} if args.model == "spindle_modal" else {}
        bar.stage(f"building the {args.model} FMU")
        fmu = build_fmu(load_model(args.model, **opts), out_dir=tmp, validate=False).path
        bar.stage("oracle: input derivatives at DT")
        t_ref, r_ref, wall_ref = run_driven(fmu, args.solver, args.rtol, DT, True)
        bar.advance(f"oracle: {wall_ref:.1f} s")
        peak = float(np.max(r_ref))
        rows = []
        for h, interp in runs:
            what = f"{'derivatives' if interp else 'staircase'} at {h:.4g} s"
            bar.stage(f"{what}: running ({args.repeats}x)")
            walls = []
            for _ in range(args.repeats):
                if h == DT and interp:
                    t, r, wall = t_ref, r_ref, wall_ref
                else:
                    t, r, wall = run_driven(fmu, args.solver, args.rtol, h, interp)
                walls.append(wall)
            # at the communication points both runs have
            k_ref, k_run = max(1, round(h / DT)), max(1, round(DT / h))
            err = float(np.max(np.abs(r[k_run - 1::k_run] - r_ref[k_ref - 1::k_ref])) / peak)
            rows.append({"inputs": "derivatives" if interp else "staircase",
                         "comm_step_s": h, "comm_steps": len(t),
                         "wall_s": statistics.median(walls), "error": err})
            bar.advance(f"{what}: {rows[-1]['wall_s']:.2f} s, error {err:.1e}")
    base = rows[0]["wall_s"]
    for r in rows:
        r["speedup_vs_staircase"] = base / r["wall_s"]
    result = {"scene": {"model": args.model, "ramp_s": RAMP, "hold_s": HOLD, "dt_s": DT,
                        "top_rpm": TOP_RPM, "solver": args.solver, "rtol": args.rtol,
                        "repeats": args.repeats},
              "oracle": "input derivatives at dt_s", "rows": rows}
    print(table(["inputs", "comm step", "steps", "wall s", "speedup", "error"],
                [[r["inputs"], f"{r['comm_step_s']:.4g}", str(r["comm_steps"]),
                  f"{r['wall_s']:.3f}", f"{r['speedup_vs_staircase']:.2f}",
                  f"{r['error']:.2e}"] for r in rows]))
    write_json(args.out or ROOT / "docs" / "results" / "spindle_runup_interp.json", result)
    return 0


DRIVER = Path(__file__).resolve().with_name("spindle_runup_driver.c")


def compile_driver(fmu: Path, tmp: Path) -> Path:
    """The FMU's sources/ plus the driver, compiled into one program."""
    src = tmp / "sources"
    with zipfile.ZipFile(fmu) as z:
        for name in z.namelist():
            if name.startswith("sources/"):
                z.extract(name, tmp)
    exe = tmp / "runup"
    probe = ["-DLF_PROBE_SCHUR"] if (src / "lf_schur.c").exists() else []
    cmd = ["gcc", "-std=c99", "-O2", *probe, "-I", str(src), "-I", str(fmi_headers_dir()),
           *map(str, sorted(src.glob("*.c"))), str(DRIVER), "-lm", "-o", str(exe)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"gcc failed: {proc.stderr[-2000:]}")
    return exe


def run_counters(exe: Path, fmu: Path, solver: str, rtol: float, interp: bool,
                 repeats: int) -> dict:
    md = fmpy.read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    args = [SOLVERS.index(solver) + 1, rtol, 1e-12, DT, int(interp), RAMP, HOLD, TOP_RPM, ECC,
            repeats] + [vr[k] for k in ("solver", "solver_atol", "Omega", "e_b", "e_w", "r_top")] \
        + [md.guid]
    proc = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"driver failed: {proc.stderr[-2000:]}")
    out = {k: float(v) for k, v in (ln.split() for ln in proc.stdout.splitlines())}
    return out


# cost of one call at the end state (C driver, best of 5 rounds): right-hand
# side, Jacobian, factorization and solve of alpha*I - J (Schur path), and the
# same two on the dense path
COST_KEYS = ("rhs_us", "jac_us", "factor_us", "solve_us", "dense_factor_us", "dense_solve_us")


def loomfmu_version() -> str:
    """The loomfmu version measured, with '+changes' when the tree differs from
    its last commit (figures say the version, not a commit)."""
    from importlib import metadata
    try:
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=ROOT, capture_output=True, text=True).stdout.strip()
    except OSError:
        dirty = ""
    return metadata.version("loomfmu") + ("+changes" if dirty else "")


def load_average() -> list[float]:
    """1, 5 and 15 minute load averages at the end of the run (the cores are
    shared: CPU times are inflated under load)."""
    try:
        import os
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return []


def main_counters(args) -> int:
    sim = RAMP + HOLD
    rows = []
    with tempfile.TemporaryDirectory() as tmp, \
            Progress(total=2 * len(args.solvers), desc="spindle run-up counters") as bar:
        opts = {"n_modes": args.n_modes} if args.model == "spindle_modal" else {}
        bar.stage(f"building the {args.model} FMU")
        fmu = build_fmu(load_model(args.model, **opts), out_dir=tmp, validate=False).path
        bar.stage("compiling the C driver")
        exe = compile_driver(fmu, Path(tmp))
        for solver in args.solvers:
            for interp in (False, True):
                what = f"{solver}, {'derivatives' if interp else 'staircase'}"
                bar.stage(f"{what}: running ({args.repeats}x)")
                r = run_counters(exe, fmu, solver, args.rtol, interp, args.repeats)
                rows.append({"solver": solver,
                             "inputs": "derivatives" if interp else "staircase",
                             "cpu_s": r["cpu_s"], "rtf": r["cpu_s"] / sim,
                             **{k: int(r[k]) for k in ("steps", "rejected", "rhs", "jac", "lu")},
                             "steps_per_lu": r["steps"] / max(r["lu"], 1.0),
                             "eliminated": int(r.get("eliminated", 0)),
                             "cost_us": {k[:-3]: r[k] for k in COST_KEYS if k in r},
                             "r_top_max": r["r_top_max"], "r_top_end": r["r_top_end"]})
                bar.advance(f"{what}: {r['cpu_s']:.2f} CPU s, {int(r['steps'])} steps")
    ref = rows[0]["r_top_max"]
    for r in rows:
        r["r_top_max_rel_diff"] = abs(r["r_top_max"] - ref) / ref
    result = {"scene": {"model": args.model, "ramp_s": RAMP, "hold_s": HOLD, "dt_s": DT,
                        "top_rpm": TOP_RPM, "rtol": args.rtol, "atol": 1e-12,
                        "repeats": args.repeats, "timing": "CPU time of the C driver, median"},
              "version": loomfmu_version(), "load_average": load_average(),
              "command": "python benchmarks/spindle_runup.py --counters --solvers "
                         + " ".join(args.solvers) + f" --repeats {args.repeats}",
              "rows": rows}
    # st/lu: "-" for a solver without factorizations (the JSON keeps steps / 1)
    print(table(["solver", "inputs", "cpu s", "cpu/sim", "steps", "rej", "rhs", "jac", "lu",
                 "st/lu", "dmax r_top"],
                [[r["solver"], r["inputs"], f"{r['cpu_s']:.3f}", f"{r['rtf']:.3f}",
                  *(str(r[k]) for k in ("steps", "rejected", "rhs", "jac", "lu")),
                  f"{r['steps_per_lu']:.2f}" if r["lu"] else "-",
                  f"{r['r_top_max_rel_diff']:.2e}"] for r in rows], left=2))
    cost = rows[-1]["cost_us"]
    if cost:
        print(f"{rows[-1].get('eliminated', 0)} states eliminated by the Schur path; cost per call "
              "(us, end state): " + ", ".join(f"{k} {v:.2f}" for k, v in cost.items()))
    write_json(args.out or ROOT / "docs" / "results" / "spindle_runup_counters.json", result)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=" ".join(__doc__.splitlines()[:2]))
    ap.add_argument("--modes", type=int, nargs="*", default=[1, 2, 3, 4, 5, 6, 8],
                    help="mode counts of the modal FMUs against the full one (default 1 2 3 "
                         "4 5 6 8)")
    ap.add_argument("--solver", default="rodas4", choices=SOLVERS,
                    help="solver of the modal comparison and of --interp (default rodas4)")
    ap.add_argument("--rtol", type=float, default=1e-6,
                    help="relative tolerance (default 1e-6)")
    ap.add_argument("--repeats", type=int, default=3,
                    help="timed runs per row, the median kept (default 3)")
    ap.add_argument("--out", type=Path, default=None,
                    help="the JSON file to write (default: docs/results/spindle_runup.json, with "
                         "--interp docs/results/spindle_runup_interp.json, with --counters "
                         "docs/results/spindle_runup_counters.json, in this repository)")
    ap.add_argument("--interp", action="store_true", help="input derivatives against the "
                    "staircase (writes docs/results/spindle_runup_interp.json)")
    ap.add_argument("--interp-steps", type=int, nargs="*", default=[1, 5, 25, 125],
                    help="communication steps of the interpolated runs, in units of DT "
                         "(default 1 5 25 125)")
    ap.add_argument("--stair-refine", type=int, nargs="*", default=[1, 10],
                    help="communication steps of the staircase runs, DT divided by these "
                         "(default 1 10)")
    ap.add_argument("--model", default="spindle", choices=("spindle", "spindle_modal"),
                    help="--interp and --counters: the model (default spindle)")
    ap.add_argument("--n-modes", type=int, default=4,
                    help="modes of spindle_modal with --model spindle_modal (default 4)")
    ap.add_argument("--counters", action="store_true", help="C driver without Python: "
                    "solver counters and CPU time (writes docs/results/spindle_runup_counters.json)")
    solvers = [s for s in ("rodas4", "ros34pw2") if s in SOLVERS]
    ap.add_argument("--solvers", nargs="*", default=solvers, choices=SOLVERS,
                    help=f"--counters: the solvers (default {' '.join(solvers)})")
    args = ap.parse_args(argv)
    if args.interp:
        return main_interp(args)
    if args.counters:
        return main_counters(args)
    sim_time = RAMP + HOLD
    with tempfile.TemporaryDirectory() as tmp, \
            Progress(total=1 + len(args.modes), desc="spindle run-up") as bar:
        bar.stage("spindle: building and running the full FMU")
        full = build_fmu(load_model("spindle"), out_dir=tmp, validate=False).path
        ref, wall_full = run(full, args.solver, args.rtol, args.repeats)
        bar.advance(f"spindle: {wall_full:.2f} s")
        peak = float(np.max(ref["r_top"]))
        rows = [{"model": "spindle", "n_modes": None, "states": None,
                 "wall_s": wall_full, "rtf": wall_full / sim_time, "error": 0.0}]
        for n in args.modes:
            bar.stage(f"spindle_modal, {n} modes: building and running")
            model = load_model("spindle_modal", n_modes=n)
            path = build_fmu(model, out_dir=Path(tmp) / f"m{n}", validate=False).path
            res, wall = run(path, args.solver, args.rtol, args.repeats)
            err = float(np.max(np.abs(res["r_top"] - ref["r_top"])) / peak)
            rows.append({"model": "spindle_modal", "n_modes": n,
                         "states": len(model.of_kind("state")), "wall_s": wall,
                         "rtf": wall / sim_time, "error": err})
            bar.advance(f"spindle_modal, {n} modes: {wall:.2f} s, error {err:.1e}")
    rows[0]["states"] = len(load_model("spindle").of_kind("state"))
    i_crit = int(np.argmax(ref["r_top"][: int(0.3 * RAMP / DT)]))  # below 4800 rpm
    result = {"scene": {"ramp_s": RAMP, "hold_s": HOLD, "dt_s": DT, "top_rpm": TOP_RPM,
                        "solver": args.solver, "rtol": args.rtol},
              "peak_r_top_m": peak, "critical_rpm": float(TOP_RPM * ref["time"][i_crit] / RAMP),
              "rows": rows}
    # the fewest modes from which on every larger count stays within 1 %
    fewest = None
    for r in reversed(rows[1:]):
        if r["error"] > 0.01:
            break
        fewest = r["n_modes"]
    result["fewest_modes_within_1pct"] = fewest
    print(table(["model", "modes", "states", "wall s", "wall/sim", "error"],
                [[r["model"], str(r["n_modes"] or "-"), str(r["states"]), f"{r['wall_s']:.3f}",
                  f"{r['rtf']:.4f}", f"{r['error']:.2e}"] for r in rows]))
    print(f"first critical passed at about {result['critical_rpm']:.0f} rpm (peak of r_top "
          f"below 4800 rpm); fewest modes within 1 % from there on: "
          f"{result['fewest_modes_within_1pct']}")
    write_json(args.out or ROOT / "docs" / "results" / "spindle_runup.json", result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
