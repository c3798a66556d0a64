"""``modelDescription.xml`` for FMI 2.0 and 3.0, co-simulation and model
exchange, from one variable table.

:func:`variable_table` lists every variable the FMU exposes once: name, type,
causality, variability, initial, description, unit, range, start and both
versions' value references, all from :func:`loomfmu.export.codegen.real_table` (the
table the C declaration is written from), the settings, the enumerations and
the modes.  :func:`model_structure` gives the dependencies by variable name,
from the sparsity of the exact CasADi Jacobians (:mod:`loomfmu.export.fmi_structure`).
The two writers below only spell these in each version's elements.

Value references::

    FMI 2.0  Real: codegen's Real vr; der(x_k) (model exchange) = LF_NREAL + k
             Integer/Enumeration: the runtime's Integer vr (lf_model.h)
    FMI 3.0  unique across all types: Float64 = the Real vr, der(x_k) = LF_NREAL + k
             (reserved in co-simulation too), Int32/Enumeration = LF_NREAL + LF_NX +
             Integer vr, time = LF_NREAL + LF_NX + LF_N_INTEGER, event indicator j
             (model exchange) = that + 1 + j

Dependencies: an output lists the inputs it depends on directly (Outputs; in
model exchange the states too); a state derivative the states and inputs
(Derivatives / ContinuousStateDerivative);
an initial unknown the parameters, states with an exact start and inputs.
"""
from __future__ import annotations

import importlib.metadata
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

from loomfmu.declare.model import Model
from loomfmu.declare.solvers import SOLVER_DESCRIPTIONS, SOLVER_INDEX, SOLVERS
from loomfmu.declare.units import UNITS, display_factor
from loomfmu.export.codegen import real_table
from loomfmu.export.dae import DaeForm
from loomfmu.export.fmi_structure import Structure, model_structure
from loomfmu.export.runtime_files import LOG_CATEGORIES

__all__ = ["FMI_VERSIONS", "INTERFACES", "SOLVER_INDEX", "ModelVar", "check_variant",
           "model_description", "terminals_and_icons", "tool_info", "variable_table"]

FMI_VERSIONS = (2, 3)
#: "cs": co-simulation (our embedded solvers), "me": model exchange (the
#: importer integrates), "both": one FMU with both interfaces
INTERFACES = ("cs", "me", "both")
#: Integer parameter every FMU has: the solver as a plain Integer
#: Name prefix of the FMI 3.0 event-indicator variables (model exchange)
INDICATOR_PREFIX = "event_indicator."

#: What the C facades implement, written into the interface elements.  The
#: owners of the facades flip a flag when their C provides it.
FMI2_CS = {"needsExecutionTool": "false", "canHandleVariableCommunicationStepSize": "true",
           "canInterpolateInputs": "true", "maxOutputDerivativeOrder": "1",
           "canRunAsynchronuously": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
           "canNotUseMemoryManagementFunctions": "false", "canGetAndSetFMUstate": "true",
           "canSerializeFMUstate": "true", "providesDirectionalDerivative": "true"}
FMI2_ME = {"needsExecutionTool": "false", "completedIntegratorStepNotNeeded": "false",
           "canBeInstantiatedOnlyOncePerProcess": "false",
           "canNotUseMemoryManagementFunctions": "false", "canGetAndSetFMUstate": "true",
           "canSerializeFMUstate": "true", "providesDirectionalDerivative": "true"}
FMI3_COMMON = {"needsExecutionTool": "false", "canBeInstantiatedOnlyOncePerProcess": "false",
               "canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
               "providesDirectionalDerivatives": "true", "providesAdjointDerivatives": "false"}
FMI3_CS = {**FMI3_COMMON, "canHandleVariableCommunicationStepSize": "true",
           "maxOutputDerivativeOrder": "1", "providesIntermediateUpdate": "false",
           "mightReturnEarlyFromDoStep": "true",
           "canReturnEarlyAfterIntermediateUpdate": "false", "hasEventMode": "true"}
