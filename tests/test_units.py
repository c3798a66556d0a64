"""One unit per quantity: every speed is rad/s in the model description, with
the FMI display unit rpm where machine builders read rpm; no unit in a
variable's name; values given with a unit (``--set omega_loom=240rpm``, a
scene's ``"240 rpm"``) are converted, a unit of another quantity refused."""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import fmpy
import numpy as np
import pytest

from loomfmu.cli.commands import UsageError, _description_of, check_start_values
from loomfmu.cli.dispatch import main as cli_main
from loomfmu.declare.model import Model
from loomfmu.declare.units import UNITS, display_factor, split_quantity, to_unit
from loomfmu.export.dae import dae_form
from loomfmu.export.fmi_xml import model_description
from loomfmu.registry import MODELS, VARIANTS, load_model

#: rpm per rad/s, written out independently of loomfmu.declare.units
RPM_PER_RAD_S = 60 / (2 * math.pi)

#: the speeds machine builders read in rpm: (model, variable)
SPEEDS = [("backrest", "omega_loom"), ("backrest_regularized", "omega_loom"),
          ("loom_shaft", "omega_0"), ("loom_shaft", "omega_out"),
          ("heald_frame", "omega"), ("heald_frame_planar", "omega"),
          ("heald_frame_rigid", "omega"), ("spindle", "Omega"), ("spindle_modal", "Omega"),
          ("drive", "n"), ("drive", "n_out"), ("drive", "n_min")]

#: words that name a unit: none may be part of a variable's name
UNIT_WORDS = {"rpm", "rps", "hz", "deg", "mm", "cm", "kn", "kw", "degc", "percent",
              "rad_s", "m_s", "krpm"}


def every_model():
    for name in sorted(MODELS):
        yield name, load_model(name)
        for options in VARIANTS.get(name, []):
            yield f"{name} {options}", load_model(name, **options)


def _xml(model, version: int) -> str:
    return model_description(model, dae_form(model), "{00000000-0000-0000-0000-000000000000}",
                             ["model.c"], fmi_version=version)


def test_no_variable_is_in_rpm_or_carries_a_unit_in_its_name():
    seen = 0
    for label, model in every_model():
        for v in model.variables:
            seen += 1
            assert v.unit not in ("rpm", "rpm/V", "rpm/m"), (label, v.name, v.unit)
            if v.unit:
                assert UNITS[v.unit].get("factor", 1.0) == 1.0, (label, v.name, v.unit)
            words = set(re.split(r"[_.]", v.name.lower()))
            assert not words & UNIT_WORDS, (label, v.name)
            assert not any(v.name.lower().endswith("_" + w) for w in UNIT_WORDS), \
                (label, v.name)
    assert seen > 300  # the drive alone has 200 cam coefficients


@pytest.mark.parametrize("version", [2, 3])
def test_speeds_are_rad_per_s_with_display_unit_rpm_in_the_model_description(version):
    factor = None
    for name in sorted({m for m, _ in SPEEDS}):
        root = ET.fromstring(_xml(load_model(name), version))
        (unit,) = [u for u in root.iter("Unit") if u.get("name") == "rad/s"]
        (shown,) = unit.findall("DisplayUnit")
        assert shown.get("name") == "rpm" and shown.get("offset") is None
        factor = float(shown.get("factor"))
        assert factor == pytest.approx(RPM_PER_RAD_S, rel=1e-15)
        for model, var in SPEEDS:
            if model != name:
                continue
            if version == 2:
                (sv,) = [s for s in root.iter("ScalarVariable") if s.get("name") == var]
                el = sv.find("Real")
            else:
                (el,) = [s for s in root.iter("Float64") if s.get("name") == var]
            assert (el.get("unit"), el.get("displayUnit")) == ("rad/s", "rpm"), (name, var)
    assert factor is not None


def test_every_variable_with_a_display_unit_is_listed():
    """A speed in rad/s with a display unit is one of SPEEDS (and the other
    rad/s variables are rates of mechanisms nobody reads in rpm: the backrest's
    lever, the frame's hinge angles)."""
    found = {(label.split()[0], v.name) for label, m in every_model() for v in m.variables
             if v.display_unit}
    assert found == set(SPEEDS)


