"""The work behind ``loomfmu list|build|simulate|verify`` (parsing is in cli.py)."""
from __future__ import annotations

import difflib
import json
import math
import os
import sys
import tempfile
import zipfile
from pathlib import Path
from types import SimpleNamespace

from loomfmu.declare.checks import MAX_POINTS, check_output_options
from loomfmu.fidelity import LEVELS
from loomfmu.progress import Progress
from loomfmu.registry import FIDELITY, MODELS, load_model, option_defaults


class UsageError(Exception):
    """A command line that names something that does not exist or is out of range."""


# ---------------------------------------------------------------- arguments
def parse_value(text: str):
    """'3' -> 3, '2.5' -> 2.5, 'true' -> True, 'none' -> None, else the string."""
    low = text.strip().lower()
    if low in ("true", "false"):
        return low == "true"
    if low == "none":
        return None
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def parse_assignments(items: list[str], flag: str) -> dict:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise UsageError(f"{flag} {item!r}: expected NAME=VALUE")
        out[key.strip()] = parse_value(value)
    return out


def _suggest(name: str, allowed) -> str:
    close = difflib.get_close_matches(name, list(allowed), n=3)
    return f" (did you mean {', '.join(close)}?)" if close else ""


def check_model(name: str) -> None:
    if name not in MODELS:
        raise UsageError(f"model {name!r} is unknown{_suggest(name, MODELS)}; "
                         f"allowed: {', '.join(sorted(MODELS))}")


def declare_check_option(name: str, key: str) -> None:
    """A UsageError unless model ``name``'s build() takes option ``key``."""
    allowed = option_defaults(name)
    if key not in allowed:
        raise UsageError(f"--option {key}: model {name} has no such build option"
                         f"{_suggest(key, allowed)}; allowed: "
                         f"{', '.join(allowed) or 'none'}")


def declare(name: str, options: dict):
    """load_model with the options checked against the model's build()."""
    check_model(name)
    for key in options:
        declare_check_option(name, key)
    try:
        return load_model(name, **options)
    except ValueError as e:  # a value the model's build() refuses: say which --option
        if not options:
            raise
        given = " ".join(f"{k}={v}" for k, v in options.items())
        raise UsageError(f"--option {given}: {e}") from None


def check_range(flag: str, value: float, lo: float, hi: float | None = None) -> None:
    ok = math.isfinite(value) and value > lo and (hi is None or value < hi)
    if not ok:
        span = f"in ({lo:g}, {hi:g})" if hi is not None else f"> {lo:g}"
        raise UsageError(f"{flag} {value!r}: allowed: a finite number {span}")


# ---------------------------------------------------------------- list
def cmd_list(args) -> int:
    rows = {name: {"mechanism": next((m for m, lv in FIDELITY.items() if name in lv), "-"),
                   "options": option_defaults(name)} for name in sorted(MODELS)}
    if args.json:
        print(json.dumps({"models": rows, "fidelity": FIDELITY,
                          "levels": {n: vars(lv) for n, lv in LEVELS.items()}},
                         indent=2, default=str))
        return 0
    wn = max(len(n) for n in rows) + 2
    wm = max(len(r["mechanism"]) for r in rows.values()) + 2
    print(f"{'model':<{wn}}{'mechanism':<{wm}}build options (default)")
    for name, row in rows.items():
        opts = ", ".join(f"{k}={v!r}" for k, v in row["options"].items()) or "-"
        print(f"{name:<{wn}}{row['mechanism']:<{wm}}{opts}")
    print("\nfidelity levels, lowest first (docs/guides/fidelity.md):")
    for mech, levels in FIDELITY.items():
        print(f"  {mech}: {' < '.join(levels)}")
        for name in levels:
            lv = LEVELS[name]
            print(f"    {name}: leaves out {'; '.join(lv.leaves_out) or 'nothing'}")
            print(f"      represents {'; '.join(lv.represents)}; suffices: {lv.suffices}")
    return 0


# ---------------------------------------------------------------- build
def _worst(res: dict) -> tuple[str, dict]:
    name = max(res["errors"], key=lambda k: res["errors"][k]["max_rel_range"])
    return name, res["errors"][name]


