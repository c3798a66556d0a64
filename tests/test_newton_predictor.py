"""Algebraic loops in the runtime (src/loomfmu/runtime/lf_newton.c): the torn
form (Newton on a few unknowns, the others in closed form) and, for loops
solved on every unknown, Newton's memory (lf_newton_mem.h): inside a step, a
solve of the unknowns w starts from the first-order predictor and takes
simplified Newton iterations with the kept dF/dw.

The backrest models' verification runs, driven by the C benchmark driver
(loomfmu.bench.limit) compiled three times from the same FMU sources, all
counting their Newton work (-DLF_NEWTON_STATS): as shipped (torn), and
solved on every unknown (-DLF_TEAR=0) with the memory and without it
(-DLF_NEWTON_MEMORY=0: Newton from the last solve).  The memory cuts the
residual evaluations and the factorizations per solve; the torn form solves
a smaller loop in fewer iterations; the results of all three stay those of
Newton to far below the integration tolerance (the friction modes switch at
the same events).  A reset instance and a restored
state run as a fresh one (the memory is no part of the FMU state: each step
starts without it; tests/test_fmu_state.py checks restored states bit for
bit)."""
from __future__ import annotations

import re

import numpy as np
import pytest

from loomfmu import build_fmu, load_model
from loomfmu.bench import limit as L

pytestmark = pytest.mark.slow  # builds FMUs

MODELS = ("backrest", "backrest_regularized")
SOLVERS = ("dopri5", "rodas4", "rk4", "ros34pw2")
STATS = re.compile(r"newton_stats: solves (\d+) hits (\d+) full (\d+) full_it (\d+) "
                   r"simplified (\d+) simplified_it (\d+) fallbacks (\d+)")


def _driver(fmu, work, *defines):
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(L, "STRICT_FLAGS", (*L.STRICT_FLAGS, *defines))
        work.mkdir()
        return L.compile_driver(fmu, work)


@pytest.fixture(scope="module", params=MODELS)
def drivers(request, tmp_path_factory):
    work = tmp_path_factory.mktemp(request.param)
    model = load_model(request.param)
    fmu = build_fmu(model, out_dir=work, validate=False).path
    return (model, fmu,
            _driver(fmu, work / "memory", "-DLF_NEWTON_STATS", "-DLF_TEAR=0"),
            _driver(fmu, work / "plain", "-DLF_NEWTON_STATS", "-DLF_TEAR=0",
                    "-DLF_NEWTON_MEMORY=0"),
            _driver(fmu, work / "torn", "-DLF_NEWTON_STATS"))


def _run(exe, model, solver):
    import subprocess
    proc = subprocess.run([str(exe), repr(model.stop_time), repr(model.step_size), "1e-6",
                           "1e-9", solver, "1", "1"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
    import json
    m = STATS.search(proc.stderr)
    assert m, proc.stderr[-2000:]
    keys = ("solves", "hits", "full", "full_it", "simplified", "simplified_it", "fallbacks")
    return json.loads(proc.stdout), dict(zip(keys, map(int, m.groups())))


@pytest.mark.parametrize("solver", SOLVERS)
def test_memory_cuts_newton_work_and_keeps_the_results(drivers, solver):
    model, _, memory, plain, _ = drivers
    got, n = _run(memory, model, solver)
    ref, n0 = _run(plain, model, solver)
    # without the memory every solve is Newton with a new dF/dw each iteration
    assert n0["simplified"] == 0 and n0["full"] > 0
    solves, solves0 = n["full"] + n["simplified"], n0["full"]
    assert solves == pytest.approx(solves0, rel=0.02)  # the same run, the same solves
    res_per_solve = (n["full_it"] + n["simplified_it"]) / solves
    res_per_solve0 = n0["full_it"] / solves0
    lu_per_solve = n["full_it"] / solves
    assert res_per_solve0 > 2.2  # Newton's steps, the last one only to confirm
    assert res_per_solve < 2.35 and res_per_solve < 0.9 * res_per_solve0
    assert lu_per_solve < 0.25  # about one factorization per step
    assert n["fallbacks"] <= 0.01 * solves
    # the same simulation: steps, events, and outputs far within the tolerance
    assert got["steps"] == pytest.approx(ref["steps"], rel=0.01)
    assert got["events"] == ref["events"] and got["newton_failures"] == 0
    for name, y in ref["y_end"].items():
        assert got["y_end"][name] == pytest.approx(y, rel=1e-8, abs=1e-9), name


@pytest.mark.parametrize("solver", SOLVERS)
def test_the_torn_loop_takes_fewer_iterations_and_keeps_the_results(drivers, solver):
    model, _, _, plain, torn = drivers
    got, n = _run(torn, model, solver)
    ref, n0 = _run(plain, model, solver)
    # the torn Newton counts a solve as "full" and each of its iterations
    assert n["simplified"] == 0 and n["fallbacks"] == 0
    assert n["full"] == pytest.approx(n0["full"], rel=0.02)  # the same solves
    it, it0 = n["full_it"] / n["full"], n0["full_it"] / n0["full"]
    assert it < 0.9 * it0 and it < 2.2
    assert got["steps"] == pytest.approx(ref["steps"], rel=0.01)
    assert got["events"] == ref["events"] and got["newton_failures"] == 0
    for name, y in ref["y_end"].items():
        assert got["y_end"][name] == pytest.approx(y, rel=1e-8, abs=1e-9), name


def _run_fmpy(s, n, comm, outputs):
    ys, t = [], 0.0
    for _ in range(n):
        s.fmu.doStep(t, comm)
        t += comm
        ys.append(s.get(*outputs))
    return np.array(ys)


OUTPUTS = ["phi1_out", "omega2_out", "M1f_out", "M2f_out", "N1"]


@pytest.mark.parametrize("solver", [1, 2])
def test_reset_instance_runs_as_a_fresh_one(drivers, slave_factory, solver):
    model, fmu, _, _, _ = drivers
    n, comm = 150, model.step_size
    fresh = slave_factory(fmu, "fresh")
    fresh.start(solver=solver)
    first = _run_fmpy(fresh, n, comm, OUTPUTS)
    again = slave_factory(fmu, "again")
    again.start(solver=solver)
    _run_fmpy(again, 60, comm, OUTPUTS)
    again.fmu.reset()
    again.start(solver=solver)
    np.testing.assert_array_equal(_run_fmpy(again, n, comm, OUTPUTS), first)
