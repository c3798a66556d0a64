"""``modelDescription.xml`` for FMI 2.0 Co-Simulation, from the declaration.

Variable order and value references come from :func:`loomfmu.codegen.real_table`
(the same table the C declaration is written from).  Dependencies in
``ModelStructure`` are computed from the sparsity of the exact CasADi
Jacobians: an output lists the inputs it depends on directly (Outputs), and
the parameters, states and inputs it depends on at initialization
(InitialUnknowns).
"""
from __future__ import annotations

import importlib.metadata
import math
import xml.etree.ElementTree as ET

import casadi as ca

from .codegen import SOLVER_DESCRIPTIONS, SOLVERS, RealVar, real_table
from .declare import Model
from .ode import DaeForm
from .runtime_files import LOG_CATEGORIES
from .units import UNITS


#: Header values used when the installed package's metadata does not state them
#: (pyproject.toml's ``authors`` and ``license`` flow into every model
#: description; these apply only when running from a source tree).
DEFAULT_AUTHOR = "the loomfmu developers"
DEFAULT_LICENSE = ("none stated: the loomfmu package declares no license; ask the authors "
                   "before redistributing")


def tool_info() -> dict[str, str]:
    """The fmiModelDescription header attributes that name the tool and its
    terms: author, version (the loomfmu package version), copyright, license,
    generationTool.  No generationDateAndTime: a build of the same declaration
    gives the same file."""
    try:
        meta = importlib.metadata.metadata("loomfmu")
        version = meta["Version"]
        author = meta.get("Author") or meta.get("Author-email") or DEFAULT_AUTHOR
        license_ = meta.get("License-Expression") or meta.get("License") or DEFAULT_LICENSE
    except importlib.metadata.PackageNotFoundError:  # running from a source tree
        version, author, license_ = "0+unknown", DEFAULT_AUTHOR, DEFAULT_LICENSE
    return {"author": author, "version": version, "copyright": f"Copyright {author}",
            "license": license_, "generationTool": f"loomfmu {version}"}


def _num(v: float) -> str:
    return repr(float(v))


def _depends(expr: ca.SX, syms: ca.SX) -> list[list[int]]:
    """For each row of ``expr``, the columns of ``syms`` it structurally depends on."""
    if expr.numel() == 0 or syms.numel() == 0:
        return [[] for _ in range(expr.numel())]
    sp = ca.jacobian(expr, syms).sparsity()
    rows: list[list[int]] = [[] for _ in range(expr.numel())]
    for r, c in zip(*sp.get_triplet()):
        rows[r].append(c)
    return rows


def _scalar_variable(parent: ET.Element, row: RealVar, computed_starts: set[str]) -> None:
    causality = {"setting": "parameter", "parameter": "parameter", "input": "input",
                 "output": "output"}.get(row.kind, "local")
    variability = {"setting": "fixed", "parameter": "fixed"}.get(row.kind, "continuous")
    attrs = {"name": row.name, "valueReference": str(row.vr), "causality": causality,
             "variability": variability, "description": row.description}
    if row.kind == "state":
        computed = row.name in computed_starts
        attrs["initial"] = "approx" if computed else "exact"
        if computed:
            attrs["description"] += (" (start computed at initialization from the "
                                     "parameters, unless set)")
    elif row.kind in ("output", "algebraic"):
        attrs["initial"] = "calculated"
    sv = ET.SubElement(parent, "ScalarVariable", attrs)
    real = {}
    if row.unit:
        real["unit"] = row.unit
    if math.isfinite(row.min):
        real["min"] = _num(row.min)
    if math.isfinite(row.max):
        real["max"] = _num(row.max)
    if row.var is not None and row.var.nominal is not None:
        real["nominal"] = _num(row.var.nominal)
    if row.start is not None and row.kind not in ("output", "algebraic"):
        real["start"] = _num(row.start)
    ET.SubElement(sv, "Real", real)


def _resolved_outputs(dae: DaeForm) -> ca.SX:
    """Outputs with the unknowns w and the delayed values d eliminated, for the
    dependency analysis.  w: substituted for explicit models; for implicit ones
    replaced by a stand-in that depends on everything F depends on.  d: by the
    delayed expression itself (a delay may be zero: direct feedthrough)."""
    y = dae.y
    if dae.implicit:
        known = ca.vertsplit(ca.vertcat(dae.x, dae.u, dae.p))
        stand_in = sum((k for k in known if ca.depends_on(dae.F, k)), ca.SX(0))
        y = ca.substitute(y, dae.w, ca.repmat(stand_in, dae.w.numel(), 1))
    else:
        y = ca.substitute(y, dae.w, dae.wsol)
    if dae.d.numel():
        y = ca.substitute(y, dae.d, dae.g)
    return y


#: Integer parameter every FMU has: the solver as a plain Integer
SOLVER_INDEX = "solver_index"