def _table(head: list[tuple[str, str]], rows: list[list[str]]) -> str:
    """Columns as wide as their widest cell (header included), two spaces
    apart; head: (title, "<" or ">") per column."""
    widths = [max(len(h), *(len(r[k]) for r in rows)) for k, (h, _) in enumerate(head)]
    def line(cells):
        return "  ".join(f"{c:{a}{w}}" for c, (_, a), w in zip(cells, head, widths)).rstrip()
    return "\n".join([line([h for h, _ in head]), *(line(r) for r in rows)])


def summary(reports: dict[str, dict]) -> str:
    """One row per FMU and solver (or importer run); name: the FMU's variant
    (e.g. two_mass_force_fmi3_me)."""
    head = [("model", "<"), ("solver", "<"), ("worst output", "<"), ("max abs err", ">"),
            ("rel. to range", ">"), ("FMU s", ">"), ("scipy s", ">"), ("problems", ">")]
    rows = []
    for name, rep in reports.items():
        problems = str(len(rep["validation_problems"]))
        scipy_s = rep.get("reference_wall_seconds")
        scipy_s = "" if scipy_s is None else f"{scipy_s:.3f}"
        for solver, res in rep.get("solvers", {}).items():
            if res.get("error") or not res.get("errors"):
                rows.append([name, solver, "run failed (below)", "", "", "", scipy_s,
                             problems])
                continue
            worst, e = _worst(res)
            rows.append([name, solver, worst, f"{e['max_abs']:.3e}",
                         f"{e['max_rel_range']:.3e}", f"{res['wall_seconds']:.3f}", scipy_s,
                         problems])
        if "solvers" not in rep:
            rows.append([name, "-", "not verified", "", "", "", "", problems])
    return _table(head, rows)


def failures(reports: dict[str, dict], max_error: float) -> list[str]:
    out = [f"{name}: {len(r['validation_problems'])} validation problems: "
           f"{r['validation_problems'][0]}" for name, r in reports.items()
           if r["validation_problems"]]
    for name, r in reports.items():
        for solver, res in r.get("solvers", {}).items():
            if res.get("error") or not res.get("errors"):
                out.append(f"{name} {solver}: the run failed: {res.get('error', 'no result')}")
                continue
            worst = max(e["max_rel_range"] for e in res["errors"].values())
            if not worst <= max_error:
                out.append(f"{name} {solver}: error {worst:.3g} of the range > "
                           f"--max-error {max_error:g}")
    return out


def _verify_with_progress(fmu, model, bar: Progress, **kw) -> dict:
    from loomfmu.verification.verify import verify
    return verify(fmu, model, on_stage=lambda text: bar.stage(f"{model.name}: {text}"), **kw)


def _build_one(name: str, model, args, on_stage) -> tuple[str, dict]:
    """Build, verify and document one model; returns (FMU stem, report row)."""
    from loomfmu.fmu.builder import build_fmu
    from loomfmu.fmu.documentation import write_documentation
    from loomfmu.verification.verify import verify as verify_fmu
    on_stage(f"{name}: generating C, compiling, validating")
    result = build_fmu(model, out_dir=args.out_dir, fmi_version=args.fmi_version,
                       interface=args.interface, platforms=args.platforms)
    rep = {"fmu": str(result.path), "guid": result.guid,
           "fmi_version": result.fmi_version, "interface": result.interface,
           "platforms": list(result.platforms),
           "build_seconds": result.build_seconds,
           "validation_problems": result.problems, "options": args.option_values}
    verify = not args.no_verify and args.interface != "me"
    if verify:
        rep |= {"rtol": args.rtol, **verify_fmu(
            result.path, model, on_stage=lambda text: on_stage(f"{name}: {text}"),
            rtol=args.rtol)}
    elif not args.no_verify:
        rep["verification"] = ("not run: model exchange only (the importer's solver "
                               "integrates); 'loomfmu verify FMU' runs it once "
                               "through FMPy's CVode; build --interface both to "
                               "verify the embedded solvers")
    on_stage(f"{name}: documentation (equations in MathML)")
    write_documentation(result.path, model, verification=rep if verify else None,
                        readable=True)
    return result.path.stem, rep


def _build_in_worker(name: str, args) -> tuple[str, dict]:
    """One model's build in a worker process (declared there: a CasADi
    expression graph is not sent between processes)."""
    return _build_one(name, declare(name, args.option_values), args, lambda text: None)


