"""Every FMU documents itself: documentation/index.html generated from the
declaration and the model description, and a model description that names
its author, version and generation tool."""
from __future__ import annotations

import html
import importlib.metadata
import re
import shutil
import xml.etree.ElementTree as ET
import zipfile

import casadi as ca
import numpy as np
import pytest

from loomfmu import MODELS, build_fmu, load_model
from loomfmu.declare.solvers import SETTINGS
from loomfmu.fmu.documentation import DOC_MEMBER, html_for, write_documentation
from loomfmu.verification.verify import verify

pytestmark = pytest.mark.slow  # builds FMUs

_BUILT: dict = {}


@pytest.fixture
def built(request, dist):
    """The test run's build of a model: conftest's fixture where there is one,
    else built here once per session into the same folder."""
    def get(name):
        try:
            return request.getfixturevalue(f"{name}_fmu")
        except pytest.FixtureLookupError:
            pass
        if name not in _BUILT:
            _BUILT[name] = build_fmu(load_model(name), out_dir=dist)
        return _BUILT[name]
    return get


def _read(path):
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n) for n in z.namelist()}, z.namelist()


def _visible_text(page: str) -> str:
    body = re.sub(r"<style>.*?</style>", "", page, flags=re.S)
    return html.unescape(re.sub(r"<[^>]+>", " ", body))


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_fmu_carries_its_documentation(built, name):
    result = built(name)
    assert result.problems == [], result.problems  # fmpy validation still passes
    files, order = _read(result.path)
    assert order.count(DOC_MEMBER) == 1
    page = files[DOC_MEMBER].decode("utf-8")
    md = ET.fromstring(files["modelDescription.xml"])

    cells = set(re.findall(r'<td class="name">([^<]*)</td>', page))
    names = [sv.get("name") for sv in md.iter("ScalarVariable")]
    missing = [n for n in names if html.escape(n, quote=True) not in cells]
    assert not missing, f"variables not listed in {DOC_MEMBER}: {missing}"

    text = " ".join(_visible_text(page).split())
    assert "the importer's tolerance overrides solver_rtol" in text
    assert "fmi2SetupExperiment" in text
    rtol = next(s for s in SETTINGS if s.name == "solver_rtol")
    assert f"tolerance outside [{rtol.min:.6g}, {rtol.max:.6g}] is limited" in text
    assert "_fmt(" not in page
    settings = md.find("ModelVariables").findall("ScalarVariable")
    starts = {sv.get("name"): next(iter(sv)).get("start") for sv in settings}
    for s in SETTINGS:  # every runtime setting with its start in the solver section
        assert re.search(rf'<td class="name">{s.name}</td><td class="num">'
                         rf'{float(starts[s.name]):.6g}</td>', page), s.name
    assert "Not verified at build" in text and "loomfmu verify" in text
    assert load_model(name).description in text
    # self-contained: no scripts, no external files
    assert "<script" not in page.lower()
    assert not re.search(r'\b(src|href)="(?!#)', page)

    version = importlib.metadata.version("loomfmu")
    assert md.get("version") == version
    assert md.get("generationTool") == f"loomfmu {version}"
    assert md.get("author") and md.get("license") and md.get("copyright")


def test_documentation_shows_the_verification(heald_frame_rigid_fmu, tmp_path):
    fmu = tmp_path / "heald_frame_rigid.fmu"
    shutil.copy(heald_frame_rigid_fmu.path, fmu)
    model = load_model("heald_frame_rigid")
    before, _ = _read(fmu)
    ver = verify(fmu, model, solvers=("dopri5",), rtol=1e-6)
    write_documentation(fmu, model, verification={**ver, "rtol": 1e-6})
    after, order = _read(fmu)

    assert order.count(DOC_MEMBER) == 1
    assert {n: b for n, b in after.items() if n != DOC_MEMBER} == \
        {n: b for n, b in before.items() if n != DOC_MEMBER}
    page = after[DOC_MEMBER].decode("utf-8")
    text = " ".join(_visible_text(page).split())
    assert "Not verified at build" not in text
    assert f"method {model.reference_method}" in text
    errors = ver["solvers"]["dopri5"]["errors"]
    assert set(errors) == {v.name for v in model.of_kind("output")}
    section = page.split('<section id="verification">', 1)[1].split("<h3>dopri5:", 1)[1]
    for out, e in errors.items():
        row = re.search(rf'<td class="name">{re.escape(out)}</td>(.*?)</tr>', section, re.S)
        assert row, out
        cells = re.findall(r'<td class="num">([^<]*)</td>', row.group(1))
        assert cells == [f"{e['max_abs']:.3g}", f"{e['max_rel_range']:.3g}"]
    worst = max(errors, key=lambda n: errors[n]["max_rel_range"])
    assert f"worst relative error {errors[worst]['max_rel_range']:.3g} ({worst})" in text


