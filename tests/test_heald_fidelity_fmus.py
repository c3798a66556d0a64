"""The planar and rigid heald-frame FMUs: fmpy validation, agreement with
their scipy references, and with the spatial model where the physics says
they must agree."""
from __future__ import annotations

import numpy as np
import pytest
from fmpy.validation import validate_fmu

from loomfmu import load_model
from loomfmu.heald.claims import start_values
from loomfmu.verification.reference import reference
from loomfmu.verification.verify import compare, simulate

pytestmark = pytest.mark.slow  # builds FMUs

PLANAR = ["h", "h_ddot", "y2_out", "T", "f_y", "N_rem"]
RIGID = ["h", "h_ddot", "T", "f_x", "f_y", "N_rem", "G_rem"]


@pytest.mark.parametrize("fixture, name, outputs", [
    ("heald_frame_planar_fmu", "heald_frame_planar", PLANAR),
    ("heald_frame_rigid_fmu", "heald_frame_rigid", RIGID)])
def test_fmu_validates_and_agrees_with_reference(request, fixture, name, outputs):
    fmu = request.getfixturevalue(fixture)
    assert fmu.problems == [] and validate_fmu(str(fmu.path)) == []
    run = simulate(fmu.path, solver="dopri5", rtol=1e-6, atol=1e-10, output=outputs)
    ref = reference(load_model(name), t_end=run.t[-1], t_eval=run.t, rtol=1e-11, atol=1e-13)
    errs = compare(run, ref, outputs)
    assert max(e["max_rel_range"] for e in errs.values()) < 2e-5, errs


def test_spatial_hinge_load_agrees_with_reference(heald_frame_fmu):
    model = load_model("heald_frame")
    run = simulate(heald_frame_fmu.path, rtol=1e-6, atol=1e-10, output=["N_rem", "G_rem"])
    ref = reference(model, t_end=run.t[-1], t_eval=run.t, rtol=1e-11, atol=1e-13)
    assert compare(run, ref, ["N_rem"])["N_rem"]["max_rel_range"] < 2e-5
    assert run.y["G_rem"][0] == pytest.approx((4.6 + 9.0 / 9.80665) * 9.80665)


def test_planar_equals_spatial_in_the_vertical(heald_frame_fmu, heald_frame_planar_fmu):
    """x and y are coupled only through the warp tension, a function of the
    frame position: the planar model's y2 and N_rem equal the spatial ones
    for any shed asymmetry (k_z set at run time with its equilibrium start)."""
    for k_z in (1.0, 5.0):
        sp = simulate(heald_frame_fmu.path, rtol=1e-9, atol=1e-13, output=["y2_out", "N_rem"],
                      values=start_values("heald_frame", {"k_z": k_z}))
        pl = simulate(heald_frame_planar_fmu.path, rtol=1e-9, atol=1e-13,
                      output=["y2_out", "N_rem"],
                      values=start_values("heald_frame_planar", {"k_z": k_z}))
        for o in ("y2_out", "N_rem"):
            assert np.max(np.abs(pl.y[o] - sp.y[o])) < 1e-6 * np.ptp(sp.y[o]), (k_z, o)


def test_symmetric_shed_gives_no_horizontal_vibration(heald_frame_fmu):
    sym = simulate(heald_frame_fmu.path, rtol=1e-8, output=["x1_out", "x2_out"],
                   values=start_values("heald_frame", {"k_z": 1.0}))
    asym = simulate(heald_frame_fmu.path, rtol=1e-8, output=["x2_out"])
    assert np.max(np.abs(sym.y["x2_out"])) < 1e-12
    assert np.max(np.abs(asym.y["x2_out"])) > 1e-3
