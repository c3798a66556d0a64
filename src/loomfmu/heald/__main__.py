"""python -m loomfmu.heald {claims, fidelity, design}: see loomfmu.heald.claims."""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from . import claims as cl


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m loomfmu.heald")
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("claims", help="check the seeds' claims -> docs/heald_claims.md")
    c.add_argument("--out", type=Path, default=Path("docs/heald_claims.md"))
    f = sub.add_parser("fidelity", help="rigid/planar vs spatial -> docs/heald_fidelity.md")
    f.add_argument("--out", type=Path, default=Path("docs/heald_fidelity.md"))
    d = sub.add_parser("design", help="slat width b1 for a given gap to the next frame")
    d.add_argument("--gap", type=float, required=True, help="clearance (m)")
    d.add_argument("--d1", type=float, default=None, help="wall thickness (m)")
    args = ap.parse_args(argv)
    if args.cmd == "claims":
        text = cl.claims_markdown(cl.claims())
    elif args.cmd == "fidelity":
        from ..builder import build_fmu
        from ..registry import load_model
        with tempfile.TemporaryDirectory() as tmp:
            fmus = {f: build_fmu(load_model(n), out_dir=tmp).path for f, n in (
                ("spatial", "heald_frame"), ("planar", "heald_frame_planar"),
                ("rigid", "heald_frame_rigid"))}
            text = cl.fidelity_markdown(cl.fidelity(fmus))
    else:
        print(json.dumps(cl.design_section(args.gap, d1=args.d1)))
        return 0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    print(text)
    print(f"written: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