def _build_all(names: list[str], models: dict, args, bar: Progress) -> dict[str, dict]:
    """Each model's report row, in the order of ``names``. With --jobs > 1 the
    models build in that many processes, the slowest known first (each build
    already compiles its C files on every core; the scipy reference, the FMU
    runs and the documentation of one model run on one)."""
    jobs = min(args.jobs, len(names))
    if jobs <= 1:
        rows = {}
        for name in names:
            stem, rows[stem] = _build_one(name, models[name], args, bar.stage)
            bar.advance(f"{name}: done")
        return rows
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    order = sorted(names, key=lambda n: -_BUILD_WEIGHT.get(n, 1.0))
    done: dict[str, tuple[str, dict]] = {}
    bar.stage(f"{len(names)} models in {jobs} processes")
    # What a worker needs of the command line (the parsed Namespace holds
    # argparse's own functions, which do not pickle).
    plain = SimpleNamespace(**{k: getattr(args, k) for k in (
        "out_dir", "fmi_version", "interface", "no_verify", "rtol", "option_values",
        "platforms")})
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(_build_in_worker, name, plain): name for name in order}
        for future in as_completed(futures):
            name = futures[future]
            done[name] = future.result()
            bar.advance(f"{name}: done")
    return dict(done[name] for name in names)


#: Relative cost of a model's build (generated C, scipy reference,
#: documentation), measured with ``loomfmu build`` at loomfmu 0.1.0: the
#: slowest start first so that the processes finish together.
_BUILD_WEIGHT = {"backrest_regularized": 78, "spindle": 70, "spindle_modal": 43,
                 "backrest": 22}


def cmd_build(args) -> int:
    check_output_options(args, folders=["out_dir"])
    check_range("--rtol", args.rtol, 0.0, 1.0)
    check_range("--max-error", args.max_error, 0.0)
    if args.jobs is None:
        args.jobs = os.cpu_count() or 1
    elif args.jobs < 1:
        raise UsageError(f"--jobs {args.jobs}: allowed: an integer >= 1")
    names = list(dict.fromkeys(args.models)) or sorted(MODELS)  # each model once
    for name in names:
        check_model(name)
    from loomfmu.fmu.platforms import ENV, parse
    if args.platforms is not None:  # before any build
        parse(args.platforms, args.fmi_version, arg="--platforms")
    elif os.environ.get(ENV, "").strip():
        parse(os.environ[ENV].strip(), args.fmi_version, arg=ENV)
    args.option_values = parse_assignments(args.option, "--option")
    for name in names:  # every option known to every model, before any build
        for key in args.option_values:
            declare_check_option(name, key)
    # Declared here when built here; each worker process declares its own.
    models = ({name: declare(name, args.option_values) for name in names}
              if min(args.jobs, len(names)) <= 1 else {})
    out_dir: Path = args.out_dir
    from loomfmu.fmu.platforms import select
    chosen, _ = select(args.platforms, args.fmi_version)
    print(f"loomfmu build: binaries for {', '.join(chosen)} (--platforms or ${ENV} choose; "
          "each cross compiler adds about the native compiling)", file=sys.stderr)
    with Progress(total=len(names), desc="build") as bar:
        reports = _build_all(names, models, args, bar)
    report_path = out_dir / "report.json"
    old = {}
    if report_path.exists():
        try:
            old = json.loads(report_path.read_text())
        except json.JSONDecodeError:
            old = {}
    report_path.write_text(json.dumps({**old, **reports}, indent=2, default=str))
    print(summary(reports))
    print(f"report: {report_path}")
    bad = failures(reports, args.max_error)
    for line in bad:
        print(f"FAILED {line}", file=sys.stderr)
    return 1 if bad else 0


# ---------------------------------------------------------------- simulate
def _fmu_description(path: Path, hint: str = ""):
    """The model description of the FMU file ``path``; a UsageError naming
    the file where it is missing, not a zip or has no readable
    modelDescription.xml."""
    import fmpy
    if not path.is_file() or not zipfile.is_zipfile(path):
        raise UsageError(f"FMU {str(path)!r} does not exist or is not an FMU (zip)" + hint)
    try:
        return fmpy.read_model_description(str(path))
    except Exception as exc:  # fmpy raises plain Exceptions for a bad description
        raise UsageError(f"FMU {str(path)!r} has no readable modelDescription.xml: "
                         f"{exc}") from None