def test_write_documentation_refuses_what_it_cannot_document(heald_frame_rigid_fmu, tmp_path):
    not_fmu = tmp_path / "x.fmu"
    not_fmu.write_text("not a zip")
    with pytest.raises(ValueError, match="fmu_path"):
        write_documentation(not_fmu, load_model("heald_frame_rigid"))
    with pytest.raises(ValueError, match="modelName"):
        write_documentation(heald_frame_rigid_fmu.path, load_model("backrest"))
    with pytest.raises(ValueError, match="verification"):
        html_for(load_model("heald_frame_rigid"), {"errors": {}})
    with pytest.raises(ValueError, match="verification"):
        html_for(load_model("heald_frame_rigid"), [("dopri5", {})])


def _mm(description: str) -> float:
    return float(re.search(r"z = ([0-9.]+) mm", description).group(1))


def test_spindle_states_say_where_each_node_is():
    m = load_model("spindle")
    p = {v.name: v.start for v in m.of_kind("parameter")}
    n_low, n_cone = m.options["n_low"], m.options["n_cone"]
    bolster, whorl = n_low, n_low + 1
    top = whorl + n_cone
    expect = {0: ("footstep", 0.0), bolster: ("bolster", p["L_s"]),
              whorl: ("whorl", p["L_s"] + p["L_w"]),
              top: ("top", p["L_s"] + p["L_w"] + p["L_up"])}
    for k in range(top + 1):
        d = m.var(f"n{k}.x").description
        z = (k * p["L_s"] / n_low if k <= bolster else
             p["L_s"] + p["L_w"] + (k - whorl) * p["L_up"] / n_cone)
        assert _mm(d) == pytest.approx(z * 1e3, abs=0.05), d
        if k in expect:
            assert expect[k][0] in d, d
        else:
            assert "interior" in d or "bobbin" in d, d
        assert f"node {k}" in m.var(f"n{k}.vy").description


def test_spindle_modal_states_say_which_mode_and_frequency():
    from loomfmu.models.spindle import RPM, spindle_system
    m = load_model("spindle_modal")
    am, sp = spindle_system()
    f = ca.Function("mk", [am.syms("parameter"), sp.Omega], [sp.M, sp.K])
    M, K = (np.array(a) for a in f(am.starts("parameter"), m.options["basis_rpm"] * RPM))
    xi, _ = sp.plane_indices()
    lam = np.linalg.eigvals(np.linalg.solve(M[np.ix_(xi, xi)], K[np.ix_(xi, xi)]))
    hz = np.sort(np.sqrt(np.abs(lam.real))) / (2 * np.pi)
    for i in range(2 * m.options["n_modes"]):
        d = m.var(f"eta{i}").description
        k = i // 2
        assert f"mode {k + 1}, {'xy'[i % 2]} plane" in d, d
        got = float(re.search(r"([0-9.]+) Hz", d).group(1))
        assert got == pytest.approx(hz[k], abs=0.06), d
        assert f"{got:.1f} Hz" in m.var(f"deta{i}").description


def test_same_declaration_same_description_and_page(heald_frame_rigid_fmu, tmp_path):
    again = build_fmu(load_model("heald_frame_rigid"), out_dir=tmp_path)
    first, _ = _read(heald_frame_rigid_fmu.path)
    second, _ = _read(again.path)
    assert again.guid == heald_frame_rigid_fmu.guid
    for member in ("modelDescription.xml", DOC_MEMBER):
        assert first[member] == second[member], member


def test_readable_page_shows_the_derivation():
    """With readable=True (what loomfmu build writes) the page carries the
    Derivation of inspect's report: every named quantity under its group
    heading, one level below the section (no link, no script)."""
    model = load_model("heald_frame_planar")
    assert model.quantities, "the planar heald frame keeps its derivation's quantities"
    page = html_for(model, readable=True)
    assert "<h2>Derivation and equations</h2>" in page and "<h3>Derivation</h3>" in page
    groups = {q.group for q in model.quantities}
    for g in groups:
        assert f"<h4>{html.escape(g)}</h4>" in page, g
    for q in model.quantities:
        assert f"<code>{html.escape(q.name)}</code>" in page, q.name
    assert "<script" not in page.lower() and not re.search(r'\b(src|href)="(?!#)', page)
    plain = html_for(model)
    assert "<h2>Equations</h2>" in plain and "Derivation" not in plain


@pytest.mark.parametrize("name, keys", [("heald_frame", ("D1", "D2", "D3", "D4")),
                                        ("backrest", ("B1", "B2", "B3", "B4"))])
def test_print_defects_are_listed_one_item_each(name, keys):
    """The seed's print defects in 'What it is' are one list item each, with
    printed and corrected form (before: one run-on paragraph of four)."""
    page = html_for(load_model(name))
    about = page.split('<section id="about">', 1)[1].split("</section>", 1)[0]
    items = re.findall(r"<li><b>([A-Z]\d)</b>(.*?)</li>", about, flags=re.S)
    assert [k for k, _ in items] == list(keys), items
    for _, text in items:
        assert "printed" in text and "corrected" in text


