"""spindle_modal with static_correction=True (mode-acceleration recovery
q = B eta + R F): against the full FE spindle on the periodic solution at
16 000 rpm, the support-force amplitude errors of 4 modes fall; the orbit of
the blade's top stays as good.  Real gcc builds, real fmpy runs."""
from __future__ import annotations

import math
import time

import numpy as np
import pytest

from loomfmu import build_fmu, load_model
from loomfmu.spindle.start import periodic_start
from loomfmu.verification.verify import simulate

pytestmark = pytest.mark.slow  # builds FMUs

RPM, ECC, REVOLUTIONS = 16000.0, 5e-6, 3
OUTPUTS = ["r_top", "F_upper", "F_lower"]


def _amplitudes(fmu_path, start):
    stop = REVOLUTIONS * 60.0 / RPM
    t0 = time.process_time()
    run = simulate(fmu_path, solver="rodas4", rtol=1e-8, atol=1e-14, stop_time=stop,
                   output_interval=stop / 150,
                   values={"Omega": RPM * 2 * math.pi / 60, "e_b": ECC, "e_w": ECC, **start}, output=OUTPUTS)
    cpu = (time.process_time() - t0) / stop
    return {k: float(np.mean(run.y[k])) for k in OUTPUTS}, cpu


@pytest.fixture(scope="module")
def measured(spindle_fmu, tmp_path_factory):
    full, cpu_full = _amplitudes(spindle_fmu.path, periodic_start("spindle", n_rpm=RPM,
                                                                  e_b=ECC, e_w=ECC))
    start = periodic_start("spindle_modal", n_rpm=RPM, e_b=ECC, e_w=ECC)
    rows = {}
    for corr in (False, True):
        fmu = build_fmu(load_model("spindle_modal", n_modes=4, static_correction=corr),
                        out_dir=tmp_path_factory.mktemp(f"sc{int(corr)}"))
        amp, cpu = _amplitudes(fmu.path, start)
        rows[corr] = ({k: amp[k] / full[k] - 1.0 for k in OUTPUTS}, cpu)
    print(f"\nfull FE: {full}, CPU {cpu_full:.3f} s/s")
    for corr, (err, cpu) in rows.items():
        print(f"4 modes, static_correction={corr}: "
              + ", ".join(f"{k} {100 * e:+.2f} %" for k, e in err.items())
              + f", CPU {cpu:.3f} s/s")
    return rows


def test_correction_cuts_support_force_errors(measured):
    plain, corrected = measured[False][0], measured[True][0]
    for name in ("F_upper", "F_lower"):
        assert abs(corrected[name]) < 0.5 * abs(plain[name]), (name, plain, corrected)


def test_correction_keeps_the_blade_top_orbit(measured):
    assert abs(measured[True][0]["r_top"]) < 0.01


def test_static_correction_must_be_a_bool():
    with pytest.raises(ValueError, match="static_correction"):
        load_model("spindle_modal", static_correction="yes")


def test_default_build_unchanged():
    m = load_model("spindle_modal")
    assert m.options.get("static_correction") is False
    assert not any(q.name == "R_res" for q in m.quantities)
    assert any(q.name == "R_res" for q in
               load_model("spindle_modal", static_correction=True).quantities)
