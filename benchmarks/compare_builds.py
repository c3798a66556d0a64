"""Compare two builds of the FMUs bit for bit: every FMU's default experiment
run through FMPy, every output array compared as raw bytes, and the size of
each FMU's state after initialization.

    .venv/bin/python benchmarks/compare_builds.py OLD_DIR NEW_DIR
        # two folders of FMUs built before, e.g. by
        #   loomfmu build --no-verify --out-dir OLD_DIR   (old source tree)
        #   loomfmu build --no-verify --out-dir NEW_DIR   (new source tree)
    .venv/bin/python benchmarks/compare_builds.py --build OLD_TREE NEW_TREE OUT_DIR [MODEL ...]
        # builds every model (or the MODELs named) from two source trees
        # (e.g. a `git worktree` of the old commit and this one) into
        # OUT_DIR/old and OUT_DIR/new first (FMI 2.0 co-simulation,
        # --no-verify), then compares them
    .venv/bin/python benchmarks/compare_builds.py --sizes DIR
        # only the state sizes of one folder's FMUs

Every FMU name found in both folders (``*.fmu``) is compared: FMI 2.0 and
3.0, co-simulation or model exchange (``fmpy.simulate_fmu`` picks
co-simulation where the FMU offers it), with the default experiment of its
model description (start, stop, tolerance) and FMPy's default output
interval.  Each output's array is compared with ``tobytes()``: the same
float64 bit patterns, NaNs in the same places, the same number of rows.
One line per FMU:

    backrest             identical   (2 001 rows, 14 columns)  state 9 144 -> 9 144 bytes
    drive                DIFFERS     max |diff| 3.1e-12 (u_delayed)  state ...

The state size is fmi2SerializedFMUstateSize (fmi3SerializedFMUStateSize)
of the state got right after initialization (instantiate, setup, enter and
exit initialization mode at the default start time).  Exit status 1 if any
FMU differs (results, or a state size), is missing from one folder, or
fails to run; 0 if every one is identical.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np


def run(fmu: Path) -> np.ndarray:
    """The default experiment's result (FMPy's structured array)."""
    from fmpy import simulate_fmu
    return simulate_fmu(str(fmu))


def state_size(fmu: Path) -> int:
    """Bytes of the serialized FMU state right after initialization."""
    from ctypes import byref, c_size_t

    from fmpy import extract, read_model_description
    md = read_model_description(str(fmu))
    unzipdir = extract(str(fmu))
    ex = md.defaultExperiment
    start = float(ex.startTime) if ex is not None and ex.startTime is not None else 0.0
    try:
        if md.fmiVersion.startswith("3"):
            from fmpy.fmi3 import FMU3Model, FMU3Slave
            if md.coSimulation is not None:
                inst = FMU3Slave(guid=md.guid, unzipDirectory=unzipdir,
                                 modelIdentifier=md.coSimulation.modelIdentifier)
            else:
                inst = FMU3Model(guid=md.guid, unzipDirectory=unzipdir,
                                 modelIdentifier=md.modelExchange.modelIdentifier)
            inst.instantiate()
            inst.enterInitializationMode(startTime=start)
            inst.exitInitializationMode()
            state = inst.getFMUState()
            size = c_size_t()
            inst.fmi3SerializedFMUStateSize(inst.component, state, byref(size))
            inst.freeFMUState(state)
        else:
            from fmpy.fmi2 import FMU2Model, FMU2Slave
            if md.coSimulation is not None:
                inst = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                                 modelIdentifier=md.coSimulation.modelIdentifier)
            else:
                inst = FMU2Model(guid=md.guid, unzipDirectory=unzipdir,
                                 modelIdentifier=md.modelExchange.modelIdentifier)
            inst.instantiate()
            inst.setupExperiment(startTime=start)
            inst.enterInitializationMode()
            inst.exitInitializationMode()
            state = inst.getFMUstate()
            size = c_size_t()
            inst.fmi2SerializedFMUstateSize(inst.component, state, byref(size))
            inst.freeFMUstate(state)
        inst.terminate()
        inst.freeInstance()
        return int(size.value)
    finally:
        import shutil
        shutil.rmtree(unzipdir, ignore_errors=True)


def compare(a: np.ndarray, b: np.ndarray) -> tuple[bool, str]:
    """(identical, description) of two results, column by column."""
    if a.dtype.names != b.dtype.names:
        return False, f"columns differ: {a.dtype.names} vs {b.dtype.names}"
    if a.shape != b.shape:
        return False, f"{a.shape[0]} vs {b.shape[0]} rows"
    worst, where, differing = 0.0, "", []
    for name in a.dtype.names:
        x, y = np.ascontiguousarray(a[name]), np.ascontiguousarray(b[name])
        if x.tobytes() == y.tobytes():
            continue
        differing.append(name)
        xf, yf = x.astype(np.float64), y.astype(np.float64)
        nan_moved = not np.array_equal(np.isnan(xf), np.isnan(yf))
        with np.errstate(invalid="ignore"):
            d = np.abs(xf - yf)
        d = float(np.nanmax(d)) if np.any(~np.isnan(d)) else float("nan")
        if nan_moved:
            d = float("inf")
        if not (d <= worst):
            worst, where = d, name
    if not differing:
        return True, f"({a.shape[0]} rows, {len(a.dtype.names)} columns)"
    return False, (f"max |diff| {worst:.3g} ({where}); {len(differing)} of "
                   f"{len(a.dtype.names)} columns differ")


def sizes_only(folder: Path) -> int:
    for fmu in sorted(folder.glob("*.fmu")):
        print(f"{fmu.stem:32s} state {state_size(fmu)} bytes", flush=True)
    return 0


def compare_folders(old: Path, new: Path) -> int:
    names = sorted({p.name for p in old.glob("*.fmu")} | {p.name for p in new.glob("*.fmu")})
    if not names:
        print(f"no FMUs in {old} or {new}")
        return 1
    bad = 0
    for name in names:
        stem = name[:-4]
        if not (old / name).exists() or not (new / name).exists():
            print(f"{stem:32s} MISSING in {old if not (old / name).exists() else new}")
            bad = 1
            continue
        try:
            same, text = compare(run(old / name), run(new / name))
            s_old, s_new = state_size(old / name), state_size(new / name)
        except Exception as exc:  # a failed run is a difference, reported
            print(f"{stem:32s} FAILED      {type(exc).__name__}: {exc}")
            bad = 1
            continue
        sizes = f"state {s_old} -> {s_new} bytes" + ("" if s_old == s_new else " (CHANGED)")
        print(f"{stem:32s} {'identical' if same else 'DIFFERS  '}   {text}  {sizes}",
              flush=True)
        bad |= (not same) or s_old != s_new
    print("all identical" if not bad else "differences found")
    return 1 if bad else 0


_BUILD_IN_TREE = """
import importlib.util, runpy, sys
tree = sys.argv.pop(1)
sys.path.insert(0, tree + "/src")
import loomfmu
assert loomfmu.__file__.startswith(tree), (loomfmu.__file__, tree)
spec = importlib.util.spec_from_file_location(
    "loomfmu.models", tree + "/models/__init__.py",
    submodule_search_locations=[tree + "/models"])
