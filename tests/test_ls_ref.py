"""The reference result every FMU carries (FMI-LS-REF), and its check.

The slow tests build FMUs and check them with FMPy alone, in a subprocess
that imports no loomfmu code (benchmarks/ls_ref_fmpy_check.py), in FMI 2.0
and 3.0, co-simulation and model exchange; then damaged copies of one FMU
(manifest, CSV, tolerance, values) through ``loomfmu check``.
"""
from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

from loomfmu import build_fmu, load_model
from loomfmu.fmu import reference_results as rr

ROOT = Path(__file__).resolve().parents[1]
CHECKER = ROOT / "benchmarks" / "ls_ref_fmpy_check.py"
BIN = Path(sys.executable).parent
#: cheap models; each variant of FMI 2.0/3.0 x co-simulation/model exchange once
VARIANTS = [("heald_frame_rigid", 2, "cs"), ("heald_frame_rigid", 3, "me"),
            ("loom_shaft", 2, "me"), ("loom_shaft", 3, "cs")]


# ------------------------------------------------------------------ quick
def test_manifest_is_valid_against_the_standard_and_names_the_files():
    xml = rr.manifest_xml("m", {"cs": 1e-3, "me": 1e-2})
    assert rr.manifest_problems(xml.encode()) == []
    root = ET.fromstring(xml)
    ns = "{http://fmi-standard.org/fmi-ls-manifest}"
    assert root.tag == "fmiReferences"
    assert root.get(f"{ns}fmi-ls-name") == "org.fmi-standard.fmi-ls-ref"
    assert root.get(f"{ns}fmi-ls-version") == rr.LS_VERSION
    assert root.get(f"{ns}fmi-ls-description") == rr.LS_DESCRIPTION
    roles = {r.get("role"): (r.get("source"), r.get("type")) for r in root.findall("Related")}
    assert roles == {"result": ("m_ref.csv", "text/csv"),
                     "experiment/smoke-test": ("default_experiment.exp",
                                               "application/x-ma-hs-experiments"),
                     "report": ("../../documentation/fmi-ls-ref.txt", "text/plain")}


@pytest.mark.parametrize("edit, needle", [
    (lambda s: s.replace('fmi-ls-name="org.fmi-standard.fmi-ls-ref"',
                         'fmi-ls-name="org.fmi-standard.fmi-ls-xcp"'), "fmi-ls-name"),
    (lambda s: s.replace(' fmi-ls:fmi-ls-description="Layered Standard providing information '
                         'on related files included in an FMU."', ""), "fmi-ls-description"),
    (lambda s: s.replace('role="result"', 'role="results"'), "role"),
    (lambda s: s.replace('role="experiment/smoke-test"', 'role="experiment/smoke"'), "role"),
    (lambda s: s.replace("<fmiReferences", "<fmiReference").replace(
        "</fmiReferences>", "</fmiReference>"), "fmiReference"),
    (lambda s: s[:-40], "not XML"),
])
def test_a_manifest_with_wrong_content_is_refused(edit, needle):
    xml = edit(rr.manifest_xml("m", {"cs": 1e-3}))
    problems = rr.manifest_problems(xml.encode())
    assert problems and needle in problems[0], problems


def test_experiment_times_are_fmpys_communication_points():
    t = rr.experiment_times(0.0, 0.41887902047863906, 1e-3)
    assert len(t) == 420 and t[1] == 1e-3 and t[-1] == 0.41887902047863906
    t = rr.experiment_times(0.0, 1.0, 1e-3)
    assert len(t) == 1001 and t[-1] == 1.0 and np.all(np.diff(t) > 0)


