"""Every model on every platform: build the FMI 3.0 co-simulation FMU for
x86-64 Linux, x86-64 Windows and aarch64 Linux, run each binary over the
model's default experiment with our driver (natively, under wine, under
qemu-aarch64) and compare with the native run.

    python benchmarks/platforms.py [MODEL ...] [--json docs/results/platforms.json]
                                   [--markdown FILE] [--contract-models M,...]
    python benchmarks/platforms.py --table-from docs/results/platforms.json

Build times: each platform's binary built alone into an empty object cache
(everything compiled), wall seconds of ``build_fmu`` (generation, compile on
every core, link, zip; validation off). The FMU that runs is then built for
all three platforms at once, from that cache.

Runs: one driver process per platform for all models
(loomfmu.fmu.platform_run: co-simulation, one doStep per output interval,
the embedded dopri5 at its default tolerance). Agreement: whether every
output at every output time has the native run's bits, else the largest
|difference| relative to the output's range over the native run.

--contract-models: these models' aarch64 binaries are also built with
``-ffp-contract=fast`` in place of ``-ffp-contract=off`` (gcc may then fuse
a * b + c into one fused multiply-add, rounded once) and compared in the
same way: what the flag buys.

--libm: compile tests/c/math_probe.c for each platform with the C library's
sin, cos, exp, pow, ... (-DPROBE_LIBM) and with the runtime's own (under
"lf_math"), 20 000 arguments each and the special values, run it the same
way and count, per function, the results whose bits differ from the native
run's; with --json, only that entry of an existing file is replaced.

--solvers-of MODEL: MODEL's FMI 3.0 co-simulation FMU run with each embedded
solver (dopri5, rk4, ros34pw2: ``solver_index`` set by the driver) natively
and on every other platform: whether a difference comes from the adaptive
step sequence (a fixed step has none); with --json, only that entry of an
existing file is replaced.

FMI 2.0 co-simulation gives FMI 3.0's numbers bit for bit natively
(docs/guides/fmi_variants.md), so FMI 3.0 stands for both here; FMI 2.0
names no aarch64 folder. Exit 1 if a build or a run failed.
"""
from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from loomfmu import build_fmu, load_model
from loomfmu.fmu import builder
from loomfmu.fmu.platform_run import compare, missing_tools, run_on
from loomfmu.fmu.platforms import PLATFORMS
from loomfmu.registry import MODELS

EMULATOR = {"linux64": "native", "win64": "wine", "aarch64": "qemu-aarch64"}
#: the elementary functions on MATH_PROBE_N arguments each and the special
#: ones: the C library's (built with -DPROBE_LIBM) and the runtime's own
MATH_PROBE_N = 20000
MATH_PROBE = Path(__file__).resolve().parent.parent / "tests" / "c" / "math_probe.c"
RUNTIME = Path(__file__).resolve().parent.parent / "src" / "loomfmu" / "runtime"
MATH_SOURCES = [str(RUNTIME / f) for f in ("lf_math.c", "lf_trig.c")]


def solvers_of(model: str, work: Path) -> dict:
    """Each embedded solver on every platform, against the native run."""
    names = [n for n in PLATFORMS if missing_tools(n) is None]
    fmu = build_fmu(load_model(model), out_dir=work, fmi_version=3, validate=False,
                    platforms=names).path
    solvers = {"dopri5": 1, "rk4": 3, "ros34pw2": 4}
    runs = [(fmu, "cs", {"solver_index": i}) for i in solvers.values()]
    native = run_on("linux64", runs)
    out: dict = {"rk4_vs_dopri5_native": compare(native[0], native[1])}
    for name in names[1:]:
        for solver, n, r in zip(solvers, native, run_on(name, runs)):
            out.setdefault(name, {})[solver] = (compare(n, r) if n.ok and r.ok else
                                                {"ok": False, "message": n.message + r.message})
    return out


def libm(work: Path) -> dict:
    """Per platform and function: results of tests/c/math_probe.c whose bits
    differ from the native run's, with the C library's functions and (under
    "lf_math") with the runtime's own."""
    from loomfmu.fmu.platform_run import wine_env
    outs: dict[str, dict[str, list[str]]] = {"libm": {}, "lf_math": {}}
    for name in [n for n in PLATFORMS if missing_tools(n) is None]:
        p = PLATFORMS[name]
        for kind, flags in (("libm", ["-DPROBE_LIBM"]), ("lf_math", [])):
            exe = work / f"{kind}_{name}{'.exe' if p.windows else ''}"
            subprocess.run([p.cc, "-std=c99", "-O2", "-ffp-contract=off", *flags, f"-I{RUNTIME}",
                            "-o", str(exe), str(MATH_PROBE), *MATH_SOURCES,
                            *(["-static-libgcc"] if p.windows else ["-lm"])], check=True)
            outs[kind][name] = subprocess.run(
                [*p.emulator, str(exe), str(MATH_PROBE_N)], capture_output=True, text=True,
                check=True, env=wine_env() if p.windows else None
            ).stdout.replace("\r", "").split("\n")
    return _differing(outs["libm"]) | {"lf_math": _differing(outs["lf_math"])}