def test_fmpy_reads_the_display_unit_and_its_factor(tmp_path):
    for version in (2, 3):
        path = tmp_path / f"modelDescription{version}.xml"
        path.write_text(_xml(load_model("loom_shaft"), version))
        md = fmpy.read_model_description(str(path))
        (unit,) = [u for u in md.unitDefinitions if u.name == "rad/s"]
        (shown,) = unit.displayUnits
        assert shown.name == "rpm"
        assert float(shown.factor) == pytest.approx(RPM_PER_RAD_S, rel=1e-15)
        assert float(shown.offset) == 0.0
        var = next(v for v in md.modelVariables if v.name == "omega_0")
        assert (var.unit, var.displayUnit) == ("rad/s", "rpm")
        # value_display = factor * value_unit (+ offset): 8 pi rad/s is 240 rpm
        assert float(shown.factor) * float(var.start) == pytest.approx(240.0, rel=1e-14)


@pytest.mark.slow
@pytest.mark.parametrize("version", [2, 3])
def test_an_fmu_with_display_units_validates(tmp_path, version):
    from loomfmu import build_fmu
    fmu = build_fmu(load_model("loom_shaft"), out_dir=tmp_path, fmi_version=version)
    assert fmu.problems == []
    from fmpy.validation import validate_fmu
    assert validate_fmu(str(fmu.path)) == []


def test_display_unit_is_checked_at_declaration():
    m = Model("probe", description="display unit checks")
    m.parameter("w", 1.0, unit="rad/s", display_unit="rpm", description="speed",
                source="assumption: test")
    assert m.var("w").display_unit == "rpm"
    for unit, shown in (("rad/s", "m"), ("m", "rpm"), ("", "rpm"), ("rad/s", "furlong"),
                        ("rad/s", "rad/s")):
        with pytest.raises(ValueError, match=r"x: display_unit = .*; allowed"):
            m.parameter("x", 1.0, unit=unit, display_unit=shown, description="speed",
                        source="assumption: test")
    assert display_factor("rad/s", "rpm") == pytest.approx(RPM_PER_RAD_S, rel=1e-15)


def test_quantities_with_units_convert():
    assert split_quantity("240rpm") == (240.0, "rpm")
    assert split_quantity(" 240 rpm ") == (240.0, "rpm")
    assert split_quantity("-1.5e3 rad/s") == (-1500.0, "rad/s")
    assert split_quantity("2.5") == (2.5, "")
    assert split_quantity("fast") is None
    assert to_unit(240.0, "rpm", "rad/s") == pytest.approx(8 * math.pi, rel=1e-15)
    assert to_unit(240.0, "rpm", "rad/s", {"rpm": (RPM_PER_RAD_S, 0.0)}) == \
        pytest.approx(8 * math.pi, rel=1e-15)
    assert to_unit(3.0, "rad/s", "rad/s") == 3.0
    with pytest.raises(ValueError, match=r"unit 'm' does not measure what 'rad/s' does; "
                                         r"allowed: rad/s, rpm"):
        to_unit(240.0, "m", "rad/s")


def test_cli_set_accepts_a_unit_of_the_same_quantity():
    md, _ = _description_of("backrest", {})
    plain = check_start_values(md, {"omega_loom": 25.132741228718345})
    for text in ("240rpm", "240 rpm", " 240 rpm"):
        got = check_start_values(md, {"omega_loom": text})
        assert got["omega_loom"] == pytest.approx(plain["omega_loom"], rel=1e-15)
    assert check_start_values(md, {"omega_loom": "25 rad/s"}) == {"omega_loom": 25.0}
    with pytest.raises(UsageError, match=r"^--set omega_loom=240m: omega_loom is in rad/s; "
                                         r"allowed units: rad/s, rpm$"):
        check_start_values(md, {"omega_loom": "240m"})
    with pytest.raises(UsageError, match=r"allowed: \[0.10472, 209.44\] rad/s = \[1, 2000\] "
                                         r"rpm$"):
        check_start_values(md, {"omega_loom": "3000 rpm"})


def test_cli_refuses_a_wrong_unit_in_one_line_with_exit_2(capsys):
    with pytest.raises(SystemExit) as e:
        cli_main(["simulate", "backrest", "--set", "omega_loom=240m"])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["loomfmu simulate: error: --set omega_loom=240m: omega_loom is in rad/s; "
                   "allowed units: rad/s, rpm"]


@pytest.mark.slow
def test_cli_simulate_shows_a_speed_in_both_units(tmp_path, capsys):
    assert cli_main(["simulate", "loom_shaft", "--set", "omega_0=300rpm", "--stop", "0.1",
                     "--step", "0.01"]) == 0
    out = capsys.readouterr().out
    assert "set: omega_0 = 31.4159 rad/s (300 rpm)" in out
    rows = [line.split() for line in out.splitlines()]
    i = next(k for k, r in enumerate(rows) if r and r[0] == "omega_out")
    assert rows[i][-1] == "rad/s" and float(rows[i][1]) == pytest.approx(10 * math.pi,
                                                                          rel=1e-5)
    assert rows[i + 1][-1] == "rpm" and float(rows[i + 1][0]) == pytest.approx(300.0,
                                                                              rel=1e-5)