def _description_of(target: str, options: dict):
    """The model description of an .fmu file, or of a model generated without
    compiling (so that names and values are checked before a build)."""
    import fmpy
    if target.endswith(".fmu") or os.sep in target or Path(target).is_file():
        md = _fmu_description(Path(target))  # a file: an FMU or nothing
        if options:
            raise UsageError("--option applies to a MODEL, not to a built FMU")
        return md, None
    from loomfmu.export.dae import dae_form
    from loomfmu.export.fmi_xml import model_description
    model = declare(target, options)
    xml = model_description(model, dae_form(model), "{00000000-0000-0000-0000-000000000000}",
                            ["model.c"])
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "modelDescription.xml"
        path.write_text(xml)
        return fmpy.read_model_description(str(path)), model


def _unit(var) -> str:
    unit = getattr(var, "unit", None) or (var.declaredType.unit if getattr(
        var, "declaredType", None) is not None else None)
    return unit or ""


def _bound(var, which: str):
    value = getattr(var, which, None)
    if value is None and getattr(var, "declaredType", None) is not None:
        value = getattr(var.declaredType, which, None)
    return None if value is None else float(value)


def display_units(md, unit: str) -> dict[str, tuple[float, float]]:
    """The display units the model description ``md`` defines under
    ``unit``: {name: (factor, offset)}, value_display = factor * value + offset."""
    for u in getattr(md, "unitDefinitions", None) or []:
        if u.name == unit:
            return {d.name: (float(d.factor), float(d.offset))
                    for d in getattr(u, "displayUnits", None) or []}
    return {}


def _display_unit(var) -> str:
    return getattr(var, "displayUnit", None) or (getattr(var.declaredType, "displayUnit", None)
                                                 if getattr(var, "declaredType", None)
                                                 is not None else None) or ""


def show_value(md, var, value: float, fmt: str = ".6g") -> str:
    """'25.1327 rad/s (240 rpm)': the value in its unit, and in its display
    unit where the model description gives it one."""
    from loomfmu.declare.units import show
    unit, shown = _unit(var), _display_unit(var)
    table = display_units(md, unit)
    return show(value, unit, shown if shown in table else "", table, fmt)


def _with_unit(md, name: str, var, value):
    """A Real's value given as text with a unit ('240rpm', '240 rpm') in the
    variable's unit; other values unchanged.  UsageError for a unit that
    does not measure the variable's quantity."""
    from loomfmu.declare.units import allowed_units, split_quantity, to_unit
    if var.type != "Real" or not isinstance(value, str):
        return value
    parsed = split_quantity(value)
    if parsed is None:
        return value
    number, given = parsed
    unit = _unit(var)
    table = display_units(md, unit)
    try:
        return to_unit(number, given, unit, table)
    except ValueError:
        allowed = allowed_units(unit, table)
        raise UsageError(f"--set {name}={value}: {name} is in {unit or 'no unit'}"
                         f"; allowed units: {', '.join(allowed) if allowed else 'none (a plain number)'}"
                         ) from None


