"""loomfmu sweep {design-map, drive-grid, hinge, trends, loom-stick, run}: parameter studies on dask.

    loomfmu sweep design-map [--gap 0.004] [--workers 2 | --scheduler tcp://host:8786]
    loomfmu sweep drive-grid
    loomfmu sweep hinge
    loomfmu sweep trends
    loomfmu sweep loom-stick
    loomfmu sweep run MODEL --grid b1=0.008,0.012 --figure max_abs:x2_out --stop 0.42

Each writes OUT_DIR/<study>.csv (one row per case, with its status and the
FMU's log line when it failed or warned) and the charts; rerunning resumes
(finished cases are skipped) unless --fresh. Exit 1 if a case failed or
completed with a warning of the FMU (status "warning", e.g. an input outside
its range); 130 when interrupted (SIGINT, ^C), with one line saying how many
finished cases the results file kept and how to resume.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from loomfmu.declare.checks import OneLineParser, check_number, check_writable, path_arg
from loomfmu.declare.solvers import SOLVERS


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--workers", type=int, default=2,
                   help="local dask worker processes, one thread each (1 ... 64; default 2)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="a running dask scheduler (tcp://host:8786) instead of the local "
                        "cluster; its workers need loomfmu installed (default: none, the "
                        "local cluster)")
    p.add_argument("--connect-timeout", type=float, default=10.0, metavar="SECONDS",
                   help="how long to wait for --scheduler to answer (0 < . <= 600; "
                        "default 10): no answer, a closed port or another service there "
                        "is an error (exit 2)")
    p.add_argument("--out-dir", type=path_arg, default=Path("docs/results/sweep"),
                   help="tables and charts (default: %(default)s)")
    p.add_argument("--fresh", action="store_true",
                   help="start over instead of resuming from OUT_DIR/<study>.csv")
    p.add_argument("--batch", type=int, default=1,
                   help="cases per dask task (default 1; more for short cases, to spread "
                        "dask's few ms per task)")
    p.add_argument("--fmu", type=path_arg, default=None,
                   help="a built .fmu of the study's model (default: build it now)")


def _command(sub, name: str, text: str) -> argparse.ArgumentParser:
    """A subcommand whose one line shows in the list and atop its own --help."""
    return sub.add_parser(name, help=text, description=text)


def _parser(prog: str) -> argparse.ArgumentParser:
    ap = OneLineParser(prog=prog, description="Parameter studies on dask.distributed "
                                 "(an embedded LocalCluster, or --scheduler).")
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = _command(sub, "design-map", "heald frame: b1, d1 vs max |x2| over loom widths and "
                 "k_z -> OUT_DIR/design_map.{csv,png,md}")
    d.add_argument("--gap", type=float, default=0.004,
                   help="clearance to the neighbouring frame, m (> 0; default 0.004): the "
                        "smallest b1 meeting it, per (width, k_z, d1)")
    _common(d)
    g = _command(sub, "drive-grid", "drive tracking error over tau, T, cam "
                 "-> OUT_DIR/drive_grid.{csv,png,md}")
    _common(g)
    h = _command(sub, "hinge", "rigid frame's hinge load over every preset and speed "
                 "-> OUT_DIR/hinge.{csv,png}")
    _common(h)
    t = _command(sub, "trends", "spindle trend studies on the full FMU against (15) "
                 "-> OUT_DIR/trends.{csv,png,md}")
    _common(t)
    k = _command(sub, "loom-stick", "the loom composed into one FMU: picks/min x the "
                 "backrest's preload vs stick share and peak hinge load "
                 "-> OUT_DIR/loom_stick.{csv,png,md}")
    _common(k)
    r = _command(sub, "run", "any model: a grid, lists or a Latin hypercube of values")
    r.add_argument("model", metavar="MODEL",
                   help="a model of the registry (loomfmu list), built with --option")
    r.add_argument("--grid", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="an axis of a full-factorial grid (repeatable)")
    r.add_argument("--list", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="values taken together, case by case (repeatable, equal lengths)")
    r.add_argument("--lhs", action="append", default=[], metavar="NAME=LO:HI",
                   help="an axis of a Latin hypercube (repeatable; with --samples, --seed)")
    r.add_argument("--samples", type=int, default=16, help="Latin hypercube size (default 16)")
    r.add_argument("--seed", type=int, default=0, help="Latin hypercube seed (default 0)")
    r.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="a start value of every case (repeatable)")
    r.add_argument("--figure", action="append", required=True, metavar="KIND:OUTPUT[@T]",
                   help="what to record of each case (repeatable): KIND one of max_abs, max, "
                        "min, mean, final, ptp, rms of OUTPUT from T s on")
    r.add_argument("--stop", type=float, required=True, help="stop time, s (> 0)")
    r.add_argument("--step", type=float, default=None,
                   help="communication step, s (default stop/1000)")
    r.add_argument("--solver", default="dopri5", choices=SOLVERS, metavar="SOLVER",
                   help=f"the FMU's solver: {' | '.join(SOLVERS)} (default dopri5)")
    r.add_argument("--rtol", type=float, default=1e-6, help="(0, 0.1]; default 1e-6")
    r.add_argument("--atol", type=float, default=1e-9, help="> 0; default 1e-9")
    r.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="build option of the model (repeatable)")
    r.add_argument("--name", default=None, help="the study's name (file names; default MODEL)")
    _common(r)
    return ap


def _number(text: str, what: str):
    t = text.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    try:
        return int(t) if t.lstrip("+-").isdigit() else float(t)
    except ValueError:
        raise ValueError(f"{what}: {text!r:.40}; allowed: numbers (or true/false)") from None


def _valuer(model: str, options: dict):
    """value(name, text, what): ``text`` as a number (:func:`_number`), or a
    number with a unit of the same quantity as the model's variable
    ``name`` ('240rpm', '240 rpm'), converted to the variable's unit."""
    from loomfmu.declare.units import allowed_units, split_quantity, to_unit
    declared = []

    def value(name: str, text: str, what: str):
        parsed = split_quantity(text)
        if parsed is None or not parsed[1]:
            return _number(text, what)
        if not declared:
            from loomfmu.registry import load_model
            declared.append(load_model(model, **options))
        unit = declared[0].var(name).unit
        try:
            return to_unit(parsed[0], parsed[1], unit)
        except ValueError:
            allowed = allowed_units(unit)
            raise ValueError(f"{what}: {text!r:.40}: {name} is in {unit or 'no unit'}; "
                             f"allowed units: {', '.join(allowed) if allowed else 'none'}"
                             ) from None
    return value


