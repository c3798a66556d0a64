"""The spindle FMUs (full FE and modal): validation, agreement with the scipy
reference, and the time-domain response at constant speed against the
frequency-domain unbalance response (15)."""
from __future__ import annotations

import numpy as np
import pytest
from fmpy.validation import validate_fmu

from loomfmu import load_model
from loomfmu.spindle.analysis import RPM, unbalance_response
from loomfmu.spindle.study import Spindle
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import compare, simulate

pytestmark = pytest.mark.slow  # builds FMUs

OUTPUTS = ["x_top", "y_top", "r_top", "x_footstep", "r_footstep", "F_upper_x",
           "F_upper", "F_lower_x", "F_lower"]
RTOL = 1e-6
# A short window of the default scene (start from rest at 16 000 rpm): the
# stiff full model's DOP853 reference costs ~1 s per ms here.
T_END = 0.004


@pytest.fixture(scope="module")
def models():
    return {"spindle": load_model("spindle"), "spindle_modal": load_model("spindle_modal")}


@pytest.fixture(scope="module")
def refs(models, spindle_fmu, spindle_modal_fmu):
    out = {}
    for name, fmu in (("spindle", spindle_fmu), ("spindle_modal", spindle_modal_fmu)):
        grid = simulate(fmu.path, stop_time=T_END, output=["r_top"]).t
        out[name] = reference(models[name], t_end=grid[-1], t_eval=grid, rtol=1e-11,
                              atol=1e-15)
    return out


def test_both_fmus_validate_without_problems(spindle_fmu, spindle_modal_fmu):
    for fmu in (spindle_fmu, spindle_modal_fmu):
        assert fmu.problems == []
        assert validate_fmu(str(fmu.path)) == []


@pytest.mark.parametrize("name,solver", [("spindle", "rodas4"), ("spindle", "dopri5"),
                                         ("spindle", "ros34pw2"),
                                         ("spindle_modal", "rodas4"),
                                         ("spindle_modal", "dopri5"),
                                         ("spindle_modal", "rk4"),
                                         ("spindle_modal", "ros34pw2")])
def test_fmu_agrees_with_its_scipy_reference(name, solver, spindle_fmu, spindle_modal_fmu,
                                             refs):
    fmu = spindle_fmu if name == "spindle" else spindle_modal_fmu
    run = simulate(fmu.path, solver=solver, rtol=RTOL, atol=1e-12, stop_time=T_END,
                   output=OUTPUTS)
    errs = compare(run, refs[name], OUTPUTS)
    worst = max(e["max_rel_range"] for e in errs.values())
    # the unbalance sets in at once: the start excites every mode, the error
    # stays within a small multiple of rtol relative to each output's range
    assert worst < 50 * RTOL, errs
    assert np.max(refs[name].y["r_top"]) > 1e-6  # the scene moves the blade


def _steady_start(sp: Spindle, rpm: float, ecc: float, **overrides) -> dict:
    """Start values on the periodic solution (15): q(0) = A2, v(0) = w A1."""
    w = rpm * RPM
    v = sp.values(**overrides)
    M, C, G, K = sp.matrices(w, v)
    n = M.shape[0]
    P1, P2 = np.zeros(n), np.zeros(n)
    for role, mass in (("bobbin", v["m_b"] + v["fill"] * v["m_y"]), ("whorl", v["m_w"])):
        node = sp.sp.nodes[role]
        P2[sp.sp.idx(f"n{node}.x")] += mass * ecc * w**2
        P1[sp.sp.idx(f"n{node}.y")] += mass * ecc * w**2
    A1, A2 = unbalance_response(M, C + w * G, K, w, P1, P2)
    start = {}
    for i, d in enumerate(sp.sp.dofs):
        node, comp = d.split(".")
        start[d] = A2[i]
        start[f"{node}.v{comp}"] = w * A1[i]
    return start, A1, A2


@pytest.mark.parametrize("rpm", [6000.0, 16000.0])
def test_constant_speed_response_is_the_unbalance_response_15(spindle_fmu, rpm):
    """Started on the periodic solution of (15), the FMU stays on it: the top
    of the blade follows A1 sin wt + A2 cos wt (a transient would show as a
    deviation of the size of the response itself).  From rest, the response
    converges to it as the transient decays."""
    sp = Spindle({})
    ecc = 5e-6
    start, A1, A2 = _steady_start(sp, rpm, ecc)
    top = sp.sp.nodes["top"]
    ix = sp.sp.idx(f"n{top}.x")
    values = {"Omega": rpm * RPM, "e_b": ecc, "e_w": ecc, **start}
    run = simulate(spindle_fmu.path, solver="rodas4", rtol=1e-8, atol=1e-14,
                   stop_time=0.02, values=values, output=["x_top"])
    w = rpm * RPM
    expected = A1[ix] * np.sin(w * run.t) + A2[ix] * np.cos(w * run.t)
    amp = np.hypot(A1[ix], A2[ix])
    assert np.max(np.abs(run.y["x_top"] - expected)) < 1e-4 * amp
    # from rest, with a well-damped film (the default film damps the first
    # mode by only 1.7 %), the deviation from (15) decays
    _, A1, A2 = _steady_start(sp, rpm, ecc, eta=0.5)
    rest = simulate(spindle_fmu.path, solver="rodas4", rtol=1e-6, atol=1e-12,
                    stop_time=0.3, output_interval=1e-3,
                    values={"Omega": rpm * RPM, "e_b": ecc, "e_w": ecc, "eta": 0.5},
                    output=["x_top"])
    exp_r = A1[ix] * np.sin(w * rest.t) + A2[ix] * np.cos(w * rest.t)
    dev = np.abs(rest.y["x_top"] - exp_r)
    early, late = dev[rest.t < 0.05].max(), dev[rest.t > 0.25].max()
    assert late < 0.05 * early, (early, late)