# ------------------------------------------------------------- variants
def _variant_page(name: str, fmi_version: int, interface: str, verification=None) -> str:
    from loomfmu.export.dae import dae_form
    from loomfmu.export.fmi_xml import model_description
    model = load_model(name)
    xml = model_description(model, dae_form(model), "{00000000-0000-0000-0000-000000000000}",
                            [], fmi_version=fmi_version, interface=interface)
    return html_for(model, verification, model_description_xml=xml)


def _section(page: str, anchor: str) -> str:
    body = page.split(f'<section id="{anchor}">', 1)[1].split("</section>", 1)[0]
    return " ".join(_visible_text(body).split())


@pytest.mark.parametrize("version", [2, 3])
def test_model_exchange_only_page_says_what_the_importer_must_do(version):
    """An ME-only FMU: no embedded-solver section; completedIntegratorStep,
    event iteration, nominals 1.0, the solver* parameters unused."""
    page = _variant_page("two_mass_force", version, "me")
    nav = re.search(r"<nav>(.*?)</nav>", page).group(1)
    assert "Solvers and tolerances" not in nav and "Integration by the importer" in nav
    text = _section(page, "solver")
    assert f"fmi{version}CompletedIntegratorStep after every accepted step" in text
    assert "event mode" in text and "gives 1.0 for every state" in text
    assert "unused in model exchange" in text
    for s in SETTINGS:
        assert s.name in text
    # nothing about the embedded solvers' tolerance rule
    assert "Tolerance rule" not in page and "dopri5" not in text


def test_both_page_keeps_the_solvers_and_adds_the_importer_s_duties():
    text = _section(_variant_page("two_mass_force", 2, "both"), "solver")
    assert "Tolerance rule" in text and "fmi2CompletedIntegratorStep" in text
    assert "unused in model exchange" in text


def test_the_adaptive_solvers_are_those_of_codegen():
    from loomfmu.declare.solvers import ADAPTIVE_SOLVERS, SOLVER_DESCRIPTIONS, SOLVERS
    text = _section(_variant_page("two_mass_force", 2, "cs"), "solver")
    adaptive = [s for s in SOLVERS if "adaptive" in SOLVER_DESCRIPTIONS[s]]
    assert "ros34pw2" in adaptive and list(ADAPTIVE_SOLVERS) == adaptive
    listed = re.search(r"relative tolerance of the adaptive solvers \(([^)]*)\)", text).group(1)
    assert sorted(re.split(r", | and ", listed)) == sorted(adaptive)


@pytest.mark.parametrize("interface", ["cs", "me", "both"])
def test_fmi3_pages_name_fmi3_functions(interface):
    """No fmi2 name on an FMI 3.0 page (fmi3DoStep, fmi3Discard, fmi3GetFloat64...),
    no fmi3 name on an FMI 2.0 page."""
    page3 = _visible_text(_variant_page("drive", 3, interface))
    assert not re.findall(r"fmi2[A-Z]\w*", page3), set(re.findall(r"fmi2[A-Z]\w*", page3))
    page2 = _visible_text(_variant_page("drive", 2, interface))
    assert not re.findall(r"fmi3[A-Z]\w*", page2)
    if interface != "me":
        assert "fmi3DoStep" in page3 and "fmi3Discard" in page3
        assert "fmi3EnterInitializationMode" in page3 and "fmi2DoStep" in page2
    if interface != "cs":
        assert "fmi3CompletedIntegratorStep" in page3 and "fmi3UpdateDiscreteStates" in page3


def test_model_exchange_with_a_delay_states_the_step_limit_and_how_to_run_fmpy():
    text = _section(_variant_page("drive", 3, "me"), "solver")
    assert "tau = 0.5 s" in text
    assert "steps between completed integrator steps must not be longer than tau" in text
    assert "fmi3Discard with a log line" in text
    assert 'fmi_type="ModelExchange"' in text and "output_interval" in text
    assert "50 × tau = 25 s" in text
    # without a delay: no such paragraph
    assert "tau" not in _section(_variant_page("two_mass_force", 3, "me"), "solver")


def test_model_exchange_verification_is_documented_as_one_cvode_run():
    from loomfmu.verification.verify import ME_LABEL
    ver = {"reference_wall_seconds": 1.0, "reference_rhs_calls": 10, "rtol": 1e-6,
           "solvers": {ME_LABEL: {"interface": "me", "wall_seconds": 0.1, "log": [],
                                  "errors": {"v1_out": {"max_abs": 1e-4,
                                                        "max_rel_range": 2e-5}}}}}
    page = _variant_page("two_mass_force", 3, "me", ver)
    text = _section(page, "verification")
    assert "FMPy model exchange, once: FMPy's CVode" in text
    assert "co-simulation with the embedded" not in text
    assert f"{ME_LABEL}: worst relative error 2e-05 (v1_out)" in text
    failed = {**ver, "solvers": {ME_LABEL: {"interface": "me", "error": "refused: Discard",
                                            "errors": {}}}}
    assert "refused: Discard" in _section(
        _variant_page("drive", 3, "me", failed), "verification")