def _pairs(items: list[str], flag: str) -> dict[str, str]:
    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"{flag} {item!r:.60}; allowed: NAME=VALUE")
        k, v = item.split("=", 1)
        out[k.strip()] = v
    return out


def _run_study_from_args(args):
    from loomfmu.registry import MODELS
    from loomfmu.sweep.figures import parse_figure
    from loomfmu.sweep.space import grid, latin_hypercube, lists
    from loomfmu.sweep.study import Study
    if args.model not in MODELS:
        raise ValueError(f"MODEL = {args.model!r:.60}; allowed: one of "
                         f"{', '.join(sorted(MODELS))}")
    options = {k: _number(v, f"--option {k}") if v.strip().lstrip("+-").replace(
        ".", "", 1).isdigit() else v for k, v in _pairs(args.option, "--option").items()}
    value = _valuer(args.model, options)
    kinds = [k for k in ("grid", "list", "lhs") if getattr(args, k)]
    if len(kinds) != 1:
        raise ValueError("--grid, --list, --lhs: give one kind of space; allowed: exactly one "
                         f"of them (given: {', '.join(kinds) or 'none'})")
    if kinds == ["lhs"]:
        bounds = {}
        for k, v in _pairs(args.lhs, "--lhs").items():
            if ":" not in v:
                raise ValueError(f"--lhs {k}={v!r:.40}; allowed: NAME=LO:HI")
            bounds[k] = tuple(value(k, x, f"--lhs {k}") for x in v.split(":", 1))
        cases = latin_hypercube(bounds, n=args.samples, seed=args.seed)
    else:
        axes = {k: [value(k, x, f"--{kinds[0]} {k}") for x in v.split(",")]
                for k, v in _pairs(getattr(args, kinds[0]), f"--{kinds[0]}").items()}
        cases = (grid if kinds == ["grid"] else lists)(**axes)
    stop = check_number("--stop", args.stop, lo=0.0, lo_open=True, unit="s")
    step = stop / 1000 if args.step is None else args.step
    fixed = {k: value(k, v, f"--set {k}") for k, v in _pairs(args.set, "--set").items()}
    return Study(args.model, cases=cases, figures=[parse_figure(f) for f in args.figure],
                 stop_time=stop, output_interval=step, solver=args.solver, rtol=args.rtol,
                 atol=args.atol, fixed=fixed, options=options,
                 name=args.name or args.model)


