"""The fidelity levels (loomfmu.fidelity) and the per-scene selector
(loomfmu.machines.fidelity): real FMUs of the loom scene run on our master and
compared against the highest-fidelity run; bad arguments named."""
from __future__ import annotations

import math

import numpy as np
import pytest

from loomfmu.cli.scene import main as scene_main
from loomfmu.fidelity import LEVELS, SPINDLE_MODES_HZ, cut_frequency, level, undeclared
from loomfmu.machines import fidelity as sf
from loomfmu.registry import FIDELITY

STOP = 0.5   # s: two picks of the loom at 240 picks/min


@pytest.fixture(scope="module")
def loom_eval(tmp_path_factory):
    """The loom with the seed's tension model (each frame's tension from its
    own shed, docs/guides/heald_fidelity.md's case), two runs per combination."""
    outs = ["frame_a.N_rem", "frame_a.x2_out", "back.S2a", "back.M1f_out"]
    return sf.evaluate("loom", outs, stop_time=STOP, fmu_dir=tmp_path_factory.mktemp("fid"),
                       progress=False, repeats=2, scene_options={"tension": "prescribed"})


def test_every_level_of_the_registry_is_declared_with_what_it_leaves_out():
    assert undeclared() == []
    for levels in FIDELITY.values():
        for m in levels:
            lv = level(m)
            assert lv.represents and lv.cost and lv.suffices
            if len(levels) > 1 and m != levels[-1]:      # a reduced level says what it drops
                assert lv.leaves_out


def test_the_spindle_mode_table_matches_the_modal_model_declaration():
    from loomfmu.registry import load_model
    m = load_model("spindle_modal", n_modes=len(SPINDLE_MODES_HZ))
    found = []
    for k in range(len(SPINDLE_MODES_HZ)):
        desc = m.var(f"eta{2 * k}").description
        found.append(float(desc.split(" Hz")[0].rsplit(" ", 1)[1]))
    assert found == pytest.approx(SPINDLE_MODES_HZ, rel=1e-3)
    assert cut_frequency("spindle_modal", {"n_modes": 4}) == SPINDLE_MODES_HZ[4]


@pytest.mark.slow
def test_the_selector_picks_the_full_models_when_no_reduced_level_is_within_tol(loom_eval):
    tol = 1e-10
    sel = loom_eval.select(tol, ["frame_a.N_rem", "back.M1f_out"])
    assert sel.best is sel.rows[-1]
    assert sel.best.levels == {"frames": "heald_frame", "backrest": "backrest"}
    assert all(r.error > tol for r in sel.rows[:-1])


@pytest.mark.slow
def test_the_selector_picks_the_rigid_frame_for_hinge_loads_at_one_percent(loom_eval):
    # documented case (docs/guides/heald_fidelity.md): the rigid frame's kinetostatic
    # hinge load is within 0.9 % of the spatial model's range
    sel = loom_eval.select(0.01, ["frame_a.N_rem"])
    rigid = [r for r in sel.rows if r.levels["frames"] == "heald_frame_rigid"]
    assert all(0.001 < r.error <= 0.01 for r in rigid)
    # which passing row is cheapest is a CPU-time measurement: the scene's
    # cost is mostly the master and the backrest, so on a loaded machine the
    # frames' levels can swap places; the rule is what is checked: the choice
    # passes, costs within COST_NOISE of the cheapest passing row, and no
    # lower-ranked passing row is that cheap
    passing = [r for r in sel.rows if r.error <= 0.01]
    near = [r for r in passing if r.cpu_s <= min(p.cpu_s for p in passing) * (1 + sf.COST_NOISE)]
    assert sel.best in near
    assert loom_eval._rank(sel.best) == min(loom_eval._rank(r) for r in near)
    tight = loom_eval.select(0.001, ["frame_a.N_rem"])
    passing = [r for r in tight.rows if r.error <= 0.001]
    # at 0.1 % the rigid frame fails and the planar frame passes; which of the
    # planar and spatial frames is cheaper is a CPU-time measurement (the
    # planar one is ~0.9x the spatial one's cost, within the selector's
    # COST_NOISE on a loaded machine), so the choice is checked by cost below
    assert all(r.levels["frames"] != "heald_frame_rigid" for r in passing)
    assert any(r.levels["frames"] == "heald_frame_planar" for r in passing)
    assert tight.best.levels["frames"] in ("heald_frame_planar", "heald_frame")
    assert tight.best.cpu_s <= min(r.cpu_s for r in passing) * (1 + sf.COST_NOISE)


@pytest.mark.slow
def test_a_level_without_the_output_predicts_zero_and_fails(loom_eval):
    sel = loom_eval.select(0.01, ["frame_a.x2_out"])
    assert sel.best.levels["frames"] == "heald_frame"
    y = loom_eval.reference["frame_a.x2_out"]
    for r in sel.rows:
        if r.levels["frames"] != "heald_frame":
            assert "frame_a.x2_out" in r.absent
            assert r.error == pytest.approx(np.abs(y).max() / np.ptp(y))


