"""One declaration, four interfaces: FMI 2.0 and 3.0 model descriptions for
co-simulation, model exchange or both, written from one variable table
(loomfmu.export.fmi_xml), and the builder's FMU layout per variant.

Oracles: FMPy's validation (the FMI schemas and its model-structure checks),
FMPy's own schema for terminalsAndIcons.xml and buildDescription.xml, the
FMU's generated C headers compiled and run (the value-reference convention
the C facades implement), the symbolic declaration (states, events, inputs),
and the shared library's exported functions (nm).
"""
from __future__ import annotations

import importlib.util
import re
import subprocess
import zipfile
from pathlib import Path

import fmpy
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu
from lxml import etree

from loomfmu import build_fmu, load_model
from loomfmu.export.codegen import model_guid, real_table
from loomfmu.export.dae import dae_form
from loomfmu.export.fmi_xml import (
    INDICATOR_PREFIX,
    fmi3_text,
    model_description,
    terminals_and_icons,
    variable_table,
)
from loomfmu.fmu.builder import fmi_headers_dir, terminals_problems
from loomfmu.fmu.documentation import DOC_MEMBER

#: modes, events, implicit (backrest); a delay (drive); events, explicit,
#: ports of two kinds (heald_frame_rigid); direct feedthrough (two_mass_force)
XML_MODELS = ("backrest", "drive", "heald_frame_rigid", "two_mass_force")
VARIANTS = [(v, i) for v in (2, 3) for i in ("cs", "me", "both")]
SCHEMA = Path(fmpy.__file__).parent / "schema" / "fmi3"


@pytest.fixture(scope="module")
def declared():
    out = {}
    for name in XML_MODELS:
        model = load_model(name)
        dae = dae_form(model)
        out[name] = model, dae, model_guid(model, dae)
    return out


def _md(declared, name, fmi_version, interface, tmp_path):
    model, dae, guid = declared[name]
    folder = tmp_path / f"{name}_{fmi_version}_{interface}"
    folder.mkdir()
    (folder / "modelDescription.xml").write_text(model_description(
        model, dae, guid, ["a.c"], fmi_version=fmi_version, interface=interface))
    return folder


@pytest.mark.parametrize("name", XML_MODELS)
@pytest.mark.parametrize("fmi_version,interface", VARIANTS)
def test_every_variant_description_has_no_fmpy_problem(declared, name, fmi_version,
                                                       interface, tmp_path):
    folder = _md(declared, name, fmi_version, interface, tmp_path)
    assert validate_fmu(str(folder)) == []
    md = read_model_description(str(folder))
    assert md.fmiVersion == f"{fmi_version}.0"
    assert (md.coSimulation is not None) == (interface in ("cs", "both"))
    assert (md.modelExchange is not None) == (interface in ("me", "both"))


def _by_name(md):
    return {v.name: v for v in md.modelVariables}


@pytest.mark.parametrize("name", XML_MODELS)
def test_one_table_gives_both_versions_the_same_variables(declared, name, tmp_path):
    """Names, causality, variability, initial, unit, start, range and
    description agree between FMI 2.0 and 3.0 (descriptions with the FMI
    function names of their version); FMI 3.0 adds only `time` and the
    event-indicator variables of model exchange."""
    v2 = _by_name(read_model_description(str(_md(declared, name, 2, "both", tmp_path))))
    v3 = _by_name(read_model_description(str(_md(declared, name, 3, "both", tmp_path))))
    extra = set(v3) - set(v2)
    model, dae, _ = declared[name]
    assert extra == {"time"} | {INDICATOR_PREFIX + e.name for e in model.events}
    assert set(v2) <= set(v3)
    for n, a in v2.items():
        b = v3[n]
        for attr in ("causality", "variability", "initial", "unit", "start", "min", "max"):
            assert getattr(a, attr) == getattr(b, attr), (n, attr)
        assert fmi3_text(a.description) == b.description, n
        assert not re.findall(r"fmi2[A-Z]", b.description), (n, b.description)
        assert {"Real": "Float64", "Integer": "Int32"}.get(a.type, a.type) == b.type, n
    # co-simulation only: the same table less the derivatives
    cs = _by_name(read_model_description(str(_md(declared, name, 2, "cs", tmp_path))))
    assert set(v2) - set(cs) == {f"der({x.name})" for x in model.of_kind("state")}