def _study_from_args(args):
    from loomfmu.machines import studies
    gap = None
    if args.cmd == "design-map":
        gap = check_number("--gap", args.gap, lo=0.0, lo_open=True, unit="m")
        return studies.design_map(), gap
    if args.cmd == "run":
        return _run_study_from_args(args), gap
    return studies.STUDIES[args.cmd](), gap


def _run(study, out: Path, args):
    from loomfmu.sweep.connect import MAX_CONNECT_TIMEOUT
    from loomfmu.sweep.run import run_study
    check_number("--connect-timeout", args.connect_timeout, lo=0.0, hi=MAX_CONNECT_TIMEOUT,
                 lo_open=True, unit="s")
    return run_study(study, out=out, workers=args.workers, scheduler=args.scheduler,
                     fmu=args.fmu, resume=not args.fresh, batch=args.batch,
                     connect_timeout=args.connect_timeout)


def _interrupted(prog: str, out: Path) -> int:
    """Exit code 130 (as a shell's for SIGINT) with one line: what was kept, and
    how to resume."""
    import signal

    from loomfmu.sweep import store
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # a second ^C must not cut the line
    try:
        kept = len(store.read_rows(out))
    except (OSError, ValueError):
        kept = 0
    print(f"{prog}: interrupted: {kept} finished case(s) kept in {out}; run the same "
          "command again to resume (finished cases are skipped)", file=sys.stderr, flush=True)
    return 130


def _check_out_dir(out_dir: Path, out: Path) -> None:
    """OUT_DIR is (or can be made) a writable directory and OUT_DIR/<study>.csv
    is not a directory: checked before any case runs (ValueError, exit 2)."""
    check_writable("--out-dir", out_dir, folder=True)
    out_dir.mkdir(parents=True, exist_ok=True)
    if out.is_dir():
        raise ValueError(f"--out-dir {str(out_dir)!r}: {out.name} in it is a directory; "
                         "allowed: a directory where that name is free or a results file")


