"""What a scene knows of a component: its FMU interface, read from a
``modelDescription.xml`` (variables with causality, unit and value
reference; units as SI base-unit exponents with factor and offset; which
outputs depend directly on which inputs: an output whose description
states no dependencies depends on every input, as FMI 2.0 and 3.0 say),
plus its ports.

A registered model's interface comes from the model description its
declaration generates (no compiler run); an FMU's from the file.  Ports are
not part of FMI 2.0: a registered model's come from its declaration
(``Model.ports``); an FMU given by path has none (connect its variables).
"""
from __future__ import annotations

import math
import os
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from fmpy import read_model_description

from loomfmu.declare.units import UNITS

#: SI base units in FMI's BaseUnit order
BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")


@dataclass(frozen=True)
class UnitInfo:
    """A unit as value_SI = factor * value + offset, with SI exponents."""

    name: str
    exponents: tuple[float, ...]
    factor: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True)
class VarInfo:
    name: str
    causality: str       # FMI: parameter, calculatedParameter, input, output, local, independent
    variability: str    # FMI: constant, fixed, tunable, discrete, continuous
    type: str           # Real, Integer, Boolean, String, Enumeration
    unit: str           # "" when dimensionless or not stated
    vr: int
    initial: str | None
    description: str = ""
    min: float = -math.inf
    max: float = math.inf
    display_unit: str = ""  # the unit people read it in (FMI displayUnit), "" none

    @property
    def range(self) -> tuple[float, float]:
        return self.min, self.max


@dataclass(frozen=True)
class PortInfo:
    name: str
    kind: str
    roles: dict[str, str]   # role -> variable name
    description: str = ""


@dataclass
class Interface:
    """The outside of one FMU: variables, units, direct feedthrough and ports."""

    model_name: str
    guid: str
    variables: dict[str, VarInfo]
    units: dict[str, UnitInfo]
    feedthrough: dict[str, tuple[str, ...]]   # output -> inputs it depends on directly
    ports: dict[str, PortInfo] = field(default_factory=dict)
    can_get_set_state: bool = False
    #: outputs whose model description states no dependencies: taken to
    #: depend directly on every input, as FMI 2.0 and 3.0 say
    assumed: tuple[str, ...] = ()
    #: unit -> {display unit: (factor, offset)}, value_display = factor *
    #: value + offset (the model description's DisplayUnit elements)
    display: dict[str, dict[str, tuple[float, float]]] = field(default_factory=dict)

    def in_unit(self, var: str, value: float, given: str) -> float:
        """``value`` given in unit ``given`` as a value of variable ``var``
        (in its unit); ValueError naming the allowed units."""
        from loomfmu.declare.units import to_unit
        unit = self.variables[var].unit
        return to_unit(value, given, unit, self.display.get(unit))

    def show(self, var: str, value: float, fmt: str = ".6g") -> str:
        """'25.1327 rad/s (240 rpm)': ``value`` of ``var`` in its unit and,
        where it has one, its display unit."""
        from loomfmu.declare.units import show
        v = self.variables[var]
        table = self.display.get(v.unit, {})
        return show(value, v.unit, v.display_unit if v.display_unit in table else "", table,
                    fmt)

    def unit(self, name: str) -> UnitInfo | None:
        """The unit ``name``: from the model description, else loomfmu's table,
        else None (a name only: compared by name)."""
        if not name:
            return UnitInfo("", (0.0,) * len(BASE))
        if name in self.units:
            return self.units[name]
        if name in UNITS:
            return unit_from_table(name)
        return None


def unit_from_table(name: str) -> UnitInfo:
    """A unit of loomfmu.declare.units.UNITS."""
    entry = UNITS[name]
    return UnitInfo(name, tuple(float(entry.get(b, 0)) for b in BASE),
                    float(entry.get("factor", 1.0)), float(entry.get("offset", 0.0)))


def conversion(src: UnitInfo | None, dst: UnitInfo | None, src_name: str,
               dst_name: str) -> tuple[float, float] | None:
    """(gain, bias) with value_dst = gain * value_src + bias, or None when the
    units measure different quantities (or an unknown unit differs by name)."""
    if src_name == dst_name:
        return 1.0, 0.0
    if src is None or dst is None or src.exponents != dst.exponents:
        return None
    gain = src.factor / dst.factor
    bias = (src.offset - dst.offset) / dst.factor
    return gain, bias


class AssumedDependencies(UserWarning):
    """An FMU's output states no dependencies in its model description: it is
    taken to depend directly on every input (FMI 2.0 and 3.0), which may
    close algebraic loops that the master then iterates."""


