"""Instruction counts of the C-level benchmark's runs (load-immune).

``loomfmu bench limit`` times each model's verification run driven through
its FMI functions by a C program; on a shared machine a time per call below
0.05 us moves by tens of per cent between runs.  This script counts
instructions instead: the same driver (``loomfmu.bench.limit.compile_driver``,
built from the FMU's own sources) under valgrind's callgrind, collecting
inside the fmi2* calls only, over the model's default experiment (rtol 1e-6,
atol 1e-9, one repeat).  Per model it prints the run's instructions, the
solver's counters, the average instructions of one call of the right-hand
side in the run (``lf_rhs``, inclusive) and

    ratio = instructions / (accepted steps x stages x lf_rhs instructions)

the limit of docs/guides/limit.md with the run's average right-hand side (without
the drive's history samples, so its ratio here is not the benchmark's).

Needs valgrind (``apt install valgrind``; not a Python dependency).

    python benchmarks/limit_instructions.py [--dist dist] [--solver dopri5] [MODEL ...]
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from loomfmu.bench.limit import STAGES, compile_driver
from loomfmu.registry import MODELS


def count(fmu: Path, solver: str, work: Path) -> dict:
    md = zipfile.ZipFile(fmu).read("modelDescription.xml").decode()
    stop = re.search(r'stopTime="([^"]+)"', md).group(1)
    step = re.search(r'stepSize="([^"]+)"', md).group(1)
    exe = compile_driver(fmu, work)
    out = work / "callgrind.out"
    proc = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                           "--toggle-collect=fmi2*", str(exe), stop, step, "1e-6", "1e-9",
                           solver, "1", "1"], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"{fmu.name}: the driver failed: {proc.stderr[-1000:]}")
    run = json.loads(proc.stdout)
    ann = subprocess.run(["callgrind_annotate", "--inclusive=yes", str(out)],
                         capture_output=True, text=True, check=True).stdout
    total = int(re.search(r"([\d,]+) \(100\.0%\)\s+PROGRAM TOTALS", ann).group(1)
                .replace(",", ""))
    m = re.search(r"([\d,]+) \([\d. ]+%\)\s+\S*_lf_rhs ", ann)
    per_rhs = int(m.group(1).replace(",", "")) / run["rhs"] if m and run["rhs"] else None
    stages = STAGES[solver][0]
    ratio = total / (run["steps"] * stages * per_rhs) if per_rhs else None
    return {"instructions": total, "steps": run["steps"], "rejected": run["rejected"],
            "rhs": run["rhs"], "rhs_instructions": per_rhs, "ratio": ratio}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("models", nargs="*", help="models (default: every model of the registry)")
    ap.add_argument("--dist", type=Path, default=Path("dist"),
                    help="directory of the built FMUs <model>.fmu (default dist; "
                         "python build_fmu.py builds them)")
    ap.add_argument("--solver", default="dopri5", choices=sorted(STAGES),
                    help="the embedded solver (default dopri5)")
    args = ap.parse_args(argv)
    if shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None:
        print("valgrind (with callgrind_annotate) is not installed", file=sys.stderr)
        return 2
    models = args.models or sorted(MODELS)
    missing = [m for m in models if not (args.dist / f"{m}.fmu").is_file()]
    if missing:
        print(f"no FMU for {', '.join(missing)} in {args.dist} (python build_fmu.py builds "
              "them)", file=sys.stderr)
        return 2
    print(f"| model | instructions | steps (rej.) | RHS | instr. per RHS | ratio ({args.solver}) |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in models:
            r = count(args.dist / f"{name}.fmu", args.solver, Path(tmp) / name)
            ratio = f"{r['ratio']:.2f}" if r["ratio"] else "–"
            per = f"{r['rhs_instructions']:.0f}" if r["rhs_instructions"] else "–"
            print(f"| {name} | {r['instructions'] / 1e6:.3f} M | {r['steps']} ({r['rejected']}) "
                  f"| {r['rhs']} | {per} | {ratio} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