FMI3_ME = {**FMI3_COMMON, "needsCompletedIntegratorStep": "true"}


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


def check_variant(fmi_version, interface) -> None:
    """ValueError naming the argument unless (fmi_version, interface) is one
    of FMI_VERSIONS x INTERFACES."""
    if type(fmi_version) is not int or fmi_version not in FMI_VERSIONS:
        raise ValueError(f"fmi_version = {fmi_version!r}; allowed: 2 or 3")
    if not isinstance(interface, str) or interface not in INTERFACES:
        raise ValueError(f"interface = {interface!r:.40}; allowed: 'cs', 'me' or 'both'")


@dataclass(frozen=True)
class ModelVar:
    """One exposed variable, for both versions.  type: "Real", "Integer" or
    "Enumeration" (FMI 3.0: Float64, Int32, Enumeration); vr2: the FMI 2.0
    value reference (None: FMI 3.0 only); attrs: the type element's attributes
    (unit, min, max, nominal, start, declaredType) as text; derivative_of: the
    state a der(x) variable is the derivative of."""

    name: str
    type: str
    vr2: int | None
    vr3: int
    causality: str
    variability: str
    initial: str | None
    description: str
    attrs: dict = field(default_factory=dict)
    derivative_of: str | None = None


def _num(v: float) -> str:
    return repr(float(v))


def _real_vars(model: Model) -> list[ModelVar]:
    computed = set(model.initials)
    out = []
    for row in real_table(model):
        causality = {"setting": "parameter", "parameter": "parameter", "input": "input",
                     "output": "output"}.get(row.kind, "local")
        variability = {"setting": "fixed", "parameter": "fixed"}.get(row.kind, "continuous")
        description, initial = row.description, None
        if row.kind == "state":
            initial = "approx" if row.name in computed else "exact"
            if row.name in computed:
                description += (" (start computed at initialization from the parameters, "
                                "unless set)")
        elif row.kind in ("output", "algebraic"):
            initial = "calculated"
        attrs = {}
        if row.unit:
            attrs["unit"] = row.unit
        if row.var is not None and row.var.display_unit:
            attrs["displayUnit"] = row.var.display_unit
        if math.isfinite(row.min):
            attrs["min"] = _num(row.min)
        if math.isfinite(row.max):
            attrs["max"] = _num(row.max)
        if row.var is not None and row.var.nominal is not None:
            attrs["nominal"] = _num(row.var.nominal)
        if row.start is not None and row.kind not in ("output", "algebraic"):
            attrs["start"] = _num(row.start)
        out.append(ModelVar(row.name, "Real", row.vr, row.vr, causality, variability, initial,
                            description, attrs))
    return out


def _integer_vars(model: Model, int0: int) -> list[ModelVar]:
    """solver, the modes, delay_interpolation, solver_index: the runtime's
    Integer value references 0, 1, ... (lf_model.h)."""
    solvers = "; ".join(f"{i} = {s}" for i, s in enumerate(SOLVERS, 1))
    out = [ModelVar("solver", "Enumeration", 0, int0, "parameter", "fixed", None,
                    "embedded solver: " + solvers, {"declaredType": "Solver", "start": "1"})]
    for v in model.of_kind("mode"):
        k = len(out)
        out.append(ModelVar(v.name, "Integer", k, int0 + k, "output", "discrete", "calculated",
                            v.description, {"min": str(int(v.min)), "max": str(int(v.max))}))
    if model.delays:
        k = len(out)
        out.append(ModelVar("delay_interpolation", "Enumeration", k, int0 + k, "parameter",
                            "fixed", None, "how the history of delayed values is interpolated: "
                            "1 = hermite, 2 = linear",
                            {"declaredType": "DelayInterpolation", "start": "1"}))
    # the solver again as a plain Integer: importers that cannot set an
    # Enumeration (libcosim) can choose the solver through it
    k = len(out)
    out.append(ModelVar(SOLVER_INDEX, "Integer", k, int0 + k, "parameter", "fixed", None,
                        "the embedded solver as an Integer, for importers that cannot set an "
                        "Enumeration: 0 = as `solver` says; otherwise it wins over `solver`: "
                        + solvers, {"start": "0", "min": "0", "max": str(len(SOLVERS))}))
    return out