@pytest.mark.parametrize("text, needle", [
    ("", "not a reference CSV"),
    ("t,x\n0,1\n1,2\n", "not a reference CSV"),
    ("time,x\n0,1\n", "fewer than two rows"),
    ("time,x\n0,1\n1,nan\n", "line 3: x = nan is not finite"),
    ("time,x\n0,1\n1,inf\n", "not finite"),
    ("time,x\n0,1\n1,abc\n", "line 3: not a number"),
    ("time,x\n0,1\n1\n", "line 3: 1 values"),
    ("time,x\n1,1\n0,2\n", "times do not increase"),
    ("time,x,x\n0,1,1\n1,2,2\n", "appears twice"),
    ("\x00\x01PK garbage", "not a reference CSV"),
])
def test_a_damaged_csv_is_refused_naming_what_is_wrong(text, needle):
    with pytest.raises(rr.ReferenceResultError, match=None) as e:
        rr.parse_csv(text, "m_ref.csv")
    assert needle in str(e.value)


def test_csv_round_trip_keeps_every_digit():
    t = np.array([0.0, 0.1, 0.2])
    y = np.array([1 / 3, -2e-300, 7.123456789012345e12])
    t2, cols = rr.parse_csv(rr.result_csv(t, {"y": y}), "x")
    assert np.array_equal(t2, t) and np.array_equal(cols["y"], y)


def test_sources_resolve_relative_to_the_manifest():
    assert rr._resolve("m_ref.csv") == f"{rr.LS_DIR}/m_ref.csv"
    assert rr._resolve("../../documentation/fmi-ls-ref.txt") == rr.LS_DOC
    assert rr._resolve("https://example.org/x.csv") is None
    assert rr._resolve("/abs.csv") is None
    assert rr._resolve("../../../outside.csv") is None


def test_the_key_is_the_declaration_not_the_fmi_variant():
    a, b = load_model("loom_shaft"), load_model("loom_shaft")
    assert rr.reference_key(a) == rr.reference_key(b)
    assert rr.reference_key(a) != rr.reference_key(load_model("heald_frame_rigid"))


def test_the_csv_comes_from_the_reference_cache_shared_with_the_verification(tmp_path,
                                                                           monkeypatch):
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(tmp_path / "objects"))
    assert rr.reference_cache_dir() == tmp_path / "references"
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(tmp_path / "cache"))
    assert rr.reference_cache_dir() == tmp_path / "cache-references"
    model = load_model("heald_frame_rigid")
    first = rr.reference_result(model)
    again = rr.reference_result(load_model("heald_frame_rigid"))
    assert not first.cached and again.cached and again.csv == first.csv
    # the verification's reference (its default tolerances, the FMU's grid) is that one
    from loomfmu.verification.reference import reference
    t, _ = rr.parse_csv(first.csv, "csv")
    ref = reference(model, t_eval=t, rtol=1e-11, atol=1e-13, method=model.reference_method)
    assert ref.cached and (rr.REF_RTOL, rr.REF_ATOL) == (1e-11, 1e-13)
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", "off")
    assert not rr.reference_result(model).cached


# ------------------------------------------------------------------ slow: built FMUs
@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("lsref")
    return {(m, v, i): build_fmu(load_model(m), out_dir=out, fmi_version=v, interface=i,
                                 reference_results=True).path for m, v, i in VARIANTS}


def fmpy_only(*paths) -> tuple[int, list[dict], list[str]]:
    """The checker run in a subprocess; also returns the loomfmu modules it
    imported (none expected)."""
    code = ("import runpy, sys, json\n"
            f"sys.argv = {[str(CHECKER), *map(str, paths)]!r}\n"
            "try:\n"
            f"    runpy.run_path({str(CHECKER)!r}, run_name='__main__')\n"
            "except SystemExit as e:\n"
            "    rc = e.code\n"
            "print('MODULES', json.dumps(sorted(m for m in sys.modules "
            "if m.split('.')[0] == 'loomfmu')))\n"
            "sys.exit(rc)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600, cwd=ROOT)
    rows = [json.loads(ln) for ln in proc.stdout.splitlines() if ln.startswith("{")]
    mods = json.loads(proc.stdout.split("MODULES ", 1)[1])
    return proc.returncode, rows, mods


@pytest.mark.slow
def test_every_variant_matches_its_own_reference_with_fmpy_alone(built):
    rc, rows, mods = fmpy_only(*built.values())
    assert mods == []
    assert rc == 0, rows
    assert {(Path(r["fmu"]).name, r["interface"]) for r in rows} == {
        ("heald_frame_rigid.fmu", "cs"), ("heald_frame_rigid_fmi3_me.fmu", "me"),
        ("loom_shaft_fmi2_me.fmu", "me"), ("loom_shaft_fmi3_cs.fmu", "cs")}
    for r in rows:
        assert r["ok"] and r["worst"] <= r["tolerance"], r
        assert r["tolerance"] == rr.CHECK_TOLERANCE[r["interface"]]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["drive", "backrest"])
