"""``loomfmu rotor``: the spindle rotor's studies from the command line
(calibrate, trends, charts, all, critical)."""
from __future__ import annotations

import sys
from pathlib import Path

from loomfmu.declare.checks import OneLineParser, check_number, check_output_options
from loomfmu.progress import Progress
from loomfmu.spindle.study import DOCS, WORK_RPM, Spindle, write_calibration
from loomfmu.spindle.trends import STUDIES, write_charts, write_trends

#: a critical speed within this fraction of the working speed is flagged
CRITICAL_MARGIN = 0.1


def _critical(args) -> int:
    """loomfmu rotor critical: the critical speeds of both bobbins, flagged
    within CRITICAL_MARGIN of the working speed."""
    values = {}
    for item in args.set:
        name, sep, text = item.partition("=")
        if not sep or not name.strip():
            raise ValueError(f"--set {item!r}; allowed: NAME=VALUE")
        try:
            values[name.strip()] = float(text)
        except ValueError:
            raise ValueError(f"--set {item!r}: {text!r} is not a number") from None
    if "fill" in values:
        raise ValueError("--set fill: both bobbins are computed (fill 0 and 1); allowed: "
                         "other parameters")
    speed = check_number("--speed", args.speed, lo=0.0, lo_open=True, hi=1e5, unit="rpm")
    sp = Spindle({})
    sp.values(**values)   # names and ranges checked before the scan
    top = max(40000.0, 2.5 * speed)
    print(f"critical speeds (forward whirl = spin speed) up to {top:g} rpm; working speed "
          f"{speed:g} rpm" + (f"; {', '.join(f'{k} = {v:g}' for k, v in values.items())}"
                              if values else ""))
    near = []
    for label, fill in (("empty bobbin", 0.0), ("full bobbin", 1.0)):
        crit = sp.critical_speeds({**values, "fill": fill}, max_rpm=top)
        text = ", ".join(f"{c:.0f} ({100 * (c - speed) / speed:+.0f} %)" for c in crit)
        print(f"  {label:<13} {text or 'none'}")
        near += [(label, c) for c in crit if abs(c - speed) <= CRITICAL_MARGIN * speed]
    for label, c in near:
        print(f"warning: {label}: a critical speed at {c:.0f} rpm is within "
              f"{100 * CRITICAL_MARGIN:g} % of the working speed {speed:g} rpm",
              file=sys.stderr)
    return 0


def main(argv=None, prog: str = "loomfmu rotor") -> int:
    ap = OneLineParser(prog=prog, description="Spindle studies (seed 003): "
                                 "calibration to the seed's natural frequencies, amplitude "
                                 "against speed, section V's parameter trends, charts.")
    ap.add_argument("command", choices=["calibrate", "trends", "charts", "all", "critical"],
                    help="critical: the critical speeds (forward whirl = spin speed) of "
                         "the empty and the full bobbin and their margin to the working "
                         "speed, printed (--set, --speed); "
                         "calibrate: fit the supports to the seed's six frequencies -> "
                         "OUT/spindle_calibration.md; trends: parameter studies -> "
                         "OUT/spindle_trends.md and OUT/spindle/trend_*.png; charts: "
                         "Campbell, unbalance response, compliance -> OUT/spindle/*.png; all: the "
                         "three in turn")
    ap.add_argument("--out", type=Path, default=DOCS,
                    help="output folder (default: %(default)s)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="critical: a spindle parameter (repeatable), e.g. k_d=0.8")
    ap.add_argument("--speed", type=float, default=WORK_RPM,
                    help=f"critical: the working speed, rpm (default {WORK_RPM:g})")
    args = ap.parse_args(argv)
    if args.command == "critical":
        try:
            return _critical(args)
        except ValueError as exc:
            ap.exit(2, f"{prog} critical: error: {exc}\n")
    if args.set or args.speed != WORK_RPM:
        ap.error("--set and --speed apply to the command critical")
    check_output_options(args, folders=["out"])
    todo = ["calibrate", "trends", "charts"] if args.command == "all" else [args.command]
    with Progress(total=len(todo), desc="rotor") as bar:
        for what in todo:
            if what == "calibrate":
                bar.stage("calibrating the supports to the seed's six frequencies")
                out = args.out / "spindle_calibration.md"
                write_calibration(out)
                print(f"written: {out}\nwritten: {out.with_suffix('.json')}")
            elif what == "trends":
                bar.stage("parameter studies (4 studies)")
                out = args.out / "spindle_trends.md"
                write_trends(out)
                for path in [out, out.with_suffix(".json")] + [
                        out.parent / "spindle" / f"trend_{name}.png" for name in STUDIES]:
                    print(f"written: {path}")
            else:
                bar.stage("Campbell diagram, unbalance response, compliance")
                for path in write_charts(args.out / "spindle"):
                    print(f"written: {path}")
            bar.advance(f"{what}: done")
    return 0


if __name__ == "__main__":  # python -m loomfmu.spindle calibrate|trends|charts|all|critical
    sys.exit(main())