def model_description(model: Model, dae: DaeForm, guid: str, sources: list[str]) -> str:
    rows = real_table(model)
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": model.name, "guid": guid,
        "description": model.description, **tool_info(),
        "variableNamingConvention": "structured", "numberOfEventIndicators": "0"})
    cs = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": model.name, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true", "canInterpolateInputs": "true",
        "maxOutputDerivativeOrder": "1", "canRunAsynchronuously": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "canNotUseMemoryManagementFunctions": "false", "canGetAndSetFMUstate": "true",
        "canSerializeFMUstate": "true", "providesDirectionalDerivative": "false"})
    files = ET.SubElement(cs, "SourceFiles")
    for f in sources:
        if f.endswith(".c"):
            ET.SubElement(files, "File", {"name": f})

    used = sorted({r.unit for r in rows if r.unit})
    ud = ET.SubElement(root, "UnitDefinitions")
    for u in used:
        unit = ET.SubElement(ud, "Unit", {"name": u})
        ET.SubElement(unit, "BaseUnit", {k: str(v) for k, v in UNITS[u].items()})

    td = ET.SubElement(root, "TypeDefinitions")
    st = ET.SubElement(td, "SimpleType", {"name": "Solver"})
    en = ET.SubElement(st, "Enumeration")
    for i, s in enumerate(SOLVERS, 1):
        ET.SubElement(en, "Item", {"name": s, "value": str(i),
                                   "description": SOLVER_DESCRIPTIONS[s]})

    if model.delays:
        st = ET.SubElement(td, "SimpleType", {"name": "DelayInterpolation"})
        en = ET.SubElement(st, "Enumeration")
        ET.SubElement(en, "Item", {"name": "hermite", "value": "1", "description":
                                   "cubic Hermite on the solver's accepted points "
                                   "(values and exact time derivatives)"})
        ET.SubElement(en, "Item", {"name": "linear", "value": "2", "description":
                                   "linear between accepted points (for comparison)"})

    lc = ET.SubElement(root, "LogCategories")
    for name, desc in LOG_CATEGORIES:
        ET.SubElement(lc, "Category", {"name": name, "description": desc})

    ET.SubElement(root, "DefaultExperiment", {
        "startTime": "0.0", "stopTime": _num(model.stop_time), "tolerance": "1e-06",
        "stepSize": _num(model.step_size)})

    mv = ET.SubElement(root, "ModelVariables")
    for row in rows:
        _scalar_variable(mv, row, set(model.initials))
    sv = ET.SubElement(mv, "ScalarVariable", {
        "name": "solver", "valueReference": "0", "causality": "parameter",
        "variability": "fixed", "description": "embedded solver: " + "; ".join(
            f"{i} = {s}" for i, s in enumerate(SOLVERS, 1))})
    ET.SubElement(sv, "Enumeration", {"declaredType": "Solver", "start": "1"})
    for k, v in enumerate(model.of_kind("mode"), 1):
        sv = ET.SubElement(mv, "ScalarVariable", {
            "name": v.name, "valueReference": str(k), "causality": "output",
            "variability": "discrete", "initial": "calculated",
            "description": v.description})
        ET.SubElement(sv, "Integer", {"min": str(int(v.min)), "max": str(int(v.max))})

    if model.delays:
        sv = ET.SubElement(mv, "ScalarVariable", {
            "name": "delay_interpolation", "valueReference": str(1 + len(model.of_kind("mode"))),
            "causality": "parameter", "variability": "fixed",
            "description": "how the history of delayed values is interpolated: "
                           "1 = hermite, 2 = linear"})
        ET.SubElement(sv, "Enumeration", {"declaredType": "DelayInterpolation", "start": "1"})

    # the solver again as a plain Integer: importers that cannot set an
    # Enumeration (libcosim) can choose the solver through it
    if any(r.name == SOLVER_INDEX for r in rows):
        raise ValueError(f"model {model.name}: variable name {SOLVER_INDEX!r} is reserved "
                         "(every FMU has it)")
    sv = ET.SubElement(mv, "ScalarVariable", {
        "name": SOLVER_INDEX,
        "valueReference": str(1 + len(model.of_kind("mode")) + (1 if model.delays else 0)),
        "causality": "parameter", "variability": "fixed",
        "description": "the embedded solver as an Integer, for importers that cannot set an "
                       "Enumeration: 0 = as `solver` says; otherwise it wins over `solver`: "
                       + "; ".join(f"{i} = {s}" for i, s in enumerate(SOLVERS, 1))})
    ET.SubElement(sv, "Integer", {"start": "0", "min": "0", "max": str(len(SOLVERS))})

    _model_structure(root, model, dae, rows)
    ET.indent(root, "  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _model_structure(root: ET.Element, model: Model, dae: DaeForm, rows: list[RealVar]) -> None:
    index = {r.name: r.vr + 1 for r in rows}  # 1-based position in ModelVariables
    modes = model.of_kind("mode")
    for k, v in enumerate(modes):
        index[v.name] = len(rows) + 2 + k  # after the Reals and `solver`
    names = {k: [v.name for v in model.of_kind(k)] for k in ("parameter", "state", "input")}
    y_rows = [r for r in rows if r.kind == "output"]
    y = _resolved_outputs(dae)
    ms = ET.SubElement(root, "ModelStructure")
    outputs = ET.SubElement(ms, "Outputs")
    for r, cols in zip(y_rows, _depends(y, dae.u)):
        deps = sorted(index[names["input"][c]] for c in cols)
        ET.SubElement(outputs, "Unknown", {
            "index": str(index[r.name]), "dependencies": " ".join(map(str, deps)),
            "dependenciesKind": " ".join("dependent" for _ in deps)})
    for v in modes:  # discrete states: change only at events inside a step
        ET.SubElement(outputs, "Unknown", {"index": str(index[v.name]), "dependencies": "",
                                           "dependenciesKind": ""})
    init = ET.SubElement(ms, "InitialUnknowns")
    # states with a computed start (initial="approx") are not known at
    # initialization: their start expressions stand in for them
    y0 = ca.substitute(y, dae.x, dae.init)
    known = ca.vertcat(dae.p, dae.x, dae.u)
    known_names = names["parameter"] + names["state"] + names["input"]
    for r, cols in zip(y_rows, _depends(y0, known)):
        deps = sorted(index[known_names[c]] for c in cols)
        ET.SubElement(init, "Unknown", {
            "index": str(index[r.name]), "dependencies": " ".join(map(str, deps)),
            "dependenciesKind": " ".join("dependent" for _ in deps)})
    for v in modes:  # chosen at initialization from everything known
        ET.SubElement(init, "Unknown", {"index": str(index[v.name])})