def main(argv=None, prog: str = "loomfmu sweep") -> int:
    args = _parser(prog).parse_args(argv)
    from loomfmu.machines import charts, studies
    try:  # a refused value, path or scheduler: one line, exit 2
        study, gap = _study_from_args(args)
        out = args.out_dir / f"{study.name}.csv"
        _check_out_dir(args.out_dir, out)
        res = _run(study, out, args)
    except (ValueError, ImportError) as exc:  # ImportError: dask.distributed missing
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # ^C: the finished rows are in OUT, say so in one line
        return _interrupted(prog, out)
    written = [out]
    if args.cmd == "design-map":
        summary = studies.smallest_b1(res.rows, gap)
        md = args.out_dir / "design_map.md"
        md.write_text(design_markdown(summary, gap))
        written += [md, charts.design_map_chart(res.rows, args.out_dir / "design_map.png", gap)]
    elif args.cmd == "drive-grid":
        md = args.out_dir / "drive_grid.md"
        md.write_text(drive_markdown(res.rows))
        written += [md, charts.drive_grid_chart(res.rows, args.out_dir / "drive_grid.png")]
    elif args.cmd == "hinge":
        from loomfmu.mechanics.heald_presets import preset_names
        md = args.out_dir / "hinge.md"
        md.write_text(hinge_markdown(res.rows, preset_names(),
                                     studies.hinge_closed_form(res.rows)))
        written += [md, charts.hinge_chart(res.rows, preset_names(), args.out_dir / "hinge.png")]
    elif args.cmd == "trends":
        table = studies.trends_against_15(res.rows, study.fixed["ecc"])
        md = args.out_dir / "trends.md"
        md.write_text(trends_markdown(table, study.fixed["ecc"]))
        written += [md, charts.trends_chart(table, args.out_dir / "trends.png")]
    elif args.cmd == "loom-stick":
        md = args.out_dir / "loom_stick.md"
        md.write_text(loom_stick_markdown(res.rows))
        written += [md, charts.loom_stick_chart(res.rows, args.out_dir / "loom_stick.png")]
    failed = res.failed
    warned = sum(r["status"] == "warning" for r in failed)
    where = (f"{args.workers} local workers" if args.scheduler is None
             else f"workers of {args.scheduler}")
    print(f"{study.name}: {len(res.rows)} cases, {res.executed} run now "
          f"({where}), {res.skipped} "
          f"resumed from {out}, {len(failed) - warned} failed, {warned} with a warning; "
          f"{res.wall_s:.1f} s")
    for r in failed[:10]:
        print(f"  case {r['index']} {r['status']}: {r['message']}")
    for path in written:
        print(f"written: {path}")
    return 1 if failed else 0


def loom_stick_markdown(rows: list[dict]) -> str:
    ok = sorted((r for r in rows if r["status"] == "ok"), key=lambda r: (r["ppm"], r["preload"]))
    lines = ["# The loom as one model: speed against the backrest's preload", "",
             "Generated by `loomfmu sweep loom-stick` (see docs/guides/sweep.md): the loom "
             "scene composed into one FMU over 1 s; the backrest's static warp tension S0 "
             "(and with it the spring's preload) scaled by the factor; the share of the run "
             "either pivot of the backrest is stuck, and the peak load on frame a's drive "
             "hinge.", "",
             "| picks/min | preload factor | stuck (% of the run) | peak abs N_rem (N) |",
             "|---|---|---|---|"]
    for r in ok:
        lines.append(f"| {r['ppm']:g} | {r['preload']:g} | {100 * r['stick_share']:.1f} | "
                     f"{r['max_abs_frame_a.N_rem']:.0f} |")
    return "\n".join(lines) + "\n"


def design_markdown(summary: list[dict], gap: float) -> str:
    lines = ["# Heald frame design map: smallest slat width for a gap",
             "",
             "Generated by `loomfmu sweep design-map` (see docs/guides/sweep.md): the smallest slat "
             f"width b1 whose max |x2| over two frame cycles stays below the gap {gap * 1e3:g} "
             "mm, interpolated (log-log) between the map's grid points.",
             "",
             "| loom width (m) | k_z | d1 (mm) | smallest b1 (mm) | note |",
             "|---|---|---|---|---|"]
    for r in summary:
        b1 = "" if r["b1_min"] is None else f"{r['b1_min'] * 1e3:.2f}"
        lines.append(f"| {r['width_cm'] / 100:g} | {r['k_z']:g} | {r['d1'] * 1e3:g} | {b1} "
                     f"| {r['note']} |")
    return "\n".join(lines) + "\n"