def test_model_exchange_matches_its_reference_with_fmpy_alone(tmp_path, name):
    """drive: FMPy's CVode completes a step only at output points and steps
    past them by more than the delay: the FMU takes the delayed value from the
    history's Taylor line (up to tau / 2, with a warning) instead of refusing.
    backrest: its algebraic loop is solved by Newton on every unknown in model
    exchange (the torn form reached other roots of the friction law there).
    Each run reproduces the reference result the FMU carries."""
    path = build_fmu(load_model(name), out_dir=tmp_path, fmi_version=2, interface="me",
                     reference_results=True).path
    rc, rows, mods = fmpy_only(path)
    assert mods == [] and rc == 0, rows
    (r,) = rows
    assert r["interface"] == "me" and r["ok"] and r["worst"] <= r["tolerance"], r


@pytest.mark.slow
def test_the_fmu_carries_the_files_and_one_csv_for_all_variants(built):
    csvs = set()
    for (m, _, _), path in built.items():
        with zipfile.ZipFile(path) as z:
            names = set(z.namelist())
            assert {rr.LS_MANIFEST, f"{rr.LS_DIR}/{m}_ref.csv",
                    f"{rr.LS_DIR}/{rr.EXPERIMENT_FILE}", rr.LS_DOC} <= names
            assert rr.manifest_problems(z.read(rr.LS_MANIFEST)) == []
            csvs.add((m, z.read(f"{rr.LS_DIR}/{m}_ref.csv")))
            page = z.read("documentation/index.html").decode()
            assert "Reference result inside" in page and "loomfmu check" in page
            exp = ET.fromstring(z.read(f"{rr.LS_DIR}/{rr.EXPERIMENT_FILE}"))
            md = ET.fromstring(z.read("modelDescription.xml")).find("DefaultExperiment")
            sim = exp.find("Experiment/TransientSimulation")
            assert sim.get("stopTime") == md.get("stopTime")
            assert exp.find("Experiment").get("tolerance") == md.get("tolerance")
    assert len(csvs) == 2  # one CSV per model, the same bytes in each variant


def run_check(*args):
    return subprocess.run([str(BIN / "loomfmu"), "check", *map(str, args)],
                          capture_output=True, text=True, timeout=600)


def damaged(src: Path, dst: Path, edit) -> Path:
    """A copy of the FMU ``src`` with ``edit(name, data) -> data | None``
    applied to each member (None: left out)."""
    with zipfile.ZipFile(src) as a, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as b:
        for info in a.infolist():
            data = edit(info.filename, a.read(info.filename))
            if data is not None:
                b.writestr(info, data)
    return dst


def _csv_member(name):
    return name.endswith("_ref.csv")


def _scale_column(data: bytes, factor: float) -> bytes:
    lines = data.decode().splitlines()
    out = [lines[0]]
    for ln in lines[1:]:
        cells = ln.split(",")
        cells[1] = repr(float(cells[1]) * factor + 1e-3)
        out.append(",".join(cells))
    return ("\n".join(out) + "\n").encode()


def _rename_first_output(data: bytes) -> bytes:
    head, rest = data.split(b"\n", 1)
    cells = head.split(b",")
    return b",".join([cells[0], b"no_such_output", *cells[2:]]) + b"\n" + rest


def _keep_rows(data: bytes, n: int) -> bytes:
    return ("\n".join(data.decode().splitlines()[:n + 1]) + "\n").encode()


def _drop_last_column(data: bytes) -> bytes:
    return ("\n".join(",".join(ln.split(",")[:-1]) for ln in data.decode().splitlines())
            + "\n").encode()


