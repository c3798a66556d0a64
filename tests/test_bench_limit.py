"""`loomfmu bench limit` (a smoke test on one small model, never timed): the
C driver, compiled from the FMU's own sources, runs the verification
experiment to the same final outputs as FMPy, its counters obey what each
method must do, and bad arguments are refused."""
from __future__ import annotations

import json
import math
import subprocess

import pytest

from loomfmu import build_fmu, load_model
from loomfmu.bench import limit as L
from loomfmu.bench import main
from loomfmu.declare.solvers import SOLVERS

pytestmark = pytest.mark.slow  # builds FMUs

MODEL = "loom_shaft"


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    work = tmp_path_factory.mktemp("limit")
    model = load_model(MODEL)
    fmu = build_fmu(model, out_dir=work, validate=False).path
    return model, fmu, L.compile_driver(fmu, work / "driver")


@pytest.mark.parametrize("solver", SOLVERS)
def test_driver_reproduces_fmpy_and_counts_what_the_method_needs(built, solver):
    import fmpy
    model, fmu, exe = built
    c = L.run_driver(exe, stop=model.stop_time, step=model.step_size, solver=solver,
                     repeats=1, best_of=1)
    md = fmpy.read_model_description(str(fmu), validate=False)
    f = L.fmpy_run(fmu, md, stop=model.stop_time, step=model.step_size, solver=solver,
                   repeats=1)
    # the same FMU code, the same calls: the same numbers
    assert c["y_end"].keys() == f["y_end"].keys() and c["y_end"]
    for name, y in f["y_end"].items():
        assert c["y_end"][name] == pytest.approx(y, rel=1e-12, abs=1e-300), name
    assert c["t_end"] == pytest.approx(model.stop_time, rel=1e-12)
    stages, jacs = L.STAGES[solver]
    assert c["rhs"] >= stages * c["steps"] > 0
    assert c["jac"] >= (jacs or 0) * c["steps"] and c["lu"] >= (jacs or 0) * c["steps"]
    if solver == "rk4":  # fixed step: exactly stop / h_fixed steps, none rejected
        assert c["steps"] == round(model.stop_time / model.h_fixed)
        assert c["rejected"] == 0
    assert c["rhs_s"] > 0 and c["jac_s"] > 0 and c["out_s"] > 0 and c["cpu_s"] > 0
    r = L.row(c, f)
    jac_calls = c["jac"] if jacs is None else jacs * c["steps"]
    assert c["hist_s"] == 0  # no delay: no history to sample
    assert r["limit_s"] == pytest.approx(c["steps"] * stages * c["rhs_s"] + jac_calls * c["jac_s"])
    assert math.isfinite(r["ratio"]) and r["ratio"] > 0
    assert r["comm_steps"] == round(model.stop_time / model.step_size)


@pytest.mark.parametrize("args, message", [
    (["1", "1e-3", "1e-6", "1e-9", "euler", "1", "1"], "solver = euler"),
    (["1", "1e-3", "-1e-6", "1e-9", "dopri5", "1", "1"], "rtol = -1e-6"),
    (["1", "1e-3", "1e-6", "1e-9", "dopri5", "0", "1"], "repeats = 0"),
    (["1", "1e-3", "1e-6", "1e-9", "dopri5", "1", "1", "nope=1"], "no Real variable nope"),
    (["1", "1e-3"], "usage"),
])
def test_driver_refuses_bad_arguments(built, args, message):
    proc = subprocess.run([str(built[2]), *args], capture_output=True, text=True)
    assert proc.returncode == 2 and message in proc.stderr and proc.stdout == ""


def test_driver_takes_start_values(built):
    model, _, exe = built
    name = next(v.name for v in model.of_kind("parameter"))
    start = next(v.start for v in model.of_kind("parameter") if v.name == name)
    base = L.run_driver(exe, stop=model.stop_time, step=model.step_size, solver="dopri5",
                        repeats=1, best_of=1)
    other = L.run_driver(exe, stop=model.stop_time, step=model.step_size, solver="dopri5",
                         repeats=1, best_of=1, values={name: 1.5 * start})
    assert other["y_end"] != base["y_end"]


@pytest.mark.parametrize("kw, arg", [
    ({"models": ["no_such_model"]}, "models"),
    ({"solvers": ["euler"]}, "solvers"),
    ({"repeats": 0}, "repeats"),
    ({"best_of": 65}, "best_of"),
    ({"fmpy_repeats": -1}, "fmpy_repeats"),
])
def test_limit_refuses_bad_arguments(kw, arg):
    with pytest.raises(ValueError, match=arg):
        L.limit(**{"models": [MODEL], **kw})


def test_cli_writes_the_table(tmp_path):
    out, page = tmp_path / "limit.json", tmp_path / "limit.md"
    assert main(["limit", "--models", MODEL, "--solvers", "rk4", "--repeats", "1",
                 "--best-of", "1", "--fmpy-repeats", "1", "--out", str(out),
                 "--page", str(page)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [(r["model"], r["solver"]) for r in rows] == [(MODEL, "rk4")]
    assert f"| {MODEL} | rk4 |" in page.read_text()
    # notes written below the marker survive the next run; the tables are new
    page.write_text(page.read_text().replace(f"| {MODEL} | rk4 |", "| stale | rk4 |")
                    + "\n" + L.NOTES_MARKER + "\n\nmeasured by hand\n")
    L.write(json.loads(out.read_text()), None, page, "cmd")
    text = page.read_text()
    assert text.count(L.NOTES_MARKER) == 1 and text.endswith("measured by hand\n")
    assert "| stale |" not in text and f"| {MODEL} | rk4 |" in text
    with pytest.raises(SystemExit):
        main(["limit", "--models", "no_such_model"])


def test_a_delay_model_pays_one_history_sample_per_step(tmp_path):
    """The drive keeps the history of its delayed speed: the driver times one
    sample of it (lf_hist_sample) and the limit adds one per accepted step."""
    model = load_model("drive")
    fmu = build_fmu(model, out_dir=tmp_path, validate=False).path
    exe = L.compile_driver(fmu, tmp_path / "driver")
    c = L.run_driver(exe, stop=2.0, step=model.step_size, solver="dopri5", repeats=1,
                     best_of=1)
    assert c["hist_s"] > 0 and c["rhs_s"] > 0
    stages, _ = L.STAGES["dopri5"]
    r = L.row(c, None)
    assert r["limit_s"] == pytest.approx(c["steps"] * (stages * c["rhs_s"] + c["hist_s"]))


def test_a_landing_with_a_tiny_error_grows_the_step(heald_frame_rigid_fmu, tmp_path):
    """The rigid heald frame over its whole run in one communication step:
    its clock state phi' = omega gives dopri5 an error near zero, and its
    steps land before each known break (a dwell's start or end).  After a
    landing the next step takes the proposal the landing was shortened
    from, or, where the error predicted for that proposal is far inside the
    tolerance, the controller's own longer step (lf_dopri5.c): 28 steps.
    Keeping the proposal alone (-DLF_DP_LAND_GROW=0) took 34."""
    model = load_model("heald_frame_rigid")
    exe = L.compile_driver(heald_frame_rigid_fmu.path, tmp_path / "driver")
    c = L.run_driver(exe, stop=model.stop_time, step=model.stop_time, solver="dopri5",
                     repeats=1, best_of=1)
    assert c["events"] > 0 and c["rejected"] == 0, c
    assert c["steps"] <= 30, c["steps"]
