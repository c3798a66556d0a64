"""SSP 1.0 export: a ``.ssp`` file (a zip of ``SystemStructure.ssd`` and
``resources/<component>.fmu``) that SSP engines run, e.g. libcosim.

The SSD holds one system with a ``ssd:Component`` per component (source
``resources/<component>.fmu``, ``ssd:Connectors`` for the inputs, outputs and
parameters that are connected, set or recorded), the parameter and start values as an inline
``ssv:ParameterSet`` per component, the connections (with an
``ssc:LinearTransformation`` where units are converted), the units used
(``ssd:Units``) and the default experiment.  It is validated against the
SSP 1.0 schemas that ship with FMPy before it is written.

A scene's ``solver`` setting (an Enumeration) is written as the
``solver_index`` Integer parameter every loomfmu FMU has (the same number):
libcosim cannot set Enumerations.  A state's start value is in the parameter
set too; :func:`loomfmu.scene.libcosim.run_ssp` passes it on as an initial
value, which libcosim needs for a variable that is not a parameter or input.
"""
from __future__ import annotations

import shutil
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

from loomfmu.export.fmi_xml import SOLVER_INDEX
from loomfmu.scene.declare import Scene
from loomfmu.scene.fmus import build_fmus

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
for _p, _u in (("ssd", SSD), ("ssc", SSC), ("ssv", SSV)):
    ET.register_namespace(_p, _u)


def _q(ns: str, tag: str) -> str:
    return f"{{{ns}}}{tag}"


def _num(v: float) -> str:
    return repr(float(v))


def _values(comp) -> dict[str, float]:
    """The component's parameter and start values as the SSD writes them
    (the ``solver`` Enumeration as the ``solver_index`` Integer where the FMU
    has it)."""
    values = {**comp.parameters, **comp.start}
    if "solver" in values and SOLVER_INDEX in comp.interface.variables:
        values[SOLVER_INDEX] = values.pop("solver")
    return values


def ssd_text(scene: Scene, *, step: float | None = None) -> str:
    """The ``SystemStructure.ssd`` of ``scene`` (validated against the schema)."""
    root = ET.Element(_q(SSD, "SystemStructureDescription"),
                      {"name": scene.name, "version": "1.0"})
    if scene.description:
        root.set("description", scene.description)
    system = ET.SubElement(root, _q(SSD, "System"), {"name": scene.name})
    elements = ET.SubElement(system, _q(SSD, "Elements"))
    used_units: dict[str, object] = {}
    for comp in scene.components.values():
        iface = comp.interface
        names = ([c.src_var for c in scene.connections if c.src == comp.name]
                 + [c.dst_var for c in scene.connections if c.dst == comp.name]
                 + list(_values(comp))
                 + [v for c, v in scene.recorded_variables() if c == comp.name])
        names = list(dict.fromkeys(names))
        el = ET.SubElement(elements, _q(SSD, "Component"), {
            "name": comp.name, "type": "application/x-fmu-sharedlibrary",
            "source": f"resources/{comp.name}.fmu"})
        conns = ET.SubElement(el, _q(SSD, "Connectors"))
        for n in names:
            v = iface.variables[n]
            kind = v.causality
            if kind not in ("input", "output", "parameter", "calculatedParameter"):
                continue   # a state's start value: set by name in the parameter set
            c = ET.SubElement(conns, _q(SSD, "Connector"), {"name": n, "kind": kind})
            typ = {"Enumeration": "Integer"}.get(v.type, v.type)
            attrs = {}
            if typ == "Real" and v.unit:
                attrs["unit"] = v.unit
                used_units[v.unit] = iface.unit(v.unit)
            ET.SubElement(c, _q(SSC, typ), attrs)
        values = _values(comp)
        if values:
            pb = ET.SubElement(ET.SubElement(el, _q(SSD, "ParameterBindings")),
                               _q(SSD, "ParameterBinding"))
            ps = ET.SubElement(ET.SubElement(pb, _q(SSD, "ParameterValues")),
                               _q(SSV, "ParameterSet"), {"version": "1.0",
                                                         "name": f"{comp.name}_values"})
            params = ET.SubElement(ps, _q(SSV, "Parameters"))
            for n, value in values.items():
                p = ET.SubElement(params, _q(SSV, "Parameter"), {"name": n})
                if iface.variables[n].type in ("Integer", "Enumeration"):
                    ET.SubElement(p, _q(SSV, "Integer"), {"value": str(int(value))})
                else:
                    ET.SubElement(p, _q(SSV, "Real"), {"value": _num(value)})
    if scene.connections:
        cs = ET.SubElement(system, _q(SSD, "Connections"))
        for c in scene.connections:
            e = ET.SubElement(cs, _q(SSD, "Connection"), {
                "startElement": c.src, "startConnector": c.src_var,
                "endElement": c.dst, "endConnector": c.dst_var})
            if (c.gain, c.bias) != (1.0, 0.0):
                ET.SubElement(e, _q(SSC, "LinearTransformation"),
                              {"factor": _num(c.gain), "offset": _num(c.bias)})
    units = {n: u for n, u in used_units.items() if u is not None}
    if units:
        ue = ET.SubElement(root, _q(SSD, "Units"))
        for name, u in sorted(units.items()):
            unit = ET.SubElement(ue, _q(SSC, "Unit"), {"name": name})
            base = {k: str(int(e)) for k, e in zip(("kg", "m", "s", "A", "K", "mol", "cd",
                                                    "rad"), u.exponents) if e}
            if u.factor != 1.0:
                base["factor"] = _num(u.factor)
            if u.offset != 0.0:
                base["offset"] = _num(u.offset)
            ET.SubElement(unit, _q(SSC, "BaseUnit"), base)
    ET.SubElement(root, _q(SSD, "DefaultExperiment"),
                  {"startTime": "0.0", "stopTime": _num(scene.stop_time)})
    ET.indent(root, "  ")
    text = '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode")
    problems = validate_ssd(text)
    if problems:
        raise ValueError(f"scene {scene.name!r}: the SSD does not validate: "
                         + "; ".join(problems))
    return text + "\n"