def outputs_without_dependencies(xml: str | bytes) -> set[str]:
    """The outputs of a model description (its text) whose ModelStructure
    entry has no ``dependencies`` attribute, or that have no entry: by FMI
    2.0 and 3.0 such an output depends on every input (and known).  An
    empty ``dependencies=""`` states that it depends on none."""
    root = ET.fromstring(xml)
    if root.get("fmiVersion", "").startswith("3"):
        mv = root.find("ModelVariables")
        names = {el.get("valueReference"): el.get("name") for el in
                 (list(mv) if mv is not None else []) if el.get("causality") == "output"}
        listed = {el.get("valueReference"): el for el in root.findall("ModelStructure/Output")}
        return {n for vr, n in names.items()
                if vr not in listed or "dependencies" not in listed[vr].attrib}
    svs = root.findall("ModelVariables/ScalarVariable")
    outputs = {k + 1: v.get("name") for k, v in enumerate(svs)
               if v.get("causality") == "output"}
    listed = {int(el.get("index", 0)): el for el in root.findall("ModelStructure/Outputs/Unknown")}
    return {n for k, n in outputs.items()
            if k not in listed or "dependencies" not in listed[k].attrib}


def interface_from_description(md, ports: dict[str, PortInfo] | None = None, *,
                               undeclared=()) -> Interface:
    """An :class:`Interface` from an fmpy ``ModelDescription``; ``undeclared``:
    the outputs whose dependencies the description does not state (they
    depend on every input: :func:`outputs_without_dependencies`)."""
    variables = {}
    for v in md.modelVariables:
        unit = v.unit or (v.declaredType.unit if v.declaredType is not None and
                          getattr(v.declaredType, "unit", None) else "") or ""
        shown = getattr(v, "displayUnit", None) or (
            getattr(v.declaredType, "displayUnit", None) if v.declaredType is not None
            else None) or ""
        variables[v.name] = VarInfo(v.name, v.causality, v.variability, v.type, unit,
                                    int(v.valueReference), v.initial, v.description or "",
                                    _bound(v.min, -math.inf), _bound(v.max, math.inf), shown)
    units, display = {}, {}
    for u in md.unitDefinitions:
        display[u.name] = {d.name: (float(d.factor), float(d.offset))
                           for d in getattr(u, "displayUnits", None) or []}
        b = u.baseUnit
        if b is None:
            continue
        units[u.name] = UnitInfo(u.name, tuple(float(getattr(b, k, 0)) for k in BASE),
                                 float(b.factor), float(b.offset))
    feed = {o.variable.name: tuple(d.name for d in (o.dependencies or ())
                                   if d.causality == "input")
            for o in md.outputs}
    inputs = tuple(n for n, v in variables.items() if v.causality == "input")
    assumed = tuple(sorted(n for n in undeclared if n in variables))
    for name in assumed:
        feed[name] = inputs
    cs = md.coSimulation
    if cs is None:
        raise ValueError(f"model {md.modelName!r} has no CoSimulation interface; "
                         "allowed: an FMI 2.0 co-simulation FMU")
    return Interface(md.modelName, md.guid, variables, units, feed, dict(ports or {}),
                     bool(cs.canGetAndSetFMUstate), assumed,
                     {k: v for k, v in display.items() if v})


def _bound(text, default: float) -> float:
    try:
        return float(text) if text is not None else default
    except (TypeError, ValueError):
        return default


def interface_of_fmu(path: str | os.PathLike) -> Interface:
    """The interface of the FMU at ``path`` (no ports)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"fmu = {str(path)!r}: no such file; allowed: a path to an .fmu")
    try:
        md = read_model_description(str(path))
        with zipfile.ZipFile(path) as z:
            undeclared = outputs_without_dependencies(z.read("modelDescription.xml"))
    except Exception as exc:  # not a zip, no modelDescription.xml, invalid XML
        raise ValueError(f"fmu = {str(path)!r}: not a readable FMU ({exc})") from None
    return interface_from_description(md, undeclared=undeclared)


def interface_of_model(model) -> Interface:
    """The interface of a declared model (loomfmu.declare.model.Model): its model
    description, generated without compiling, and its declared ports."""
    from loomfmu.export.dae import dae_form
    from loomfmu.export.fmi_xml import model_description
    xml = model_description(model, dae_form(model), "{00000000-0000-0000-0000-000000000000}",
                            ["model.c"])
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "modelDescription.xml"
        f.write_text(xml)
        md = read_model_description(str(f))
    ports = {p.name: PortInfo(p.name, p.kind, dict(p.variables), p.description)
             for p in model.ports}
    return interface_from_description(md, ports, undeclared=outputs_without_dependencies(xml))


def is_finite_number(value) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))
