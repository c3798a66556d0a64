"""Scenes: every connection is checked at declaration (wrong kind, unit,
direction, an input driven twice, an unknown variable, ...), values are
checked, units are converted on the way, an SSP export validates against the
SSP 1.0 schema, and the `loomfmu scene` command answers."""
from __future__ import annotations

import math
import re
import warnings
import zipfile

import numpy as np
import pytest

from loomfmu.cli.scene import main
from loomfmu.machines import two_mass as tm
from loomfmu.scene import Scene, run
from loomfmu.scene.fmus import build_fmus
from loomfmu.scene.run import MIN_JUDGED_STEPS, Result, UnresolvedCoupling
from loomfmu.scene.ssp import ssd_text, validate_ssd

#: rpm -> rad/s, written out independently of loomfmu.declare.units
RPM = 2 * math.pi / 60


def loom() -> Scene:
    s = Scene("loom_parts", stop_time=0.02, step=1e-3)
    s.add("drive", model="drive", options={"harmonics": 1, "cam": "none"})
    s.add("frame", model="heald_frame_rigid")
    s.add("back", model="backrest")
    return s


def tacho():
    """A declared speed source in rpm (every registered model's speeds are
    rad/s): what a foreign FMU in another unit looks like to a scene."""
    from loomfmu.declare.model import Model
    m = Model("tacho", description="constant speed source in rpm", stop_time=0.02,
              step_size=1e-3, h_fixed=1e-4)
    n = m.parameter("n", 2000.0, unit="rpm", description="speed", min=1.0, max=1e5,
                    source="assumption: a test value")
    x = m.state("x", 0.0, unit="rad", description="angle")
    m.eq(m.der(x), n * RPM)
    m.output("speed", n, unit="rpm", description="speed")
    m.port("shaft", "flange", speed="speed", description="speed in rpm")
    return m


def raises(match: str):
    return pytest.raises(ValueError, match=match)


# -- connection checks ----------------------------------------------------------------
def test_port_kinds_must_match():
    s = loom()
    with raises(r"connection drive.spindles -> back.warp_front: port kinds differ "
                r"\('flange' and 'warp'\); allowed: a port of kind 'flange' of back: none"):
        s.connect("drive.spindles", "back.warp_front")
    assert s.connections == []


def test_direction_each_role_an_output_on_one_side_and_an_input_on_the_other():
    m = Scene("masses")
    m.add("a", model="two_mass_force")
    m.add("b", model="two_mass_force")
    m.add("c", model="two_mass_displacement")
    # two force sides: the force is an output on both, the position an input on both
    with raises(r"connection a.coupling -> b.coupling: role 'force' is a.F_c \(output\) "
                r"and b.F_c \(output\); allowed: an output on one side and an input on "
                r"the other"):
        m.connect("a.coupling", "b.coupling")
    assert len(m.connect("c.coupling", "a.coupling")) == 3
    s = loom()
    with raises(r"back.warp_pull is an input variable; allowed: an output of back"):
        s.connect("back.warp_pull", "frame.omega")
    with raises(r"frame.dl is an output variable; allowed: an input of frame"):
        s.connect("drive.n_out", "frame.dl")
    with raises(r"frame.k_z is a parameter variable; allowed: an input of frame"):
        s.connect("drive.n_out", "frame.k_z")


def test_units_must_measure_the_same_quantity_and_are_converted():
    s = loom()
    s.add("tacho", model=tacho())
    with raises(r"connection tacho.speed -> back.warp_pull: unit 'rpm' of tacho.speed "
                r"cannot be converted to 'm' of back.warp_pull; allowed: units of the "
                r"same quantity"):
        s.connect("tacho.speed", "back.warp_pull")
    (c,) = s.connect("tacho.shaft", "frame.shaft")   # rpm out, rad/s in
    assert (c.src, c.src_var, c.dst, c.dst_var) == ("tacho", "speed", "frame", "omega")
    assert c.gain == pytest.approx(RPM, rel=1e-15) and c.bias == 0.0
    s = loom()
    (c,) = s.connect("drive.spindles", "frame.shaft")   # rad/s both
    assert (c.gain, c.bias) == (1.0, 0.0)


def test_an_input_is_driven_once():
    s = loom()
    s.add("drive2", model="drive", options={"harmonics": 1, "cam": "none"})
    s.connect("drive.n_out", "frame.omega")
    with raises(r"connection drive2.spindles -> frame.shaft: input frame.omega is already "
                r"driven by drive.n_out -> frame.omega; allowed: one connection into each"):
        s.connect("drive2.spindles", "frame.shaft")
    with raises(r"frame.omega \(start\): driven by connection drive.n_out -> frame.omega"):
        s.set("frame", start={"omega": 10.0})
    assert len(s.connections) == 1