def _differing(outs: dict[str, list[str]]) -> dict:
    """Per platform other than linux64 and function: lines that differ."""
    native = outs["linux64"]
    result = {}
    for name, lines in outs.items():
        if name == "linux64":
            continue
        diff: dict[str, int] = {}
        for a, b in zip(native, lines):
            if a != b:
                fn = a.split()[0]
                diff[fn] = diff.get(fn, 0) + 1
        funcs = sorted({ln.split()[0] for ln in native if ln})
        result[name] = {f: diff.get(f, 0) for f in funcs}
        result[name]["_same_length"] = len(native) == len(lines)
    return result


def _version(cmd: list[str]) -> str:
    try:
        return subprocess.run(cmd, capture_output=True, text=True).stdout.splitlines()[0]
    except (OSError, IndexError):
        return "(not installed)"


def _contract_fast():
    """The builder's flags with -ffp-contract=fast (restored on exit)."""
    class Ctx:
        def __enter__(self):
            self.saved = builder.STRICT_FLAGS, builder.GENERATED_FLAGS
            swap = {"-ffp-contract=off": "-ffp-contract=fast"}
            builder.STRICT_FLAGS = tuple(swap.get(f, f) for f in self.saved[0])
            builder.GENERATED_FLAGS = tuple(swap.get(f, f) for f in self.saved[1])

        def __exit__(self, *exc):
            builder.STRICT_FLAGS, builder.GENERATED_FLAGS = self.saved
    return Ctx()


def measure(models: list[str], contract_models: list[str], work: Path) -> dict:
    names = [n for n in PLATFORMS if missing_tools(n) is None]
    skipped = {n: missing_tools(n) for n in PLATFORMS if n not in names}
    rows: dict[str, dict] = {}
    fmus = {}
    for model in models:
        decl = load_model(model)
        row = rows[model] = {"build_seconds": {}, "runs": {}}
        # a fresh cache per model: each platform's build compiles everything
        # (the compiler's identity is in the key), the all-platform build reuses it
        os.environ["LOOMFMU_BUILD_CACHE"] = str(work / f"cache-{model}")
        for name in names:
            res = build_fmu(decl, out_dir=work / name, fmi_version=3, validate=False,
                            platforms=[name])
            row["build_seconds"][name] = round(res.build_seconds, 2)
            print(f"{model}: {name} built in {res.build_seconds:.1f} s", flush=True)
        res = build_fmu(decl, out_dir=work / "all", fmi_version=3, platforms=names)
        row["validation_problems"] = list(res.problems)
        row["fmu_bytes"] = res.path.stat().st_size
        fmus[model] = res.path
        if model in contract_models and "aarch64" in names:
            with _contract_fast():
                fast = build_fmu(decl, out_dir=work / "fast", fmi_version=3, validate=False,
                                 platforms=["aarch64"])
            fmus[model, "fast"] = fast.path
    runs = [(fmus[m], "cs") for m in models]
    native = None
    for name in names:
        t0 = time.perf_counter()
        out = run_on(name, runs)
        seconds = time.perf_counter() - t0
        print(f"{name}: {len(out)} runs in {seconds:.1f} s", flush=True)
        if name == "linux64":
            native = out
        for model, r in zip(models, out):
            cell = {"ok": r.ok, "message": r.message, "rows": int(len(r.time))}
            if r.ok and native is not None and native[models.index(model)].ok:
                cell |= compare(native[models.index(model)], r)
            rows[model]["runs"][name] = cell
        rows_total = {"seconds_all_models": round(seconds, 1)}
        rows.setdefault("_driver", {})[name] = rows_total
    contract = {}
    fast_models = [m for m in models if (m, "fast") in fmus]
    if fast_models and native is not None:
        out = run_on("aarch64", [(fmus[m, "fast"], "cs") for m in fast_models])
        for model, r in zip(fast_models, out):
            contract[model] = ({"ok": True} | compare(native[models.index(model)], r)
                               if r.ok else {"ok": False, "message": r.message})
    return {
        "command": "python benchmarks/platforms.py " + " ".join(sys.argv[1:]),
        "loomfmu": importlib.metadata.version("loomfmu"),
        "host": f"{platform.machine()} {platform.system()}, {os.cpu_count()} cores (shared)",
        "tools": {n: _version([PLATFORMS[n].cc, "--version"]) for n in PLATFORMS}
        | {"wine": _version(["wine", "--version"]),
           "qemu-aarch64": _version(["qemu-aarch64", "--version"])},
        "platforms": names, "skipped": skipped, "models": rows,
        "aarch64_ffp_contract_fast": contract,
    }


