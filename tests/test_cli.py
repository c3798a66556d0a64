"""The ``loomfmu`` command as a user meets it: help everywhere, usage errors
in one line with exit code 2, a real build, simulation and verification, and
progress lines in logs. Every call runs the installed console script in a
subprocess, as a shell would."""
from __future__ import annotations

import csv
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from loomfmu.declare.solvers import SOLVERS
from loomfmu.registry import MODELS

pytestmark = pytest.mark.slow  # the command end to end: subprocesses that build FMUs

BIN = Path(sys.executable).parent
LOOMFMU = [str(BIN / "loomfmu")] if (BIN / "loomfmu").exists() else \
    [sys.executable, "-m", "loomfmu"]
ROOT = Path(__file__).resolve().parents[1]


def run(*args, cwd=None, env=None, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run([*LOOMFMU, *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout,
                          env={**os.environ, "LOOMFMU_PROGRESS": "plain", **(env or {})})


SUBCOMMANDS = [["list"], ["build"], ["simulate"], ["verify"], ["check"], ["docs"], ["heald"],
               ["heald", "claims"], ["heald", "fidelity"], ["heald", "design"], ["drive"],
               ["drive", "table"], ["drive", "charts"], ["drive", "tracking"], ["rotor"],
               ["bench"], ["inspect"], ["scene"], ["scene", "run"], ["scene", "build"],
               ["scene", "inspect"], ["scene", "export"], ["scene", "fidelity"], ["sweep"],
               ["sweep", "run"], ["sweep", "design-map"], ["sweep", "drive-grid"],
               ["sweep", "loom-stick"], ["heald", "tension-input"]]


def test_console_script_is_installed():
    assert (BIN / "loomfmu").exists(), "pip install did not create the loomfmu script"


@pytest.mark.parametrize("words", [[]] + SUBCOMMANDS, ids=lambda w: " ".join(w) or "top")
def test_help_works_everywhere(words):
    res = run(*words, "--help")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("usage: loomfmu"), res.stdout[:200]


def test_python_dash_m_is_the_same_command():
    res = subprocess.run([sys.executable, "-m", "loomfmu", "list", "--json"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert set(json.loads(res.stdout)["models"]) == set(MODELS)


def test_list_names_every_model_option_and_fidelity_level():
    res = run("list")
    assert res.returncode == 0, res.stderr
    for name in MODELS:
        assert f"\n{name} " in "\n" + res.stdout
    data = json.loads(run("list", "--json").stdout)
    levels = [m for lv in data["fidelity"].values() for m in lv]
    assert sorted(levels) == sorted(MODELS)
    assert "friction" in data["models"]["backrest"]["options"]


@pytest.mark.parametrize("args, needle", [
    (["build", "no_such_model"], "allowed: backrest"),
    (["build", "heald_frame", "--option", "no_such=1"], "allowed: end_dwell"),
    (["build", "heald_frame", "--option", "end_dwell=sideways"], "end_dwell"),
    (["build", "heald_frame", "--option", "end_dwell"], "NAME=VALUE"),
    (["build", "heald_frame", "--option", "warp_tension=bogus"],
     "--option warp_tension=bogus: warp_tension = 'bogus'; allowed: 'geometry', 'input'"),
    (["build", "--rtol", "nan"], "--rtol"),
    (["build", "--rtol", "2"], "--rtol"),
    (["build", "--max-error", "-1"], "--max-error"),
    (["build", "--fmi-version", "5"], "--fmi-version"),
    (["build", "--interface", "hil"], "--interface"),
    (["build", "two_mass_force", "--platforms", "win32"], "allowed: linux64, win64 (or"),
    (["build", "two_mass_force", "--platforms", ","], "--platforms"),
    (["build", "two_mass_force", "--platforms", "aarch64"], "no binaries folder in FMI 2.0"),
    (["simulate", "no_such_model"], "allowed:"),
    (["simulate", "missing.fmu"], "does not exist"),
    (["simulate", "backrest", "--stop", "-1"], "--stop"),
    (["simulate", "backrest", "--step", "inf"], "--step"),
    (["simulate", "backrest", "--solver", "euler"], "--solver"),
    (["verify", "missing.fmu"], "does not exist"),
    (["verify", "heald_frame"], "loomfmu build heald_frame"),
    (["simulate", "heald_frame_rigid", "--set", "k_z=abc"], "a number"),
    (["simulate", "heald_frame_rigid", "--set", "omega=1e9"], "[0, 500] rad/s"),
    (["simulate", "heald_frame_rigid", "--set", "solver=7"], "dopri5, rodas4, rk4"),
    (["simulate", "heald_frame_rigid", "--set", "solver=euler"], "dopri5, rodas4, rk4"),
    (["simulate", "heald_frame_rigid", "--plot", "x.jpg2"], "png"),
    (["simulate", "heald_frame_rigid", "--stop", "1e6"], "larger --step"),
    (["simulate", "heald_frame_rigid", "--step", "1", "--stop", "0.42"], "allowed: a step <= 0.42"),
    (["simulate", "heald_frame_rigid", "--stopp", "1"], "unrecognized arguments"),
    (["bench", "charts", "--models", "nope"], "allowed"),
    (["bench", "speed", "--repeats", "0"], "--repeats"),
    (["rotor", "nope"], "invalid choice"),
    (["nope"], "invalid choice"),
    (["build", "--jobs", "1e3"], "--jobs"),
    (["build", "--fmi-version"], "--fmi-version"),
    (["scene", "run"], "scene"),
    (["sweep", "nope"], "invalid choice"),
    (["inspect", "backrest", "--format", "pdf"], "--format"),
    (["heald", "nope"], "invalid choice"),
])
def test_usage_errors_say_what_is_allowed_in_one_line_and_exit_2(args, needle):
    res = run(*args)
    assert res.returncode == 2, (res.returncode, res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1, res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert needle in last, res.stderr


def test_a_bad_platforms_variable_is_one_line_before_any_build(tmp_path):
    res = run("build", "loom_shaft", "--out-dir", tmp_path, env={"LOOMFMU_PLATFORMS": "amd64"})
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert res.stderr.strip().splitlines() == [res.stderr.strip()], res.stderr
    assert "LOOMFMU_PLATFORMS: unknown platform 'amd64'" in res.stderr
    assert not list(tmp_path.iterdir())


def test_top_level_help_lists_every_subcommand_of_each_analysis():
    """'loomfmu --help' names each analysis' subcommands (e.g. bench ...
    limit) exactly as the analysis' own parser has them."""
    from loomfmu.cli.dispatch import ANALYSES
    for name, (_, helptext) in ANALYSES.items():
        if " | " not in helptext:
            continue
        listed = set(helptext.split(": ", 1)[1].split(" | "))
        usage = run(name, "--help").stdout
        choices = re.search(r"\{([^}]*)\}", usage)
        assert choices, (name, usage[:300])
        assert listed == set(choices.group(1).split(",")), (name, helptext, choices.group(0))


def test_cli_guide_command_table_names_every_subcommand():
    """The table of commands in docs/guides/cli.md lists each analysis'
    subcommands (its rows `loomfmu NAME a\\|b ...`, together), as the parser
    has them."""
    from loomfmu.cli.dispatch import ANALYSES
    readme = (Path(__file__).resolve().parents[1] / "docs" / "guides" / "cli.md").read_text()
    for name, (_, helptext) in ANALYSES.items():
        if " | " not in helptext:
            continue
        rows = re.findall(rf"^\| `loomfmu {name} ([^`\s]+)", readme, flags=re.M)
        listed = {w for r in rows for w in r.replace("\\|", "|").split("|")}
        wanted = set(helptext.split(": ", 1)[1].split(" | "))
        assert wanted <= listed, (name, sorted(wanted - listed))


def test_a_file_that_is_not_an_fmu_is_a_usage_error(tmp_path):
    """Not a zip, or a zip without modelDescription.xml: one line naming the
    file, exit 2 (before: simulate showed zipfile's traceback)."""
    (tmp_path / "text.fmu").write_text("hello")
    with zipfile.ZipFile(tmp_path / "nomd.fmu", "w") as z:
        z.writestr("readme.txt", "no model description")
    for name, needle in (("text.fmu", "is not an FMU (zip)"),
                         ("nomd.fmu", "no readable modelDescription.xml")):
        for command in ("simulate", "verify"):
            res = run(command, str(tmp_path / name))
            assert res.returncode == 2, (command, name, res.stderr)
            assert "Traceback" not in res.stderr
            last = res.stderr.strip().splitlines()[-1]
            assert needle in last and name in last, (command, last)


def test_simulate_unknown_variable_is_a_usage_error(tmp_path):
    res = run("simulate", "backrest", "--set", "no_such_parameter=1", cwd=tmp_path)
    assert res.returncode == 2 and "no_such_parameter" in res.stderr
    res = run("simulate", "backrest", "--output", "phi1_outt", cwd=tmp_path)
    assert res.returncode == 2 and "phi1_out" in res.stderr  # the suggestion


def test_design_out_of_range_is_refused_with_the_range():
    res = run("heald", "design", "--gap", "-0.004")
    assert res.returncode == 2, res.stdout + res.stderr
    assert "gap" in res.stderr and "Traceback" not in res.stderr


def _design(*args):
    return subprocess.run([sys.executable, "-m", "loomfmu.heald", "design", *args],
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, "LOOMFMU_PROGRESS": "plain"})


def test_design_at_the_edge_of_its_range_says_so():
    # a gap so wide that the narrowest slat in the search range already meets it
    res = _design("--gap", "10")
    assert res.returncode == 2, res.stdout + res.stderr
    assert "lower edge of b1_range" in res.stderr
    # a preset and --set reach the search: with the Texo 1.8 m frame's masses
    # and warp tension and k_z = 5 the narrowest slat bends far less than
    # with the model's defaults
    preset = _design("--gap", "10", "--preset", "STB-180 Texo", "--set", "k_z=5")
    assert preset.returncode == 2, preset.stdout + preset.stderr

    def bend(r):
        return float(re.search(r"gives max \|x2\| = (\S+) m", r.stderr).group(1))
    assert bend(preset) < 0.5 * bend(res), (preset.stderr, res.stderr)
    # --b1-range reaches the search: its edge is the one named
    narrow = _design("--gap", "10", "--b1-range", "0.003", "0.004")
    assert narrow.returncode == 2 and "b1_range = [0.003, 0.004]" in narrow.stderr, \
        narrow.stderr


@pytest.mark.parametrize("args, needle", [
    (["--gap", "-1"], "error: gap = -1.0; allowed:"),
    (["--gap", "0.004", "--preset", "STB-999"], "width '999' cm is not in table 1"),
    (["--gap", "0.004", "--set", "k_z=abc"], "is not a number"),
    (["--gap", "0.004", "--set", "k_z"], "allowed: NAME=VALUE"),
    (["--gap", "0.004", "--b1-range", "0.1", "0.05"], "allowed: LO < HI"),
    (["--gap", "0.012", "--set", "omega=1e-9"], "values['omega'] = 1e-09; allowed"),
    (["--gap", "0.012", "--set", "x2=0.1"], "['x2'] are states of heald_frame"),
    (["--gap", "0.012", "--d1", "0.001", "--set", "d1=0.002"], "allowed: one of them"),
    (["--gap", "0.012", "--preset", ""], "preset = ''; allowed:"),
    (["--gap", "0.004", "--b1-range", "0.001", "0.05"], "--b1-range = 0.001"),
])
def test_design_refuses_bad_arguments_before_searching(args, needle):
    res = _design(*args)
    assert res.returncode == 2, res.stdout + res.stderr
    assert needle in res.stderr.strip().splitlines()[-1], res.stderr
    assert "searching" not in res.stderr  # refused before the search's progress line


def test_design_names_the_width_at_which_a_constraint_broke():
    """m_RR = 3 kg holds at the model's b1 but not at the search's widest
    slat: the error says where (before: as if --set were infeasible)."""
    res = _design("--gap", "0.012", "--set", "m_RR=3")
    assert res.returncode == 2, res.stdout + res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert "at the slat width b1 = 0.1 m of the search" in last and "m_RR" in last, last


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    res = run("build", "heald_frame_rigid", "--out-dir", out)
    return out, res


def test_build_verifies_reports_documents_and_shows_progress(built):
    out, res = built
    assert res.returncode == 0, res.stderr
    # plain progress lines in a log: counted, with the stage
    assert "build [0/1] heald_frame_rigid: generating C" in res.stderr
    assert "build [1/1] heald_frame_rigid: done" in res.stderr
    assert "scipy reference" in res.stderr
    report = json.loads((out / "report.json").read_text())
    rep = report["heald_frame_rigid"]
    assert set(rep["solvers"]) == set(SOLVERS)
    worst = max(e["max_rel_range"] for s in rep["solvers"].values()
                for e in s["errors"].values())
    assert worst < 1e-3
    with zipfile.ZipFile(out / "heald_frame_rigid.fmu") as z:
        page = z.read("documentation/index.html").decode()
    assert "rodas4" in page and "reference" in page.lower()
    # the equations as loomfmu.inspection.readable prints them (MathML), not CasADi text
    assert "<math" in page and "loomfmu inspect heald_frame_rigid" in page


def test_simulate_an_fmu_writes_csv_and_plot(built, tmp_path):
    out, _ = built
    fmu = out / "heald_frame_rigid.fmu"
    res = run("simulate", fmu, "--stop", "0.2", "--step", "0.01", "--solver", "rodas4",
              "--set", "omega=40", "--output", "h", "--output", "T",
              "--csv", tmp_path / "r.csv", "--plot", tmp_path / "r.png")
    assert res.returncode == 0, res.stderr
    assert "h " in res.stdout and " m\n" in res.stdout
    rows = list(csv.reader((tmp_path / "r.csv").read_text().splitlines()))
    assert rows[0] == ["time [s]", "h [m]", "T [N]"]
    assert len(rows) == 1 + 21 and float(rows[-1][0]) == pytest.approx(0.2)
    assert (tmp_path / "r.png").read_bytes()[:4] == b"\x89PNG"


def test_simulate_reports_a_refusal_with_exit_1(built):
    out, _ = built
    res = run("simulate", out / "heald_frame_rigid.fmu", "--stop", "0.1",
              "--set", "solver_h_max=-1")
    assert res.returncode in (1, 2), res.stdout
    assert "Traceback" not in res.stderr


def test_simulate_names_the_solver_that_ran_and_keeps_the_default_step(built, tmp_path):
    out, _ = built
    fmu = out / "heald_frame_rigid.fmu"
    res = run("simulate", fmu, "--set", "solver=3", "--stop", "2", "--output", "h",
              "--csv", tmp_path / "a.csv")
    assert res.returncode == 0, res.stderr
    assert "solver rk4" in res.stdout
    # the DefaultExperiment's step (1 ms), not one FMPy widens for long runs
    rows = list(csv.reader((tmp_path / "a.csv").read_text().splitlines()))
    assert len(rows) == 1 + 2001
    res2 = run("simulate", fmu, "--solver", "rk4", "--stop", "2", "--output", "h",
               "--csv", tmp_path / "b.csv")
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes(), res2.stderr


def test_verify_an_fmu_without_its_binary_says_so_in_one_line(built, tmp_path):
    out, _ = built
    broken = tmp_path / "nobin.fmu"
    with zipfile.ZipFile(out / "heald_frame_rigid.fmu") as src, \
            zipfile.ZipFile(broken, "w") as dst:
        for item in src.infolist():
            if not item.filename.startswith("binaries/"):
                dst.writestr(item, src.read(item))
    res = run("verify", broken, "--solver", "dopri5")
    assert res.returncode == 1 and "Traceback" not in res.stderr, res.stderr
    assert "the FMU could not be run" in res.stderr.strip().splitlines()[-1], res.stderr


def test_verify_an_fmu(built, tmp_path):
    out, _ = built
    res = run("verify", out / "heald_frame_rigid.fmu", "--solver", "dopri5")
    assert res.returncode == 0, res.stderr
    assert "heald_frame_rigid" in res.stdout and "dopri5" in res.stdout
    # a renamed copy is reported under its model's name, not the file's
    copy = tmp_path / "hf.fmu"
    shutil.copy(out / "heald_frame_rigid.fmu", copy)
    res = run("verify", copy, "--solver", "dopri5")
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines()[-1].split()[0] == "heald_frame_rigid", res.stdout
    # an impossible bound fails with exit 1, not 2
    res = run("verify", out / "heald_frame_rigid.fmu", "--solver", "rk4",
              "--max-error", "1e-300")
    assert res.returncode == 1 and "FAILED" in res.stderr


def test_build_jobs_builds_models_in_processes_with_the_serial_report(built, tmp_path):
    """--jobs 2: two models in two processes, each counted when done, the
    report's rows in the order of the command line and equal (but for the
    times) to a serial build's."""
    out, _ = built
    res = run("build", "two_mass_force", "heald_frame_rigid", "--jobs", "2",
              "--out-dir", tmp_path)
    assert res.returncode == 0, res.stderr
    assert "2 models in 2 processes" in res.stderr and "build [2/2]" in res.stderr
    report = json.loads((tmp_path / "report.json").read_text())
    assert list(report) == ["two_mass_force", "heald_frame_rigid"]
    serial = json.loads((out / "report.json").read_text())["heald_frame_rigid"]

    def untimed(rep):
        return {k: v for k, v in rep.items() if k not in ("fmu", "build_seconds", "solvers") and "seconds" not in k}
    assert untimed(report["heald_frame_rigid"]) == untimed(serial)
    for solver, s in serial["solvers"].items():
        assert report["heald_frame_rigid"]["solvers"][solver]["errors"] == s["errors"]
    assert (tmp_path / "two_mass_force.fmu").is_file()


@pytest.mark.parametrize("jobs", ["0", "-1", "two"])
def test_build_jobs_out_of_range_is_one_line(jobs, tmp_path):
    res = run("build", "two_mass_force", "--jobs", jobs, "--out-dir", tmp_path)
    assert res.returncode == 2 and "--jobs" in res.stderr.strip().splitlines()[-1]
    assert "Traceback" not in res.stderr and not list(tmp_path.iterdir())


def test_build_model_exchange_variant_is_named_reported_and_not_verified(tmp_path):
    """--fmi-version/--interface: the variant's own file name and report key,
    zero validation problems, no verification (model exchange is integrated
    by the importer), and the default FMU name untouched."""
    res = run("build", "heald_frame_rigid", "--fmi-version", "2", "--interface", "me",
              "--out-dir", tmp_path)
    assert res.returncode == 0, res.stderr
    fmu = tmp_path / "heald_frame_rigid_fmi2_me.fmu"
    assert fmu.exists() and not (tmp_path / "heald_frame_rigid.fmu").exists()
    rep = json.loads((tmp_path / "report.json").read_text())["heald_frame_rigid_fmi2_me"]
    assert rep["fmu"] == str(fmu) and rep["validation_problems"] == []
    assert (rep["fmi_version"], rep["interface"]) == (2, "me")
    assert "solvers" not in rep and "not run: model exchange" in rep["verification"]
    assert "scipy reference" not in res.stderr
    with zipfile.ZipFile(fmu) as z:
        md = z.read("modelDescription.xml").decode()
    assert "<ModelExchange" in md and "<CoSimulation" not in md


@pytest.fixture(scope="module")
def variants(tmp_path_factory):
    """two_mass_force as FMI 3.0 model exchange only and FMI 2.0 both."""
    out = tmp_path_factory.mktemp("variants")
    for version, interface in (("3", "me"), ("2", "both")):
        res = run("build", "two_mass_force", "--fmi-version", version, "--interface",
                  interface, "--no-verify", "--out-dir", out)
        assert res.returncode == 0, res.stderr
    return out


def _rows(stdout: str) -> list[list[str]]:
    """The summary table's rows, cells split at two or more spaces."""
    import re
    lines = [ln for ln in stdout.splitlines() if ln.strip()]
    start = next(i for i, ln in enumerate(lines) if ln.startswith("model "))
    return [re.split(r"\s{2,}", ln.strip()) for ln in lines[start + 1:]
            if not ln.startswith("written:")]


def test_verify_a_model_exchange_fmu_runs_the_importer_once(variants, tmp_path):
    """Not four rows named after solvers that do not run: one FMPy CVode run,
    labelled so, under the variant's name; --document writes that row."""
    from loomfmu.verification.verify import ME_LABEL
    fmu = tmp_path / "two_mass_force_fmi3_me.fmu"
    fmu.write_bytes((variants / fmu.name).read_bytes())
    res = run("verify", fmu, "--document")
    assert res.returncode == 0, res.stderr
    rows = _rows(res.stdout)
    assert [r[:2] for r in rows] == [["two_mass_force_fmi3_me", ME_LABEL]], res.stdout
    assert not any(s in res.stdout for s in SOLVERS)
    with zipfile.ZipFile(fmu) as z:
        page = z.read("documentation/index.html").decode()
    section = page.split('<section id="verification">', 1)[1].split("</section>", 1)[0]
    assert f"<h3>{ME_LABEL}: worst relative error" in section
    assert not any(f"<h3>{s}:" in section for s in SOLVERS)
    assert "Not verified at build" not in page
    # --solver means nothing here: refused in one line, exit 2
    res = run("verify", fmu, "--solver", "rk4")
    assert res.returncode == 2 and "model exchange only" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and "Traceback" not in res.stderr


def test_verify_a_both_fmu_checks_the_embedded_solvers_and_optionally_the_importer(variants):
    from loomfmu.verification.verify import ME_LABEL
    fmu = variants / "two_mass_force_fmi2_both.fmu"
    res = run("verify", fmu, "--solver", "ros34pw2", "--model-exchange")
    assert res.returncode == 0, res.stderr
    assert [r[:2] for r in _rows(res.stdout)] == [["two_mass_force_fmi2_both", "ros34pw2"],
                                                  ["two_mass_force_fmi2_both", ME_LABEL]]
    res = run("verify", fmu, "--solver", "rk4")
    assert [r[1] for r in _rows(res.stdout)] == ["rk4"]


def test_simulate_a_model_exchange_fmu_names_the_importer_and_refuses_solver(variants):
    fmu = variants / "two_mass_force_fmi3_me.fmu"
    res = run("simulate", fmu, "--stop", "0.5")
    assert res.returncode == 0, res.stderr
    assert "FMPy's CVode" in res.stdout and "dopri5" not in res.stdout
    res = run("simulate", fmu, "--stop", "0.5", "--solver", "rk4")
    assert res.returncode == 2 and "model exchange only" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and "Traceback" not in res.stderr
    # a both FMU: co-simulation with the embedded solver, --solver taken
    res = run("simulate", variants / "two_mass_force_fmi2_both.fmu", "--stop", "0.5",
              "--solver", "ros34pw2")
    assert res.returncode == 0 and "solver ros34pw2" in res.stdout, res.stderr


def test_summary_columns_are_as_wide_as_their_contents():
    from loomfmu.cli.commands import summary
    from loomfmu.verification.verify import ME_LABEL
    err = {"errors": {"a_rather_long_output_name": {"max_abs": 1e-3, "max_rel_range": 2e-4}},
           "wall_seconds": 0.5}
    rep = {"validation_problems": [], "reference_wall_seconds": 1.25,
           "solvers": {s: err for s in (*SOLVERS, ME_LABEL)}}
    lines = summary({"two_mass_force_fmi2_both": rep, "x": {"validation_problems": []}}) \
        .splitlines()
    import re
    head = re.split(r"\s{2,}", lines[0])
    assert head[:3] == ["model", "solver", "worst output"]
    for line in lines[1:-1]:
        cells = re.split(r"\s{2,}", line)
        assert len(cells) == len(head), line  # no cell runs into the next
    # the columns line up: each header starts where its column does
    start = lines[0].index("worst output")
    assert all(ln[start - 2:start] == "  " for ln in lines)
    assert lines[-1].split()[:3] == ["x", "-", "not"]


def test_build_fmu_py_is_a_thin_wrapper():
    res = subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--help"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and "usage: loomfmu build" in res.stdout
    res = subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "nope"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2 and "allowed" in res.stderr


def test_analysis_outputs_go_where_the_user_says(tmp_path):
    res = run("drive", "table", "--out", tmp_path / "law.md", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "law.md").read_text().startswith("#")


def test_model_exchange_run_is_compared_at_its_communication_points_only():
    """FMPy's model exchange records an event time twice (before, after):
    those rows are left out, or the jump would count as the FMU's error."""
    import numpy as np

    from loomfmu.verification.verify import FmuRun, _output_points
    t = np.array([0.0, 0.001, 0.0015, 0.0015, 0.002, 0.003, 0.003, 0.004])
    y = np.arange(len(t), dtype=float)
    run = _output_points(FmuRun(t, {"a": y}, 0.1))
    assert list(run.t) == [0.0, 0.001, 0.002, 0.003, 0.004]
    assert list(run.y["a"]) == [0.0, 1.0, 4.0, 6.0, 7.0]  # on the grid: the value after
