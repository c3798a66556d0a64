"""Misuse of the public Python API: every bad call is refused with a
ValueError naming the argument, and good calls still work.

The table of bad calls lives in benchmarks/api_misuse.py (which also counts
the outcomes: ``python benchmarks/api_misuse.py``).  Each call runs in a
forked child with a time limit, so a call that hangs fails fast instead of
hanging the suite, and a crash fails the one case.
"""
from __future__ import annotations

import importlib.util
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from loomfmu import load_model
from loomfmu.declare.checks import (
    check_array,
    check_choice,
    check_int,
    check_mapping,
    check_names,
    check_number,
)
from loomfmu.heald import hinge_load_kinetostatic
from loomfmu.heald.hinge import KINETOSTATIC_PARAMETERS
from loomfmu.registry import MODELS, build_options
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import simulate

pytestmark = pytest.mark.slow  # its fixture builds the heald frame FMU

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("api_misuse", ROOT / "benchmarks" /
                                               "api_misuse.py")
misuse = importlib.util.module_from_spec(_spec)
sys.modules["api_misuse"] = misuse
_spec.loader.exec_module(misuse)

CASES = misuse.cases()
#: time limit of one bad call (s): a refusal takes milliseconds; design_section
#: at the edges integrates twice (~5 s)
TIMEOUT = 60.0


@pytest.fixture(scope="module")
def fx(tmp_path_factory):
    f = misuse.Fixtures(tmp_path_factory.mktemp("misuse"))
    f.prepare()
    return f


def _id(case) -> str:
    return re.sub(r"\s+", " ", case.label)[:80]


@pytest.mark.parametrize("case", CASES, ids=[_id(c) for c in CASES])
def test_bad_call_is_refused_naming_the_argument(case, fx):
    outcome, detail = misuse.run_case(case, fx, TIMEOUT)
    assert outcome == "refused", f"{case.label}: {outcome}: {detail}"


def test_the_table_covers_the_issue_examples():
    labels = " | ".join(c.label for c in CASES)
    for example in ("load_model('drive', m=100000)", "reference(t_end=inf)",
                    "simulate(stop_time=-1.0)", "reference(rtol=inf)", "fourier(p, 10000000)",
                    "hinge_load_kinetostatic(0.0, omgea=100)", "'m_RR': -1.0",
                    "'T_min': 0.9, 'T_max': 0.5", "reference(t_eval=[0.5], t_end=0.01)",
                    "reference(values={'omgea'", "simulate(output=['N_remm'])",
                    "load_model('backrest_regularized', friction='events')",
                    "harmonics=True", "design_section(10)",
                    # the adversarial findings on the declaration layer and API
                    "m.output('y', [x; 2x])", "m.output('y', SX(0, 1))",
                    "m.delay('d', [x; 2x], 0.1)", "m.output('y', [x, x])",
                    "description='a\\x00b'", "m.state('solver_rtol', 0)",
                    "simulate(values={'solver': 7})", "build_fmu(out_dir=<an existing file>)"):
        assert example in labels, example
    assert len(CASES) >= 340


def test_runner_tells_hangs_crashes_and_silence_apart(fx):
    """The runner itself: a hang, a crash, a silent return and a wrong
    exception are not counted as refusals."""
    import os
    import time
    Case = misuse.Case
    assert misuse.run_case(Case("sleep", "x", lambda f: time.sleep(30)), fx, 1.0)[0] == "hung"
    assert misuse.run_case(Case("exit", "x", lambda f: os._exit(3)), fx, 5.0)[0] == "crashed"
    assert misuse.run_case(Case("ok", "x", lambda f: 1), fx, 5.0)[0] == "accepted"
    assert misuse.run_case(Case("te", "x", lambda f: int("x", base=None)), fx,
                           5.0)[0] == "wrong-exception"
    assert misuse.run_case(Case("ve", "x", lambda f: check_number("y", -1, lo=0)), fx,
                           5.0)[0] == "unnamed"