@pytest.mark.slow
def test_check_passes_with_exit_0(built):
    res = run_check(built[("loom_shaft", 3, "cs")])
    assert res.returncode == 0, res.stderr
    assert "theta_out" in res.stdout and "within the tolerance" in res.stdout


@pytest.mark.slow
@pytest.mark.parametrize("edit, code, needle", [
    (lambda n, d: None if _csv_member(n) else d, 2, "listed in the manifest is not in the FMU"),
    (lambda n, d: None if n == rr.LS_MANIFEST else d, 2, "no reference result inside"),
    (lambda n, d: b"\x00garbage\xff" if _csv_member(n) else d, 2, "cannot be read"),
    (lambda n, d: b"hello\n" if _csv_member(n) else d, 2, "not a reference CSV"),
    (lambda n, d: d.replace(b"\n0.001", b"\nnan", 1) if _csv_member(n) else d, 2,
     "not finite"),
    (lambda n, d: d.replace(b"fmi-ls-ref\" fmi", b"fmi-ls-bus\" fmi")
     if n == rr.LS_MANIFEST else d, 2, "fmi-ls-name"),
    (lambda n, d: d.replace(b'role="result"', b'role="document"')
     if n == rr.LS_MANIFEST else d, 2, "lists no result"),
    (lambda n, d: d.replace(b'maxDeviationRelativeToRange="0.001"',
                            b'maxDeviationRelativeToRange="-1"')
     if n == rr.LS_MANIFEST else d, 2, "tolerance"),
    (lambda n, d: d.replace(b"<Annotations>", b"<!--").replace(b"</Annotations>", b"-->")
     if n == rr.LS_MANIFEST else d, 2, "states no tolerance"),
    (lambda n, d: _rename_first_output(d) if _csv_member(n) else d, 2,
     "not a variable of the FMU"),
    (lambda n, d: _scale_column(d, 1.1) if _csv_member(n) else d, 1, "OUTSIDE"),
    (lambda n, d: _keep_rows(d, 2) if _csv_member(n) else d, 2, "communication points"),
    (lambda n, d: _keep_rows(d, 49) if _csv_member(n) else d, 2, "communication points"),
    (lambda n, d: _drop_last_column(d) if _csv_member(n) else d, 2, "has no column for the output"),
    (lambda n, d: b"<fmiModelDescription" if n == "modelDescription.xml" else d, 2,
     "modelDescription.xml cannot be read"),
    (lambda n, d: b"<foo/>" if n == "modelDescription.xml" else d, 2, "not an FMU"),
], ids=["csv-absent", "manifest-absent", "csv-binary", "csv-corrupt", "csv-nan",
        "manifest-name", "manifest-role", "tolerance-negative", "tolerance-absent",
        "csv-unknown-output", "reference-mismatch", "csv-two-rows", "csv-cut-short",
        "csv-output-missing", "md-not-xml", "md-not-fmi"])
