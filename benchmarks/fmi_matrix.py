"""Every model in every FMI variant: build, validate with FMPy, run through FMPy.

    python benchmarks/fmi_matrix.py [MODEL ...] [--variants 2:cs 2:me 3:cs 3:me]
                                    [--stop 0.1] [--out-dir DIR] [--json FILE]

For each model and variant (FMI version : interface) it builds the FMU
(loomfmu.build_fmu), counts ``fmpy.validate_fmu`` problems, and simulates it
with ``fmpy.simulate_fmu`` (co-simulation: the embedded dopri5; model
exchange: FMPy's CVode) up to --stop (default: the model's DefaultExperiment,
capped at --stop when given).  A model-exchange run of a model with delays
that the FMU refuses (FMPy's CVode steps up to stop/50 and completes steps
only at output points: longer than the delay) is retried at 1/2, 1/4, 1/8 of
the stop time, and the note says so.  Prints one table row per (model, variant):
build seconds, problems, run status (ok / the first line of the error),
wall seconds of the run, and the number of result rows.  Exit 1 if any
variant has a validation problem or a failed run.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import fmpy

from loomfmu import build_fmu, load_model
from loomfmu.registry import MODELS

VARIANTS = ("2:cs", "2:me", "3:cs", "3:me")


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


def run_one(name: str, fmi_version: int, interface: str, out_dir: Path,
            stop: float | None) -> dict:
    """Build, validate and run one variant; a dict of what happened."""
    row = {"model": name, "fmi_version": fmi_version, "interface": interface}
    try:
        res = build_fmu(load_model(name), out_dir=out_dir, fmi_version=fmi_version,
                        interface=interface)
    except Exception as e:  # noqa: BLE001 (the table reports it)
        return {**row, "build": f"failed: {str(e).splitlines()[0][:120]}", "problems": None,
                "run": "not run"}
    row |= {"build": "ok", "build_seconds": round(res.build_seconds, 2),
            "problems": len(res.problems), "first_problem": res.problems[:1]}
    md = fmpy.read_model_description(str(res.path))
    stop_time = float(md.defaultExperiment.stopTime)
    if stop is not None:
        stop_time = min(stop_time, stop)
    kind = "CoSimulation" if interface != "me" else "ModelExchange"
    t0 = time.perf_counter()
    row |= _run(res.path, kind, stop_time)
    if row["run"] != "ok" and kind == "ModelExchange" and load_model(name).delays:
        # FMPy's CVode takes steps up to (stop - start)/50 and calls
        # completedIntegratorStep only at output points: a delay needs steps
        # shorter than tau, so a long run is refused by the FMU (logged); the
        # same FMU at shorter stop times
        first = row["run"]
        for k in (2, 4, 8):
            row |= _run(res.path, kind, stop_time / k)
            if row["run"] == "ok":
                row["note"] = (f"ok at stop {stop_time / k:g} s; at {stop_time:g} s: "
                               f"{first[:60]}")
                break
    row["run_seconds"] = round(time.perf_counter() - t0, 3)
    return row


def _run(path: Path, kind: str, stop_time: float) -> dict:
    try:
        out = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=stop_time,
                                validate=False)
        return {"run": "ok", "rows": len(out), "t_end": float(out["time"][-1])}
    except Exception as e:  # noqa: BLE001 (the table reports it)
        return {"run": f"failed: {str(e).splitlines()[0][:120] if str(e) else type(e).__name__}"}


def table(rows: list[dict]) -> str:
    lines = [f"{'model':<22}{'variant':<9}{'build s':>8}{'problems':>9}  {'run':<8}"
             f"{'run s':>7}{'rows':>6}  note"]
    for r in rows:
        note = r["build"] if r["build"] != "ok" else (
            r["run"] if r["run"] != "ok" else r.get("note") or
            "; ".join(r.get("first_problem", [])))
        lines.append(
            f"{r['model']:<22}{r['fmi_version']}:{r['interface']:<7}"
            f"{r.get('build_seconds', float('nan')):>8.1f}"
            f"{'-' if r['problems'] is None else r['problems']:>9}  "
            f"{'ok' if r['run'] == 'ok' else 'FAILED':<8}{r.get('run_seconds', float('nan')):>7.2f}"
            f"{r.get('rows', 0):>6}  {note[:110]}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("models", nargs="*", default=sorted(MODELS))
    ap.add_argument("--variants", nargs="+", type=_variant,
                    default=[_variant(v) for v in VARIANTS])
    ap.add_argument("--stop", type=float, default=None,
                    help="cap on the stop time in s (default: the DefaultExperiment's)")
    ap.add_argument("--out-dir", type=Path, default=None)
    ap.add_argument("--json", type=Path, default=None, help="write the rows as JSON")
    args = ap.parse_args(argv)
    for name in args.models:
        if name not in MODELS:
            ap.error(f"model {name!r}; allowed: {', '.join(sorted(MODELS))}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = args.out_dir or Path(tmp)
        for name in args.models:
            for v, i in args.variants:
                rows.append(run_one(name, v, i, out_dir, args.stop))
                print(table(rows[-1:]).splitlines()[1], file=sys.stderr, flush=True)
    print(table(rows))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))
    bad = [r for r in rows if r["build"] != "ok" or r["problems"] or r["run"] != "ok"]
    print(f"{len(rows) - len(bad)} of {len(rows)} variants built with 0 problems and ran")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
