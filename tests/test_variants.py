"""A build with non-default options is its own model: its name, FMU file
name and model identifier say the options, and the docs list each
variant's interface."""
from __future__ import annotations

import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

from loomfmu import build_fmu, load_model
from loomfmu.inspection.model_pages import model_markdown
from loomfmu.registry import MODELS, VARIANTS, non_default_options, variant_name


def test_a_default_build_keeps_its_name():
    for name in MODELS:
        m = load_model(name)
        assert m.name == name and m.variant_of == "" and m.registry_name == name


def test_options_of_another_registry_entry_take_its_name():
    m = load_model("backrest", friction="regularized")
    assert m.name == "backrest_regularized" and m.variant_of == ""
    m = load_model("backrest", friction="regularized", fronts=2)
    assert m.name == "backrest_regularized_fronts_2" and m.variant_of == "backrest_regularized"


def test_options_equal_to_the_defaults_keep_the_name():
    m = load_model("backrest", friction="events", eps=1e-3, shedding=True, fronts=1)
    assert m.name == "backrest"
    assert load_model("drive", harmonics=96).name == "drive"
    assert load_model("spindle_modal", basis_rpm=16000).name == "spindle_modal"


@pytest.mark.parametrize("name, options, expected", [
    ("heald_frame", {"warp_tension": "input"}, "heald_frame_warp_tension_input"),
    ("backrest", {"fronts": 2}, "backrest_fronts_2"),
    ("backrest", {"fronts": 2, "eps": 0.01}, "backrest_eps_0p01_fronts_2"),
    ("backrest_regularized", {"eps": 1e-4}, "backrest_regularized_eps_0p0001"),
    ("spindle_modal", {"static_correction": True}, "spindle_modal_static_correction_true"),
    ("drive", {"max_delay": 2.5, "cam": "none"}, "drive_cam_none_max_delay_2p5"),
])
def test_the_name_says_the_non_default_options(name, options, expected):
    m = load_model(name, **options)
    assert m.name == expected and m.variant_of == name and m.registry_name == name
    assert m.options == {**m.options, **options}


def test_variant_names_are_c_identifiers_and_differ_by_value():
    names = {variant_name("drive", {"max_delay": v}) for v in (2.5, 25, 0.25, -2.5, 2.5e-7)}
    assert len(names) == 5
    for n in names:
        assert n.isidentifier(), n
    assert non_default_options("backrest", {"fronts": 1, "shedding": False}) == {
        "shedding": False}


def test_every_listed_variant_changes_the_interface_and_its_page_says_how():
    for name, variants in VARIANTS.items():
        base = load_model(name)
        page = model_markdown(base)
        assert "## Variants with another interface" in page
        for options in variants:
            var = load_model(name, **options)
            io = {(k, v.name) for k in ("input", "output") for v in var.of_kind(k)}
            io0 = {(k, v.name) for k in ("input", "output") for v in base.of_kind(k)}
            assert io != io0, (name, options)
            assert f"`{var.name}`" in page
            for _kind, vname in io ^ io0:
                assert f"`{vname}`" in page.split("## Variants")[1], (name, vname)
        assert "## Variants" not in model_markdown(load_model(name, **variants[0]))


@pytest.mark.slow
def test_a_variant_fmu_is_named_for_its_options(tmp_path):
    result = build_fmu(load_model("heald_frame_rigid", warp_tension="input"),
                       out_dir=tmp_path, validate=False)
    assert result.path.name == "heald_frame_rigid_warp_tension_input.fmu"
    md = read_model_description(str(result.path))
    assert md.coSimulation.modelIdentifier == "heald_frame_rigid_warp_tension_input"
    assert md.modelName == "heald_frame_rigid_warp_tension_input"
    with zipfile.ZipFile(result.path) as z:
        assert "binaries/linux64/heald_frame_rigid_warp_tension_input.so" in z.namelist()
    names = {v.name for v in md.modelVariables}
    assert {"T", "T_end"} <= names
    default = build_fmu(load_model("heald_frame_rigid"), out_dir=tmp_path, validate=False)
    assert Path(default.path).name == "heald_frame_rigid.fmu" and default.path.is_file()