def validate_ssd(source) -> list[str]:
    """Every problem of an SSD, one message each (empty: none).

    ``source`` is the SSD's text (it starts with ``<``) or the path of an
    ``.ssp`` file.  The SSD is checked against the SSP 1.0 schema (shipped
    with FMPy), and every parameter value must be a finite number; an
    ``.ssp`` must also be a zip archive holding ``SystemStructure.ssd`` and,
    for each component, its ``source`` as an FMU (a zip archive with a
    ``modelDescription.xml``)."""
    if isinstance(source, str) and source.lstrip().startswith("<"):
        return _ssd_problems(source.encode())[0]
    return _ssp_problems(Path(source))


def _ssd_problems(data: bytes, where: str = ""):
    """(problems, parsed document or None) of an SSD's bytes."""
    import math

    import fmpy.ssp
    from lxml import etree
    try:
        doc = etree.fromstring(data)
    except etree.XMLSyntaxError as exc:
        return [f"{where}not well-formed XML: {exc}"], None
    schema = etree.XMLSchema(file=str(Path(fmpy.ssp.__file__).parent / "schema" /
                                      "SystemStructureDescription.xsd"))
    problems = [] if schema.validate(doc) else \
        [f"{where}line {e.line}: {e.message}" for e in schema.error_log]
    for el in doc.iter(_q(SSV, "Real"), _q(SSV, "Integer")):
        value = el.get("value")
        try:
            finite = math.isfinite(float(value))
        except (TypeError, ValueError):
            finite = False
        if not finite:
            par = el.getparent()
            comp = next((a.get("name") for a in el.iterancestors(_q(SSD, "Component"))), "?")
            problems.append(f"{where}line {el.sourceline}: {comp}."
                            f"{par.get('name') if par is not None else '?'} = {value!r}; "
                            "allowed: a finite number")
    return problems, doc


def _ssp_problems(path: Path) -> list[str]:
    import io
    if not path.is_file():
        return [f"{path}: no such file"]
    if not zipfile.is_zipfile(path):
        return [f"{path}: not a zip archive (an .ssp is one)"]
    try:
        with zipfile.ZipFile(path) as z:
            names = set(z.namelist())
            if "SystemStructure.ssd" not in names:
                return [f"{path}: no SystemStructure.ssd in the archive"]
            problems, doc = _ssd_problems(z.read("SystemStructure.ssd"), "SystemStructure.ssd ")
            if doc is None:
                return problems
            for comp in doc.iter(_q(SSD, "Component")):
                name, source = comp.get("name"), comp.get("source")
                if source not in names:
                    problems.append(f"component {name}: its source {source!r} is not in the "
                                    f"archive (it holds: {', '.join(sorted(names))})")
                    continue
                try:
                    with zipfile.ZipFile(io.BytesIO(z.read(source))) as fmu:
                        if "modelDescription.xml" not in fmu.namelist():
                            problems.append(f"component {name}: {source} has no "
                                            "modelDescription.xml (not an FMU)")
                        elif fmu.testzip() is not None:
                            problems.append(f"component {name}: {source} is damaged "
                                            f"({fmu.testzip()} does not check)")
                except zipfile.BadZipFile as exc:
                    problems.append(f"component {name}: {source} is not an FMU, or is cut "
                                    f"short ({exc})")
    except (zipfile.BadZipFile, OSError, EOFError) as exc:
        return [f"{path}: a damaged zip archive ({exc})"]
    return problems


def export_ssp(scene: Scene, out, *, fmu_dir=None, fmus: dict | None = None) -> Path:
    """Write ``scene`` as an SSP file ``out`` (FMUs built into ``fmu_dir``,
    default a temporary folder, unless given as ``fmus``)."""
    out = Path(out)
    if out.suffix != ".ssp":
        raise ValueError(f"out = {str(out)!r}; allowed: a file name ending in .ssp")
    text = ssd_text(scene)
    with tempfile.TemporaryDirectory() as tmp:
        if fmus is None:
            fmus = build_fmus(scene, fmu_dir if fmu_dir is not None else tmp)
        out.parent.mkdir(parents=True, exist_ok=True)
        part = out.with_suffix(".ssp.tmp")
        with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("SystemStructure.ssd", text)
            for name in scene.components:
                z.write(fmus[name], f"resources/{name}.fmu")
        shutil.move(part, out)
    return out