def test_unknown_names_are_refused_with_what_is_allowed():
    s = loom()
    with raises(r"drive has no variable or port 'speed'; allowed: an output of drive "
                r"\(.*n_out.*\) or a port \(spindles\)"):
        s.connect("drive.speed", "frame.omega")
    with raises(r"no component 'fram' in scene 'loom_parts'; allowed: back, drive, frame"):
        s.connect("drive.n_out", "fram.omega")
    with raises(r"'drive_n_out'; allowed: 'component.variable' or 'component.port'"):
        s.connect("drive_n_out", "frame.omega")
    with raises(r"drive.spindles is a port and frame.omega is not"):
        s.connect("drive.spindles", "frame.omega")
    # a port that does not exist (the one-front backrest has warp_front only)
    with raises(r"connection frame.warp -> back.warp_front_a: back has no port "
                r"'warp_front_a' \(it does not exist\); allowed: a port of back "
                r"\(warp_back, warp_front\)"):
        s.connect("frame.warp", "back.warp_front_a")
    with raises(r"connection back.warp_front_b -> frame.warp: back has no port "
                r"'warp_front_b' \(it does not exist\); allowed: a port of back "
                r"\(warp_back, warp_front\)"):
        s.connect("back.warp_front_b", "frame.warp")
    with raises(r"both ends are in component 'back'"):
        s.connect("back.S2", "back.warp_pull")
    with raises(r"model = 'loom'; allowed: one of .*two_mass_force"):
        s.add("x", model="loom")
    with raises(r"component 'drive' is already in scene"):
        s.add("drive", model="drive")
    with raises(r"record 'frame.nope': no such variable"):
        s.record("frame.nope")


def test_a_value_with_a_unit_is_converted_or_refused_naming_the_allowed_units():
    s = loom()
    s.set("back", parameters={"omega_loom": "240 rpm"})
    assert s.components["back"].parameters["omega_loom"] == pytest.approx(8 * math.pi,
                                                                           rel=1e-15)
    s.set("back", parameters={"omega_loom": "240rpm"})
    assert s.components["back"].parameters["omega_loom"] == pytest.approx(8 * math.pi,
                                                                           rel=1e-15)
    s.set("back", parameters={"omega_loom": "25 rad/s"})
    assert s.components["back"].parameters["omega_loom"] == 25.0
    with raises(r"back.omega_loom \(parameters\) = '240 m': omega_loom is in rad/s; "
                r"allowed units: rad/s, rpm$"):
        s.set("back", parameters={"omega_loom": "240 m"})
    with raises(r"back.S0 \(parameters\) = '240 rpm': S0 is in N; allowed units: N$"):
        s.set("back", parameters={"S0": "240 rpm"})
    with raises(r"back.omega_loom \(parameters\) = 'fast'; allowed: a finite number"):
        s.set("back", parameters={"omega_loom": "fast"})


def test_values_are_checked():
    s = loom()
    with raises(r"drive.n_min = -5 rad/s \(-47.7465 rpm\); allowed: a number in "
                r"\[0.10472, 10472\] rad/s = \[1, 100000\] rpm"):
        s.set("drive", parameters={"n_min": -5.0})
    with raises(r"back.S2 \(start\): an output variable; allowed: .*letoff"):
        s.set("back", start={"S2": 1.0})
    with raises(r"back.omega1 \(parameters\): a local variable; allowed: .*S0"):
        s.set("back", parameters={"omega1": 1.0})
    with raises(r"back.S0 = nan; allowed: a finite number"):
        s.set("back", parameters={"S0": float("nan")})
    with raises(r"back.solver = 1.5; allowed: an integer"):
        s.set("back", parameters={"solver": 1.5})
    s.set("back", parameters={"S0": 2500.0, "solver": 2}, start={"omega1": 0.1})
    assert s.components["back"].parameters == {"S0": 2500.0, "solver": 2}


@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory):
    """The two-mass FMUs, built once for this module."""
    path = tmp_path_factory.mktemp("scene_fmus")
    build_fmus(tm.scene(), path)
    return path