@pytest.mark.parametrize("name", XML_MODELS)
def test_dependencies_agree_between_versions(declared, name, tmp_path):
    """Outputs, derivatives and initial unknowns list the same variables in
    both versions (FMI 2.0 by index, FMI 3.0 by value reference)."""
    def deps(md):
        return {kind: {u.variable.name: None if u.dependencies is None else
                       sorted(d.name for d in u.dependencies) for u in getattr(md, kind)}
                for kind in ("outputs", "derivatives", "initialUnknowns")}
    d2 = deps(read_model_description(str(_md(declared, name, 2, "me", tmp_path))))
    d3 = deps(read_model_description(str(_md(declared, name, 3, "me", tmp_path))))
    assert d2 == d3
    model, dae, _ = declared[name]
    assert len(d2["derivatives"]) == dae.nx


def test_feedthrough_and_state_dependencies_follow_the_equations(declared, tmp_path):
    """two_mass_force: an output that depends on the input force directly
    lists it (co-simulation: inputs only; model exchange: the states too);
    every derivative depends on some state or input, none on a parameter
    (parameters are not listed for derivatives)."""
    model, dae, _ = declared["two_mass_force"]
    md = read_model_description(str(_md(declared, "two_mass_force", 3, "me", tmp_path)))
    inputs = {v.name for v in model.of_kind("input")}
    states = {v.name for v in model.of_kind("state")}
    fed = {u.variable.name for u in md.outputs if {d.name for d in u.dependencies} & inputs}
    assert fed, "no output of two_mass_force lists its input: feedthrough lost"
    # model exchange: outputs also depend on the states the importer sets
    assert any({d.name for d in u.dependencies} & states for u in md.outputs)
    cs = read_model_description(str(_md(declared, "two_mass_force", 3, "cs", tmp_path)))
    for u in cs.outputs:  # co-simulation: the knowns are the inputs only
        assert {d.name for d in u.dependencies} <= inputs, u.variable.name
    assert {u.variable.name for u in cs.outputs if {d.name for d in u.dependencies}} == fed
    for u in md.derivatives:
        names = {d.name for d in u.dependencies}
        assert names and names <= states | inputs, (u.variable.name, names)


@pytest.mark.parametrize("name", ("backrest", "heald_frame_rigid"))
def test_model_exchange_declares_states_and_event_indicators(declared, name, tmp_path):
    model, dae, _ = declared[name]
    md2 = read_model_description(str(_md(declared, name, 2, "me", tmp_path)))
    md3 = read_model_description(str(_md(declared, name, 3, "me", tmp_path)))
    states = [v.name for v in model.of_kind("state")]
    for md in (md2, md3):  # der(x_k) in state order, each pointing at its state
        assert [u.variable.derivative.name for u in md.derivatives] == states
        assert [u.variable.name for u in md.derivatives] == [f"der({x})" for x in states]
    assert md2.numberOfEventIndicators == dae.e.numel() > 0
    assert [u.variable.name for u in md3.eventIndicators] == [
        INDICATOR_PREFIX + e.name for e in model.events]
    cs = read_model_description(str(_md(declared, name, 2, "cs", tmp_path)))
    assert cs.numberOfEventIndicators == 0 and not cs.derivatives


