"""The benchmark command runs (a smoke test, never timed): one small model,
the coarsest sweep, CSV and charts written, our FMU's points present with
finite errors.  The benchmarks themselves are not part of the test suite."""
from __future__ import annotations

import csv
import math
import sys

import pytest

from loomfmu.bench import main
from loomfmu.bench.scenes import BENCH


@pytest.mark.slow
def test_charts_command_runs_on_one_model(tmp_path):
    assert main(["charts", "--quick", "--models", "drive", "--out", str(tmp_path)]) == 0
    with (tmp_path / "points.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert (tmp_path / "drive_wp.png").stat().st_size > 0
    assert (tmp_path / "drive_delay.png").stat().st_size > 0
    assert "| drive |" in (tmp_path / "summary.md").read_text()
    fmu = [r for r in rows if r["study"] == "wp" and r["family"] == "fmu"]
    assert {r["method"] for r in fmu} == {"dopri5", "rodas4", "ros34pw2", "rk4"}
    for r in fmu:
        assert r["status"] == "ok" and math.isfinite(float(r["err_max"]))
        assert math.isfinite(float(r["err_final"])) and float(r["seconds"]) > 0
    assert any(r["family"] == "scipy" for r in rows)


@pytest.mark.parametrize("extra, hide, message", [
    ([], True, "loomfmu.sweep runs on dask.distributed, which is not installed: "
               "pip install 'loomfmu[distributed]'"),
    (["--scheduler", "localhost"], False, "scheduler = 'localhost'; allowed: None or an "
                                          "address such as tcp://host:8786"),
], ids=["no-distributed", "bad-scheduler"])
def test_charts_on_dask_refused_in_one_line_with_exit_2(tmp_path, monkeypatch, capsys, extra,
                                                        hide, message):
    """Without dask.distributed (or with a bad --scheduler) `bench charts
    --dask` says so in one line and exits 2, as `loomfmu sweep` does, before
    any work (it printed a 20-line traceback)."""
    if hide:
        monkeypatch.setitem(sys.modules, "distributed", None)  # as if not installed
    out = tmp_path / "charts"
    code = main(["charts", "--dask", "--quick", "--models", "drive", "--out", str(out), *extra])
    assert (code, capsys.readouterr().err) == (2, f"loomfmu bench: error: {message}\n")
    assert not out.exists()


def test_every_scene_names_outputs_of_its_model():
    for name, scene in BENCH.items():
        assert 2 <= len(scene.outputs) <= 4, name


@pytest.mark.slow
def test_fmu_runner_reuses_one_instance_and_matches_a_fresh_run(tmp_path):
    """The charts time our FMU on one kept instance, reset before each run:
    the results are those of a new instance bit for bit, a run that fails
    (a start value outside its range) raises with the FMU's log and the
    next run works on a new instance."""
    import numpy as np
    import pytest

    from loomfmu.bench.runners import Fmu
    from loomfmu.registry import load_model

    fmu = Fmu(load_model("loom_shaft"), tmp_path)
    kw = dict(solver="dopri5", rtol=1e-6, atol=1e-9, stop=0.05, interval=1e-3,
              outputs=["theta_out", "omega_out"])
    fresh = fmu.run(fresh=True, **kw)
    first = fmu.run(**kw)
    kept = fmu._instance
    second = fmu.run(**kw, values={"delta": 0.2})
    third = fmu.run(**kw)
    assert fmu._instance is kept
    for name in kw["outputs"]:
        assert np.array_equal(first.y[name], fresh.y[name])
        assert np.array_equal(third.y[name], fresh.y[name])
    assert not np.array_equal(second.y["omega_out"], fresh.y["omega_out"])
    with pytest.raises(RuntimeError, match="log: .*delta"):
        fmu.run(**kw, values={"delta": 0.9})
    assert fmu._instance is None
    again = fmu.run(**kw)
    assert np.array_equal(again.y["theta_out"], fresh.y["theta_out"])


@pytest.mark.slow
def test_fmu_runner_shared_by_two_threads_takes_turns(tmp_path):
    """Two threads running one Fmu (one kept instance) take turns: every run
    equals a fresh one bit for bit (without the lock the heap was corrupted
    and the interpreter aborted)."""
    import threading

    import numpy as np

    from loomfmu.bench.runners import Fmu
    from loomfmu.registry import load_model

    fmu = Fmu(load_model("loom_shaft"), tmp_path)
    kw = dict(solver="dopri5", rtol=1e-6, atol=1e-9, stop=0.05, interval=1e-3,
              outputs=["theta_out"])
    fresh = fmu.run(fresh=True, **kw).y["theta_out"]
    results = []

    def work():
        for _ in range(15):
            results.append(fmu.run(**kw).y["theta_out"])

    threads = [threading.Thread(target=work) for _ in range(2)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert len(results) == 30
    assert all(np.array_equal(r, fresh) for r in results)


@pytest.mark.parametrize("module", ["loomfmu.bench.cli", "loomfmu.cli.sweep"])
def test_help_gives_every_command_a_line_and_every_option_its_default(module):
    """`loomfmu bench --help` and `loomfmu sweep --help`: each command has its
    line (and shows it atop its own --help); each option has a help text
    that states its default where it has one (flags and repeatable options
    have none)."""
    import argparse
    import importlib

    parser = importlib.import_module(module)._parser("prog")
    parser = parser[0] if isinstance(parser, tuple) else parser
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    assert {a.dest: a.help for a in sub._choices_actions}.keys() == sub.choices.keys()
    for cmd, helpline in ((a.dest, a.help) for a in sub._choices_actions):
        assert helpline and sub.choices[cmd].description == helpline, cmd
        for a in sub.choices[cmd]._actions:
            if isinstance(a, argparse._HelpAction):
                continue
            assert a.help, (cmd, a.dest)
            if a.default not in (None, False, []) and not a.required:
                assert "default" in a.help, (cmd, a.option_strings, a.default, a.help)
