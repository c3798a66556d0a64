"""loomfmu.spindle.start.periodic_start: the spindle FMUs started there run on
their periodic solution (no transient), full FE and modal."""
from __future__ import annotations

import math

import numpy as np
import pytest

from loomfmu.spindle.start import periodic_start
from loomfmu.spindle.study import Spindle
from loomfmu.verification.verify import simulate

pytestmark = pytest.mark.slow  # builds FMUs

ECC = 5e-6
REVOLUTIONS = 5


def _run(fmu, rpm, start, parameters=None, solver="rodas4"):
    stop = REVOLUTIONS * 60.0 / rpm
    return simulate(fmu.path, solver=solver, rtol=1e-8, atol=1e-14, stop_time=stop,
                    output_interval=stop / 200,
                    values={"Omega": rpm * 2 * math.pi / 60, "e_b": ECC, "e_w": ECC, **(parameters or {}),
                            **start},
                    output=["r_top", "r_footstep"])


def _spread(run, name, ref=None):
    """Largest deviation of an orbit radius from ``ref`` (default: its value at
    t = 0), relative to ref."""
    r = run.y[name]
    ref = r[0] if ref is None else ref
    return float(np.max(np.abs(r - ref)) / ref)


@pytest.mark.parametrize("rpm,parameters", [(16000.0, {}),
                                            (6000.0, {"fill": 1.0, "phase_b": 1.0})])
def test_full_fmu_started_there_stays_on_the_orbit_of_15(spindle_fmu, rpm, parameters):
    start = periodic_start("spindle", n_rpm=rpm, e_b=ECC, e_w=ECC, parameters=parameters)
    run = _run(spindle_fmu, rpm, start, parameters)
    # isotropic supports, forward-rotating forces: the orbit is a circle, so
    # the radius of the top of the blade stays constant without a transient
    # measured 8e-13 and 2e-12 (16 000 rpm, rodas4 at rtol 1e-8)
    assert _spread(run, "r_top") < 1e-6
    assert _spread(run, "r_footstep") < 1e-6
    if not parameters:  # the orbit radius of the independent (15) solve of rotor_study
        top, bottom = Spindle({}).unbalance(rpm, e_b=ECC, e_w=ECC)
        assert run.y["r_top"][0] == pytest.approx(top, rel=1e-6)
        assert run.y["r_footstep"][0] == pytest.approx(bottom, rel=1e-6)


def test_full_fmu_from_positions_only_rings(spindle_fmu):
    """The check above can fail: the same positions without the rates start
    a transient that the radius shows at once."""
    rpm = 16000.0
    start = periodic_start("spindle", n_rpm=rpm, e_b=ECC, e_w=ECC)
    orbit = Spindle({}).unbalance(rpm, e_b=ECC, e_w=ECC)[0]
    start = {k: (0.0 if ".v" in k else v) for k, v in start.items()}
    assert _spread(_run(spindle_fmu, rpm, start), "r_top", orbit) > 0.1


@pytest.mark.parametrize("rpm,parameters", [(16000.0, {}), (1885.0, {}),
                                            (11000.0, {"fill": 1.0, "phase_w": -2.0})])
def test_modal_fmu_started_there_stays_on_its_orbit(spindle_modal_fmu, rpm, parameters):
    start = periodic_start("spindle_modal", n_rpm=rpm, e_b=ECC, e_w=ECC,
                           parameters=parameters)
    assert set(start) == {"phi"} | {f"{s}{i}" for s in ("eta", "deta") for i in range(8)}
    run = _run(spindle_modal_fmu, rpm, start, parameters)
    assert _spread(run, "r_top") < 1e-6
    if "phase_w" not in parameters:  # rotor_study's (15) has the unbalances in phase
        # the modal orbit is the full model's within the truncation
        top, _ = Spindle({}).unbalance(rpm, values=parameters, e_b=ECC, e_w=ECC)
        assert run.y["r_top"][0] == pytest.approx(top, rel=1e-2)
    zero = _run(spindle_modal_fmu, rpm, {k: 0.0 for k in start})
    # from rest it does not hold the orbit
    assert _spread(zero, "r_top", run.y["r_top"][0]) > 0.1


def test_bad_arguments_are_refused_naming_them():
    for kwargs, word in ((dict(model="rotor", n_rpm=1.0), "model"),
                         (dict(n_rpm=-1.0), "n_rpm"), (dict(n_rpm=5e4), "n_rpm"),
                         (dict(n_rpm=1.0, e_b=1.0), "e_b"),
                         (dict(n_rpm=1.0, parameters={"fill": 2.0}), "fill"),
                         (dict(n_rpm=1.0, parameters={"n_rpm": 1.0}), "parameters"),
                         (dict(n_rpm=1.0, options={"n_modes": 3}), "options"),
                         (dict(model="spindle_modal", n_rpm=1.0, options={"n_modes": 0}),
                          "n_modes")):
        with pytest.raises(ValueError, match=word):
            periodic_start(**kwargs)
