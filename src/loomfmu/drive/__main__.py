"""loomfmu drive {table, charts, tracking}: see loomfmu.drive.report
and loomfmu.drive.tracking."""
from __future__ import annotations

import sys
from pathlib import Path

from loomfmu.declare.checks import OneLineParser, check_output_options
from loomfmu.drive import report


def main(argv=None, prog: str = "loomfmu drive") -> int:
    ap = OneLineParser(prog=prog, description="Spindle-drive analyses.")
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("table", help="law constants, Fourier coefficients, cam -> docs/guides/drive_law.md")
    t.add_argument("--out", type=Path, default=Path("docs/guides/drive_law.md"),
                   help="output file (default: %(default)s)")
    c = sub.add_parser("charts", help="speed law, cam profile, error vs m -> docs/results/drive/*.png")
    c.add_argument("--out-dir", type=Path, default=Path("docs/results/drive"),
                   help="output folder (default: %(default)s)")
    k = sub.add_parser("tracking", help="drive FMU with compensated / uncompensated cam "
                       "-> docs/guides/drive_tracking.md")
    k.add_argument("--out", type=Path, default=Path("docs/guides/drive_tracking.md"),
                   help="output file (default: %(default)s)")
    args = ap.parse_args(argv)
    check_output_options(args, files=["out"], folders=["out_dir"])
    if args.cmd == "tracking":
        from loomfmu.drive.tracking import write_tracking
        from loomfmu.progress import Progress
        with Progress(total=1, desc="drive tracking") as bar:
            bar.stage("simulating the drive FMU: both cams for 9 (tau, T), then the "
                      "assumed drive's cams on 9 other drives")
            text = write_tracking(args.out)
            bar.advance("done")
        print(text)
        print(f"written: {args.out}")
    elif args.cmd == "table":
        text = report.law_markdown()
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)
        print(text)
        print(f"written: {args.out}")
    else:
        for path in report.write_charts(args.out_dir):
            print(f"written: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
