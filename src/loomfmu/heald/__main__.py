"""loomfmu heald {claims, fidelity, design, tension-input}: see loomfmu.heald.claims
and loomfmu.heald.tension_input."""
from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from loomfmu.declare.checks import OneLineParser, check_number, check_output_options
from loomfmu.heald import claims as cl


def main(argv=None, prog: str = "loomfmu heald") -> int:
    ap = OneLineParser(prog=prog, description="Heald-frame analyses.")
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("claims", help="check the seeds' claims -> docs/guides/heald_claims.md")
    c.add_argument("--out", type=Path, default=Path("docs/guides/heald_claims.md"),
                   help="output file (default: %(default)s)")
    f = sub.add_parser("fidelity", help="rigid/planar vs spatial -> docs/guides/heald_fidelity.md")
    f.add_argument("--out", type=Path, default=Path("docs/guides/heald_fidelity.md"),
                   help="output file (default: %(default)s)")
    d = sub.add_parser("design", help="slat width b1 for a given gap to the next frame",
                       description="The smallest slat width b1 whose largest horizontal "
                       "mid-section displacement max |x2| over two frame cycles of the "
                       "spatial model stays below the gap (Brent's method on the scipy "
                       "reference). The criterion assumes the neighbouring frame's slat "
                       "stays where it is: where both frames deflect, what counts is their "
                       "relative motion.")
    d.add_argument("--gap", type=float, required=True,
                   help="clearance to the neighbouring frame, m (> 0)")
    d.add_argument("--d1", type=float, default=None,
                   help="slat wall thickness, m (default: the model's)")
    d.add_argument("--preset", default=None, metavar="NAME",
                   help="a seed-002 loom preset, e.g. 'STB-180 Texo' (default: the model's "
                        "own parameters)")
    d.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="a parameter of heald_frame, over the preset's (repeatable), "
                        "e.g. k_z=5")
    d.add_argument("--b1-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                   help="slat widths searched, m (default: 0.005 0.1; within 0.002 ... 0.2)")
    d.add_argument("--json", action="store_true", help="print the result as JSON")
    w = sub.add_parser("tension-input", help="the warp tension as an input: lockstep with "
                       "the geometry tension, shared defaults, the frame in opposition -> "
                       "docs/guides/heald_tension_input.md")
    w.add_argument("--out", type=Path, default=Path("docs/guides/heald_tension_input.md"),
                   help="output file (default: %(default)s)")
    args = ap.parse_args(argv)
    check_output_options(args, files=["out"])
    from loomfmu.progress import Progress
    if args.cmd == "claims":
        with Progress(total=1, desc="heald claims") as bar:
            bar.stage("simulating the seeds' scenes")
            text = cl.claims_markdown(cl.claims())
            bar.advance("done")
    elif args.cmd == "fidelity":
        from loomfmu.fmu.builder import build_fmu
        from loomfmu.fmu.platforms import HOST
        from loomfmu.registry import load_model
        levels = (("spatial", "heald_frame"), ("planar", "heald_frame_planar"),
                  ("rigid", "heald_frame_rigid"))
        with tempfile.TemporaryDirectory() as tmp, \
                Progress(total=len(levels) + 1, desc="heald fidelity") as bar:
            fmus = {}
            for level, name in levels:
                bar.stage(f"building {name}")
                fmus[level] = build_fmu(load_model(name), out_dir=tmp, platforms=HOST,
                    reference_results=False).path
                bar.advance(f"{name} built")
            bar.stage("simulating and comparing the three levels")
            text = cl.fidelity_markdown(cl.fidelity(fmus))
            bar.advance("compared")
    elif args.cmd == "tension-input":
        text = _tension_input(Progress)
    else:
        try:  # the arguments checked before the search starts
            values = _design_values(args)
            if args.b1_range:
                lo, hi = (check_number("--b1-range", b, lo=0.002, hi=0.2, unit="m")
                          for b in args.b1_range)
                if not lo < hi:
                    raise ValueError(f"--b1-range {lo:g} {hi:g}; allowed: LO < HI")
            kw = {"d1": args.d1, "values": values,
                  **({"b1_range": tuple(args.b1_range)} if args.b1_range else {})}
            cl.check_design(args.gap, **kw)
            with Progress(total=1, desc="heald design") as bar:
                bar.stage(f"searching the slat width b1 for gap {args.gap:g} m "
                          "(one spatial simulation per trial)")
                res = cl.design_section(args.gap, **kw)
                bar.advance("done")
        except ValueError as exc:
            print(f"{prog} design: error: {exc}", file=sys.stderr)
            return 2
        if args.json:
            print(json.dumps(res))
        else:
            _print_design(res)
        return 0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    print(text)
    print(f"written: {args.out}")
    return 0


def _tension_input(Progress) -> str:
    from loomfmu.fmu.builder import build_fmu
    from loomfmu.fmu.platforms import HOST
    from loomfmu.heald import tension_input as ti
    from loomfmu.registry import load_model
    with tempfile.TemporaryDirectory() as tmp, \
            Progress(total=4, desc="heald tension-input") as bar:
        bar.stage("building heald_frame (geometry and input tension), heald_frame_rigid (input)")
        geo = build_fmu(load_model("heald_frame"), out_dir=Path(tmp) / "geometry", platforms=HOST,
                    reference_results=False).path
        inp = build_fmu(load_model("heald_frame", warp_tension="input"),
                        out_dir=Path(tmp) / "input", platforms=HOST,
                    reference_results=False).path
        rigid = build_fmu(load_model("heald_frame_rigid", warp_tension="input"),
                          out_dir=Path(tmp) / "input", platforms=HOST,
                    reference_results=False).path
        bar.advance("built")
        bar.stage("lockstep runs at communication steps 1e-3, 1e-4, 1e-5 s")
        errors = ti.lockstep_errors(geo, inp)
        bar.advance("lockstep done")
        bar.stage("defaults")
        dflt = ti.defaults()
        bar.advance("defaults done")
        bar.stage("frames in opposition")
        opp = ti.opposition(rigid)
        bar.advance("done")
    return ti.markdown(errors, dflt, opp)


def _design_values(args) -> dict[str, float]:
    """heald_frame parameters for the design search: the preset's, then --set."""
    from loomfmu.mechanics.heald_presets import preset_values
    values = (dict(preset_values(args.preset, "heald_frame")) if args.preset is not None
              else {})
    for item in args.set:
        name, sep, text = item.partition("=")
        if not sep or not name.strip():
            raise ValueError(f"--set {item!r}; allowed: NAME=VALUE")
        try:
            values[name.strip()] = float(text)
        except ValueError:
            raise ValueError(f"--set {item!r}: {text!r} is not a number") from None
    return values


def _print_design(res: dict) -> None:
    """The design result with units (lengths in mm)."""
    labels = {"b1": "slat width b1", "d1": "wall thickness d1",
              "max_x2": "largest mid-section displacement max |x2|",
              "gap": "gap to the next frame (the bound on max |x2|)"}
    for key, value in res.items():
        if key in labels and isinstance(value, (int, float)):
            print(f"{labels[key]:<48}{value * 1e3:10.3f} mm")
        elif key == "b1_range":
            lo, hi = value
            print(f"{'slat widths searched':<48}{lo * 1e3:10.3f} ... {hi * 1e3:.3f} mm")
        else:
            print(f"{key:<48}{value}")
    print(f"{'clearance left (gap - max |x2|)':<48}"
          f"{(res['gap'] - res['max_x2']) * 1e3:10.3f} mm")


if __name__ == "__main__":
    sys.exit(main(prog="python -m loomfmu.heald"))
