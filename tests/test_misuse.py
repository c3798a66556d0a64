"""Misuse, bad values and corrupted FMU states, against sanitizer builds
(-fsanitize=address,undefined with LeakSanitizer) of two models.

Each case of tests/c/misuse.c runs in its own process, so a crash, a read
past an array, undefined behaviour or a leak fails the test instead of
killing pytest.  A case passes when every misuse call is refused (fmi2Error
or NULL) with a log line and the simulation then continues bit for bit as an
untouched one (zero OK-with-wrong-answer).  Random one-byte corruptions of a
serialized state are sampled here; benchmarks/misuse.py counts the full set.
"""
from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

from loomfmu import load_model

pytestmark = pytest.mark.slow  # builds FMUs

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("bench_misuse", ROOT / "benchmarks" / "misuse.py")
misuse = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = misuse  # dataclasses look their module up
_spec.loader.exec_module(misuse)

MODELS = ("backrest", "drive")   # friction modes and events; delays and history
SAMPLE = 150                     # random corruptions per model and mode


@pytest.fixture(scope="module", params=MODELS)
def driver(request, tmp_path_factory):
    return misuse.build_driver(load_model(request.param), tmp_path_factory.mktemp("misuse"))


def test_every_misuse_case_is_refused_without_crash_or_leak(driver):
    cases = misuse.list_cases(driver)
    assert len(cases) >= 100, cases
    results = [misuse.run_case(driver.binary, c, driver.h) for c in cases]
    bad = [r for r in results if r.verdict not in ("refused", "clean")]
    assert not bad, "\n\n".join(f"{r.case}: {r.verdict} (exit {r.returncode})\n{r.stderr}"
                                for r in bad)
    counts = misuse.summarize_cases(results)
    assert counts["crashed"] == counts["ok_with_wrong_answer"] == 0
    # the cases the issue names are among them
    for name in ("get_real_null_vr", "free_instance_twice", "do_step_after_free",
                 "get_status_null", "debug_logging_null", "get_fmu_state_null",
                 "serialized_size_null", "serialize_null_bytes", "deserialize_null_bytes",
                 "deserialize_null_state", "get_real_nvr_max", "instantiate_null_name",
                 "instantiate_empty_name", "fmu_states_never_freed", "do_step_nan_time",
                 "do_step_h_1e-300", "start_time_1e20", "state_solver_ready_7",
                 "state_solver_method_99", "state_breakpoints_100000",
                 "state_output_nan_marked_valid"):
        assert name in cases


def test_stored_state_corruptions_are_all_refused(driver):
    k = misuse.run_corruptions(driver, seed=7, n=SAMPLE, reseal=False)
    assert k["tried"] == SAMPLE
    assert k["refused"] == SAMPLE, k


def test_resealed_corruptions_never_crash(driver):
    """Checksum recomputed: only the field checks stand; a corrupted field
    is refused (and the instance goes on where it was) or is a valid state."""
    k = misuse.run_corruptions(driver, seed=11, n=SAMPLE, reseal=True)
    assert k["crashed"] == k["refused_silently"] == k["refused_but_changed"] == 0, k
    assert k["refused"] > 0, k


def test_the_runner_counts_a_sanitizer_finding_as_a_crash(tmp_path):
    """The harness can fail: a program that leaks and reads past an array,
    built with the same flags, is classified as crashed, not as refused."""
    src = tmp_path / "bad.c"
    src.write_text('#include <stdio.h>\n#include <stdlib.h>\n'
                   'int main(int argc, char **argv) {\n'
                   '    int *a = malloc(2 * sizeof *a);\n'
                   '    (void)argv;\n'
                   '    printf("case x kind refuse verdict refused calls 1\\n");\n'
                   '    return a[argc + 4];\n}\n')
    exe = tmp_path / "bad"
    subprocess.run(["gcc", *misuse.SANITIZE, str(src), "-o", str(exe)], check=True)
    r = misuse.run_case(exe, "x", 0.01)
    assert r.verdict == "crashed", r


def test_importer_tolerance_overriding_solver_rtol_is_logged(driver, slave_factory):
    """A user's solver_rtol overridden by fmi2SetupExperiment's
    tolerance gives a warning naming both values when it takes effect."""
    fmu = driver.binary.parents[1] / f"{driver.model}.fmu"

    def run(set_rtol, tolerance):
        s = slave_factory(fmu)
        s.fmu.setupExperiment(tolerance=tolerance, startTime=0.0)
        if set_rtol:
            s.set(solver_rtol=1e-8)
        s.fmu.enterInitializationMode()
        s.fmu.exitInitializationMode()
        return [m for status, cat, m in s.log if "solver_rtol" in m and status == 1
                and cat == "logStatusWarning"]

    lines = run(True, 1e-6)
    assert len(lines) == 1 and "1e-08" in lines[0] and "1e-06" in lines[0], lines
    assert run(False, 1e-6) == []      # solver_rtol not set: nothing overridden
    assert run(True, None) == []       # no importer tolerance: solver_rtol is used


def test_model_exchange_misuse_under_the_sanitizers(tmp_path):
    """tests/c/misuse_me.c, compiled with the backrest's "both" sources
    (stick-slip events) under the sanitizers: an importer's Euler run with
    events and an FMU state, then every model-exchange misuse refused with
    one error line, no crash, no leak, no undefined behaviour."""
    import os
    import zipfile

    from loomfmu import build_fmu
    from loomfmu.fmu.builder import fmi_headers_dir
    fmu = build_fmu(load_model("backrest"), out_dir=tmp_path, interface="both",
                    validate=False).path
    with zipfile.ZipFile(fmu) as z:
        z.extractall(tmp_path / "fmu", [n for n in z.namelist() if n.startswith("sources/")])
    src = tmp_path / "fmu" / "sources"
    exe = tmp_path / "misuse_me"
    subprocess.run(["gcc", "-std=c99", *misuse.SANITIZE, "-I", str(src), "-I",
                    str(fmi_headers_dir()), *sorted(map(str, src.glob("*.c"))),
                    str(ROOT / "tests" / "c" / "misuse_me.c"), "-lm", "-o", str(exe)],
                   check=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300,
                       env={**os.environ, **misuse.SANITIZER_ENV})
    assert r.returncode == 0, r.stdout + r.stderr
    events = int(r.stdout.split()[1])
    assert events > 5 and r.stdout.split()[3] == "0", r.stdout  # stick-slip, all as expected
