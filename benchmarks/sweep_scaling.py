"""Scaling of loomfmu.sweep: the same study as a plain serial loop, as a
serial loop reusing one instance (fmi2Reset), and on dask LocalClusters of
1 and 2 worker processes; per-case overhead and bit-for-bit equality.

    python benchmarks/sweep_scaling.py [--study design-map|drive-grid|hinge ...]
        [--out docs/results/sweep/scaling.json]

The plain loop is fmpy.simulate_fmu per case (a fresh instance each time,
the extracted FMU given), what a script without loomfmu.sweep would do.
Wall times include everything the caller waits for; ``startup_s`` is the
part that starts the cluster and ships the FMU. The machine's load average
is recorded next to them: on a shared machine the times are only as good
as the cores left free. "CPU split 2 vs 1" is the 1-worker run's worker CPU
over the busiest worker's CPU with 2 workers: how far the work divides,
whatever else the machine runs (2.0: evenly).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from loomfmu.machines import studies
from loomfmu.sweep import fmu_blob, run_serial, run_study


def _figures(study, rows):
    names = [f.name for f in study.figures]
    return [(r["status"], *[float(r[n]).hex() for n in names]) for r in rows]


def measure(name: str) -> dict:
    study = studies.STUDIES[name]()
    t = time.perf_counter()
    blob = fmu_blob(study)
    build_s = time.perf_counter() - t
    n = len(study.cases)
    out = {"study": name, "model": study.model, "cases": n, "build_s": build_s,
           "load_before": os.getloadavg()[0]}
    t, c = time.perf_counter(), time.process_time()
    plain = run_serial(study, blob=blob, reuse=False)
    out["plain_loop_s"] = time.perf_counter() - t
    out["plain_loop_cpu_s"] = time.process_time() - c
    t = time.perf_counter()
    reused = run_serial(study, blob=blob, reuse=True)
    out["reuse_loop_s"] = time.perf_counter() - t
    ref = _figures(study, plain)
    out["reuse_identical"] = _figures(study, reused) == ref
    for workers in (1, 2):
        with tempfile.TemporaryDirectory() as tmp:
            res = run_study(study, out=Path(tmp) / "r.csv", workers=workers, blob=blob,
                            progress=False)
        out[f"dask{workers}_s"] = res.wall_s
        out[f"dask{workers}_startup_s"] = res.startup_s
        out[f"dask{workers}_cpu_s"] = res.worker_cpu_s + res.client_cpu_s
        out[f"dask{workers}_worker_cpu_s"] = res.worker_cpu_s
        out[f"dask{workers}_busiest_worker_cpu_s"] = res.busiest_worker_cpu_s
        out[f"dask{workers}_identical"] = _figures(study, res.rows) == ref
    batch = max(1, n // 32)  # about 16 tasks per worker of 2
    with tempfile.TemporaryDirectory() as tmp:
        res = run_study(study, out=Path(tmp) / "r.csv", workers=2, blob=blob, progress=False,
                        batch=batch)
    out.update(batch=batch, dask2_batch_s=res.wall_s, dask2_batch_startup_s=res.startup_s,
               dask2_batch_identical=_figures(study, res.rows) == ref)
    out["load_after"] = os.getloadavg()[0]
    out["overhead_per_case_ms"] = 1e3 * (out["dask1_s"] - out["dask1_startup_s"]
                                         - out["plain_loop_s"]) / n
    out["cpu_overhead_per_case_ms"] = 1e3 * (out["dask1_cpu_s"] - out["plain_loop_cpu_s"]) / n
    out["cpu_split_2_vs_1"] = out["dask1_worker_cpu_s"] / out["dask2_busiest_worker_cpu_s"]
    out["speedup_2_vs_1"] = ((out["dask1_s"] - out["dask1_startup_s"])
                             / (out["dask2_s"] - out["dask2_startup_s"]))
    out["ok_cases"] = sum(r["status"] == "ok" for r in plain)
    return out


def markdown(results: list[dict]) -> str:
    lines = ["| study | cases | plain loop | reuse loop | dask 1 worker (startup) | "
             "dask 2 workers (startup) | 2 vs 1 (no startup) | overhead / case: wall, CPU | "
             "2 workers, batches (startup) | CPU: plain loop, dask 1 worker | "
             "CPU split 2 vs 1 | identical | load avg |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        same = all(r[k] for k in ("reuse_identical", "dask1_identical", "dask2_identical",
                                  "dask2_batch_identical"))
        lines.append(
            f"| {r['study']} | {r['cases']} | {r['plain_loop_s']:.1f} s | "
            f"{r['reuse_loop_s']:.1f} s | {r['dask1_s']:.1f} s ({r['dask1_startup_s']:.1f}) | "
            f"{r['dask2_s']:.1f} s ({r['dask2_startup_s']:.1f}) | {r['speedup_2_vs_1']:.2f}x | "
            f"{r['overhead_per_case_ms']:.1f} ms, {r['cpu_overhead_per_case_ms']:.1f} ms | "
            f"{r['dask2_batch_s']:.1f} s "
            f"({r['dask2_batch_startup_s']:.1f}), {r['batch']} cases a task | "
            f"{r['plain_loop_cpu_s']:.1f} s, {r['dask1_cpu_s']:.1f} s | "
            f"{r['cpu_split_2_vs_1']:.2f}x | "
            f"{'bit for bit' if same else 'NO'} | "
            f"{r['load_before']:.1f} -> {r['load_after']:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--study", action="append", choices=sorted(studies.STUDIES),
                    default=None, help="studies to measure (default: design-map, drive-grid)")
    ap.add_argument("--out", type=Path, default=Path("docs/results/sweep/scaling.json"))
    args = ap.parse_args(argv)
    results = []
    for name in args.study or ["design-map", "drive-grid"]:
        print(f"measuring {name} ...", file=sys.stderr, flush=True)
        results.append(measure(name))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"cpus": os.cpu_count(), "results": results}, indent=1))
    text = markdown(results)
    args.out.with_suffix(".md").write_text(text)
    print(text)
    print(f"written: {args.out}, {args.out.with_suffix('.md')}")
    keys = ("dask1_identical", "dask2_identical", "dask2_batch_identical", "reuse_identical")
    return 0 if all(r[k] for r in results for k in keys) else 1


if __name__ == "__main__":
    sys.exit(main())