def test_a_damaged_reference_is_a_clear_error(built, tmp_path, edit, code, needle):
    fmu = damaged(built[("loom_shaft", 3, "cs")], tmp_path / "loom_shaft_fmi3_cs.fmu", edit)
    res = run_check(fmu)
    assert res.returncode == code, (res.returncode, res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    if code == 2:
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and needle in lines[0], res.stderr
    else:
        assert needle in res.stdout and "OUTSIDE the tolerance" in res.stderr


@pytest.mark.slow
def test_the_fmpy_only_checker_also_fails_a_mismatch(built, tmp_path):
    fmu = damaged(built[("loom_shaft", 3, "cs")], tmp_path / "bad.fmu",
                  lambda n, d: _scale_column(d, 1.1) if _csv_member(n) else d)
    rc, rows, _ = fmpy_only(fmu)
    with zipfile.ZipFile(fmu) as z:
        first = z.read(f"{rr.LS_DIR}/loom_shaft_ref.csv").decode().split("\n")[0].split(",")[1]
    assert rc == 1 and rows[0]["ok"] is False and rows[0]["worst_output"] == first


def test_check_of_a_directory_says_so(tmp_path):
    res = run_check(tmp_path)
    assert res.returncode == 2 and "a directory, not an FMU file" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_check_usage_errors_exit_2_in_one_line(tmp_path):
    (tmp_path / "text.fmu").write_text("hello")
    with zipfile.ZipFile(tmp_path / "nomd.fmu", "w") as z:
        z.writestr("readme.txt", "no model description")
    with zipfile.ZipFile(tmp_path / "noref.fmu", "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
    for path, needle in ((tmp_path / "missing.fmu", "no such file"),
                         (tmp_path / "text.fmu", "not an FMU (not a zip archive)"),
                         (tmp_path / "nomd.fmu", "no modelDescription.xml"),
                         (tmp_path / "noref.fmu", "no reference result inside"),
                         ("drive", "is a model: build it")):
        res = run_check(path)
        assert res.returncode == 2, (path, res.stdout, res.stderr)
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and needle in lines[0] and "Traceback" not in res.stderr


@pytest.mark.slow
def test_a_model_the_reference_cannot_solve_still_builds_and_says_why(tmp_path, monkeypatch):
    def refuse(model, **kw):
        raise RuntimeError(f"reference of {model.name}: the default experiment stops at "
                           "t = 0.1 s (a validity condition)")
    monkeypatch.setattr(rr, "reference_result", refuse)
    path = build_fmu(load_model("heald_frame_rigid"), out_dir=tmp_path,
                     reference_results=True).path
    with zipfile.ZipFile(path) as z:
        assert rr.manifest_problems(z.read(rr.LS_MANIFEST)) == []
        assert "stops at t = 0.1 s" in z.read(rr.LS_DOC).decode()
        assert not [n for n in z.namelist() if n.endswith("_ref.csv")]
    with pytest.raises(rr.ReferenceResultError, match="lists no result .*stops at t = 0.1 s"):
        rr.check_fmu(path)


@pytest.mark.slow
def test_the_suite_leaves_the_reference_out_unless_asked(tmp_path, monkeypatch):
    """LOOMFMU_LS_REF=off (set by tests/conftest.py) leaves extra/ out;
    reference_results=True and LOOMFMU_LS_REF=on put it in; a value that is
    not a bool is refused naming the argument."""
    model = load_model("heald_frame_rigid")
    off = build_fmu(model, out_dir=tmp_path / "off", validate=False).path
    with zipfile.ZipFile(off) as z:
        assert not [n for n in z.namelist() if n.startswith("extra/")]
    monkeypatch.setenv("LOOMFMU_LS_REF", "on")
    on = build_fmu(model, out_dir=tmp_path / "on", validate=False).path
    with zipfile.ZipFile(on) as z:
        assert rr.LS_MANIFEST in z.namelist()
    with pytest.raises(ValueError, match="reference_results"):
        build_fmu(model, out_dir=tmp_path, reference_results="yes")



@pytest.mark.slow
def test_a_composed_scene_carries_its_reference_when_asked(tmp_path, monkeypatch):
    """`loomfmu scene build two_mass --reference`: the composed FMU carries
    the reference of its default experiment, which FMPy alone reproduces;
    without the option it carries none."""
    from loomfmu.cli import main
    monkeypatch.setenv("LOOMFMU_PLATFORMS", "linux64")
    assert main(["scene", "build", "two_mass", "--out-dir", str(tmp_path / "a"),
                 "--reference"]) == 0
    (path,) = (tmp_path / "a").glob("*.fmu")
    rc, rows, mods = fmpy_only(path)
    assert mods == [] and rc == 0, rows
    (r,) = rows
    assert r["ok"] and r["worst"] <= r["tolerance"], r
    assert main(["scene", "build", "two_mass", "--out-dir", str(tmp_path / "b")]) == 0
    (plain,) = (tmp_path / "b").glob("*.fmu")
    with zipfile.ZipFile(plain) as z:
        assert not [n for n in z.namelist() if n.startswith("extra/")]