@pytest.mark.slow
def test_drive_speed_is_the_rpm_speed_converted(tmp_path, slave_factory):
    """The drive's speed in rad/s is its speed in rpm times 2 pi / 60: the
    step response of T n' + n = K u(t - tau) to a step U of u_ext at t = 0,
    n = n_min + K U (1 - e^(-(t - tau)/T)), with K and n_min of the seed's
    assumed machine in rpm (DriveParams in rev/s, x 60), against the FMU's
    output read back in rpm through the model description's display unit."""
    from loomfmu import build_fmu
    from loomfmu.mechanics.drive_params import DriveParams
    model = load_model("drive", cam="none", harmonics=1)
    dp = DriveParams()
    assert model.var("K").start == pytest.approx(dp.K * 2 * math.pi, rel=1e-15)  # rad/(s V)
    assert model.var("n_min").start == pytest.approx(dp.n_min * 2 * math.pi, rel=1e-15)
    fmu = build_fmu(model, out_dir=tmp_path, validate=False).path
    md = fmpy.read_model_description(str(fmu))
    (shown,) = next(u for u in md.unitDefinitions if u.name == "rad/s").displayUnits
    U, T, tau = 0.5, model.var("T").start, model.var("tau").start
    s = slave_factory(fmu)
    s.start(solver=1, solver_rtol=1e-10, solver_atol=1e-8)
    s.set(u_ext=U)  # the input steps at t = 0: the history holds 0 before
    t, got, rpm = 0.0, [], []
    for _ in range(300):
        s.fmu.doStep(t, 0.01)
        t += 0.01
        got.append(s.get("n_out")[0])
        rpm.append(dp.n_min * 60 + (dp.K * 60 * U * (1 - math.exp(-(t - tau) / T))
                                    if t >= tau else 0.0))
    got, rpm = np.array(got), np.array(rpm)
    assert np.ptp(rpm) > 100.0  # the step is seen
    assert np.max(np.abs(float(shown.factor) * got - rpm)) < 1e-6
    assert np.max(np.abs(got - rpm * 2 * math.pi / 60)) < 1e-6 * 2 * math.pi / 60


def test_sweep_values_take_a_unit_of_the_same_quantity():
    from loomfmu.cli.sweep import _valuer
    value = _valuer("backrest", {})
    assert value("omega_loom", "240rpm", "--grid omega_loom") == pytest.approx(8 * math.pi,
                                                                              rel=1e-15)
    assert value("omega_loom", "25.5", "--set omega_loom") == 25.5
    assert value("S0", "600", "--set S0") == 600
    with pytest.raises(ValueError, match=r"^--set omega_loom: '240 m': omega_loom is in "
                                         r"rad/s; allowed units: rad/s, rpm$"):
        value("omega_loom", "240 m", "--set omega_loom")


def test_a_composed_scene_keeps_the_display_units():
    from loomfmu.machines import spinning
    from loomfmu.scene import compose
    m = compose(spinning.scene(fidelity="spindle_modal"))
    shown = {v.name for v in m.variables if v.display_unit == "rpm"}
    assert {"drive.n", "drive.n_out", "drive.n_min", "spindle.Omega"} <= shown, shown


def test_a_bare_number_in_a_scene_is_in_the_variables_unit_and_a_range_error_says_what_was_given():
    """'25.13' in a scene is a value in rad/s (it was refused as a wrong
    unit); --set omega_0=-5rpm out of range echoes what was given and its
    value in the variable's unit."""
    import subprocess
    import sys

    from loomfmu.scene import Scene
    s = Scene("x", stop_time=0.1, step=0.01)
    s.add("sh", model="loom_shaft")
    s.set("sh", parameters={"omega_0": "25.1327412287"})
    assert s.components["sh"].parameters["omega_0"] == 25.1327412287
    res = subprocess.run([sys.executable, "-m", "loomfmu", "simulate", "loom_shaft",
                          "--set", "omega_0=-5rpm", "--stop", "0.01"],
                         capture_output=True, text=True, timeout=300)
    last = res.stderr.strip().splitlines()[-1]
    assert res.returncode == 2 and "--set omega_0=-5rpm = -0.5235987" in last, res.stderr
    assert "rad/s" in last and "rpm" in last

