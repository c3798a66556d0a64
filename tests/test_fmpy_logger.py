"""Our FMPy runs with a logger do not leave FMPy's global logger proxy
(logging.so's s_logger) pointing at a freed thunk (loomfmu.verification.fmpy_logger).

Before: verify.simulate called fmpy.simulate_fmu(logger=...), whose thunk was
freed with the instance; the next FMU on FMPy's default callbacks that logged
(simulate_fmu without logger: test_validity's test_fmpy_simulate_stops_at_the_crossing)
called freed memory: SIGSEGV / SIGILL, depending on the garbage collector's
timing, i.e. on which test files an xdist worker ran before."""
from __future__ import annotations

import subprocess
import sys

import oracles
import pytest

from loomfmu import build_fmu
from loomfmu.declare.model import Model
from loomfmu.verification import fmpy_logger

pytestmark = pytest.mark.slow  # builds FMUs


def _spring() -> Model:
    return oracles.spring("spring_log", stop_time=1.0)


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    return build_fmu(_spring(), out_dir=tmp_path_factory.mktemp("fmpy_logger")).path


SCRIPT = """
import gc, sys
import fmpy
from loomfmu.verification.verify import simulate
fmu = sys.argv[1]
run = simulate(fmu, rtol=1e-6, values={"solver_rtol": 1e-10}, stop_time=0.1)
assert any("overridden" in m for m in run.log), run.log   # our logger got the warning
gc.collect()                     # the run's instance and its callbacks are gone
res = fmpy.simulate_fmu(fmu, stop_time=0.1, start_values={"solver_rtol": 1e-10})
print("survived", res["time"][-1])
"""


def test_a_default_fmpy_run_after_verify_simulate_does_not_crash(fmu):
    """The warning (solver_rtol overridden by the importer's tolerance) of the
    second run goes through FMPy's proxy to s_logger: it must be alive."""
    p = subprocess.run([sys.executable, "-c", SCRIPT, str(fmu)], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0 and "survived 0.1" in p.stdout, (p.returncode, p.stderr[-2000:])


def test_two_live_instances_keep_their_own_logs(fmu, tmp_path):
    """FMPy's proxy has one target for the process: with instantiate_fmu(logger=)
    the first instance's messages went to the logger of the last one made."""
    from fmpy import extract, read_model_description
    unzipdir = extract(str(fmu), str(tmp_path / "fmu"))
    md = read_model_description(unzipdir)
    logs = {"a": [], "b": []}
    made = {n: fmpy_logger.instantiate(unzipdir, md, "CoSimulation",
                                       lambda e, i, s, c, m, n=n: logs[n].append(m.decode()))
            for n in ("a", "b")}
    vr = {v.name: v.valueReference for v in md.modelVariables}
    try:
        a = made["a"]
        a.setupExperiment(tolerance=1e-6, startTime=0.0)
        a.setReal([vr["solver_rtol"]], [1e-10])
        a.enterInitializationMode()
        a.exitInitializationMode()
        assert any("overridden" in m for m in logs["a"]) and logs["b"] == []
        with pytest.raises(Exception):  # noqa: B017 (FMPy raises a bare Exception on Error)
            made["b"].setDebugLogging(True, ["50%#"])  # refused: an unknown category
        # '%%' and '##' (the FMU's escapes, FMI 2.0 2.1.5) printed as one character
        assert any("50%#" in m and "50%%" not in m and "##" not in m for m in logs["b"]), logs["b"]
    finally:
        for inst in made.values():
            inst.freeInstance()