# ------------------------------------------------------------------- the helpers
def test_check_number_refuses_what_is_not_a_finite_number_in_range():
    assert check_number("a", 2, lo=0) == 2.0
    assert check_number("a", np.float64(0.5), lo=0, hi=1) == 0.5
    for bad in (math.nan, math.inf, -math.inf, True, "1", None, 1j, 10**400):
        with pytest.raises(ValueError, match=r"^a = "):
            check_number("a", bad)
    with pytest.raises(ValueError, match=r"allowed: a finite number in \(0, 1\]"):
        check_number("a", 0.0, lo=0, hi=1, lo_open=True)
    assert check_int("n", 4.0, lo=1) == 4
    for bad in (2.5, True, "3", math.inf, 0):
        with pytest.raises(ValueError, match="^n = "):
            check_int("n", bad, lo=1)


def test_check_choice_names_and_mapping():
    assert check_choice("c", "a", ("a", "b")) == "a"
    with pytest.raises(ValueError, match="c = 1; allowed: True, False"):
        check_choice("c", 1, (True, False))
    with pytest.raises(ValueError, match="did you mean 'omega'"):
        check_names("values", ["omgea"], ["omega", "phi"])
    assert check_mapping("values", {"phi": 1}, ["phi"]) == {"phi": 1.0}
    with pytest.raises(ValueError, match=r"values\['phi'\] = nan"):
        check_mapping("values", {"phi": math.nan}, ["phi"])
    with pytest.raises(ValueError, match="t: not in increasing order"):
        check_array("t", [1.0, 0.0], increasing=True)


# ------------------------------------------------------------------- good calls
def test_every_model_loads_with_its_declared_options():
    for name in MODELS:  # every build's keyword-only options (loom_shaft has none)
        assert all(isinstance(o, str) for o in build_options(name))
    assert build_options("loom_shaft") == []
    assert "warp_tension" in build_options("heald_frame")
    assert load_model("backrest", friction="regularized").name == "backrest_regularized"
    assert load_model("backrest_regularized", friction="regularized").name == \
        "backrest_regularized"
    assert load_model("drive", harmonics=8, m=10, cam="none").options["harmonics"] == 8
    assert load_model("heald_frame", preset="STB-180 Elitex wool").var("m_RR").start == 5.2


def test_reference_good_call_matches_the_closed_form_motion():
    """A rigid frame's h is the motion law: reference values at given times."""
    from loomfmu.heald.hinge import motion
    model = load_model("heald_frame_rigid")
    t = np.array([0.0, 0.013, 0.05])
    ref = reference(model, t_end=0.05, t_eval=t, values={"omega": 50.0, "T_min": 0.2})
    H, _, _ = motion(50.0 * t, omega=50.0)
    assert np.allclose(ref.y["h"], H, rtol=0, atol=1e-9)


def test_the_tension_constraint_is_checked_in_python_and_in_the_fmu(fx):
    model = load_model("heald_frame_rigid")
    with pytest.raises(ValueError, match=r"tension_order.*T_min"):
        reference(model, t_end=0.01, values={"T_min": 0.9, "T_max": 0.5})
    with pytest.raises(RuntimeError, match=r"tension_order.*T_min"):
        simulate(fx.fmu, values={"T_min": 0.9, "T_max": 0.5})
    run = simulate(fx.fmu, values={"T_min": 0.5, "T_max": 0.5}, output=["T"],
                   stop_time=0.01)
    assert np.allclose(run.y["T"], 1000 * 0.5)  # equal tensions are allowed


def test_hinge_load_takes_a_models_parameters_picked_by_name():
    model = load_model("heald_frame_rigid")
    values = {v.name: v.start for v in model.of_kind("parameter") + model.of_kind("input")}
    picked = {k: v for k, v in values.items() if k in KINETOSTATIC_PARAMETERS}
    assert set(picked) == set(KINETOSTATIC_PARAMETERS)
    phi = np.linspace(0, 4 * math.pi, 50)
    assert np.array_equal(hinge_load_kinetostatic(phi, **picked), hinge_load_kinetostatic(phi))
    with pytest.raises(TypeError, match="k_H_typo"):
        hinge_load_kinetostatic(phi, k_H_typo=1.0)


def test_design_section_inside_its_range_still_answers():
    from loomfmu.heald.claims import design_section, max_x2
    res = design_section(0.05, rtol=1e-6)
    lo, hi = res["b1_range"]
    assert lo < res["b1"] < hi
    assert res["max_x2"] <= 0.05
    # 0.1 mm narrower misses the gap: the answer is the smallest width (to the rounding)
    assert max_x2({"b1": res["b1"] - 1e-4}, rtol=1e-6) > 0.05
