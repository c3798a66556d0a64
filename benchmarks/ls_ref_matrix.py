"""Every model in every FMI variant checked against the reference result it carries.

    python benchmarks/ls_ref_matrix.py [MODEL ...] [--variants 2:cs 2:me 3:cs 3:me]
                                       [--out-dir DIR] [--json FILE]
    python benchmarks/ls_ref_matrix.py --table-from docs/results/ls_ref.json

For each model: the cost of the scipy reference result the builder puts into
every FMU (FMI-LS-REF, :mod:`loomfmu.fmu.reference_results`), computed with
its cache entry removed ("cold") and then taken from the cache ("cached": the
key's hash and the read); then each variant is built with ``build_fmu`` (the
reference from the cache) and checked by ``benchmarks/ls_ref_fmpy_check.py``
in a subprocess, which imports FMPy and numpy only: the default experiment
run by ``fmpy.simulate_fmu`` in each interface the FMU has, every output
compared with the CSV inside, relative to its range, against the tolerance
the FMU states. Exit 1 if any variant fails to build, run or stay within it.
"""
from __future__ import annotations

import argparse
import importlib.metadata
import json
import platform
import re
import subprocess
import sys
import time
from pathlib import Path

from loomfmu import build_fmu, load_model
from loomfmu.fmu.reference_results import reference_result
from loomfmu.registry import MODELS

VARIANTS = ("2:cs", "2:me", "3:cs", "3:me")
CHECKER = Path(__file__).with_name("ls_ref_fmpy_check.py")


def run(models: list[str], variants: list[str], out_dir: Path) -> dict:
    rows = {}
    for name in models:
        model = load_model(name)
        t0 = time.perf_counter()
        ref = reference_result(model, use_cache=False)  # cold: computed (and not stored)
        cold = time.perf_counter() - t0
        reference_result(model)  # in the cache now (computed once more if it was not)
        t0 = time.perf_counter()
        hit = reference_result(model)
        cached = time.perf_counter() - t0
        row = {"reference": {"cold_seconds": cold, "cached_seconds": cached,
                             "from_cache": hit.cached, "method": ref.method,
                             "rtol": ref.rtol, "rows": ref.csv.count("\n") - 1,
                             "csv_bytes": len(ref.csv.encode())}, "variants": {}}
        print(f"{name}: reference {cold:.2f} s cold, {cached:.3f} s cached", flush=True)
        for variant in variants:
            version, interface = variant.split(":")
            t0 = time.perf_counter()
            try:
                res = build_fmu(model, out_dir=out_dir, fmi_version=int(version),
                                interface=interface)
            except Exception as e:  # noqa: BLE001 (record and go on)
                row["variants"][variant] = {"error": f"build: {e}"}
                continue
            build = time.perf_counter() - t0
            proc = subprocess.run([sys.executable, str(CHECKER), str(res.path)],
                                  capture_output=True, text=True)
            checks = [json.loads(ln) for ln in proc.stdout.splitlines() if ln.startswith("{")]
            if not checks:
                checks = [{"error": proc.stderr.strip().splitlines()[-1:]}]
            row["variants"][variant] = {"build_seconds": build, "problems": len(res.problems),
                                        "check": checks}
            c = checks[0]
            print(f"  {variant}: built {build:.1f} s; " + (
                f"{c['worst']:.2e} ({c['worst_output']}) <= {c['tolerance']:g}: {c['ok']}"
                if "worst" in c else f"error: {c.get('error')}"), flush=True)
        rows[name] = row
    return rows


def self_check(models: list[str]) -> dict:
    """How far each CSV (rtol 1e-11, atol 1e-13, the build's verification's
    reference) is from the reference at rtol 1e-12, atol 1e-14: per model the
    worst output's deviation relative to its range."""
    import numpy as np

    from loomfmu.fmu.reference_results import experiment_times, parse_csv
    from loomfmu.verification.reference import reference
    out = {}
    for name in models:
        model = load_model(name)
        t, cols = parse_csv(reference_result(model).csv, name)
        t0 = time.perf_counter()
        tight = reference(model, t_eval=experiment_times(0.0, model.stop_time,
                                                         model.step_size),
                          rtol=1e-12, atol=1e-14, method=model.reference_method)
        dev = {n: float(np.max(np.abs(c - tight.y[n])) /
                        (np.ptp(tight.y[n]) or np.max(np.abs(tight.y[n])) or 1.0))
               for n, c in cols.items()}
        worst = max(dev, key=dev.get)
        out[name] = {"worst": dev[worst], "worst_output": worst,
                     "tight_seconds": time.perf_counter() - t0}
        print(f"{name}: CSV vs rtol 1e-12: {dev[worst]:.1e} ({worst})", flush=True)
    return out


def table(data: dict) -> str:
    variants = list(next(iter(data["models"].values()))["variants"])
    head = ["model", "reference cold s", "cached s",
            *(f"FMI {v.replace(':', ' ').upper()}" for v in variants)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, row in data["models"].items():
        cells = [f"`{name}`", f"{row['reference']['cold_seconds']:.2f}",
                 f"{row['reference']['cached_seconds']:.3f}"]
        for v in variants:
            res = row["variants"].get(v, {})
            c = (res.get("check") or [{}])[0]
            if "worst" in c:
                cells.append(f"{c['worst']:.1e} ({c['worst_output']}) "
                             f"{'≤' if c['ok'] else '>'} {c['tolerance']:g}")
            else:
                err = str(res.get("error") or c.get("error") or "no result")
                at = re.search(r"At t = ([0-9.eE+-]+)", err)
                cells.append(f"run failed: FMPy's CVode stopped at t = {float(at.group(1)):.3g} s"
                             if at else "failed: " + err[:80].replace("|", "/"))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="*", default=None)
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    ap.add_argument("--out-dir", type=Path, default=Path("dist/ls_ref"))
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--table-from", type=Path, default=None)
    ap.add_argument("--self-check", action="store_true",
                    help="only compare each CSV with the reference at rtol 1e-12 "
                         "(no builds); with --json, stored under 'self_check' in that file")
    args = ap.parse_args(argv)
    if args.table_from:
        print(table(json.loads(args.table_from.read_text())))
        return 0
    models = args.models or sorted(MODELS)
    if args.self_check:
        res = self_check(models)
        if args.json:
            data = json.loads(args.json.read_text()) if args.json.exists() else {}
            data["self_check"] = {"command": "python benchmarks/ls_ref_matrix.py "
                                  + " ".join(sys.argv[1:]), "models": res}
            args.json.write_text(json.dumps(data, indent=1) + "\n")
        return 0
    t0 = time.perf_counter()
    rows = run(models, args.variants, args.out_dir)
    data = {"command": "python benchmarks/ls_ref_matrix.py " + " ".join(sys.argv[1:]),
            "loomfmu": importlib.metadata.version("loomfmu"),
            "fmpy": importlib.metadata.version("fmpy"), "python": platform.python_version(),
            "wall_seconds": time.perf_counter() - t0, "models": rows}
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(data, indent=1) + "\n")
    print(table(data))
    bad = [(m, v) for m, r in rows.items() for v, res in r["variants"].items()
           if "error" in res or not all(c.get("ok") for c in res["check"])]
    for m, v in bad:
        print(f"FAILED {m} {v}", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
