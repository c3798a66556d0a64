"""Every model in every FMI variant: build, validate with FMPy, run through
FMPy, and compare each variant's outputs with the FMI 2.0 co-simulation run.

    python benchmarks/fmi_matrix.py [MODEL ...] [--variants 2:cs 2:me 3:cs 3:me]
                                    [--stop T] [--rtol 1e-8] [--out-dir DIR]
                                    [--json FILE] [--markdown FILE]
    python benchmarks/fmi_matrix.py --table-from docs/results/fmi_variants.json

For each model and variant (FMI version : interface) it builds the FMU
(loomfmu.build_fmu), counts ``fmpy.validate_fmu`` problems, and simulates it
with ``fmpy.simulate_fmu`` (co-simulation: the embedded dopri5 at solver
tolerance --rtol; model exchange: FMPy's CVode at relative tolerance --rtol,
absolute tolerance rtol x nominal = rtol) up to --stop (default: the model's
DefaultExperiment, capped at --stop when given), with the
DefaultExperiment's output interval.

A run counts as failed when the FMU logged any Discard or Error (FMPy's CVode
callback raises on a Discard inside ctypes, and CVode then sees an undefined
return value).  A model-exchange run of a model with delays that the FMU
refuses is retried at 1/2, 1/4, 1/8 of the stop time, and the note says so: FMPy 0.3.32's CVode
takes steps up to (stop - start)/50 and completes a step only at output
points, and a delay needs the importer's steps between completed steps no
longer than tau (docs/guides/runtime.md, Model exchange).

Agreement: every output of each variant at the output times it shares with
the reference run (FMI 2.0 co-simulation; of the rows at an event time, the
last, after the event), the largest |y - y_ref| relative to the
reference output's range over the run (its largest magnitude where the
range is 0).

Prints one row per (model, variant): build seconds, problems, run status,
wall seconds of the run, result rows, agreement with the reference and the
output where it is worst.  Exit 1 if any variant failed to build, has a
validation problem, or failed to run.
"""
from __future__ import annotations

import argparse
import importlib.metadata
import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import fmpy
import numpy as np

from loomfmu import build_fmu, load_model
from loomfmu.registry import MODELS

VARIANTS = ("2:cs", "2:me", "3:cs", "3:me")
REFERENCE = (2, "cs")
RTOL = 1e-8


def _variant(text: str) -> tuple[int, str]:
    try:
        v, i = text.split(":")
        out = int(v), i
    except ValueError:
        raise argparse.ArgumentTypeError(f"variant {text!r}; allowed: VERSION:INTERFACE, "
                                         "e.g. 3:me") from None
    if out[0] not in (2, 3) or out[1] not in ("cs", "me", "both"):
        raise argparse.ArgumentTypeError(f"variant {text!r}; allowed: 2|3 : cs|me|both")
    return out


def simulate(path: Path, kind: str, stop: float, interval: float, rtol: float):
    """FMPy's run of one FMU: (result or None, the FMU's Discard/Error log
    lines).  Co-simulation: our dopri5 at solver tolerance rtol (FMPy passes
    it as the experiment's tolerance); model exchange: FMPy's CVode at rtol."""
    log: list[str] = []

    def logger(*args):
        status, message = args[-3], args[-1]
        if status >= 2:
            log.append(message.decode(errors="replace"))

    try:
        res = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=stop,
                                output_interval=interval, relative_tolerance=rtol,
                                validate=False, logger=logger)
    except Exception as e:  # noqa: BLE001 (the caller reports it)
        log.append(f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}")
        return None, log
    return res, log


def agreement(ref, res) -> dict:
    """Largest |y - y_ref| of every output over the output times the two runs
    share, relative to the reference output's range (its largest magnitude
    where the range is 0); the output and the time where it is largest."""
    t, tr = ref["time"], res["time"]
    idx = np.searchsorted(tr, t, side="right") - 1  # the last row at t (after an event)
    safe = np.clip(idx, 0, None)
    last = np.r_[np.diff(t) > 0, True]  # the reference's last row at t, too
    common = last & (idx >= 0) & (np.abs(tr[safe] - t) <= 1e-9 * np.maximum(1.0, np.abs(t)))
    worst = {"difference": 0.0, "output": None, "time": None, "points": int(common.sum())}
    for name in ref.dtype.names[1:]:
        if name not in res.dtype.names:
            continue
        y = np.asarray(ref[name][common], dtype=float)
        z = np.asarray(res[name][safe[common]], dtype=float)
        if y.size == 0:
            continue
        scale = np.ptp(y) or np.max(np.abs(y)) or 1.0
        d = np.abs(z - y) / scale
        k = int(np.argmax(d))
        if not np.isfinite(d[k]) or d[k] > worst["difference"]:
            worst |= {"difference": float(d[k]), "output": name,
                      "time": float(t[common][k])}
    return worst