@pytest.mark.slow
def test_an_fmu_file_is_a_component_without_ports(fmu_dir, tmp_path):
    fmus = build_fmus(tm.scene(), fmu_dir)
    f = Scene("files")
    f.add("a", fmu=fmus["force"], start={"x1": 0.2})
    f.add("b", fmu=fmus["disp"])
    with raises(r"a has no variable or port 'coupling'"):
        f.connect("a.coupling", "b.coupling")
    f.connect("a.F_c", "b.F_in")
    f.connect("b.x2_out", "a.x2_in")
    f.connect("b.v2_out", "a.v2_in")
    with raises(r"fmu = '.*nothing.fmu': no such file"):
        f.add("c", fmu=tmp_path / "nothing.fmu")
    # the same system as the declared scene: the same trajectory
    res = run(f, step=1e-3, stop=0.05)
    ref = run(tm.scene(x1_0=0.2, tight=False), step=1e-3, stop=0.05, fmus=fmus,
              master="jacobi", extrapolation=0)
    assert np.allclose(res["a.x1_out"], ref["force.x1_out"], rtol=0, atol=1e-12)


@pytest.mark.slow
def test_a_unit_conversion_is_applied_in_the_run(tmp_path):
    s = loom()
    s.add("tacho", model=tacho(), parameters={"n": 2000.0})
    s.connect("tacho.shaft", "frame.shaft")
    s.record("tacho.speed", "frame.omega")
    res = run(s, fmu_dir=tmp_path)
    assert res["tacho.speed"][-1] == pytest.approx(2000.0, rel=1e-9)
    assert np.allclose(res["frame.omega"], RPM * res["tacho.speed"], rtol=1e-14, atol=0)
    assert not any("outside its range" in line for line in res.log["frame"])


def test_options_are_checked_before_any_fmu_is_built(tmp_path):
    s = tm.scene()
    for kw, match in (({"rtol": 0.0, "adaptive": True}, r"rtol = 0.0; allowed"),
                      ({"rtol": math.nan}, r"rtol = nan; allowed"),
                      ({"master": "newton"}, r"master = 'newton'"),
                      ({"loop_options": {"tol": 1}}, r"loop_options: unknown"),
                      ({"extrapolation": 0, "master_options": {"output_derivatives": True}},
                       r"output_derivatives = True with extrapolation = 0")):
        with raises(match):
            run(s, fmu_dir=tmp_path, **kw)
    assert list(tmp_path.iterdir()) == []      # nothing was built


def test_the_fmu_cache_is_keyed_by_the_code_not_only_the_variables(monkeypatch):
    """A model edit that keeps every variable gets a new file name (a stale
    FMU is not reused)."""
    import loomfmu.scene.fmus as fmus_mod
    from loomfmu.declare.model import Model
    from loomfmu.scene.declare import Component
    from loomfmu.scene.interface import interface_of_model

    def model(gain: float) -> Model:
        m = Model("cache_probe", description="cache test", stop_time=1.0, step_size=1e-2,
                  h_fixed=1e-3)
        x = m.state("x", 1.0, description="state")
        m.eq(m.der(x), -gain * x)
        m.output("y", x, description="output")
        return m

    comp = Component("c", interface_of_model(model(1.0)), model="cache_probe")
    names = []
    for gain in (1.0, 2.0, 1.0):
        monkeypatch.setattr(fmus_mod, "declare_model", lambda name, options, g=gain: model(g))
        names.append(fmus_mod.fmu_file_name(comp))
    assert names[0] != names[1] and names[0] == names[2]
    assert names[0].startswith("cache_probe-") and names[0].endswith(".fmu")


# -- SSP ----------------------------------------------------------------------------
def test_ssd_validates_and_carries_connections_values_and_conversions():
    s = loom()
    s.set("back", parameters={"S0": 2500.0})
    s.add("tacho", model=tacho())
    s.connect("tacho.shaft", "frame.shaft")
    text = ssd_text(s)
    assert validate_ssd(text) == []
    assert ('<ssd:Connection startElement="tacho" startConnector="speed" endElement="frame" '
            'endConnector="omega">') in text
    assert f'<ssc:LinearTransformation factor="{RPM!r}" offset="0.0" />' in text
    assert '<ssv:Parameter name="S0">' in text and '<ssv:Real value="2500.0" />' in text
    assert '<ssc:Unit name="rpm">' in text
    # the validator finds what is wrong
    broken = text.replace("<ssd:Elements>", "<ssd:Elementz>").replace("</ssd:Elements>",
                                                                       "</ssd:Elementz>")
    assert validate_ssd(broken) and "Elementz" in " ".join(validate_ssd(broken))