def variable_table(model: Model, dae: DaeForm, *, fmi_version: int = 2,
                   interface: str = "cs") -> list[ModelVar]:
    """Every variable of the model description, in ModelVariables order."""
    check_variant(fmi_version, interface)
    reals = _real_vars(model)
    if any(v.name == SOLVER_INDEX for v in reals):
        raise ValueError(f"model {model.name}: variable name {SOLVER_INDEX!r} is reserved "
                         "(every FMU has it)")
    n_real, states = len(reals), model.of_kind("state")
    ints = _integer_vars(model, n_real + len(states))
    me = interface in ("me", "both")
    ders = [ModelVar(f"der({v.name})", "Real", n_real + k, n_real + k, "local", "continuous",
                     "calculated", f"time derivative of {v.name}", derivative_of=v.name)
            for k, v in enumerate(states)] if me else []
    if fmi_version == 2:
        return reals + ints + ders
    t_vr = n_real + len(states) + len(ints)
    time = ModelVar("time", "Real", None, t_vr, "independent", "continuous", None,
                    "simulation time", {"unit": "s"})
    taken = {v.name for v in model.variables}
    indicators = []
    for j in range(dae.e.numel() if me else 0):
        label = model.events[j].name if j < len(model.events) else str(j + 1)
        name = INDICATOR_PREFIX + label
        if name in taken:
            raise ValueError(f"model {model.name}: variable name {name!r} is reserved "
                             "(FMI 3.0 event indicators)")
        desc = model.events[j].description if j < len(model.events) else ""
        indicators.append(ModelVar(name, "Real", None, t_vr + 1 + j, "local", "continuous",
                                   None, f"event indicator {label}: an event where it changes "
                                   f"sign. {desc}".strip()))
    return [time] + reals + ints + ders + indicators


# ------------------------------------------------------------------ shared elements
def _units(root: ET.Element, table: list[ModelVar]) -> None:
    """UnitDefinitions: each unit a variable uses, and under it the display
    units its variables name, ``<DisplayUnit name factor>`` with
    value_display = factor * value_unit (offset 0; see
    loomfmu.declare.units.display_factor for the standards' definition)."""
    ud = ET.SubElement(root, "UnitDefinitions")
    for u in sorted({v.attrs["unit"] for v in table if "unit" in v.attrs}):
        unit = ET.SubElement(ud, "Unit", {"name": u})
        ET.SubElement(unit, "BaseUnit", {k: str(v) for k, v in UNITS[u].items()})
        for d in sorted({v.attrs["displayUnit"] for v in table
                         if v.attrs.get("unit") == u and "displayUnit" in v.attrs}):
            ET.SubElement(unit, "DisplayUnit", {"name": d,
                                                "factor": _num(display_factor(u, d))})


def _enumerations(model: Model) -> dict[str, list[tuple[str, str]]]:
    """Enumeration types: name -> [(item name, description)], values 1, 2, ..."""
    enums = {"Solver": [(s, SOLVER_DESCRIPTIONS[s]) for s in SOLVERS]}
    if model.delays:
        enums["DelayInterpolation"] = [
            ("hermite", "cubic Hermite on the solver's accepted points (values and exact "
                        "time derivatives)"),
            ("linear", "linear between accepted points (for comparison)")]
    return enums


def _tail(root: ET.Element, model: Model) -> None:
    lc = ET.SubElement(root, "LogCategories")
    for name, desc in LOG_CATEGORIES:
        ET.SubElement(lc, "Category", {"name": name, "description": desc})
    ET.SubElement(root, "DefaultExperiment", {
        "startTime": "0.0", "stopTime": _num(model.stop_time), "tolerance": "1e-06",
        "stepSize": _num(model.step_size)})