def test_fmi3_value_references_are_unique_and_follow_the_convention(declared):
    model, dae, _ = declared["backrest"]
    table = variable_table(model, dae, fmi_version=3, interface="both")
    vrs = [v.vr3 for v in table]
    assert len(set(vrs)) == len(vrs)
    n_real, states = len(real_table(model)), model.of_kind("state")
    by = {v.name: v for v in table}
    ints = [v for v in table if v.type != "Real"]
    for v in table:
        if v.type == "Real" and v.vr2 is not None and not v.derivative_of:
            assert v.vr3 == v.vr2 < n_real
    for k, x in enumerate(states):
        assert by[f"der({x.name})"].vr3 == n_real + k == by[f"der({x.name})"].vr2
    for v in ints:
        assert v.vr3 == n_real + len(states) + v.vr2
    assert by["time"].vr3 == n_real + len(states) + len(ints)
    ev = [by[INDICATOR_PREFIX + e.name].vr3 for e in model.events]
    assert ev == [by["time"].vr3 + 1 + j for j in range(len(ev))]


@pytest.mark.parametrize("name", ("backrest", "drive"))
def test_terminals_follow_the_ports_and_fmpy_s_schema(declared, name, tmp_path):
    model, dae, _ = declared[name]
    xml = terminals_and_icons(model)
    schema = etree.XMLSchema(etree.parse(str(SCHEMA / "fmi3TerminalsAndIcons.xsd")))
    doc = etree.fromstring(xml.encode())
    schema.assertValid(doc)
    # the builder's own check finds a broken file (and none in ours)
    assert terminals_problems(xml) == []
    assert terminals_problems(xml.replace('matchingRule="bus" ', ""))
    names = set(_by_name(read_model_description(str(_md(declared, name, 3, "cs", tmp_path)))))
    terms = doc.findall("Terminals/Terminal")
    assert [t.get("name") for t in terms] == [p.name for p in model.ports]
    for t, p in zip(terms, model.ports):
        assert t.get("terminalKind") == f"loomfmu.{p.kind}"
        members = {m.get("memberName"): m.get("variableName")
                   for m in t.findall("TerminalMemberVariable")}
        assert members == p.variables and set(members.values()) <= names


@pytest.mark.parametrize("kw,arg", [({"fmi_version": 4}, "fmi_version"),
                                    ({"fmi_version": "3"}, "fmi_version"),
                                    ({"interface": "hil"}, "interface"),
                                    ({"interface": None}, "interface")])
def test_a_bad_variant_is_refused_naming_the_argument(declared, tmp_path, kw, arg):
    model, dae, guid = declared["two_mass_force"]
    with pytest.raises(ValueError, match=arg):
        build_fmu(model, out_dir=tmp_path, **kw)
    with pytest.raises(ValueError, match=arg):
        model_description(model, dae, guid, [], **kw)
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------ built FMUs
#: (model, FMI version, interface) built once for the module: FMI 2 model
#: exchange, FMI 3 co-simulation and FMI 3 model exchange (FMI 2 co-simulation
#: is what every other test builds)
BUILT = (("heald_frame_rigid", 2, "me"), ("two_mass_force", 3, "cs"), ("backrest", 3, "me"))
PLATFORM = {2: "linux64", 3: "x86_64-linux"}
#: functions the shared library must export per (version, interface)
EXPORTS = {(2, "me"): ("fmi2Instantiate", "fmi2GetDerivatives", "fmi2GetEventIndicators",
                       "fmi2CompletedIntegratorStep", "fmi2GetDirectionalDerivative"),
           (3, "cs"): ("fmi3InstantiateCoSimulation", "fmi3DoStep", "fmi3EnterStepMode",
                       "fmi3GetDirectionalDerivative"),
           (3, "me"): ("fmi3InstantiateModelExchange", "fmi3GetContinuousStateDerivatives",
                       "fmi3GetEventIndicators", "fmi3CompletedIntegratorStep",
                       "fmi3GetDirectionalDerivative")}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    return dict(zip(BUILT, variant_builds(tmp_path_factory, BUILT)))