@pytest.mark.slow
def test_the_exported_ssp_keeps_state_starts_and_the_solver_on_libcosim(fmu_dir, tmp_path):
    """A state's start (x1) reaches libcosim (it drops a parameter-set value
    of a non-input), and the solver Enumeration is written as the
    solver_index Integer (libcosim cannot set Enumerations); libcosim's run
    is then our libcosim-like Jacobi (outputs read before inputs change)."""
    pytest.importorskip("libcosimpy")
    from loomfmu.scene.libcosim import run_ssp
    from loomfmu.scene.ssp import export_ssp
    s = tm.scene(x1_0=0.25, stop_time=0.05, step=1e-3)
    s.set("force", parameters={"solver": 2})
    text = ssd_text(s)
    assert '<ssv:Parameter name="solver_index">' in text
    assert '<ssv:Parameter name="solver">' not in text
    assert '<ssv:Parameter name="x1">' in text
    fmus = build_fmus(s, fmu_dir)
    ssp = export_ssp(s, tmp_path / "tm.ssp", fmus=fmus)
    refs = s.recorded_variables()
    theirs = run_ssp(ssp, refs, step=1e-3, stop=0.05)
    ours = run(s, fmus=fmus, master="jacobi", extrapolation=0,
               master_options={"resolve_feedthrough": False})
    for c, v in refs:
        a, b = theirs[f"{c}.{v}"], ours[f"{c}.{v}"][1:]
        assert np.abs(a - b).max() <= 1e-9 * np.abs(b).max(), (c, v)
    # mass 1 started at x1 = 0.25 (the model's default start is not that)
    assert theirs["force.x1_out"][0] == pytest.approx(0.25, rel=1e-3)