def _fmt(cell: dict) -> str:
    if not cell.get("ok"):
        return f"FAILED {cell.get('message', '')}"
    if cell.get("identical"):
        return "identical bits"
    return f"{cell['max_rel_range']:.1e} ({cell['output']})"


def table(data: dict) -> str:
    names = data["platforms"]
    head = ["model"] + [f"build {n} (s)" for n in names] + \
        [f"{n} ({EMULATOR[n]})" for n in names if n != "linux64"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for model, row in data["models"].items():
        if model.startswith("_"):
            continue
        cells = [f"`{model}`"] + [f"{row['build_seconds'][n]:.1f}" for n in names] + \
            [_fmt(row["runs"][n]) for n in names if n != "linux64"]
        lines.append("| " + " | ".join(cells) + " |")
    driver = data["models"].get("_driver", {})
    lines.append("")
    lines.append("Driver wall time, all models: " + ", ".join(
        f"{n} {driver[n]['seconds_all_models']} s" for n in names if n in driver) + ".")
    if data.get("aarch64_ffp_contract_fast"):
        lines.append("")
        lines.append("aarch64 built with -ffp-contract=fast against native: " + "; ".join(
            f"`{m}` {_fmt(c)}" for m, c in data["aarch64_ffp_contract_fast"].items()) + ".")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("models", nargs="*", help="default: every model")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--markdown", type=Path, default=None)
    ap.add_argument("--contract-models", default="two_mass_force,heald_frame_rigid,"
                                                  "heald_frame,backrest,spindle_modal")
    ap.add_argument("--table-from", type=Path, default=None)
    ap.add_argument("--solvers-of", default=None, metavar="MODEL",
                    help="only MODEL, with each embedded solver")
    ap.add_argument("--libm", action="store_true",
                    help="only the math-library comparison (tests/c/math_probe.c)")
    args = ap.parse_args(argv)
    if args.solvers_of:
        if args.solvers_of not in MODELS:
            ap.error(f"unknown model {args.solvers_of!r}; allowed: {', '.join(sorted(MODELS))}")
        with tempfile.TemporaryDirectory() as tmp:
            res = solvers_of(args.solvers_of, Path(tmp))
        print(json.dumps(res, indent=1))
        if args.json:
            data = json.loads(args.json.read_text()) if args.json.exists() else {}
            data[f"solvers_{args.solvers_of}"] = res | {
                "command": "python benchmarks/platforms.py " + " ".join(argv or sys.argv[1:])}
            args.json.write_text(json.dumps(data, indent=2) + "\n")
        return 0
    if args.libm:
        with tempfile.TemporaryDirectory() as tmp:
            res = libm(Path(tmp))
        print(json.dumps(res, indent=1))
        if args.json:
            data = json.loads(args.json.read_text()) if args.json.exists() else {}
            data["libm_differing_bits"] = res
            data["libm_command"] = "python benchmarks/platforms.py --libm " + \
                " ".join(a for a in (argv or sys.argv[1:]) if a != "--libm")
            args.json.write_text(json.dumps(data, indent=2) + "\n")
        return 0
    if args.table_from:
        print(table(json.loads(args.table_from.read_text())), end="")
        return 0
    models = args.models or sorted(MODELS)
    for m in models:
        if m not in MODELS:
            ap.error(f"unknown model {m!r}; allowed: {', '.join(sorted(MODELS))}")
    contract = [m for m in args.contract_models.split(",") if m]
    with tempfile.TemporaryDirectory() as tmp:
        data = measure(models, [m for m in contract if m in models], Path(tmp))
    text = table(data)
    print(text, end="")
    if args.json:
        args.json.write_text(json.dumps(data, indent=2) + "\n")
    if args.markdown:
        args.markdown.write_text(text)
    bad = [m for m, row in data["models"].items() if not m.startswith("_")
           and (row.get("validation_problems") or not all(c["ok"] for c in row["runs"].values()))]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
