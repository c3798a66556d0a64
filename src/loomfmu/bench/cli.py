"""``loomfmu bench charts|speed|friction|limit``."""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from loomfmu.bench import classic, failures, limit, report
from loomfmu.bench.scenes import BENCH, load_scene_model
from loomfmu.bench.sweep import Plan, prepare, work_precision
from loomfmu.declare.checks import OneLineParser, check_output_options, path_arg
from loomfmu.progress import Progress

#: most local dask workers (as loomfmu.sweep.run.MAX_WORKERS; not imported
#: from there so the serial run needs no dask)
MAX_WORKERS = 64


def charts(models, *, quick: bool, out: Path, readme: Path | None, failures_on: bool,
           cmd: str, dask: dict | None = None, plan: Plan | None = None,
           only=None, c_level: bool = False) -> dict:
    """Every chart, the CSV and the summary for ``models`` (scene names).

    dask: None (serial) or the keyword arguments of
    :func:`loomfmu.bench.dask.work_precision_dask` (workers, scheduler): one
    dask task per (model, method) sweep. plan: the sweeps' settings (default
    ``Plan.make(quick)``); only: the (family, method) pairs to sweep (None:
    all); c_level: also time our FMU's points at C level (family "fmu-c",
    :func:`loomfmu.bench.limit.speed_points`)."""
    wall = time.perf_counter()
    plan = plan or Plan.make(quick)
    out.mkdir(parents=True, exist_ok=True)
    rows, infos, verdicts, cases, tasks = [], {}, {}, {}, []
    n_studies = sum(1 for n in failures.STUDIES if failures_on and n in models)
    with tempfile.TemporaryDirectory() as tmp, \
            Progress(total=len(models) + n_studies, desc="bench charts") as bar:
        if dask is not None:
            cases = _charts_dask(models, plan, quick, out, Path(tmp), infos, rows, tasks, bar,
                                 dask, only, failures_on, c_level)
        for name in models if dask is None else ():
            bar.stage(f"{name}: work-precision sweep")
            model = load_scene_model(name)
            if model is None:
                bar.advance(f"{name}: no model")
                continue
            t0 = time.perf_counter()
            case = prepare(name, BENCH[name], model, plan, quick, Path(tmp))
            cases[name] = case
            infos[name] = _info(case.scene, case.grid, case.ref_note, case.casadi_note)
            pts = work_precision(case, plan, only)
            if c_level:
                pts += limit.speed_points(name, pts, quick=quick,
                                          work=Path(tmp) / "c" / name)
            rows += pts
            report.wp_chart(rows, name, infos[name], out / f"{name}_wp.png")
            bar.advance(f"{name}: {len(pts)} work-precision points, "
                        f"{time.perf_counter() - t0:.0f} s")
        for name, study in failures.STUDIES.items():
            if not failures_on or name not in cases:
                continue
            t0 = time.perf_counter()
            bar.stage(f"{name}: failure study")
            extra = {"reg": cases.get("backrest_regularized")} if name == "backrest" else {}
            pts, verdict = study(cases[name], plan, out, quick, **extra)
            rows += pts
            verdicts[name] = verdict
            bar.advance(f"{name}: failure study, {time.perf_counter() - t0:.0f} s")
            print(f"  {verdict}", flush=True)
    report.write_csv(rows, out / "points.csv")
    table = report.speed_table(rows, list(infos))
    wall = time.perf_counter() - wall
    body = report.summary_md(table, verdicts, infos, cmd, wall)
    (out / "summary.md").write_text("# Speed against accuracy\n\n" + body)
    (out / "speed_table.json").write_text(json.dumps(
        {"target_error": report.TARGET, "quick": quick, "wall_seconds": wall,
         "table": table, "verdicts": verdicts, "scenes": infos,
         **({"dask_tasks": tasks} if dask is not None else {})}, indent=2, default=str))
    if readme is not None and report.update_readme(readme, body):
        print(f"updated: {readme} (between the bench markers)")
    print(report.speed_table_md(table))
    print(f"written: {out}/points.csv, summary.md, *.png in {wall:.0f} s")
    return {"rows": rows, "table": table, "verdicts": verdicts, "wall_seconds": wall,
            "tasks": tasks}


def _info(scene, grid, ref_note: str, casadi_note: str) -> dict:
    info = {"outputs": list(scene.outputs), "t_end": float(grid[-1]), "ref": ref_note}
    if casadi_note:
        info["ref"] += f"; no CasADi: {casadi_note.split(': ', 1)[-1]}"
    return info


