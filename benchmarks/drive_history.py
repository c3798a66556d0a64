"""The drive's state delay with a fast cam, per solver: max |n - n_ref| (rpm)
against the scipy method-of-steps reference (rtol 1e-11), 10 s, on the scene
of tests/test_drive_fmu.py (3 harmonics, 8th near 190 Hz). The delayed
values come from the history sampled on each solver's dense output, so the
result measures that dense output. Quoted in docs/guides/drive.md.

    python benchmarks/drive_history.py      # ~1 min
"""
from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_drive_fmu import CAM  # noqa: E402  (the scene the tests use)

from loomfmu import build_fmu  # noqa: E402
from loomfmu.models.drive import build  # noqa: E402
from loomfmu.verification.reference import reference  # noqa: E402
from loomfmu.verification.verify import compare, simulate  # noqa: E402


def main() -> int:
    model = build(cam="none", harmonics=3, max_delay=2.0)
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_fmu(model, out_dir=tmp).path
        grid = simulate(fmu, output=["n_out"], values=CAM, stop_time=10.0).t
        ref = reference(model, t_end=grid[-1], t_eval=grid, rtol=1e-11, atol=1e-9, values=CAM)
        print("| solver | rtol 1e-6 | rtol 1e-9 |\n|---|---|---|")
        for solver in ("dopri5", "rk4", "rodas4", "ros34pw2"):
            errs = []
            for rtol in (1e-6, 1e-9):
                values = {**CAM, "solver_h_fixed": 2e-3} if solver == "rk4" else CAM
                run = simulate(fmu, solver=solver, rtol=rtol, atol=1e-8, stop_time=10.0,
                               output=["n_out"], values=values)
                # n_out is rad/s; the table is in rpm
                errs.append(compare(run, ref, ["n_out"])["n_out"]["max_abs"] * 60 / (2 * math.pi))
            print(f"| {solver} | {errs[0]:.3g} | {errs[1]:.3g} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