def run_one(name: str, fmi_version: int, interface: str, out_dir: Path,
            stop: float | None, rtol: float) -> tuple[dict, object]:
    """Build, validate and run one variant: (a dict of what happened, the result)."""
    row = {"model": name, "fmi_version": fmi_version, "interface": interface}
    try:
        res = build_fmu(load_model(name), out_dir=out_dir, fmi_version=fmi_version,
                        interface=interface)
    except Exception as e:  # noqa: BLE001 (the table reports it)
        return {**row, "build": f"failed: {str(e).splitlines()[0][:160]}", "problems": None,
                "run": "not run"}, None
    row |= {"build": "ok", "build_seconds": round(res.build_seconds, 2),
            "problems": len(res.problems), "first_problem": res.problems[:1]}
    md = fmpy.read_model_description(str(res.path))
    stop_time = float(md.defaultExperiment.stopTime)
    if stop is not None:
        stop_time = min(stop_time, stop)
    interval = float(md.defaultExperiment.stepSize)
    kind = "CoSimulation" if interface != "me" else "ModelExchange"
    t0 = time.perf_counter()
    out, log = simulate(res.path, kind, stop_time, interval, rtol)
    row["stop"] = stop_time
    # a refused evaluation inside FMPy's CVode raises in its ctypes callback:
    # CVode then sees an undefined return value (a run may fail or go on), so
    # a run with any Discard counts as refused
    if (out is None or log) and kind == "ModelExchange" and load_model(name).delays:
        first = log[0] if log else "failed"
        for k in (2, 4, 8):
            out, log = simulate(res.path, kind, stop_time / k, interval, rtol)
            if out is not None and not log:
                row["stop"] = stop_time / k
                row["note"] = (f"FMPy's CVode (max step stop/50 = {stop_time / 50:g} s > tau) "
                               f"ran at stop {stop_time / k:g} s; at {stop_time:g} s: "
                               f"{first[:90]}")
                break
    row["run_seconds"] = round(time.perf_counter() - t0, 3)
    row["discards"] = len(log)
    if out is None:
        row["run"] = "failed: " + (log[-1][:160] if log else "no log")
    elif log:
        row["run"] = f"failed: {len(log)} Discard/Error log lines, the first: {log[0][:120]}"
        out = None
    else:
        row |= {"run": "ok", "rows": len(out), "t_end": float(out["time"][-1])}
    return row, out


def compare_rows(rows: list[dict], results: list) -> None:
    """Each row of a model gets its agreement with the model's reference run."""
    ref = {r["model"]: out for r, out in zip(rows, results)
           if (r["fmi_version"], r["interface"]) == REFERENCE and out is not None}
    for r, out in zip(rows, results):
        if out is None or r["model"] not in ref:
            continue
        if (r["fmi_version"], r["interface"]) == REFERENCE:
            r["agreement"] = None
        else:
            r["agreement"] = agreement(ref[r["model"]], out)


def _note(r: dict) -> str:
    if r["build"] != "ok":
        return r["build"]
    if r["run"] != "ok":
        return r["run"]
    return r.get("note") or "; ".join(r.get("first_problem", []))


def table(rows: list[dict]) -> str:
    """The rows as plain text (the terminal)."""
    lines = [f"{'model':<22}{'variant':<9}{'build s':>8}{'problems':>9}  {'run':<7}"
             f"{'run s':>7}{'rows':>6}  {'vs 2:cs':>9}  {'where':<14} note"]
    for r in rows:
        a = r.get("agreement")
        agree = "ref" if (r["fmi_version"], r["interface"]) == REFERENCE else (
            f"{a['difference']:.1e}" if a else "-")
        lines.append(
            f"{r['model']:<22}{r['fmi_version']}:{r['interface']:<7}"
            f"{r.get('build_seconds', float('nan')):>8.1f}"
            f"{'-' if r['problems'] is None else r['problems']:>9}  "
            f"{'ok' if r['run'] == 'ok' else 'FAILED':<7}{r.get('run_seconds', float('nan')):>7.2f}"
            f"{r.get('rows', 0):>6}  {agree:>9}  {(a or {}).get('output') or '':<14} "
            f"{_note(r)[:110]}")
    return "\n".join(lines)