def _charts_dask(models, plan, quick, out, tmp, infos, rows, tasks, bar, dask, only,
                 failures_on, c_level=False) -> dict:
    """The work-precision sweeps on dask (loomfmu.bench.dask); fills infos,
    rows and tasks, draws the charts; returns the scenes prepared here (from
    the workers' grids and references) for the failure studies."""
    from loomfmu.bench.dask import work_precision_dask
    names = [n for n in models if load_scene_model(n) is not None]
    bar.stage(f"{', '.join(names)}: work-precision sweeps on dask")
    got = work_precision_dask(names, plan, quick, only=only, **dask)
    tasks += got["tasks"]
    cases = {}
    for name in names:
        grid, ref, note, casadi_note = got["known"][name]
        infos[name] = _info(BENCH[name], grid, note, casadi_note)
        rows += got["rows"][name]
        if c_level:
            rows += limit.speed_points(name, got["rows"][name], quick=quick,
                                       work=tmp / "c" / name)
        report.wp_chart(rows, name, infos[name], out / f"{name}_wp.png")
        if failures_on:
            cases[name] = prepare(name, BENCH[name], load_scene_model(name), plan, quick, tmp,
                                  known=(grid, ref, note))
        bar.advance(f"{name}: {len(got['rows'][name])} work-precision points")
    return cases


def _command(sub, name: str, text: str) -> argparse.ArgumentParser:
    """A subcommand whose one line shows in the list and atop its own --help."""
    return sub.add_parser(name, help=text, description=text)


def _parser(prog: str) -> tuple[argparse.ArgumentParser, dict]:
    """The parser and its subparsers by command."""
    ap = OneLineParser(prog=prog,
                                 description="loomfmu benchmarks (never timed tests)")
    sub = ap.add_subparsers(dest="command", required=True)
    c = _command(sub, "charts", "work-precision and failure charts of every bench scene "
                 "-> OUT/*.png, points.csv, summary.md, speed_table.json")
    c.add_argument("--models", nargs="+", default=None, metavar="MODEL",
                   help=f"the scenes to sweep (default: all of {', '.join(BENCH)})")
    c.add_argument("--quick", action="store_true", help="coarse sweeps")
    c.add_argument("--no-failures", action="store_true", help="skip the failure studies")
    c.add_argument("--no-c-level", action="store_true",
                   help="do not time our FMU's points again at C level (the fmu-c lines, by "
                        "the driver of bench limit)")
    c.add_argument("--dask", action="store_true",
                   help="one dask task per (model, method) sweep, on a local cluster "
                        "(--workers) or --scheduler")
    c.add_argument("--workers", type=int, default=2,
                   help=f"--dask: local worker processes, one thread each (1 ... "
                        f"{MAX_WORKERS}; default 2)")
    c.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="--dask: address of a running dask scheduler (tcp://host:8786) "
                        "instead of a local cluster (default: none, a local cluster)")
    c.add_argument("--readme", type=path_arg, default=None,
                   help="page whose marked bench section to rewrite (default: docs/guides/speed.md "
                        "when --out is docs/results/bench, full runs only)")
    c.add_argument("--out", type=path_arg, default=Path("docs/results/bench"),
                   help="output folder (default %(default)s)")
    s = _command(sub, "speed", "time at a target error of one model's FMU against scipy "
                 "-> docs/results/speed.json")
    s.add_argument("--model", default="heald_frame", help="the model (default heald_frame)")
    s.add_argument("--repeats", type=int, default=5,
                   help="timed runs per point, the median kept (>= 1; default 5)")
    s.add_argument("--scales", type=float, nargs="+", default=[1.0, 10.0],
                   help="scene lengths as multiples of the model's default experiment "
                        "(default 1 10)")
    s.add_argument("--out", type=path_arg, default=Path("docs/results/speed.json"),
                   help="the JSON file (default %(default)s)")
    f = _command(sub, "friction", "backrest: regularized against event-driven friction, "
                 "error and cost as eps shrinks -> docs/results/friction.json")
    f.add_argument("--repeats", type=int, default=5,
                   help="timed runs per point, the median kept (>= 1; default 5)")
    f.add_argument("--out", type=path_arg, default=Path("docs/results/friction.json"),
                   help="the JSON file (default %(default)s)")
    lim = _command(sub, "limit", "each model's verification run at C level against its "
                   "method's limit, FMPy beside it -> docs/results/limit.json, limit.md")
    lim.add_argument("--models", nargs="+", default=None, metavar="MODEL",
                     help="the models to run (default: every model of the registry)")
    lim.add_argument("--solvers", nargs="+", default=None, metavar="SOLVER",
                     help="the solvers (default: all)")
    lim.add_argument("--repeats", type=int, default=5,
                     help="C runs per row, the median kept (1 ... 64; default 5)")
    lim.add_argument("--best-of", type=int, default=5,
                     help="timing batches of one RHS/Jacobian call, the best kept "
                          "(1 ... 64; default 5)")
    lim.add_argument("--fmpy-repeats", type=int, default=5,
                     help="FMPy runs per row, the median kept (0: none; 0 ... 64; default 5)")
    lim.add_argument("--out", type=path_arg, default=None,
                     help="the JSON file (default docs/results/limit.json)")
    lim.add_argument("--page", type=path_arg, default=None,
                     help="the markdown page to write (default docs/guides/limit.md when --out "
                          "is not given, else none)")
    return ap, {"charts": c, "speed": s, "friction": f, "limit": lim}


