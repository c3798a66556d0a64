"""``loomfmu``: the command-line front door (also ``python -m loomfmu``).

    loomfmu list                      models, build options, fidelity levels
    loomfmu build [MODEL ...]         build, validate, verify -> dist/*.fmu, report.json
                                      (--fmi-version 2|3 --interface cs|me|both
                                       --platforms linux64,win64,aarch64)
    loomfmu simulate MODEL|FMU        one run, printed, --csv / --plot
    loomfmu verify FMU                compare an FMU with its scipy reference
    loomfmu check FMU                 its default experiment against the reference inside it
    loomfmu docs                      docs/reference/models/<model>.md from the declarations
    loomfmu inspect MODEL | --all     derivation and equations, readable (docs/reference/inspect)
    loomfmu scene list|run|build|...  scenes co-simulated, composed into one FMU, SSP files
    loomfmu heald|drive|rotor|bench   the analyses (each has --help)

Exit codes: 0 done; 1 the work ran and failed (a verification above
--max-error, a simulation that returned Error/Discard); 2 a usage error (an
unknown model, option or value: one line saying what is allowed).
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
from pathlib import Path

from loomfmu.cli.commands import (
    UsageError,
    cmd_build,
    cmd_check,
    cmd_list,
    cmd_simulate,
    cmd_verify,
)
from loomfmu.declare.checks import OneLineParser, path_arg
from loomfmu.declare.solvers import SOLVERS
from loomfmu.fmu.builder import BuildError
from loomfmu.registry import MODELS

#: analyses whose own parser takes over after the subcommand: module, help
ANALYSES = {
    "heald": ("loomfmu.heald.__main__", "heald frame: claims | fidelity | design | tension-input"),
    "drive": ("loomfmu.drive.__main__", "spindle drive: table | charts | tracking"),
    "rotor": ("loomfmu.spindle.__main__", "spindle rotor: calibrate | trends | charts | all | critical"),
    "bench": ("loomfmu.bench.cli", "benchmarks: charts | speed | friction | limit"),
    "docs": ("loomfmu.inspection.model_pages", "docs/reference/models/<model>.md from the declarations"),
    "inspect": ("loomfmu.inspection.report",
                "a model's derivation and equations as HTML (MathML), Markdown or LaTeX"),
    "scene": ("loomfmu.cli.scene", "scenes, co-simulated or composed into one FMU: "
              "list | run | build | inspect | export | fidelity"),
    "sweep": ("loomfmu.cli.sweep", "studies on dask: design-map | drive-grid | hinge | trends | loom-stick | run"),
}


def _parser() -> argparse.ArgumentParser:
    ap = OneLineParser(
        prog="loomfmu", description="Textile-machine mechanisms as CasADi DAEs, exported "
                                    "as self-contained FMI 2.0/3.0 co-simulation and model-exchange FMUs.",
        epilog="Run 'loomfmu COMMAND --help' for a command's options.")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND", required=True)
    ap.set_defaults(_subparsers=sub.choices)

    p = sub.add_parser("list", help="models, their build options and fidelity levels",
                       description="List every model with its build options and the "
                                   "fidelity levels of each mechanism.")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")

    p = sub.add_parser("build", help="build, validate and verify FMUs",
                       description="Build MODELs (default: all) into OUT_DIR/<model>.fmu "
                                   "(FMI 2.0 co-simulation; other variants: "
                                   "OUT_DIR/<model>_fmi<VERSION>_<INTERFACE>.fmu, e.g. "
                                   "backrest_fmi3_me.fmu), validate each with FMPy, verify "
                                   "each solver against the scipy reference (co-simulation "
                                   "only: a model-exchange FMU is integrated by its importer), "
                                   "write OUT_DIR/report.json and "
                                   "documentation/index.html inside each FMU.")
    p.add_argument("models", nargs="*", metavar="MODEL",
                   help=f"models to build (default: all of {', '.join(sorted(MODELS))})")
    _option_arg(p)
    p.add_argument("--fmi-version", type=int, choices=[2, 3], default=2,
                   help="FMI version: 2 (FMI 2.0, the default) or 3 (FMI 3.0)")
    p.add_argument("--interface", choices=["cs", "me", "both"], default="cs",
                   help="cs: co-simulation with the embedded solvers (default); me: model "
                        "exchange (the importer integrates; not verified at build: 'loomfmu "
                        "verify FMU' runs it once through FMPy's CVode); both: one FMU with "
                        "both (the embedded solvers verified)")
    p.add_argument("--platforms", default=None, metavar="LIST",
                   help="binaries to build, comma-separated: linux64, win64, aarch64 (or "
                        "x86_64-linux, x86_64-windows, aarch64-linux; FMI 2.0 has no aarch64 "
                        "folder); default: $LOOMFMU_PLATFORMS, else every platform whose "
                        "compiler is installed (one line names those skipped)")
    p.add_argument("--no-verify", action="store_true",
                   help="skip the comparison with the scipy reference")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="build N models at once, each in its own process (>= 1; "
                        "default: the number of CPUs)")
    p.add_argument("--out-dir", type=path_arg, default=Path("dist"), help="default: dist")
    p.add_argument("--rtol", type=float, default=1e-6,
                   help="solver tolerance for the verification runs (0 < rtol < 1; "
                        "default 1e-6)")
    p.add_argument("--max-error", type=float, default=1e-3,
                   help="largest accepted error relative to the output's range (> 0; "
                        "default 1e-3); exit 1 above it")

    p = sub.add_parser("simulate", help="simulate one model or FMU",
                       description="Simulate a model (built on the fly into a temporary "
                                   "folder) or an .fmu file with FMPy; print the final "
                                   "values with units.")
    p.add_argument("target", metavar="MODEL|FMU")
    _option_arg(p)
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="start value of a parameter, input or state (repeatable)")
    p.add_argument("--stop", type=float, default=None,
                   help="stop time in s (default: the FMU's DefaultExperiment)")
    p.add_argument("--step", type=float, default=None,
                   help="communication step in s (default: the DefaultExperiment's)")
    p.add_argument("--solver", choices=SOLVERS, default=None,
                   help="embedded co-simulation solver (default dopri5); refused for a "
                        "model-exchange-only FMU, which the importer (FMPy's CVode) integrates")
    p.add_argument("--rtol", type=float, default=1e-6,
                   help="importer tolerance (0 < rtol < 1; default 1e-6)")
    p.add_argument("--output", action="append", default=None, metavar="NAME",
                   help="variable to record (repeatable; default: every output)")
    p.add_argument("--csv", type=path_arg, default=None, help="write the results as CSV")
    p.add_argument("--plot", type=path_arg, default=None, help="write a PNG chart")

    p = sub.add_parser("verify", help="compare an FMU with its scipy reference",
                       description="Run FMU with every embedded solver (or --solver) in "
                                   "co-simulation, or once with FMPy's CVode if it is model "
                                   "exchange only, and compare its outputs with a tight scipy "
                                   "reference of the same declaration.")
    p.add_argument("fmu", type=path_arg, metavar="FMU")
    p.add_argument("--model", default=None,
                   help="model name (default: the FMU's modelName)")
    _option_arg(p)
    p.add_argument("--solver", action="append", choices=SOLVERS, default=None,
                   help="embedded co-simulation solver to check (repeatable; default: all); "
                        "refused for a model-exchange-only FMU")
    p.add_argument("--model-exchange", action="store_true",
                   help="also run the FMU once as model exchange, integrated by FMPy's "
                        "CVode (the default, and the only run, for a model-exchange-only FMU)")
    p.add_argument("--rtol", type=float, default=1e-6, help="default 1e-6")
    p.add_argument("--max-error", type=float, default=1e-3, help="default 1e-3")
    p.add_argument("--document", action="store_true",
                   help="write the result into the FMU's documentation/index.html")

    p = sub.add_parser("check", help="an FMU's default experiment against the reference "
                                     "result inside it",
                       description="Run FMU's default experiment (the DefaultExperiment's "
                                   "stop time, tolerance and step) through FMPy in each "
                                   "interface it has and compare every output with the "
                                   "reference result the FMU carries under "
                                   "extra/org.fmi-standard.fmi-ls-ref (FMI-LS-REF): per "
                                   "output the largest deviation relative to its range, "
                                   "against the tolerance the FMU states. Exit 0 within it, "
                                   "1 outside it or if the run fails, 2 if FMU is missing, "
                                   "not an FMU or has no usable reference.")
    p.add_argument("fmu", type=path_arg, metavar="FMU")
    p.add_argument("--interface", choices=["cs", "me"], default=None,
                   help="only this interface (default: every one the FMU has)")

    for name, (_, helptext) in ANALYSES.items():
        p = sub.add_parser(name, help=helptext, add_help=False,
                           description=f"{helptext}. Run 'loomfmu {name} --help'.")
        p.add_argument("args", nargs=argparse.REMAINDER)
    return ap


def _option_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="build option of the model (repeatable; see 'loomfmu list')")


COMMANDS = {"list": cmd_list, "build": cmd_build, "simulate": cmd_simulate,
            "verify": cmd_verify, "check": cmd_check}


def main(argv: list[str] | None = None) -> int:
    ap = _parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in ANALYSES:  # the analysis' own parser reads the rest
        module, _ = ANALYSES[argv[0]]
        prog = f"loomfmu {argv[0]}"
        try:
            return importlib.import_module(module).main(argv[1:], prog=prog)
        except ValueError as exc:  # a value the analysis refused: a usage error
            ap.exit(2, f"{prog}: error: {exc}\n")
    args, extra = ap.parse_known_args(argv)
    if extra:  # said by the subcommand's parser, with its usage
        args._subparsers[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
    try:
        return COMMANDS[args.command](args)
    except BrokenPipeError:  # output piped into head & co.: stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except UsageError as exc:
        ap.exit(2, f"loomfmu {args.command}: error: {exc}\n")
    except ValueError as exc:  # a value the library refused: also a usage error
        ap.exit(2, f"loomfmu {args.command}: error: {exc}\n")
    except BuildError as exc:  # gcc or the symbol check failed: the work failed
        ap.exit(1, f"loomfmu {args.command}: build failed: {exc}\n")


if __name__ == "__main__":
    sys.exit(main())
