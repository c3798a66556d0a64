"""Run-up of the spindle through its first critical speed to 16 000 rpm:
the full FE FMU against the modal FMUs, and the real-time factor of each.

    python benchmarks/spindle_runup.py [--modes 1 2 3 4 5 6] [--solver rodas4]
        [--out docs/spindle_runup.json]

Scene: n_rpm ramps linearly from 0 to 16 000 rpm in ``RAMP`` seconds and is
held for ``HOLD`` seconds, set at every communication step (``DT``) as the
drive would; bobbin and whorl eccentricity 5 um each.  The error of a
reduced model is max_t |r_top,red - r_top,full| / max_t r_top,full (r_top:
radial displacement of the top of the blade).  Real-time factor: wall time /
simulated time (below 1: faster than real time), median of ``--repeats``.
"""
from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import fmpy
import numpy as np

from loomfmu import build_fmu, load_model
from loomfmu.codegen import SOLVERS

RAMP, HOLD, DT, TOP_RPM, ECC = 1.0, 0.25, 2e-4, 16000.0, 5e-6
ROOT = Path(__file__).resolve().parents[1]


def scene(t_end: float = RAMP + HOLD) -> np.ndarray:
    t = np.arange(0.0, t_end + DT / 2, DT)
    sig = np.zeros(len(t), dtype=[("time", float), ("n_rpm", float), ("e_b", float),
                                  ("e_w", float)])
    sig["time"], sig["n_rpm"] = t, TOP_RPM * np.clip(t / RAMP, 0, 1)
    sig["e_b"], sig["e_w"] = ECC, ECC
    return sig


def run(fmu: Path, solver: str, rtol: float, repeats: int):
    sig = scene()
    md = fmpy.read_model_description(str(fmu))
    times, res = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = fmpy.simulate_fmu(str(fmu), model_description=md, stop_time=sig["time"][-1],
                                output_interval=DT, input=sig, relative_tolerance=rtol,
                                start_values={"solver": SOLVERS.index(solver) + 1,
                                              "solver_atol": 1e-12},
                                output=["r_top", "r_footstep"])
        times.append(time.perf_counter() - t0)
    return res, statistics.median(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", type=int, nargs="*", default=[1, 2, 3, 4, 5, 6, 8])
    ap.add_argument("--solver", default="rodas4", choices=SOLVERS)
    ap.add_argument("--rtol", type=float, default=1e-6)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "spindle_runup.json")
    args = ap.parse_args(argv)
    sim_time = RAMP + HOLD
    with tempfile.TemporaryDirectory() as tmp:
        full = build_fmu(load_model("spindle"), out_dir=tmp, validate=False).path
        ref, wall_full = run(full, args.solver, args.rtol, args.repeats)
        peak = float(np.max(ref["r_top"]))
        rows = [{"model": "spindle", "n_modes": None, "states": None,
                 "wall_s": wall_full, "rtf": wall_full / sim_time, "error": 0.0}]
        for n in args.modes:
            model = load_model("spindle_modal", n_modes=n)
            path = build_fmu(model, out_dir=Path(tmp) / f"m{n}", validate=False).path
            res, wall = run(path, args.solver, args.rtol, args.repeats)
            err = float(np.max(np.abs(res["r_top"] - ref["r_top"])) / peak)
            rows.append({"model": "spindle_modal", "n_modes": n,
                         "states": len(model.of_kind("state")), "wall_s": wall,
                         "rtf": wall / sim_time, "error": err})
    rows[0]["states"] = len(load_model("spindle").of_kind("state"))
    i_crit = int(np.argmax(ref["r_top"][: int(0.3 * RAMP / DT)]))  # below 4800 rpm
    result = {"scene": {"ramp_s": RAMP, "hold_s": HOLD, "dt_s": DT, "top_rpm": TOP_RPM,
                        "solver": args.solver, "rtol": args.rtol},
              "peak_r_top_m": peak, "critical_rpm": float(TOP_RPM * ref["time"][i_crit] / RAMP),
              "rows": rows}
    # the fewest modes from which on every larger count stays within 1 %
    fewest = None
    for r in reversed(rows[1:]):
        if r["error"] > 0.01:
            break
        fewest = r["n_modes"]
    result["fewest_modes_within_1pct"] = fewest
    print(f"{'model':<16}{'modes':>6}{'states':>8}{'wall s':>9}{'wall/sim':>10}{'error':>10}")
    for r in rows:
        print(f"{r['model']:<16}{str(r['n_modes'] or '-'):>6}{r['states']:>8}"
              f"{r['wall_s']:>9.3f}{r['rtf']:>10.4f}{r['error']:>10.2e}")
    print(f"first critical passed at about {result['critical_rpm']:.0f} rpm (peak of r_top "
          f"below 4800 rpm); fewest modes within 1 % from there on: "
          f"{result['fewest_modes_within_1pct']}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