# -- the command ----------------------------------------------------------------------
@pytest.mark.slow
def test_scene_command(fmu_dir, tmp_path, capsys):
    assert main(["list"]) == 0
    assert "force.coupling <-> disp.coupling" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(["run", "two_mass", "--master", "newton"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "invalid choice: 'newton'" in err
    assert main(["run", "weaving"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("loomfmu scene run: error: scene = 'weaving'; allowed: ")
    assert "two_mass" in err.split("allowed: ")[1]
    assert main(["run", "two_mass", "--step", "-1"]) == 2
    csv = tmp_path / "out.csv"
    assert main(["run", "two_mass", "--stop", "0.01", "--csv", str(csv),
                 "--fmu-dir", str(fmu_dir)]) == 0
    table = np.genfromtxt(csv, delimiter=",", names=True)
    assert len(table) == 11 and table["forcex1_out"][0] == pytest.approx(0.1)
    out = tmp_path / "tm.ssp"
    assert main(["export", "two_mass", "--out", str(out), "--fmu-dir", str(fmu_dir)]) == 0
    with zipfile.ZipFile(out) as z:
        assert sorted(z.namelist()) == ["SystemStructure.ssd", "resources/disp.fmu",
                                        "resources/force.fmu"]
    assert main(["export", "two_mass", "--out", str(tmp_path / "x.zip")]) == 2
    capsys.readouterr()
    # output paths and options are checked before the run, in one line
    for argv, said in ((["--csv", str(csv / "x.csv")], f"cannot be made ('{csv}' is a file)"),
                       (["--csv", str(tmp_path)], "an existing directory, not a file; allowed"),
                       (["--csv", "/proc/x.csv"], "not writable"),
                       (["--fmu-dir", str(csv)], "an existing file, not a directory"),
                       (["--output-derivatives", "--extrapolation", "0"],
                        "output_derivatives = True with extrapolation = 0"),
                       (["--rtol", "nan", "--adaptive"], "rtol = nan")):
        assert main(["run", "two_mass", "--stop", "0.01"] + argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and said in err[0], (argv, err)


@pytest.mark.slow
def test_a_step_that_does_not_resolve_the_coupling_is_flagged(fmu_dir, capsys):
    """two_mass at a 0.1 s step (the Jacobi master's stability limit is about
    5.35 ms) ends at F_c ~ 3e13 N: scene run says so on stderr (before: exit
    0 and no word); at 1 ms it prints the step's resolution instead."""
    assert main(["run", "two_mass", "--step", "0.1", "--master", "jacobi",
                 "--extrapolation", "0", "--fmu-dir", str(fmu_dir)]) == 0
    out, err = capsys.readouterr()
    warning = [l for l in err.splitlines() if "warning:" in l]
    assert len(warning) == 1 and "do not resolve the coupled signals" in warning[0], err
    assert main(["run", "two_mass", "--step", "0.001", "--stop", "0.5",
                 "--fmu-dir", str(fmu_dir)]) == 0
    out, err = capsys.readouterr()
    assert "warning:" not in err
    line = [l for l in out.splitlines() if "largest change within one step" in l]
    assert len(line) == 1, out
    change = float(re.search(r"step: (\S+) %", line[0]).group(1))
    assert 0.5 < change < 10, line


@pytest.mark.slow
def test_run_warns_python_users_of_an_unresolved_coupling(fmu_dir):
    with pytest.warns(UnresolvedCoupling, match="disp.x2_out changes by 1.25 times"):
        run(tm.scene(), step=0.1, fmu_dir=fmu_dir, master="jacobi", extrapolation=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnresolvedCoupling)
        run(tm.scene(), step=0.001, stop=0.2, fmu_dir=fmu_dir)   # no warning


def test_largest_step_change_measures_the_resolution():
    t = np.linspace(0.0, 1.0, 101)
    data = np.zeros(101, dtype=[("time", "f8"), ("a.y", "f8"), ("b.z", "f8")])
    data["time"], data["a.y"], data["b.z"] = t, np.sin(2 * np.pi * t), 3.0
    res = Result(data, "jacobi", 100, 0, coupled=["a.y", "b.z"])
    change, name = res.largest_step_change()
    assert name == "a.y" and change == pytest.approx(2 * np.pi * 0.01, rel=1e-3)
    data["b.z"][50] = np.inf
    assert res.largest_step_change() == (math.inf, "b.z")
    # only the coupled signals are judged (a friction moment may jump)
    data["b.z"][50] = -3.0
    assert Result(data, "jacobi", 100, 0, coupled=["a.y"]).largest_step_change()[1] == "a.y"
    assert Result(data, "jacobi", 100, 0).largest_step_change() == (0.0, "")
    # a run of fewer than MIN_JUDGED_STEPS steps is not judged (a signal from
    # rest changes by about 2 / steps of its size however well resolved)
    short = Result(data[:MIN_JUDGED_STEPS], "jacobi", MIN_JUDGED_STEPS - 1, 0, coupled=["a.y"])
    assert short.largest_step_change() == (0.0, "")
    assert Result(data[:MIN_JUDGED_STEPS + 1], "jacobi", MIN_JUDGED_STEPS, 0,
                  coupled=["a.y"]).largest_step_change()[1] == "a.y"
    # a signal near zero (below atol) changes by nothing
    data["a.y"] *= 1e-12
    small = Result(data, "jacobi", 100, 0, coupled=["a.y"]).largest_step_change()[0]
    assert small < 1e-6


@pytest.mark.slow
def test_run_arguments_are_checked(fmu_dir):
    s = tm.scene()
    fmus = build_fmus(s, fmu_dir)
    with raises(r"master = 'newton'; allowed: jacobi, gauss-seidel"):
        run(s, master="newton", fmus=fmus, stop=0.01)
    with raises(r"master 'jacobi': unknown options \['order'\]; allowed: .*"
                r"resolve_feedthrough"):
        run(s, master="jacobi", fmus=fmus, stop=0.01, master_options={"order": ["disp"]})
    with raises(r"order = \['disp'\]; allowed: every component once"):
        run(s, master="gauss-seidel", fmus=fmus, stop=0.01,
            master_options={"order": ["disp"]})
    with raises(r"fmus: no FMU for components \['force'\]"):
        run(s, fmus={"disp": fmus["disp"]}, stop=0.01)
    with raises(r"step = 0.5; allowed: a finite number in \(0, 0.01\] s"):
        run(s, fmus=fmus, stop=0.01, step=0.5)
    with raises(r"rtol = 2; allowed: a number in \(0, 1\)"):
        run(s, fmus=fmus, stop=0.01, adaptive=True, rtol=2)
    # the FMUs given must be the components' and exist
    with raises(r"fmus\['disp'\] = '.*two_mass_force.*': its variables \(names, value "
                r"references, causalities\) are not those of component disp"):
        run(s, fmus={"force": fmus["force"], "disp": fmus["force"]}, stop=0.01)
    with raises(r"fmus\['disp'\] = '/nonexistent/d.fmu': no such file"):
        run(s, fmus={"force": fmus["force"], "disp": "/nonexistent/d.fmu"}, stop=0.01)
    # h_min concerns the adaptive run only; a stop below the scene's step names stop
    assert len(run(s, fmus=fmus, stop=1e-12, step=1e-12)["time"]) == 2
    with raises(r"stop = 1e-300 s is shorter than the scene's step 0.001 s"):
        run(s, fmus=fmus, stop=1e-300)
    with raises(r"output_derivatives = True with extrapolation = 0"):
        run(s, fmus=fmus, stop=0.01, extrapolation=0,
            master_options={"output_derivatives": True})
    from loomfmu.scene.libcosim import step_ns
    assert step_ns(1e-3) == 1_000_000
    with raises(r"step = 1.15e-09 s is not a whole number of nanoseconds"):
        step_ns(1.5e-10 + 1e-9)


def test_a_step_too_small_to_finish_is_refused_before_anything_runs(tmp_path, capsys):
    """A fixed step of 1e-300 s would take 2e300 communication points: it is
    refused (ValueError naming step and the allowed range) before any FMU is
    built, in Python, in a Scene's default and on the command line."""
    from loomfmu.declare.checks import MAX_POINTS
    s = tm.scene()
    with raises(r"step = 1e-300 s gives 2e\+300 communication points up to stop = 2 s; "
                rf"allowed: a step in \[2e-06, 2\] s \(at most {MAX_POINTS} points\)"):
        run(s, step=1e-300, fmu_dir=tmp_path)
    with raises(r"step = 1e-07 s gives 1e\+07 communication points up to stop = 1 s"):
        run(s, step=1e-7, stop=1.0, fmu_dir=tmp_path)
    with raises(r"step = 1e-300 s gives 2e\+300 communication points up to stop_time = 2 s"):
        tm.scene(step=1e-300)
    assert list(tmp_path.iterdir()) == []      # nothing was built
    assert main(["run", "two_mass", "--step", "1e-300", "--fmu-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "step = 1e-300 s gives" in err
    assert list(tmp_path.iterdir()) == []


def test_a_scene_given_by_name_is_refused_with_how_to_load_it():
    with raises(r"scene = 'two_mass'; allowed: a loomfmu.scene.Scene "
                r"\(loomfmu.machines.library.load_scene\('two_mass'\) gives a shipped "
                r"scene by name\)"):
        run("two_mass")
    with raises(r"scene = None; allowed: a loomfmu.scene.Scene \(declare one with "
                r"Scene\(...\)\)"):
        run(None)


@pytest.mark.slow
def test_a_run_takes_the_scenes_recommended_master_unless_given_one(fmu_dir, capsys):
    """Each seed scene declares the master, extrapolation and step its page
    recommends; run() and `scene run` take each the caller does not give."""
    s = tm.scene()
    assert (s.master, s.extrapolation, s.step) == ("gauss-seidel", 2, 1e-3)
    fmus = build_fmus(s, fmu_dir)
    res = run(s, stop=0.05, fmus=fmus)
    assert (res.master, res.extrapolation) == ("gauss-seidel", 2)
    same = run(s, stop=0.05, fmus=fmus, master="gauss-seidel", extrapolation=2)
    assert np.array_equal(res.data, same.data)
    # explicit arguments win, each on its own
    assert run(s, stop=0.05, fmus=fmus, master="jacobi").extrapolation == 2
    held = run(s, stop=0.05, fmus=fmus, master="jacobi", extrapolation=0)
    assert (held.master, held.extrapolation) == ("jacobi", 0)
    assert not np.array_equal(held.data, res.data)
    # a generic scene recommends the plain Jacobi master holding its inputs
    assert (Scene("x").master, Scene("x").extrapolation) == ("jacobi", 0)
    with raises(r"master = 'newton'; allowed: jacobi, gauss-seidel"):
        Scene("x", master="newton")
    with raises(r"extrapolation = 3; allowed: one of 0, 1, 2"):
        Scene("x", extrapolation=3)
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name, step in (("two_mass", "0.001"), ("spinning", "0.01"), ("loom", "0.002")):
        assert (f"recommended: master gauss-seidel, extrapolation 2, step {step} s (the "
                f"defaults of 'loomfmu scene run {name}')") in out
    assert main(["run", "two_mass", "--stop", "0.01", "--fmu-dir", str(fmu_dir)]) == 0
    out = capsys.readouterr().out
    assert ("scene two_mass, master gauss-seidel, extrapolation 2 (master, extrapolation, "
            "step: the scene's recommendation): 10 steps accepted") in out
