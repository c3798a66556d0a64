"""The benchmark command runs (a smoke test, never timed): one small model,
the coarsest sweep, CSV and charts written, our FMU's points present with
finite errors.  The benchmarks themselves are not part of the test suite."""
from __future__ import annotations

import csv
import math

from loomfmu.bench import main
from loomfmu.bench.scenes import BENCH


def test_charts_command_runs_on_one_model(tmp_path):
    assert main(["charts", "--quick", "--models", "drive", "--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "points.csv").open()))
    assert (tmp_path / "drive_wp.png").stat().st_size > 0
    assert (tmp_path / "drive_delay.png").stat().st_size > 0
    assert "| drive |" in (tmp_path / "summary.md").read_text()
    fmu = [r for r in rows if r["study"] == "wp" and r["family"] == "fmu"]
    assert {r["method"] for r in fmu} == {"dopri5", "rodas4", "ros34pw2", "rk4"}
    for r in fmu:
        assert r["status"] == "ok" and math.isfinite(float(r["err_max"]))
        assert math.isfinite(float(r["err_final"])) and float(r["seconds"]) > 0
    assert any(r["family"] == "scipy" for r in rows)


def test_every_scene_names_outputs_of_its_model():
    for name, scene in BENCH.items():
        assert 2 <= len(scene.outputs) <= 4, name
