"""loomfmu scene {list, run, build, inspect, export, fidelity}: scenes co-simulated or
composed into one model (docs/guides/scenes.md, docs/guides/composed.md;
fidelity: docs/guides/fidelity.md).

Exit codes: 0 done; 1 the run failed (an FMU returned Error/Discard, the
adaptive step fell below its minimum); 2 a usage error (one line).
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from loomfmu.declare.checks import OneLineParser, check_output_options, path_arg
from loomfmu.declare.solvers import SOLVERS
from loomfmu.machines.fidelity import add_parser as add_fidelity_parser
from loomfmu.machines.library import SCENES, load_scene
from loomfmu.scene.master import MASTERS


def _parser(prog: str) -> argparse.ArgumentParser:
    ap = OneLineParser(prog=prog, description="Co-simulation scenes: FMUs connected in Python, "
                 "run on loomfmu's master or exported as SSP.")
    sub = ap.add_subparsers(dest="cmd", required=True, parser_class=OneLineParser)
    sub.add_parser("list", help="the scenes, their components and connections")
    r = sub.add_parser("run", help="run a scene on our master; print the final values")
    r.add_argument("scene", help=f"one of {', '.join(sorted(SCENES))}")
    r.add_argument("--master", choices=sorted(MASTERS), default=None,
                   help="master algorithm (default: the scene's recommended one, see "
                        "'loomfmu scene list')")
    r.add_argument("--step", type=float, default=None,
                   help="communication step in s (> 0; default: the scene's); with "
                        "--adaptive the first step")
    r.add_argument("--adaptive", action="store_true",
                   help="control the step by the coupling error estimate (--rtol)")
    r.add_argument("--rtol", type=float, default=1e-3,
                   help="tolerance of the adaptive step (0 < rtol < 1; default 1e-3)")
    r.add_argument("--extrapolation", type=int, choices=(0, 1, 2), default=None,
                   help="order of the input extrapolation (0: hold; 1, 2: polynomial "
                        "through the last 2-3 values, for FMUs that interpolate inputs; "
                        "default: the scene's recommended order)")
    r.add_argument("--output-derivatives", action="store_true",
                   help="with --extrapolation 1: take the slope from the sources' "
                        "output derivatives instead of their last values")
    r.add_argument("--order", default=None,
                   help="gauss-seidel: the components in stepping order, comma-separated "
                        "(default: the scene's)")
    r.add_argument("--stop", type=float, default=None,
                   help="stop time in s (> 0; default: the scene's)")
    r.add_argument("--coupling", choices=("cosim", "monolithic"), default="cosim",
                   help="cosim: the components' FMUs on our master (default); monolithic: "
                        "the scene composed into one model and FMU (no master, no "
                        "coupling step: the options of the master do not apply)")
    r.add_argument("--solver", choices=SOLVERS, default="dopri5",
                   help="--coupling monolithic: the composed FMU's solver (default dopri5)")
    r.add_argument("--solver-rtol", type=float, default=1e-6,
                   help="--coupling monolithic: the solver's relative tolerance (default "
                        "1e-6)")
    r.add_argument("--csv", type=path_arg, default=None, help="write the results as CSV")
    r.add_argument("--fmu-dir", type=path_arg, default=None,
                   help="folder to build the FMUs into and reuse (default: a temporary one)")
    b = sub.add_parser("build", help="compose the scene into one model and build its FMU")
    b.add_argument("scene", help=f"one of {', '.join(sorted(SCENES))}")
    b.add_argument("--fmi-version", type=int, choices=(2, 3), default=2,
                   help="FMI version (default 2)")
    b.add_argument("--interface", choices=("cs", "me", "both"), default="cs",
                   help="co-simulation (default), model exchange or both")
    b.add_argument("--out-dir", type=path_arg, default=Path("dist"),
                   help="folder of the FMU (default: dist)")
    b.add_argument("--platforms", default=None, metavar="LIST",
                   help="binaries to build, comma-separated (as loomfmu build --platforms); "
                        "default: $LOOMFMU_PLATFORMS, else every platform whose compiler is "
                        "installed")
    b.add_argument("--reference", action="store_true",
                   help="carry the default experiment's reference result (FMI-LS-REF), "
                        "computed by the scipy reference: a second for two_mass, about 80 s for "
                        "loom, far longer for spinning")
    i = sub.add_parser("inspect", help="the scene composed into one model: its derivation "
                       "and equations as loomfmu inspect writes a model's")
    i.add_argument("scene", help=f"one of {', '.join(sorted(SCENES))}")
    i.add_argument("--format", choices=("html", "md", "tex"), default="html",
                   help="html (MathML, default), md (Markdown with LaTeX) or tex")
    i.add_argument("--out", type=path_arg, default=None,
                   help="file to write (default: SCENE.FORMAT; '-' prints it)")
    e = sub.add_parser("export", help="write the scene as an SSP file")
    e.add_argument("scene", help=f"one of {', '.join(sorted(SCENES))}")
    e.add_argument("--out", type=path_arg, default=None,
                   help="the .ssp file (default: ./<scene>.ssp)")
    e.add_argument("--fmu-dir", type=path_arg, default=None,
                   help="folder to build the FMUs into and reuse (default: a temporary one)")
    add_fidelity_parser(sub)
    return ap


def _list() -> int:
    for name, (factory, text) in sorted(SCENES.items()):
        s = factory()
        print(f"{name}: {text}")
        print(f"  recommended: master {s.master}, extrapolation {s.extrapolation}, step "
              f"{s.step:g} s (the defaults of 'loomfmu scene run {name}')")
        for c in s.components.values():
            print(f"  component {c.name}: {c.source}")
        for c in s.connections:
            print(f"  connection {c}" + (f"  [{c.port}]" if c.port else ""))
        for loop in s.loops():
            print("  algebraic loop (iterated): " + "; ".join(map(str, loop)))
    return 0


def _build(args) -> int:
    from loomfmu.fmu.builder import build_fmu
    from loomfmu.fmu.platforms import parse
    from loomfmu.scene.compose import compose
    check_output_options(args, folders=["out_dir"])
    if args.platforms is not None:   # a bad list: one line before any work
        parse(args.platforms, args.fmi_version, arg="--platforms")
    model = compose(load_scene(args.scene))
    res = build_fmu(model, out_dir=args.out_dir, fmi_version=args.fmi_version,
                    interface=args.interface, platforms=args.platforms,
                    reference_results=args.reference)
    n = {k: len(model.of_kind(k)) for k in ("state", "algebraic", "input", "output")}
    print(f"written: {res.path} ({res.build_seconds:.1f} s; {n['state']} states, "
          f"{n['algebraic']} algebraic variables, {n['input']} inputs, {n['output']} "
          f"outputs, {len(model.events)} event indicators, {len(model.delays)} delays); "
          f"FMPy validation: {len(res.problems)} problem(s)")
    for p in res.problems:
        print(f"  {p}")
    return 1 if res.problems else 0


def _inspect(args) -> int:
    from loomfmu.inspection.report import report
    from loomfmu.scene.compose import compose
    out = args.out if args.out is not None else Path(f"{args.scene}.{args.format}")
    if str(out) != "-":
        check_output_options(argparse.Namespace(out=out), files=["out"])
    text = report(compose(load_scene(args.scene)), args.format)
    if str(out) == "-":
        sys.stdout.write(text)
        return 0
    out.write_text(text, encoding="utf-8")
    print(f"written: {out}")
    return 0


def _run_monolithic(args, prog: str, s) -> int:
    from loomfmu.scene.monolithic import run_monolithic
    given = [f"--{o.replace('_', '-')}" for o, default in (
        ("master", None), ("adaptive", False), ("extrapolation", None), ("order", None),
        ("output_derivatives", False), ("rtol", 1e-3)) if getattr(args, o) != default]
    if given:
        raise ValueError(f"{', '.join(given)}: options of the co-simulation master; allowed "
                         "with --coupling monolithic: --step, --stop, --solver, "
                         "--solver-rtol, --csv, --fmu-dir")
    try:
        res = run_monolithic(s, step=args.step, stop=args.stop, solver=args.solver,
                             rtol=args.solver_rtol, fmu_dir=args.fmu_dir)
    except RuntimeError as exc:
        print(f"{prog}: run failed: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    last = res.data[-1]
    print(f"scene {s.name}, composed into one FMU (solver {args.solver}, rtol "
          f"{args.solver_rtol:g}): {res.accepted} output steps, t = {last['time']:.6g} s")
    _print_values(s, res)
    if args.csv is not None:
        print(f"written: {res.to_csv(args.csv)}")
    return 0


def _print_values(s, res) -> None:
    last = res.data[-1]
    for name in res.data.dtype.names[1:]:
        comp, var = name.split(".", 1)
        unit = s.components[comp].interface.variables[var].unit
        print(f"  {name} = {last[name]:.9g}" + (f" {unit}" if unit else ""))
    for comp, lines in res.log.items():
        if lines:
            print(f"  {comp} logged {len(lines)} line(s), the last: {lines[-1]}")


def _run(args, prog: str) -> int:
    from loomfmu.scene.run import UNRESOLVED, UnresolvedCoupling, run, unresolved_message
    from loomfmu.scene.system import FMUError
    check_output_options(args, files=["csv"], folders=["fmu_dir"])
    s = load_scene(args.scene)
    if args.coupling == "monolithic":
        return _run_monolithic(args, prog, s)
    given = [o for o, a, default in (("--solver", args.solver, "dopri5"),
                                     ("--solver-rtol", args.solver_rtol, 1e-6)) if a != default]
    if given:
        raise ValueError(f"{', '.join(given)}: options of the composed FMU; allowed with "
                         "--coupling cosim: the master's options (--master, --step, ...)")
    master = s.master if args.master is None else args.master
    extrapolation = s.extrapolation if args.extrapolation is None else args.extrapolation
    opts = {}
    if args.order is not None:
        if master != "gauss-seidel":
            raise ValueError(f"--order {args.order}: applies to --master gauss-seidel only "
                             f"(the master is {master})")
        opts["order"] = [x.strip() for x in args.order.split(",")]
    if args.output_derivatives:
        opts["output_derivatives"] = True
    try:
        with warnings.catch_warnings():   # said below, as a line of the command
            warnings.simplefilter("ignore", UnresolvedCoupling)
            res = run(s, master=master, step=args.step, stop=args.stop,
                      adaptive=args.adaptive, rtol=args.rtol, fmu_dir=args.fmu_dir,
                      progress=True, extrapolation=extrapolation, master_options=opts)
    except (FMUError, RuntimeError) as exc:
        one_line = " ".join(str(exc).split())
        print(f"{prog}: run failed: {one_line}", file=sys.stderr)
        return 1
    last = res.data[-1]
    chosen = [w for w, a in (("master", args.master), ("extrapolation", args.extrapolation),
                             ("step", args.step)) if a is None]
    print(f"scene {s.name}, master {res.master}, extrapolation {res.extrapolation}"
          + (f" ({', '.join(chosen)}: the scene's recommendation)" if chosen else "") + ": "
          f"{res.accepted} steps accepted, {res.rejected} rejected, t = {last['time']:.6g} s"
          + (f", {res.loop_iterations} loop iterations" if res.loop_iterations else ""))
    for name in res.data.dtype.names[1:]:
        comp, var = name.split(".", 1)
        unit = s.components[comp].interface.variables[var].unit
        print(f"  {name} = {last[name]:.9g}" + (f" {unit}" if unit else ""))
    for note in res.notes:
        print(f"  note: {note}")
    change, name = res.largest_step_change()
    if change > UNRESOLVED:
        advice = "a smaller --rtol" if args.adaptive else "a smaller --step, or --adaptive"
        print(f"{prog}: warning: " + unresolved_message(change, name).replace(
            "a smaller step, or the adaptive step", advice), file=sys.stderr)
    elif name:
        print(f"  largest change within one step: {100 * change:.3g} % of {name}'s largest "
              "magnitude (the coupling error grows with it: compare a run at half the "
              "step" + (", or a smaller --rtol)" if args.adaptive else ", or use --adaptive)"))
    for comp, lines in res.log.items():
        if lines:
            print(f"  {comp} logged {len(lines)} line(s), the last: {lines[-1]}")
    if args.csv is not None:
        print(f"written: {res.to_csv(args.csv)}")
    return 0


def main(argv=None, prog: str = "loomfmu scene") -> int:
    args = _parser(prog).parse_args(argv)
    try:
        if args.cmd == "list":
            return _list()
        if args.cmd == "run":
            return _run(args, f"{prog} run")
        if args.cmd == "build":
            return _build(args)
        if args.cmd == "inspect":
            return _inspect(args)
        if args.cmd == "fidelity":
            from loomfmu.machines.fidelity import main as fidelity
            return fidelity(args)
        from loomfmu.scene.ssp import export_ssp
        out = args.out if args.out is not None else Path(f"{args.scene}.ssp")
        check_output_options(argparse.Namespace(out=out, fmu_dir=args.fmu_dir),
                             files=["out"], folders=["fmu_dir"])
        print(f"written: {export_ssp(load_scene(args.scene), out, fmu_dir=args.fmu_dir)}")
        return 0
    except ValueError as exc:
        print(f"{prog} {args.cmd}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
