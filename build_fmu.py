"""Build every loomfmu model into dist/<model>.fmu, validate and verify each,
write dist/report.json and print a summary table.

    python build_fmu.py [--out-dir dist] [--models heald_frame ...] [--rtol 1e-6]
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
    args = ap.parse_args(argv)
    reports = {name: build_one(name, args.out_dir, args.rtol) for name in args.models}
    (args.out_dir / "report.json").write_text(json.dumps(reports, indent=2))
    print(summary(reports))
    print(f"report: {args.out_dir / 'report.json'}")
    return 1 if any(r["validation_problems"] for r in reports.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