def check_start_values(md, start: dict) -> dict:
    """Each --set NAME=VALUE against the model description: the name is a
    parameter, input or state; the value a number of the variable's type
    within its min/max (a Real's may carry a unit of the same quantity,
    '240rpm' or '240 rpm', converted to the variable's unit); an
    Enumeration also takes its item names."""
    variables = {v.name: v for v in md.modelVariables}
    from loomfmu.verification.fmpy_logger import settable_names
    settable = settable_names(md)
    out = {}
    for name, value in start.items():
        if name not in settable:
            raise UsageError(f"--set {name}: not a parameter, input or state of "
                             f"{md.modelName}{_suggest(name, settable)}; see the FMU's "
                             "documentation/index.html for the list")
        var = variables[name]
        given = value
        value = _with_unit(md, name, var, value)
        if var.type == "Enumeration" and isinstance(value, str):
            items = [item.name for item in var.declaredType.items]
            if value not in items:
                raise UsageError(f"--set {name}={value}: allowed: {', '.join(items)} "
                                 f"or 1..{len(items)}")
            value = items.index(value) + 1
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise UsageError(f"--set {name}={value!r}: allowed: a number")
        if var.type in ("Integer", "Enumeration") and not float(value).is_integer():
            raise UsageError(f"--set {name}={value!r}: allowed: an integer")
        lo, hi = _bound(var, "min"), _bound(var, "max")
        if var.type == "Enumeration" and hi is None:
            lo, hi = 1.0, float(len(var.declaredType.items))
        if not math.isfinite(value) or (lo is not None and value < lo) or \
                (hi is not None and value > hi):
            span = f"[{lo:g}, {hi:g}]" if lo is not None and hi is not None else \
                (f">= {lo:g}" if lo is not None else f"<= {hi:g}" if hi is not None
                 else "a finite number")
            if var.type == "Enumeration":
                span = (", ".join(item.name for item in var.declaredType.items)
                        + f", or {lo:g}..{hi:g}")
            unit = _unit(var)
            shown = _display_unit(var)
            table = display_units(md, unit)
            if shown in table and lo is not None and hi is not None:
                f, offset = table[shown]
                span += f" {unit} = [{f * lo + offset:g}, {f * hi + offset:g}] {shown}"
                unit = ""
            said = (f"{given} = {value!r} {_unit(var)}" if isinstance(given, str)
                    and given != value else f"{value!r}")
            raise UsageError(f"--set {name}={said}: allowed: {span}"
                             + (f" {unit}" if unit else ""))
        out[name] = int(value) if var.type in ("Integer", "Enumeration") else float(value)
    return out