@pytest.mark.parametrize("key", BUILT, ids=[f"{n}-fmi{v}-{i}" for n, v, i in BUILT])
@pytest.mark.slow
def test_built_variant_validates_and_has_its_layout(built, key, tmp_path):
    name, v, i = key
    res = built[key]
    assert res.problems == [] and validate_fmu(str(res.path)) == []
    assert res.path.name == f"{name}_fmi{v}_{i}.fmu"
    with zipfile.ZipFile(res.path) as z:
        members = set(z.namelist())
        build_h = z.read("sources/lf_build.h").decode()
        z.extractall(tmp_path)
    assert f"binaries/{PLATFORM[v]}/{name}.so" in members
    assert f"#define LF_FMI_VERSION {v}" in build_h
    assert f"#define LF_HAS_CS {int(i != 'me')}" in build_h
    assert f"#define LF_HAS_ME {int(i != 'cs')}" in build_h
    other = 3 if v == 2 else 2
    assert not [m for m in members if m.startswith(f"sources/lf_fmi{other}")]
    assert [m for m in members if m.startswith(f"sources/lf_fmi{v}") and m.endswith(".c")]
    if v == 3:  # FMPy reads it against the FMI 3 schema
        bd = fmpy.model_description.read_build_description(str(res.path))
        listed = {f for conf in bd for s in conf.sourceFileSets for f in s.sourceFiles}
        assert listed == {m[len("sources/"):] for m in members
                          if m.startswith("sources/") and m.endswith(".c")}
        assert "terminalsAndIcons/terminalsAndIcons.xml" in members
    nm = subprocess.run(["nm", "-D", "--defined-only", str(tmp_path / "binaries" / PLATFORM[v] /
                                                           f"{name}.so")],
                        capture_output=True, text=True, check=True).stdout
    exported = {ln.split()[-1] for ln in nm.splitlines()}
    assert set(EXPORTS[v, i]) <= exported, sorted(set(EXPORTS[v, i]) - exported)
    with zipfile.ZipFile(res.path) as z:  # declared where the function works
        root = etree.fromstring(z.read("modelDescription.xml"))
    flag = "providesDirectionalDerivative" + ("s" if v == 3 else "")
    kinds = root.findall("CoSimulation") + root.findall("ModelExchange")
    assert kinds and all(k.get(flag) == "true" for k in kinds)