models = importlib.util.module_from_spec(spec)
sys.modules["loomfmu.models"] = models
spec.loader.exec_module(models)
loomfmu.models = models
sys.argv[0] = "loomfmu"
runpy.run_module("loomfmu", run_name="__main__", alter_sys=True)
"""


def build(tree: Path, out: Path, models: list[str]) -> None:
    """Build the models of source tree `tree` (its package, models and C
    runtime, not the installed ones) into `out`."""
    print("building", tree, "->", out, flush=True)
    subprocess.run([sys.executable, "-c", _BUILD_IN_TREE, str(tree), "build", "--no-verify",
                    "--out-dir", str(out), *models], check=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("paths", nargs="+", type=Path,
                    help="OLD_DIR NEW_DIR; with --build: OLD_TREE NEW_TREE OUT_DIR [MODEL ...]; "
                         "with --sizes: DIR")
    ap.add_argument("--build", action="store_true",
                    help="build the models from two source trees first")
    ap.add_argument("--sizes", action="store_true", help="only print the state sizes")
    args = ap.parse_args(argv)
    if args.sizes:
        return sizes_only(args.paths[0])
    if args.build:
        if len(args.paths) < 3:
            ap.error("--build needs OLD_TREE NEW_TREE OUT_DIR")
        old_tree, new_tree, out = args.paths[:3]
        models = [str(p) for p in args.paths[3:]]
        build(old_tree.resolve(), out / "old", models)
        build(new_tree.resolve(), out / "new", models)
        return compare_folders(out / "old", out / "new")
    if len(args.paths) != 2:
        ap.error("expected OLD_DIR NEW_DIR")
    return compare_folders(*args.paths)


if __name__ == "__main__":
    sys.exit(main())