def _plot_format_ok(path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig = plt.figure()
    kinds = fig.canvas.get_supported_filetypes()
    plt.close(fig)
    if path.suffix.lstrip(".").lower() not in kinds:
        raise UsageError(f"--plot {path}: allowed endings: {', '.join(sorted(kinds))}")


def _solver_name(md, value) -> str:
    var = next(v for v in md.modelVariables if v.name == "solver")
    return [item.name for item in var.declaredType.items][int(value) - 1]


def cmd_simulate(args) -> int:
    options = parse_assignments(args.option, "--option")
    check_range("--rtol", args.rtol, 0.0, 1.0)
    for flag, value in (("--stop", args.stop), ("--step", args.step)):
        if value is not None:
            check_range(flag, value, 0.0)
    check_output_options(args, files=["csv", "plot"])
    if args.plot:
        _plot_format_ok(args.plot)
    md, model = _description_of(args.target, options)
    variables = {v.name: v for v in md.modelVariables}
    me_only = md.coSimulation is None
    if me_only and args.solver is not None:
        raise UsageError(f"--solver {args.solver}: {Path(args.target).name} is model exchange "
                         "only: the importer (FMPy's CVode) integrates and the FMU's solver "
                         "parameter is unused; drop --solver (--rtol sets CVode's tolerance)")
    start = check_start_values(md, {**({} if me_only else {"solver": args.solver or "dopri5"}),
                                    **parse_assignments(args.set, "--set")})
    outputs = args.output or [v.name for v in md.modelVariables if v.causality == "output"]
    for name in outputs:
        if name not in variables:
            raise UsageError(f"--output {name}: {md.modelName} has no such variable"
                             f"{_suggest(name, variables)}")
    experiment = md.defaultExperiment
    stop = args.stop if args.stop is not None else float(experiment.stopTime)
    step = args.step if args.step is not None else float(experiment.stepSize)
    if step > stop:
        raise UsageError(f"--step {step!r} s is longer than the run (--stop {stop!r} s); "
                         f"allowed: a step <= {stop!r} s")
    if stop / step > MAX_POINTS:
        raise UsageError(f"--stop {stop:g} with --step {step:g} gives {stop / step:.3g} "
                         f"points; allowed: at most {MAX_POINTS}: choose a larger --step")
    solver = ("FMPy's CVode (model exchange: the importer integrates)" if me_only
              else _solver_name(md, start["solver"]))
    log: list[str] = []

    def logger(*args):  # FMI 2: (component, instance, status, category, message); FMI 3
        status, category, message = args[-3:]  # (environment, status, category, message)
        log.append((status, f"{category.decode()}: {message.decode()}"))

    with tempfile.TemporaryDirectory() as tmp:
        if model is None:
            fmu = Path(args.target)
        else:
            from loomfmu.fmu.builder import build_fmu
            from loomfmu.fmu.platforms import HOST
            with Progress(total=1, desc="build") as bar:
                bar.stage(f"{model.name}: generating C, compiling")
                fmu = build_fmu(model, out_dir=tmp, validate=False, platforms=HOST,
                    reference_results=False).path
                bar.advance(f"{model.name}: built")
        from loomfmu.verification.verify import quiet_callbacks
        try:
            with quiet_callbacks():
                from loomfmu.verification.fmpy_logger import simulate as fmpy_simulate
                res = fmpy_simulate(
                    str(fmu), validate=False, stop_time=stop,
                    fmi_type="ModelExchange" if me_only else "CoSimulation",
                    output_interval=step, relative_tolerance=args.rtol, start_values=start,
                    output=outputs, logger=logger)
        except Exception as exc:  # FMPy raises on fmi2Error/fmi2Discard
            print(f"loomfmu simulate: the FMU refused: {exc}", file=sys.stderr)
            for status, line in _up_to_first_failure(log):
                print(f"  [{STATUS[status]}] {line}", file=sys.stderr)
            return 1
    if args.csv:
        _write_csv(args.csv, res, outputs, variables)
    if args.plot:
        _write_plot(args.plot, res, outputs, variables, md.modelName)
    t = res["time"]
    print(f"{md.modelName}: {len(t)} points, t = {t[0]:g} .. {t[-1]:g} s, step {step:g} s, "
          f"solver {solver}, rtol {args.rtol:g}")
    given = [n for n in start if n in set(parse_assignments(args.set, "--set"))]
    if given:
        print("set: " + ", ".join(f"{n} = {show_value(md, variables[n], start[n])}"
                                  if variables[n].type == "Real" else f"{n} = {start[n]}"
                                  for n in given))
    print(f"{'variable':<16}{'final':>14}{'min':>14}{'max':>14}  unit")
    for name in outputs:
        y = res[name]
        print(f"{name:<16}{y[-1]:>14.6g}{y.min():>14.6g}{y.max():>14.6g}  "
              f"{_unit(variables[name])}")
        shown = _display_unit(variables[name])
        table = display_units(md, _unit(variables[name]))
        if shown in table:  # the same values in the display unit
            f, offset = table[shown]
            print(f"{'':<16}{f * y[-1] + offset:>14.6g}{f * y.min() + offset:>14.6g}"
                  f"{f * y.max() + offset:>14.6g}  {shown}")
    for status, line in log:
        if status != 0:
            print(f"  log [{STATUS[status]}] {line}")
    if args.csv:
        print(f"written: {args.csv}")
    if args.plot:
        shown = min(len(outputs), PLOT_MAX)
        more = (f" (the first {shown} of {len(outputs)} outputs; choose with --output)"
                if len(outputs) > shown else "")
        print(f"written: {args.plot}{more}")
    refused = [line for status, line in log if status >= 2]
    if refused:  # FMPy's CVode steps over a Discard of the derivatives: the run failed
        print(f"loomfmu simulate: the FMU refused {len(refused)} call(s) of the importer; "
              f"first: {refused[0]}", file=sys.stderr)
        return 1
    return 0


STATUS = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal", 5: "Pending"}
PLOT_MAX = 8


def _up_to_first_failure(log: list) -> list:
    """The FMU's log up to its first Discard/Error: what a master calls after
    that (FMPy steps on) only says the call order was wrong."""
    out = []
    for status, line in log:
        out.append((status, line))
        if status >= 2:
            break
    return out[-10:]


def _write_csv(path: Path, res, names: list[str], variables) -> None:
    import numpy as np
    path.parent.mkdir(parents=True, exist_ok=True)
    header = ",".join(["time [s]"] + [f"{n} [{_unit(variables[n])}]" if _unit(variables[n]) else n for n in names])
    data = np.column_stack([res["time"]] + [res[n] for n in names])
    np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.17g")


def _write_plot(path: Path, res, names: list[str], variables, title: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    shown = names[:PLOT_MAX]
    fig, axes = plt.subplots(len(shown), 1, sharex=True, squeeze=False,
                             figsize=(8, 1.6 + 1.5 * len(shown)))
    for ax, name in zip(axes[:, 0], shown):
        ax.plot(res["time"], res[name], lw=1.2)
        unit = _unit(variables[name])
        ax.set_ylabel(f"{name}\n[{unit}]" if unit else name)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    more = f" (first {len(shown)} of {len(names)})" if len(names) > len(shown) else ""
    fig.suptitle(f"{title}{more}")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ---------------------------------------------------------------- verify
def cmd_verify(args) -> int:
    from loomfmu.declare.solvers import SOLVERS
    check_range("--rtol", args.rtol, 0.0, 1.0)
    check_range("--max-error", args.max_error, 0.0)
    hint = (f"; {args.fmu} is a model: build it with 'loomfmu build {args.fmu}' and "
            f"pass dist/{args.fmu}.fmu" if str(args.fmu) in MODELS else "")
    md = _fmu_description(args.fmu, hint)
    from loomfmu.verification.verify import ME_LABEL, fmu_interfaces
    have = fmu_interfaces(md)
    name = args.model or md.modelName
    model = declare(name, parse_assignments(args.option, "--option"))
    if "cs" not in have and args.solver:
        raise UsageError(f"--solver {args.solver[0]}: {args.fmu.name} is model exchange only: "
                         "it is verified once, integrated by FMPy's CVode (its solver "
                         "parameter is unused); drop --solver")
    if "me" not in have and args.model_exchange:
        raise UsageError(f"--model-exchange: {args.fmu.name} has no model exchange interface")
    solvers = tuple(args.solver or SOLVERS) if "cs" in have else ()
    me = args.model_exchange or "cs" not in have
    # the variant, e.g. two_mass_force_fmi3_me; a renamed file: the model's name
    variant = args.fmu.stem if args.fmu.stem.startswith(md.modelName) else md.modelName
    with Progress(total=1, desc="verify") as bar:
        try:
            runs = _verify_with_progress(args.fmu, model, bar, rtol=args.rtol,
                                         solvers=solvers, model_exchange=me)
        except (RuntimeError, OSError) as exc:  # no binary for this platform, a bad one
            print(f"loomfmu verify: the FMU could not be run: {' '.join(str(exc).split())}",
                  file=sys.stderr)
            return 1
        rep = {"rtol": args.rtol, "validation_problems": [],
               "fmi_version": int(str(md.fmiVersion)[0]),
               "interface": "both" if len(have) == 2 else have[0], **runs}
        bar.advance(f"{variant}: done" + (f" ({ME_LABEL})" if me else ""))
    if args.document:
        from loomfmu.fmu.documentation import write_documentation
        write_documentation(args.fmu, model, verification=rep, readable=True)
        print(f"written: {args.fmu}!documentation/index.html")
    print(summary({variant: rep}))
    bad = failures({variant: rep}, args.max_error)
    for line in bad:
        print(f"FAILED {line}", file=sys.stderr)
    return 1 if bad else 0


# ---------------------------------------------------------------- check
def cmd_check(args) -> int:
    """Run the FMU's default experiment and compare it with the reference result
    it carries (FMI-LS-REF): per output the deviation relative to its range."""
    from loomfmu.fmu.reference_results import ReferenceResultError, check_fmu
    hint = (f" ({args.fmu} is a model: build it with 'loomfmu build {args.fmu}' and pass "
            f"dist/{args.fmu}.fmu)" if str(args.fmu) in MODELS else "")
    try:
        results = check_fmu(args.fmu, interface=args.interface)
    except ReferenceResultError as exc:
        raise UsageError(f"{exc}{hint}") from None
    except (RuntimeError, OSError) as exc:  # no binary for this platform, a failing run
        print(f"loomfmu check: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    head = [("interface", "<"), ("output", "<"), ("max abs dev", ">"),
            ("rel. to range", ">"), ("tolerance", ">"), ("", "<")]
    words = {"cs": "co-simulation", "me": "model exchange"}
    rows = [[words[r.interface], o.name, f"{o.max_abs:.3e}", f"{o.rel_range:.3e}",
             f"{r.tolerance:g}", "ok" if o.rel_range <= r.tolerance else "OUTSIDE"]
            for r in results for o in r.outputs]
    print(_table(head, rows))
    for r in results:
        w = r.worst
        print(f"{words[r.interface]}: worst {w.name} {w.rel_range:.3e} of its range "
              f"{'<=' if r.ok else '>'} {r.tolerance:g}: {'within' if r.ok else 'OUTSIDE'} "
              "the tolerance", file=sys.stdout if r.ok else sys.stderr)
    return 0 if all(r.ok for r in results) else 1
