"""Build every loomfmu model into dist/<model>.fmu, validate and verify each,
write dist/report.json and print a summary table.

    python build_fmu.py [--out-dir dist] [--models heald_frame ...] [--rtol 1e-6]
                        [--max-error 1e-3]

Exits 1 if an FMU has a validation problem or if any solver's worst output
misses the reference by more than --max-error (relative to the output's
range; at rtol 1e-6 the models stay below 1e-3, with the spindle's modal
model, 2e-4, the closest: its micrometre states meet atol 1e-9).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from loomfmu import MODELS, build_fmu, load_model
from loomfmu.verify import verify


def build_one(name: str, out_dir: Path, rtol: float) -> dict:
    model = load_model(name)
    result = build_fmu(model, out_dir=out_dir)
    report = verify(result.path, model, rtol=rtol)
    return {"fmu": str(result.path), "guid": result.guid,
            "build_seconds": result.build_seconds, "validation_problems": result.problems,
            "rtol": rtol, **report}


def summary(reports: dict[str, dict]) -> str:
    lines = [f"{'model':<22}{'solver':<8}{'worst output':<14}{'max abs err':>13}"
             f"{'rel. to range':>15}{'FMU s':>9}{'scipy s':>9}{'problems':>10}"]
    for name, rep in reports.items():
        for solver, res in rep["solvers"].items():
            worst = max(res["errors"], key=lambda k: res["errors"][k]["max_rel_range"])
            e = res["errors"][worst]
            lines.append(f"{name:<22}{solver:<8}{worst:<14}{e['max_abs']:>13.3e}"
                         f"{e['max_rel_range']:>15.3e}{res['wall_seconds']:>9.3f}"
                         f"{rep['reference_wall_seconds']:>9.3f}"
                         f"{len(rep['validation_problems']):>10d}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", type=Path, default=Path("dist"))
    ap.add_argument("--models", nargs="*", default=sorted(MODELS), choices=sorted(MODELS))
    ap.add_argument("--rtol", type=float, default=1e-6)
    ap.add_argument("--max-error", type=float, default=1e-3,
                    help="largest accepted error relative to the output's range")
    args = ap.parse_args(argv)
    if not 0 < args.rtol < 1:
        ap.error(f"--rtol {args.rtol}: allowed (0, 1)")
    if not args.max_error > 0:
        ap.error(f"--max-error {args.max_error}: allowed > 0")
    reports = {name: build_one(name, args.out_dir, args.rtol) for name in args.models}
    (args.out_dir / "report.json").write_text(json.dumps(reports, indent=2))
    print(summary(reports))
    print(f"report: {args.out_dir / 'report.json'}")
    failures = [f"{name}: {len(r['validation_problems'])} validation problems"
                for name, r in reports.items() if r["validation_problems"]]
    for name, r in reports.items():
        for solver, res in r["solvers"].items():
            worst = max(e["max_rel_range"] for e in res["errors"].values())
            if not worst <= args.max_error:
                failures.append(f"{name} {solver}: error {worst:.3g} of the range > "
                                f"--max-error {args.max_error:g}")
    for line in failures:
        print(f"FAILED {line}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