def hinge_markdown(rows: list[dict], names: list[str], closed_form: float) -> str:
    ok = [r for r in rows if r["status"] == "ok"]
    lines = ["# Hinge loads over every preset",
             "",
             "Generated by `loomfmu sweep hinge` (see docs/guides/sweep.md): the rigid heald frame's "
             "load on one drive hinge N_rem (N, positive up) over one frame cycle, for each "
             f"of the {len(names)} presets of seed 002 at each speed. Largest difference from "
             "seed 002's kinetostatic closed form (loomfmu.heald.hinge), relative to the load's "
             f"range: {closed_form:.1e} (the FMU's 0.1 ms samples against a 200 001-point "
             "cycle).",
             "",
             "| omega (rad/s) | largest upward load (N), preset | largest downward load (N), "
             "preset |",
             "|---|---|---|"]
    for om in sorted({r["omega"] for r in ok}):
        rs = [r for r in ok if r["omega"] == om]
        hi = max(rs, key=lambda r: r["max_N_rem"])
        lo = min(rs, key=lambda r: r["min_N_rem"])
        lines.append(f"| {om:g} | {hi['max_N_rem']:.1f}, {names[hi['preset']]} | "
                     f"{lo['min_N_rem']:.1f}, {names[lo['preset']]} |")
    return "\n".join(lines) + "\n"


def trends_markdown(table: list[dict], ecc: float) -> str:
    ok = [r for r in table if "A1_fmu" in r]
    worst = max((max(r["dA1"], r["dA2"]) for r in ok), default=float("nan"))
    drift = max((r["drift"] for r in ok), default=float("nan"))
    lines = ["# Spindle trend studies on the FMU",
             "",
             "Generated by `loomfmu sweep trends` (see docs/guides/sweep.md): the full `spindle` FMU "
             "(dopri5, rtol 1e-8) started on the periodic unbalance orbit of (15) "
             "(loomfmu.spindle.start) at 16 000 rpm, eccentricity "
             f"{ecc * 1e6:.2f} um of bobbin and whorl; A1, A2 = the largest radius of the top "
             "and of the bottom of the blade over revolutions 2-3, next to (15) "
             "(`loomfmu rotor trends`). Largest relative difference from (15): "
             f"{worst:.1e}; largest drift of the top radius over the recorded revolutions: "
             f"{drift:.1e}.",
             "",
             "| study | x | A1 FMU (um) | A1 (15) (um) | A2 FMU (um) | A2 (15) (um) | "
             "max rel. difference |",
             "|---|---|---|---|---|---|---|"]
    for r in table:
        if "A1_fmu" not in r:
            lines.append(f"| {r['study']} | {r['x']:g} | {r['status']} | | | | |")
            continue
        lines.append(f"| {r['study'].replace('_', ' ')} | {r['x']:g} | "
                     f"{r['A1_fmu'] * 1e6:.3f} | {r['A1_15'] * 1e6:.3f} | "
                     f"{r['A2_fmu'] * 1e6:.3f} | {r['A2_15'] * 1e6:.3f} | "
                     f"{max(r['dA1'], r['dA2']):.1e} |")
    return "\n".join(lines) + "\n"


def drive_markdown(rows: list[dict]) -> str:
    lines = ["# Drive tracking grid",
             "",
             "Generated by `loomfmu sweep drive-grid` (see docs/guides/sweep.md): max |n - n0| in rpm "
             "after the transient at equal cam angle, the figures of `loomfmu drive tracking`.",
             "",
             "| tau (s) | T (s) | compensated vs series | compensated vs law | "
             "uncompensated vs law |",
             "|---|---|---|---|---|"]
    by = {(r["tau"], r["T"], r["compensate"]): r for r in rows if r["status"] == "ok"}
    for tau, T in sorted({(r["tau"], r["T"]) for r in rows}):
        c, u = by.get((tau, T, True)), by.get((tau, T, False))
        cell = (lambda r, k, f: "failed" if r is None else format(r[k], f))
        lines.append(f"| {tau:g} | {T:g} | {cell(c, 'vs_series_rpm', '.3g')} | "
                     f"{cell(c, 'vs_law_rpm', '.3g')} | {cell(u, 'vs_law_rpm', '.4g')} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main(prog="python -m loomfmu.cli.sweep"))