def main(argv=None, prog: str = "loomfmu bench") -> int:
    ap, subs = _parser(prog)
    args = ap.parse_args(argv)
    charts_ = args.command == "charts"   # its --out is a folder, the others' a file
    outputs = {"files": ["readme", "page"] + ([] if charts_ else ["out"]),
               "folders": ["out"] if charts_ else []}
    check_output_options(args, **outputs, make=False)
    if args.command in ("speed", "friction") and args.repeats < 1:
        subs[args.command].error(f"--repeats {args.repeats}: allowed >= 1")
    if args.command == "speed":
        from loomfmu.registry import MODELS
        if args.model not in MODELS:
            subs["speed"].error(f"--model {args.model}: not a model; allowed: "
                                f"{', '.join(MODELS)}")
    if not charts_:
        check_output_options(args, **outputs)
    if args.command == "friction":
        return classic.main_friction(args)
    if args.command == "speed":
        return classic.main_speed(args)
    if args.command == "limit":
        try:
            return _main_limit(subs["limit"], args)
        except RuntimeError as exc:  # the C driver missing or failing: the work failed
            print(f"{prog} limit: failed: {str(exc).splitlines()[0]}", file=sys.stderr)
            return 1
    ap = subs["charts"]
    if args.models is None:
        args.models = list(BENCH)
    unknown = sorted(set(args.models) - set(BENCH))
    if unknown:
        ap.error(f"--models {' '.join(unknown)}: not a scene; allowed: {', '.join(BENCH)}")
    if not 1 <= args.workers <= MAX_WORKERS:
        ap.error(f"--workers {args.workers}: allowed 1 ... {MAX_WORKERS}")
    if (args.scheduler is not None or args.workers != 2) and not args.dask:
        ap.error("--workers and --scheduler go with --dask")
    if args.dask:
        from loomfmu.bench.dask import check_dask
        try:  # dask.distributed missing, a refused scheduler: one line, exit 2 (as sweep)
            check_dask(args.workers, args.scheduler)
        except (ValueError, ImportError) as exc:
            print(f"{prog}: error: {exc}", file=sys.stderr)
            return 2
    check_output_options(args, files=["readme", "page"], folders=["out"])  # now make them
    out = args.out
    readme = args.readme
    if readme is None and not args.quick and out == Path("docs/results/bench") and \
            Path("docs/guides/speed.md").exists():
        readme = Path("docs/guides/speed.md")
    charts(args.models, quick=args.quick, out=out, readme=readme,
           failures_on=not args.no_failures, cmd="loomfmu bench charts" + (
               " --dask" if args.dask else ""),
           dask={"workers": args.workers, "scheduler": args.scheduler} if args.dask else None,
           c_level=not args.no_c_level)
    return 0


def _main_limit(ap, args) -> int:
    from loomfmu.declare.solvers import SOLVERS
    from loomfmu.registry import MODELS
    models = args.models or list(MODELS)
    solvers = args.solvers or list(SOLVERS)
    for opt, given, allowed in (("--models", models, MODELS), ("--solvers", solvers, SOLVERS)):
        unknown = sorted(set(given) - set(allowed))
        if unknown:
            ap.error(f"{opt} {' '.join(unknown)}: allowed: {', '.join(allowed)}")
    for opt, value, lo in (("--repeats", args.repeats, 1), ("--best-of", args.best_of, 1),
                           ("--fmpy-repeats", args.fmpy_repeats, 0)):
        if not lo <= value <= 64:
            ap.error(f"{opt} {value}: allowed {lo} ... 64")
    out = args.out or Path("docs/results/limit.json")
    page = args.page
    if page is None and args.out is None:
        page = Path("docs/guides/limit.md")
    cmd = "loomfmu bench limit" + (f" --models {' '.join(models)}" if args.models else "") + (
        f" --solvers {' '.join(solvers)}" if args.solvers else "")

    def done(name, rows):
        for r in rows:
            ratio = "–" if r["ratio"] is None else f"{r['ratio']:.2f}"
            fm = f", FMPy {r['fmpy']['cpu_s'] * 1e3:.3g} ms" if "fmpy" in r else ""
            print(f"{name:24s} {r['solver']:8s} C run {r['cpu_s'] * 1e3:9.3g} ms, limit "
                  f"ratio {ratio}{fm}", flush=True)

    result = limit.limit(models, solvers, repeats=args.repeats, best_of=args.best_of,
                         fmpy_repeats=args.fmpy_repeats, on_model=done)
    limit.write(result, out, page, cmd)
    print(limit.table_md(result["rows"]))
    print(f"written: {out}" + (f", {page}" if page else "")
          + f"; loomfmu bench limit took {result['wall_seconds']:.0f} s")
    return 0