def markdown(rows: list[dict]) -> str:
    """One row per model; per variant: FMPy's validation problems, whether
    it ran (and to which stop time, where shortened), its agreement with the
    reference run."""
    variants = []
    for r in rows:
        v = (r["fmi_version"], r["interface"])
        if v not in variants:
            variants.append(v)
    head = ["model"] + [f"FMI {v} {i.upper()}" for v, i in variants]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name in dict.fromkeys(r["model"] for r in rows):
        cells = [f"`{name}`"]
        for v in variants:
            r = next((x for x in rows if x["model"] == name
                      and (x["fmi_version"], x["interface"]) == v), None)
            if r is None:
                cells.append("")
                continue
            if r["build"] != "ok" or r["run"] != "ok":
                cells.append("**failed**")
                continue
            a = r.get("agreement")
            what = "reference" if v == REFERENCE else (
                "not compared" if not a else "identical" if a["difference"] == 0 else
                f"{a['difference']:.1e} ({a['output']})")
            stop = f" to {r['stop']:g} s" if r.get("note") else ""
            cells.append(f"{r['problems']}, ran{stop}; {what}")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("models", nargs="*", default=sorted(MODELS))
    ap.add_argument("--variants", nargs="+", type=_variant,
                    default=[_variant(v) for v in VARIANTS])
    ap.add_argument("--stop", type=float, default=None,
                    help="cap on the stop time in s (default: the DefaultExperiment's)")
    ap.add_argument("--rtol", type=float, default=RTOL,
                    help=f"relative tolerance of our solver (co-simulation) and of FMPy's "
                         f"CVode (model exchange); default {RTOL:g}")
    ap.add_argument("--out-dir", type=Path, default=None)
    ap.add_argument("--json", type=Path, default=None, help="write the rows as JSON")
    ap.add_argument("--markdown", type=Path, default=None,
                    help="write the per-model table as Markdown")
    ap.add_argument("--table-from", type=Path, default=None, metavar="JSON",
                    help="print the Markdown table of a run's JSON and exit (no run)")
    args = ap.parse_args(argv)
    if args.table_from:
        print(markdown(json.loads(args.table_from.read_text())["rows"]))
        return 0
    for name in args.models:
        if name not in MODELS:
            ap.error(f"model {name!r}; allowed: {', '.join(sorted(MODELS))}")
    if not 0 < args.rtol < 1:
        ap.error(f"--rtol {args.rtol}; allowed: 0 < rtol < 1")
    rows, results = [], []
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.out_dir or Path(tmp)
        for name in args.models:
            variants = sorted(args.variants, key=lambda v: v != REFERENCE)  # reference first
            for v, i in variants:
                row, out = run_one(name, v, i, out_dir, args.stop, args.rtol)
                rows.append(row)
                results.append(out)
                compare_rows(rows, results)
                print(table(rows[-1:]).splitlines()[1], file=sys.stderr, flush=True)
    print(table(rows))
    bad = [r for r in rows if r["build"] != "ok" or r["problems"] or r["run"] != "ok"]
    summary = f"{len(rows) - len(bad)} of {len(rows)} variants built with 0 problems and ran"
    print(summary)
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True, cwd=Path(__file__).parent).stdout
    meta = {"command": "python benchmarks/fmi_matrix.py " + " ".join(argv or sys.argv[1:]),
            "rtol": args.rtol,
            "version": importlib.metadata.version("loomfmu"),
            "uncommitted_files": [ln[3:] for ln in dirty.splitlines()], "fmpy": fmpy.__version__,
            "python": platform.python_version(), "seconds": round(time.perf_counter() - t_start),
            "summary": summary}
    if args.json:
        args.json.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1) + "\n")
    if args.markdown:
        args.markdown.write_text(markdown(rows) + "\n")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