@pytest.mark.slow
def test_value_reference_convention_matches_the_c_declaration(built, tmp_path):
    """The FMI 3.0 value references of the model description equal what the
    FMU's own C headers give: LF_NREAL + k, LF_NREAL + LF_NX + Integer vr,
    time and event indicators after LF_N_INTEGER."""
    res = built["backrest", 3, "me"]
    with zipfile.ZipFile(res.path) as z:
        z.extractall(tmp_path)
    src = tmp_path / "sources"
    prog = tmp_path / "vr.c"
    prog.write_text('#include <stdio.h>\n#include "lf_model.h"\n#include "lf_build.h"\n'
                    "int main(void) { printf(\"%d %d %d %d %d\\n\", (int)LF_NREAL, (int)LF_NX,"
                    " (int)LF_N_INTEGER, (int)LF_NE, LF_FMI_VERSION); return 0; }\n")
    exe = tmp_path / "vr"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Werror", "-I", str(src), "-I",
                    str(fmi_headers_dir()), str(prog), "-o", str(exe)], check=True)
    n_real, nx, n_int, ne, version = map(int, subprocess.run(
        [str(exe)], capture_output=True, text=True, check=True).stdout.split())
    assert version == 3
    md = read_model_description(str(res.path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    model = load_model("backrest")
    states = [v.name for v in model.of_kind("state")]
    assert len(states) == nx
    assert [vr[f"der({x})"] for x in states] == [n_real + k for k in range(nx)]
    assert vr["solver"] == n_real + nx
    assert vr["solver_index"] == n_real + nx + n_int - 1
    assert vr["time"] == n_real + nx + n_int
    assert [u.variable.valueReference for u in md.eventIndicators] == [
        n_real + nx + n_int + 1 + j for j in range(ne)]


@pytest.mark.slow
def test_documentation_page_names_the_interfaces(built):
    res = built["two_mass_force", 3, "cs"]
    with zipfile.ZipFile(res.path) as z:
        page = z.read(DOC_MEMBER).decode()
    assert "FMI 3.0 Co-Simulation" in page and "instantiation token" in page
    md = read_model_description(str(res.path))
    assert f"({len(md.modelVariables)} in all)" in page
    for v in md.modelVariables:
        if v.causality == "output":
            assert f'<td class="name">{v.name}</td>' in page
    with zipfile.ZipFile(built["backrest", 3, "me"].path) as z:
        page = z.read(DOC_MEMBER).decode()
    assert "FMI 3.0 Model Exchange" in page and "completedIntegratorStep" in page


# ------------------------------------------------- builds shared by the variant tests
#: (model, FMI version, interface, build options) -> BuildResult, for the
#: session: test_me, test_fmi3, test_fmi3_container, test_dirder and this
#: module ask for the same FMUs ("both" serves co-simulation and model
#: exchange from one build)
_BUILDS: dict = {}


def _key(name, fmi_version, interface, options=None):
    return name, fmi_version, interface, tuple(sorted((options or {}).items()))


def _build(key, out_root):
    name, fmi_version, interface, options = key
    folder = out_root / "-".join([name, *(f"{k}={v}" for k, v in options)])
    return build_fmu(load_model(name, **dict(options)), out_dir=folder,
                     fmi_version=fmi_version, interface=interface)


def variant_builds(tmp_path_factory, keys) -> list:
    """The BuildResults of ``keys`` ((model, fmi_version, interface[,
    options]), in their order), each built once per session; the missing ones
    on two processes (gcc dominates a build)."""
    want = [_key(*k) for k in keys]
    missing = list(dict.fromkeys(k for k in want if k not in _BUILDS))
    out_root = tmp_path_factory.getbasetemp() / "variant_builds"
    if len(missing) > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor
        with ProcessPoolExecutor(max_workers=2,
                                 mp_context=multiprocessing.get_context("fork")) as pool:
            for k, res in zip(missing, pool.map(_build, missing, [out_root] * len(missing))):
                _BUILDS[k] = res
    for k in missing:
        if k not in _BUILDS:
            _BUILDS[k] = _build(k, out_root)
    return [_BUILDS[k] for k in want]


# ------------------------------------- the four interfaces agree, model by model
_spec = importlib.util.spec_from_file_location(
    "fmi_matrix", Path(__file__).parent.parent / "benchmarks" / "fmi_matrix.py")
fmi_matrix = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fmi_matrix)

#: a short horizon per model (s) that still holds its features: the backrest's
#: first stick-slip switches, the heald frames' dwell events, the drive past
#: its delay tau = 0.5 s, a few spindle revolutions
HORIZON = {"backrest": 0.3, "backrest_regularized": 0.3, "drive": 1.5, "heald_frame": 0.1,
           "heald_frame_planar": 0.1, "heald_frame_rigid": 0.42, "loom_shaft": 0.2,
           "spindle": 0.004, "spindle_modal": 0.004, "two_mass_displacement": 1.0,
           "two_mass_force": 1.0}
#: the spindle with the coarsest mesh (37 states instead of 69: the same
#: equations; the full one builds in ~40 CPU s per variant, in
#: benchmarks/fmi_matrix.py)
OPTIONS = {"spindle": {"n_low": 1, "n_cone": 1}}
RTOL = 1e-10
POINTS = 100
#: model exchange against co-simulation, relative to each output's range, at
#: RTOL for FMPy's CVode and our dopri5 (measured: 2.9e-6 spindle_modal, 2.4e-6
#: drive: its delay's history holds the importer's completed steps only,
#: 2.0e-6 spindle, below 3e-7 for the others; at rtol 1e-8 10 to 120 times
#: larger: the gap is the solvers')
ME_BOUND = 1e-5


@pytest.fixture(scope="module")
def four_interfaces(tmp_path_factory):
    from loomfmu.registry import MODELS
    assert set(HORIZON) == set(MODELS)
    keys = [(n, v, "both", OPTIONS.get(n)) for n in sorted(MODELS) for v in (2, 3)]
    return dict(zip([k[:2] for k in keys], variant_builds(tmp_path_factory, keys)))


@pytest.mark.parametrize("name", sorted(HORIZON))
@pytest.mark.slow
def test_four_interfaces_agree(four_interfaces, name):
    """FMI 2 and 3, co-simulation and model exchange, through FMPy over a
    short horizon: FMI 3 co-simulation equals FMI 2 co-simulation (the same
    runtime and solver) to rounding, FMI 3 model exchange equals FMI 2 model
    exchange (the same core under the same CVode) to rounding, and model
    exchange agrees with co-simulation to the solvers' tolerance."""
    stop, interval = HORIZON[name], HORIZON[name] / POINTS
    runs = {}
    for v in (2, 3):
        res = four_interfaces[name, v]
        assert res.problems == []
        for kind in ("CoSimulation", "ModelExchange"):
            out, log = fmi_matrix.simulate(res.path, kind, stop, interval, RTOL)
            assert out is not None and log == [], (v, kind, log[-3:])
            assert out["time"][-1] == pytest.approx(stop)
            runs[v, kind] = out
    ref = runs[2, "CoSimulation"]
    cs3 = fmi_matrix.agreement(ref, runs[3, "CoSimulation"])
    me3 = fmi_matrix.agreement(runs[2, "ModelExchange"], runs[3, "ModelExchange"])
    me2 = fmi_matrix.agreement(ref, runs[2, "ModelExchange"])
    assert cs3["points"] == me2["points"] == POINTS + 1
    assert cs3["difference"] <= 1e-12, cs3
    assert me3["difference"] <= 1e-12, me3
    assert me2["difference"] <= ME_BOUND, me2


if __name__ == "__main__":
    # python tests/test_fmi_variants.py [RTOL,...]: the four-interface figures
    # of test_four_interfaces_agree per model and tolerance
    import sys
    import tempfile

    class _Tmp:
        def __init__(self):
            self.base = Path(tempfile.mkdtemp())

        def getbasetemp(self):
            return self.base

    from loomfmu.registry import MODELS
    rtols = [float(r) for r in (sys.argv[1] if len(sys.argv) > 1 else str(RTOL)).split(",")]
    keys = [(n, v, "both", OPTIONS.get(n)) for n in sorted(MODELS) for v in (2, 3)]
    fmus = dict(zip([k[:2] for k in keys], variant_builds(_Tmp(), keys)))
    print("model                   rtol    3:cs vs 2:cs  3:me vs 2:me  2:me vs 2:cs (output)")
    for rtol in rtols:
        for name in sorted(MODELS):
            stop = HORIZON[name]
            runs = {(v, k): fmi_matrix.simulate(fmus[name, v].path, k, stop, stop / POINTS,
                                                rtol)[0]
                    for v in (2, 3) for k in ("CoSimulation", "ModelExchange")}
            ref = runs[2, "CoSimulation"]
            cs3 = fmi_matrix.agreement(ref, runs[3, "CoSimulation"])
            me3 = fmi_matrix.agreement(runs[2, "ModelExchange"], runs[3, "ModelExchange"])
            me2 = fmi_matrix.agreement(ref, runs[2, "ModelExchange"])
            print(f"{name:<22}{rtol:>7.0e}{cs3['difference']:>14.1e}{me3['difference']:>14.1e}"
                  f"{me2['difference']:>14.1e} ({me2['output']})", flush=True)