def _deps(el_attrs: dict, deps: list[str] | None, ref: dict[str, int]) -> dict:
    if deps is None:  # depends on everything
        return el_attrs
    refs = sorted(ref[n] for n in deps)
    return {**el_attrs, "dependencies": " ".join(map(str, refs)),
            "dependenciesKind": " ".join("dependent" for _ in refs)}


def model_description(model: Model, dae: DaeForm, guid: str, sources: list[str], *,
                      fmi_version: int = 2, interface: str = "cs") -> str:
    """The model description of ``model`` for ``fmi_version`` (2 or 3) and
    ``interface`` ("cs", "me" or "both").  guid: the GUID (FMI 2.0) or
    instantiationToken (FMI 3.0); sources: the C files (FMI 2.0 lists them
    in SourceFiles; FMI 3.0 in sources/buildDescription.xml)."""
    table = variable_table(model, dae, fmi_version=fmi_version, interface=interface)
    structure = model_structure(model, dae, interface=interface,
                                indicators=[v.name for v in table
                                            if v.name.startswith(INDICATOR_PREFIX)])
    writer = _fmi2 if fmi_version == 2 else _fmi3
    root = writer(model, dae, guid, sources, interface, table, structure)
    ET.indent(root, "  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


# ------------------------------------------------------------------ FMI 2.0
def _fmi2(model, dae, guid, sources, interface, table, structure: Structure) -> ET.Element:
    me, cs = interface in ("me", "both"), interface in ("cs", "both")
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": model.name, "guid": guid,
        "description": model.description, **tool_info(),
        "variableNamingConvention": "structured",
        "numberOfEventIndicators": str(dae.e.numel() if me else 0)})
    for on, tag, attrs in ((me, "ModelExchange", FMI2_ME), (cs, "CoSimulation", FMI2_CS)):
        if on:
            el = ET.SubElement(root, tag, {"modelIdentifier": model.name, **attrs})
            files = ET.SubElement(el, "SourceFiles")
            for f in sources:
                if f.endswith(".c"):
                    ET.SubElement(files, "File", {"name": f})
    _units(root, table)
    td = ET.SubElement(root, "TypeDefinitions")
    for name, items in _enumerations(model).items():
        en = ET.SubElement(ET.SubElement(td, "SimpleType", {"name": name}), "Enumeration")
        for i, (item, desc) in enumerate(items, 1):
            ET.SubElement(en, "Item", {"name": item, "value": str(i), "description": desc})
    _tail(root, model)
    index = {v.name: i for i, v in enumerate(table, 1)}
    mv = ET.SubElement(root, "ModelVariables")
    for v in table:
        attrs = {"name": v.name, "valueReference": str(v.vr2), "causality": v.causality,
                 "variability": v.variability}
        if v.initial and v.type == "Integer":  # (attribute order as in earlier releases)
            attrs["initial"] = v.initial
        attrs["description"] = v.description
        if v.initial:
            attrs["initial"] = v.initial
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        typed = dict(v.attrs)
        if v.derivative_of:
            typed["derivative"] = str(index[v.derivative_of])
        ET.SubElement(sv, v.type, typed)
    ms = ET.SubElement(root, "ModelStructure")
    for tag, unknowns in (("Outputs", structure.outputs), ("Derivatives", structure.derivatives),
                          ("InitialUnknowns", structure.initial)):
        if tag == "Derivatives" and not me:
            continue
        el = ET.SubElement(ms, tag)
        for name, deps in sorted(unknowns.items(), key=lambda kv: index[kv[0]]):
            ET.SubElement(el, "Unknown", _deps({"index": str(index[name])}, deps, index))
    return root


# ------------------------------------------------------------------ FMI 3.0
_FMI3_TYPE = {"Real": "Float64", "Integer": "Int32", "Enumeration": "Enumeration"}