@pytest.mark.slow
def test_the_regularized_backrest_suffices_for_warp_tension_and_not_for_friction(loom_eval):
    sel = loom_eval.select(0.01, ["back.S2a"])
    reg = [r for r in sel.rows if r.levels["backrest"] == "backrest_regularized"]
    assert reg and all(r.error <= 0.01 for r in reg)
    # which passing row is chosen is a CPU-time measurement: since the
    # event-driven backrest got as cheap as the regularized one, every row
    # of this scene costs the same within noise (64-68 ms, the master's
    # work), so the rule is what is checked, as for the frames above
    passing = [r for r in sel.rows if r.error <= 0.01]
    near = [r for r in passing if r.cpu_s <= min(p.cpu_s for p in passing) * (1 + sf.COST_NOISE)]
    assert sel.best in near
    assert loom_eval._rank(sel.best) == min(loom_eval._rank(r) for r in near)
    fric = loom_eval.select(0.01, ["back.M1f_out"])
    assert all(r.error > 0.01 for r in fric.rows if r.levels["backrest"] ==
               "backrest_regularized")


@pytest.mark.slow
def test_table_json_and_chart(loom_eval, tmp_path):
    sel = loom_eval.select(0.01)
    text = sel.table()
    assert f"{STOP:g} s at step" in text and "chosen:" in text
    d = sel.to_dict()
    assert d["facts"]["components"]["frame_a"]["model"] == "heald_frame"
    assert len(d["rows"]) == 6
    assert sel.chart(tmp_path / "c.png").stat().st_size > 10_000


def test_high_content_measures_the_part_above_the_cut():
    t = np.arange(0, 1, 1e-3)
    for f_low, phase in ((3.0, 0.0), (2.7, 1.1), (0.4, 0.3)):   # not periodic in the window
        low = np.sin(2 * math.pi * f_low * t + phase)
        y = low + 0.1 * np.sin(2 * math.pi * 50 * t)
        assert sf.high_content(t, y, 20.0) == pytest.approx(0.1 / np.ptp(y), rel=0.3)
        assert sf.high_content(t, low, 20.0) < 2e-3        # the measure's floor
    assert sf.high_content(t, np.full_like(t, 2.0), 20.0) == 0.0


@pytest.mark.parametrize("kw, name", [
    ({"scene": "weaving"}, "scene"),
    ({"outputs": []}, "outputs"),
    ({"outputs": ["frame_a.nope"]}, "outputs"),
    ({"stop_time": 0.0}, "stop_time"),
    ({"step": 2.0}, "step"),
    ({"repeats": 0}, "repeats"),
    ({"master": "euler"}, "master"),
    ({"scene_options": {"frame": "heald_frame"}}, "scene_options"),
    ({"scene_options": {"tension": "pulled"}}, "tension"),
    ({"couplings": "jacobi"}, "couplings"),
    ({"couplings": []}, "couplings"),
    ({"couplings": ["cosim", "cosim"]}, "couplings"),
])
def test_bad_arguments_are_named(kw, name):
    args = {"scene": "loom", "outputs": ["frame_a.N_rem"], **kw}
    with pytest.raises(ValueError, match=name):
        sf.evaluate(args.pop("scene"), args.pop("outputs"), progress=False, **args)


@pytest.mark.parametrize("tol", [0.0, 1.0, -0.1, math.nan, "1%"])
@pytest.mark.slow
def test_bad_tolerance_is_named(tol, loom_eval):
    with pytest.raises(ValueError, match="tol"):
        loom_eval.select(tol)
    with pytest.raises(ValueError, match="tol"):
        sf.select("loom", ["frame_a.N_rem"], tol)


def test_bad_level_is_named():
    with pytest.raises(ValueError, match="model"):
        level("heald_frame_flexible")
    assert set(LEVELS) >= {m for lv in FIDELITY.values() for m in lv}


def test_the_command_refuses_a_bad_tolerance_in_one_line(capsys):
    assert scene_main(["fidelity", "loom", "--outputs", "frame_a.N_rem", "--tol", "2"]) == 2
    assert "tol" in capsys.readouterr().err


def test_loomfmu_list_prints_what_each_level_leaves_out(capsys):
    from loomfmu.cli.dispatch import main
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name, lv in LEVELS.items():
        assert f"{name}: leaves out {'; '.join(lv.leaves_out) or 'nothing'}" in out


@pytest.mark.slow
def test_the_coupling_is_a_choice_and_the_composed_reference_has_no_coupling_error(
        tmp_path, monkeypatch):
    """With both couplings every combination runs co-simulated and composed;
    the reference is the highest combination composed, and the co-simulated
    highest combination differs from it by its coupling error only. (On two
    frame levels and one backrest level of the loom: each combination is a
    composed FMU to compile, about 10 s of gcc each.)"""
    factory, slots, *rest = sf.SCENES["loom"]
    monkeypatch.setitem(sf.SCENES, "loom", (factory, {"frames": [slots["frames"][0],
                                                                 slots["frames"][-1]],
                                                      "backrest": [slots["backrest"][-1]]},
                                            *rest))
    ev = sf.evaluate("loom", ["frame_a.N_rem", "back.S2a"], stop_time=0.1,
                     fmu_dir=tmp_path, progress=False, repeats=1,
                     couplings="monolithic,cosim")
    assert len(ev.rows) == 4 and ev.facts["reference_coupling"] == "monolithic"
    assert ev.rows[-1].levels == {"frames": "heald_frame", "backrest": "backrest",
                                  "coupling": "monolithic"} and ev.rows[-1].error == 0.0
    full_cosim = next(r for r in ev.rows if r.levels == {
        "frames": "heald_frame", "backrest": "backrest", "coupling": "cosim"})
    assert 1e-6 < full_cosim.error < 0.2     # the 1 ms Jacobi step's coupling error
    sel = ev.select(0.5)      # every row passes: the cheapest, ties to composed
    assert sel.best.levels["coupling"] == "monolithic" or sel.best.cpu_s < min(
        r.cpu_s for r in sel.rows if r.levels["coupling"] == "monolithic")
