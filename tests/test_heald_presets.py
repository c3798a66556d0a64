"""Seed 002's tables as presets: Python, build time and FMU run time."""
from __future__ import annotations

import pytest
from fmpy.fmi1 import FMICallException

from loomfmu import load_model
from loomfmu.heald import preset_names, preset_values
from loomfmu.mechanics.heald_presets import TABLE2, warp_force
from loomfmu.verification.verify import simulate


def test_preset_values_come_from_the_tables():
    v = preset_values("STB-180 Elitex")
    assert v["m_RR"] == 5.2 and v["n_n"] == 500 and v["l"] == 1.8
    assert v["m_heald"] * 9.80665 == pytest.approx(9.0)
    w = preset_values("STB-450 Grob wool")
    assert w["m_RR"] == 11.9 and w["n_n"] == 1400
    assert w["T_max"] / v["T_max"] == pytest.approx(0.368 / 0.17)
    assert len(preset_names()) == 56


def test_table2_rows_are_consistent_after_the_documented_corrections():
    for width, row in TABLE2.items():
        assert row["heald_N"] == pytest.approx(row["threads"] * 0.018, rel=0.05), width
        assert row["G_sum"] == pytest.approx(row["G_rem"] + row["heald_N"], abs=0.6), width
    assert warp_force(180, "wool") == pytest.approx(184, rel=0.01)
    assert warp_force(450, "linen") == pytest.approx(189, rel=0.01)


@pytest.mark.parametrize("name, match", [("STB-200 Elitex", "width"), ("STB-180 Acme", "maker"),
                                         ("Elitex", "preset")])
def test_unknown_presets_are_rejected(name, match):
    with pytest.raises(ValueError, match=match):
        preset_values(name)


def test_preset_at_build_time_sets_start_values():
    m = load_model("heald_frame", preset="STB-330 Texo linen")
    assert m.var("m_RR").start == 8.6 and m.var("l").start == 3.3
    with pytest.raises(ValueError, match="preset"):
        load_model("heald_frame_rigid", preset="STB-999 Texo")


def test_out_of_range_value_is_rejected_in_python():
    m = load_model("heald_frame_rigid")
    with pytest.raises(ValueError, match="m_RR"):
        m.var("m_RR").check_value(-1.0)


@pytest.mark.slow
def test_preset_at_run_time_without_rebuilding(heald_frame_rigid_fmu, slave_factory):
    vals = preset_values("STB-180 Elitex", "heald_frame_rigid")  # no slat length l
    run = simulate(heald_frame_rigid_fmu.path, values=vals, output=["G_rem"])
    assert run.y["G_rem"][0] == pytest.approx(5.2 * 9.80665 + 9.0)
    s = slave_factory(heald_frame_rigid_fmu.path)
    s.fmu.setupExperiment(startTime=0.0)
    with pytest.raises(FMICallException) as exc:
        s.set(m_RR=-3.0)
    assert exc.value.status == 3  # fmi2Error
    assert any("m_RR" in m and "range" in m for _, _, m in s.log)