#: FMI 2.0 names whose FMI 3.0 counterpart is not fmi3 + the same name.
_FMI3_NAMES = {
    "fmi2GetRealStatus(fmi2LastSuccessfulTime)":
        "the lastSuccessfulTime argument of fmi3DoStep",
    "fmi2SetupExperiment": "fmi3EnterInitializationMode",
    "fmi2GetReal": "fmi3GetFloat64", "fmi2SetReal": "fmi3SetFloat64",
    "fmi2GetDerivatives": "fmi3GetContinuousStateDerivatives",
    "fmi2GetContinuousStates": "fmi3GetContinuousStates",
    "fmi2SetContinuousStates": "fmi3SetContinuousStates",
    "fmi2NewDiscreteStates": "fmi3UpdateDiscreteStates",
    "fmi2Component": "fmi3Instance",
}


def fmi3_text(text: str) -> str:
    """``text`` written with FMI 2.0 names (fmi2DoStep, fmi2Discard, ...) with
    the FMI 3.0 names: for the FMI 3 model description and documentation page."""
    for old, new in _FMI3_NAMES.items():
        text = text.replace(old, new)
    return re.sub(r"\bfmi2(?=[A-Z])", "fmi3", text)


def _fmi3(model, dae, guid, sources, interface, table, structure: Structure) -> ET.Element:
    me, cs = interface in ("me", "both"), interface in ("cs", "both")
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": model.name, "instantiationToken": guid,
        "description": model.description, **tool_info(),
        "variableNamingConvention": "structured"})
    if me:
        ET.SubElement(root, "ModelExchange", {"modelIdentifier": model.name, **FMI3_ME})
    if cs:
        ET.SubElement(root, "CoSimulation", {"modelIdentifier": model.name, **FMI3_CS})
    _units(root, table)
    td = ET.SubElement(root, "TypeDefinitions")
    for name, items in _enumerations(model).items():
        en = ET.SubElement(td, "EnumerationType", {"name": name})
        for i, (item, desc) in enumerate(items, 1):
            ET.SubElement(en, "Item", {"name": item, "value": str(i), "description": desc})
    _tail(root, model)
    vr = {v.name: v.vr3 for v in table}
    mv = ET.SubElement(root, "ModelVariables")
    for v in table:
        attrs = {"name": v.name, "valueReference": str(v.vr3),
                 "description": fmi3_text(v.description),
                 "causality": v.causality, "variability": v.variability}
        if v.initial:
            attrs["initial"] = v.initial
        if v.derivative_of:
            attrs["derivative"] = str(vr[v.derivative_of])
        ET.SubElement(mv, _FMI3_TYPE[v.type], {**attrs, **v.attrs})
    ms = ET.SubElement(root, "ModelStructure")
    for tag, unknowns in (("Output", structure.outputs),
                          ("ContinuousStateDerivative", structure.derivatives),
                          ("InitialUnknown", structure.initial),
                          ("EventIndicator", structure.indicators)):
        if tag in ("ContinuousStateDerivative", "EventIndicator") and not me:
            continue
        for name, deps in sorted(unknowns.items(), key=lambda kv: vr[kv[0]]):
            ET.SubElement(ms, tag, _deps({"valueReference": str(vr[name])}, deps, vr))
    return root


def terminals_and_icons(model: Model) -> str | None:
    """FMI 3.0 ``terminalsAndIcons/terminalsAndIcons.xml``: one Terminal per
    declared port (kind ``loomfmu.<port kind>``, matched by member name, the
    roles as members: a port may carry a subset of its kind's roles, so the
    matching rule is "bus"); None for a model without ports."""
    if not model.ports:
        return None
    root = ET.Element("fmiTerminalsAndIcons", {"fmiVersion": "3.0"})
    terms = ET.SubElement(root, "Terminals")
    for p in model.ports:
        t = ET.SubElement(terms, "Terminal", {
            "name": p.name, "matchingRule": "bus", "terminalKind": f"loomfmu.{p.kind}",
            "description": p.description or f"{p.kind} port"})
        for role, var in p.variables.items():
            ET.SubElement(t, "TerminalMemberVariable", {
                "variableName": var, "memberName": role, "variableKind": "signal"})
    ET.indent(root, "  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
