"""Reference results inside the FMU, as the layered standard FMI-LS-REF lays them out.

FMI-LS-REF ("FMI Layered Standard References", github.com/modelica/fmi-ls-ref,
release v1.0.0-beta.1, whose manifest table prescribes the version attribute
``1.0.0-alpha.1``) lets an FMU carry related files with a role each, listed in
``extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml`` (root element
``fmiReferences`` with the attributes ``fmi-ls-name``, ``fmi-ls-version`` and
``fmi-ls-description`` in the namespace ``http://fmi-standard.org/fmi-ls-manifest``,
one ``Related`` element per file: ``type`` (MIME), ``source`` (URI relative to
the manifest), ``role``, ``description``). Every FMU the builder makes carries:

* ``<model>_ref.csv`` (role ``result``, ``text/csv``): the outputs of the
  model's default experiment (start 0, the DefaultExperiment's stop time, one
  row per communication step) computed by the scipy reference
  (:func:`loomfmu.verification.reference.reference`) at rtol
  :data:`REF_RTOL`, atol :data:`REF_ATOL`, ``time`` first, one column per
  output, every number to 17 significant digits;
* ``default_experiment.exp`` (role ``experiment/smoke-test``,
  ``application/x-ma-hs-experiments``, the MA-HS-Experiments format the
  standard names for experiments): the default experiment (start, stop,
  step, the solver tolerance of the DefaultExperiment) with the CSV as its
  ``References``;
* ``documentation/fmi-ls-ref.txt`` (role ``report``), the file the standard
  recommends for what the reference files are, their intent and the
  deviation to expect: how the reference was computed and the tolerance the
  FMU is checked to.

The tolerance (:data:`CHECK_TOLERANCE`, per interface) is also in the
manifest, machine-readable, as an ``Annotation`` of the result's ``Related``
element (type :data:`ANNOTATION_TYPE`): per output, the largest
|y_FMU - y_ref| over the CSV's times divided by the output's range in the
CSV (its magnitude where the range is zero, 1 where both are zero), for the
default experiment run as its DefaultExperiment says (FMPy with the
interface, and the DefaultExperiment's stepSize as output interval), at most
that number.

The reference run costs seconds to a minute per model (backrest_regularized,
integrated by Radau, and the full spindle are the heavy ones); it is the
one the build's verification uses (same times, same tolerances), kept in
the reference cache (:mod:`loomfmu.verification.reference_cache`, off with
``LOOMFMU_BUILD_CACHE=off``), so that a build and its verification and the
four FMI variants of one model compute it once.

:func:`check_fmu` does what a user of the FMU can do with FMPy alone: run
the default experiment and compare it with the CSV inside.
"""
from __future__ import annotations

import csv
import io
import math
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from loomfmu.declare.model import Model
from loomfmu.export.caches import reference_cache_dir  # noqa: F401  (where the references live)
from loomfmu.verification import reference_cache
from loomfmu.verification.times import experiment_times

#: The layered standard's name, its folder under extra/ and its fixed description.
LS_NAME = "org.fmi-standard.fmi-ls-ref"
LS_DIR = f"extra/{LS_NAME}"
LS_MANIFEST = f"{LS_DIR}/fmi-ls-manifest.xml"
LS_DESCRIPTION = "Layered Standard providing information on related files included in an FMU."
#: The value the standard's manifest table prescribes for fmi-ls-version
#: (unchanged in its release v1.0.0-beta.1).
LS_VERSION = "1.0.0-alpha.1"
#: The manifest's attribute namespace (FMI 3.0's layered-standard manifest).
LS_NS = "http://fmi-standard.org/fmi-ls-manifest"
#: The standard's recommended documentation file, relative to the FMU's root.
LS_DOC = "documentation/fmi-ls-ref.txt"
#: The experiment file and its MIME type (MA-HS-Experiments).
EXPERIMENT_FILE = "default_experiment.exp"
EXPERIMENT_TYPE = "application/x-ma-hs-experiments"
#: Roles defined by the standard that this FMU's files take.
ROLES = {"result": "result", "experiment": "experiment/smoke-test", "report": "report"}
#: Type of the manifest's annotation carrying the check's tolerance.
ANNOTATION_TYPE = "org.loomfmu.reference-check"
#: The scipy reference's tolerances for the CSV: those of the build's
#: verification (:func:`loomfmu.verification.verify.verify`), so that one
#: reference run serves both.
REF_RTOL = 1e-11
REF_ATOL = 1e-13
#: Largest deviation of any output relative to its range that the check
#: accepts, by interface: co-simulation (the embedded solver at the
#: DefaultExperiment's tolerance) and model exchange (the importer's solver).
CHECK_TOLERANCE = {"cs": 1e-3, "me": 1e-2}


def csv_name(model_name: str) -> str:
    """The result CSV's file name inside :data:`LS_DIR`."""
    return f"{model_name}_ref.csv"


# ------------------------------------------------------------------ the build
@dataclass
class ReferenceResult:
    """The default experiment's outputs by the scipy reference."""

    csv: str
    names: list[str]
    wall_seconds: float        # of the reference run (when it was computed)
    cached: bool               # taken from the cache by this build
    method: str
    rtol: float = REF_RTOL
    atol: float = REF_ATOL
    rhs_calls: int = 0
    key: str = ""
    meta: dict = field(default_factory=dict)


def reference_key(model: Model) -> str:
    """SHA-256 (hex) of the declaration the reference CSV is made of (its DAE
    form, variables, validity conditions, modes and default experiment): the
    same for every FMI variant of one declaration."""
    return reference_cache.model_key(model)


def reference_result(model: Model, *, use_cache: bool = True) -> ReferenceResult:
    """The CSV of ``model``'s default experiment by the scipy reference, from
    the reference cache when the same reference was computed before (the
    build's verification asks for the same one: same times, same tolerances)."""
    from loomfmu.verification.reference import reference
    ref = reference(model, t_eval=experiment_times(0.0, model.stop_time, model.step_size),
                    rtol=REF_RTOL, atol=REF_ATOL, method=model.reference_method,
                    cache=use_cache)
    if ref.violation is not None:
        raise RuntimeError(f"reference of {model.name}: the default experiment stops at "
                           f"t = {ref.violation[2]:g} s ({ref.violation[0]}: "
                           f"{ref.violation[1]}); no reference result can be written")
    names = [v.name for v in model.of_kind("output")]
    text = result_csv(ref.t, {n: ref.y[n] for n in names})
    return ReferenceResult(text, names, ref.wall_seconds, ref.cached, model.reference_method,
                           REF_RTOL, REF_ATOL, ref.n_rhs, reference_key(model))


def result_csv(t, columns: dict[str, np.ndarray]) -> str:
    """``time`` and the columns as CSV, numbers to 17 significant digits."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["time", *columns])
    cols = [np.asarray(c, dtype=float) for c in columns.values()]
    for i, ti in enumerate(np.asarray(t, dtype=float)):
        w.writerow([f"{ti:.17g}", *(f"{c[i]:.17g}" for c in cols)])
    return out.getvalue()


def _interfaces(md: ET.Element) -> list[str]:
    return [k for k, tag in (("cs", "CoSimulation"), ("me", "ModelExchange"))
            if md.find(tag) is not None]


def stated_tolerance(interfaces: list[str]) -> dict[str, float]:
    """The check's tolerance for each interface the FMU has."""
    return {k: CHECK_TOLERANCE[k] for k in interfaces}


def manifest_xml(model_name: str, tolerance: dict[str, float] | None) -> str:
    """``fmi-ls-manifest.xml``: the three files with their roles, and the
    check's tolerance as an annotation of the result; tolerance None: the
    report alone (no reference result could be computed)."""
    ET.register_namespace("fmi-ls", LS_NS)
    root = ET.Element("fmiReferences", {f"{{{LS_NS}}}fmi-ls-name": LS_NAME,
                                        f"{{{LS_NS}}}fmi-ls-version": LS_VERSION,
                                        f"{{{LS_NS}}}fmi-ls-description": LS_DESCRIPTION})
    if tolerance is None:
        ET.SubElement(root, "Related", {
            "type": "text/plain", "source": f"../../{LS_DOC}", "role": ROLES["report"],
            "description": "Why this FMU carries no reference result"})
        ET.indent(root, "  ")
        return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(
            root, encoding="unicode") + "\n"
    result = ET.SubElement(root, "Related", {
        "type": "text/csv", "source": csv_name(model_name), "role": ROLES["result"],
        "description": "Outputs of the default experiment by the scipy reference "
                       f"(rtol {REF_RTOL:g}); the FMU matches them within the tolerance "
                       "annotated here, relative to each output's range"})
    ann = ET.SubElement(ET.SubElement(result, "Annotations"), "Annotation",
                        {"type": ANNOTATION_TYPE})
    for interface, tol in tolerance.items():
        ET.SubElement(ann, "Tolerance", {
            "interface": {"cs": "CoSimulation", "me": "ModelExchange"}[interface],
            "maxDeviationRelativeToRange": f"{tol:g}"})
    ET.SubElement(root, "Related", {
        "type": EXPERIMENT_TYPE, "source": EXPERIMENT_FILE, "role": ROLES["experiment"],
        "description": "The default experiment, with the result above as its reference"})
    ET.SubElement(root, "Related", {
        "type": "text/plain", "source": f"../../{LS_DOC}", "role": ROLES["report"],
        "description": "How the reference result was computed and how the FMU is "
                       "checked against it"})
    ET.indent(root, "  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(
        root, encoding="unicode") + "\n"


def experiment_xml(model_name: str, exp: ET.Element) -> str:
    """The default experiment in the MA-HS-Experiments format."""
    root = ET.Element("Experiments", {
        "name": "Default experiment",
        "description": f"Smoke test of {model_name}: the FMU's DefaultExperiment, compared "
                       "with the reference result"})
    attrs = {"name": "default", "description": "The DefaultExperiment of "
             "modelDescription.xml; outputs compared with the reference result"}
    if exp.get("tolerance") is not None:
        attrs["tolerance"] = exp.get("tolerance")
    e = ET.SubElement(root, "Experiment", attrs)
    ET.SubElement(e, "TransientSimulation", {k: exp.get(k) for k in
                                             ("startTime", "stopTime", "stepSize")
                                             if exp.get(k) is not None})
    ET.SubElement(e, "References", {"source": csv_name(model_name), "type": "text/csv"})
    ET.indent(root, "  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(
        root, encoding="unicode") + "\n"


def report_text(model: Model, ref: ReferenceResult, exp: ET.Element,
                tolerance: dict[str, float]) -> str:
    """``documentation/fmi-ls-ref.txt``: the reference files, their intent and
    the deviation to expect."""
    words = {"cs": "co-simulation (the embedded solver)",
             "me": "model exchange (the importer's solver)"}
    tol = "; ".join(f"{words[k]}: {v:g}" for k, v in tolerance.items())
    return "\n".join([
        f"Reference result of {model.name} (FMI-LS-REF {LS_VERSION})",
        "",
        f"extra/{LS_NAME}/ holds, listed in its fmi-ls-manifest.xml:",
        f"  {csv_name(model.name)}  role result: the outputs of the default experiment",
        f"  {EXPERIMENT_FILE}  role experiment/smoke-test: that experiment",
        "and this file (role report).",
        "",
        "The default experiment: start "
        f"{exp.get('startTime')} s, stop {exp.get('stopTime')} s, communication step "
        f"{exp.get('stepSize')} s, tolerance {exp.get('tolerance')} (the DefaultExperiment "
        "of modelDescription.xml).",
        "",
        "How the result was computed: the model's declaration (the same equations, events, "
        "modes and delays as the C code) integrated by scipy's solve_ivp, method "
        f"{ref.method}, rtol {ref.rtol:g}, atol {ref.atol:g}, independently of the FMU's "
        "runtime; one row per communication step, numbers to 17 significant digits.",
        "",
        "What to expect: run the default experiment as the DefaultExperiment says and "
        "compare each output at the CSV's times. The deviation of an output is the largest "
        "|y_FMU - y_ref| divided by the output's range in the CSV (its magnitude where the "
        "range is zero). The FMU is checked to at most: " + tol + ". The embedded solver's "
        "and the importer's error at the DefaultExperiment's tolerance make most of it; "
        "the reference's own error (against a run at rtol 1e-12) is at most 1.1e-9 of the "
        "range for loomfmu's models.",
        "",
        "How to check: loomfmu check FMU (prints each output's deviation; exit 0 within "
        "the tolerance, 1 outside), or with FMPy alone: fmpy.simulate_fmu(FMU) and the CSV.",
        ""])


def write_reference_results(root: Path, model: Model) -> ReferenceResult | None:
    """The builder's hook: write the manifest, the reference CSV, the
    experiment and the report into the unzipped FMU at ``root`` (which holds
    modelDescription.xml already). Where the reference cannot be computed the
    manifest lists the report alone, which says why; returns None then."""
    md = ET.parse(root / "modelDescription.xml").getroot()
    exp = md.find("DefaultExperiment")
    if exp is None:
        raise ValueError(f"{model.name}: no DefaultExperiment in the model description")
    folder = root / LS_DIR
    folder.mkdir(parents=True, exist_ok=True)
    (root / "documentation").mkdir(exist_ok=True)
    try:
        ref = reference_result(model)
    except (RuntimeError, ValueError, ArithmeticError, np.linalg.LinAlgError) as e:
        # a declaration the reference cannot solve over the default experiment (a
        # validity condition failing in it, delays with events): the FMU is built
        # without a result, and the report says why
        reason = " ".join(str(e).split())
        (folder / "fmi-ls-manifest.xml").write_text(manifest_xml(model.name, None))
        (root / LS_DOC).write_text(f"No reference result for {model.name}: {reason}\n")
        return None
    tolerance = stated_tolerance(_interfaces(md))
    (folder / "fmi-ls-manifest.xml").write_text(manifest_xml(model.name, tolerance))
    (folder / csv_name(model.name)).write_text(ref.csv)
    (folder / EXPERIMENT_FILE).write_text(experiment_xml(model.name, exp))
    (root / LS_DOC).write_text(report_text(model, ref, exp, tolerance))
    return ref


# ------------------------------------------------------------------ the check
class ReferenceResultError(ValueError):
    """The FMU has no usable reference result (missing, malformed, not finite)."""


@dataclass
class OutputCheck:
    name: str
    max_abs: float
    rel_range: float


@dataclass
class CheckResult:
    """One run of the default experiment against the FMU's reference."""

    fmu: str
    interface: str
    tolerance: float
    outputs: list[OutputCheck]

    @property
    def worst(self) -> OutputCheck:
        return max(self.outputs, key=lambda o: o.rel_range)

    @property
    def ok(self) -> bool:
        return all(o.rel_range <= self.tolerance for o in self.outputs)


def manifest_problems(xml: bytes) -> list[str]:
    """Problems of a manifest against the standard: the schema below (built on
    FMPy's FMI 3.0 fmi3LayeredStandardManifest.xsd and fmi3Annotation.xsd)."""
    from lxml import etree
    try:
        doc = etree.fromstring(xml)
    except etree.XMLSyntaxError as e:
        return [f"fmi-ls-manifest.xml is not XML: {e}"]
    schema = _manifest_schema()
    if not schema.validate(doc):
        return [f"fmi-ls-manifest.xml line {e.line}: {e.message}" for e in schema.error_log]
    # the schema's fixed values, which libxml2 does not enforce on attribute references
    out = []
    for attr, fixed in (("fmi-ls-name", LS_NAME), ("fmi-ls-description", LS_DESCRIPTION)):
        if doc.get(f"{{{LS_NS}}}{attr}") != fixed:
            out.append(f"fmi-ls-manifest.xml: {attr} = {doc.get(f'{{{LS_NS}}}{attr}')!r}; "
                       f"the standard fixes it to {fixed!r}")
    return out


def _manifest_schema():
    """The FMI-LS-REF manifest as the standard's tables define it, as XML Schema."""
    import fmpy
    from lxml import etree
    d = (Path(fmpy.__file__).parent / "schema" / "fmi3").as_uri()
    roles = ("document|requirement|specification|model|parameter|system|testcase|"
             "experiment(/(smoke-test|validation|uncertainty-analysis))?|result|method|"
             "rationale|report|request|delivery|configuration|signature|"
             "serialized-state(/.*)?|meta-data|other")
    xsd = f"""<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema"
 xmlns:fmi-ls="{LS_NS}" elementFormDefault="qualified">
 <xs:import namespace="{LS_NS}" schemaLocation="{d}/fmi3LayeredStandardManifest.xsd"/>
 <xs:include schemaLocation="{d}/fmi3Annotation.xsd"/>
 <xs:element name="fmiReferences"><xs:complexType><xs:sequence>
  <xs:element name="Related" minOccurs="0" maxOccurs="unbounded"><xs:complexType>
   <xs:sequence>
    <xs:element name="Label" minOccurs="0" maxOccurs="unbounded"><xs:complexType>
     <xs:attribute name="name" type="xs:string" use="required"/>
     <xs:attribute name="description" type="xs:string"/></xs:complexType></xs:element>
    <xs:element ref="Annotations" minOccurs="0"/>
   </xs:sequence>
   <xs:attribute name="type" type="xs:string" default="application/octet-stream"/>
   <xs:attribute name="source" type="xs:anyURI" use="required"/>
   <xs:attribute name="role" use="required"><xs:simpleType>
    <xs:restriction base="xs:string"><xs:pattern value="({roles})"/></xs:restriction>
   </xs:simpleType></xs:attribute>
   <xs:attribute name="description" type="xs:string"/>
  </xs:complexType></xs:element>
  <xs:element ref="Annotations" minOccurs="0"/>
 </xs:sequence>
 <xs:attribute ref="fmi-ls:fmi-ls-name" use="required" fixed="{LS_NAME}"/>
 <xs:attribute ref="fmi-ls:fmi-ls-version" use="required"/>
 <xs:attribute ref="fmi-ls:fmi-ls-description" use="required" fixed="{LS_DESCRIPTION}"/>
 </xs:complexType></xs:element>
</xs:schema>"""
    return etree.XMLSchema(etree.fromstring(xsd.encode()))


def read_reference(fmu: Path | str) -> tuple[dict[str, float], np.ndarray, dict]:
    """(tolerance by interface, times, outputs by name) of the reference inside
    ``fmu``; :class:`ReferenceResultError` says what is missing or wrong."""
    path = Path(fmu)
    if path.is_dir():
        raise ReferenceResultError(f"{path}: a directory, not an FMU file")
    if not path.is_file():
        raise ReferenceResultError(f"{path}: no such file")
    if not zipfile.is_zipfile(path):
        raise ReferenceResultError(f"{path}: not an FMU (not a zip archive)")
    with zipfile.ZipFile(path) as z:
        names = set(z.namelist())
        if "modelDescription.xml" not in names:
            raise ReferenceResultError(f"{path}: not an FMU (no modelDescription.xml)")
        if LS_MANIFEST not in names:
            raise ReferenceResultError(f"{path.name}: no reference result inside (no {LS_MANIFEST})")
        manifest = z.read(LS_MANIFEST)
        problems = manifest_problems(manifest)
        if problems:
            raise ReferenceResultError(f"{path.name}: {problems[0]}")
        root = ET.fromstring(manifest)
        results = [r for r in root.findall("Related")
                   if r.get("role") == "result" and r.get("type") == "text/csv"]
        if not results:
            why = ""
            if LS_DOC in names:
                why = z.read(LS_DOC).decode("utf-8", "replace").strip().splitlines()[0][:300]
            raise ReferenceResultError(f"{path.name}: the manifest lists no result of type "
                                       "text/csv" + (f" ({LS_DOC}: {why})" if why else ""))
        rel = results[0]
        member = _resolve(rel.get("source"))
        if member is None or member not in names:
            raise ReferenceResultError(f"{path.name}: the reference result "
                                       f"{rel.get('source')!r} listed in the manifest is not in the "
                                       "FMU")
        tolerance = _tolerance(rel, path.name)
        try:
            text = z.read(member).decode("utf-8")
        except (UnicodeDecodeError, zipfile.BadZipFile, OSError) as e:
            raise ReferenceResultError(f"{path.name}: {member} cannot be read ({e})") from None
    t, cols = parse_csv(text, f"{path.name}: {member}")
    return tolerance, t, cols


def _resolve(source: str | None) -> str | None:
    """The archive member a relative URI in the manifest names, or None."""
    if not source or ":" in source.split("/")[0] or source.startswith("/"):
        return None
    parts = LS_DIR.split("/")
    for p in source.split("/"):
        if p == "..":
            if not parts:
                return None
            parts.pop()
        elif p not in ("", "."):
            parts.append(p)
    return "/".join(parts)


def _tolerance(rel: ET.Element, where: str) -> dict[str, float]:
    out = {}
    for ann in rel.findall("Annotations/Annotation"):
        if ann.get("type") != ANNOTATION_TYPE:
            continue
        for tol in ann.findall("Tolerance"):
            key = {"CoSimulation": "cs", "ModelExchange": "me"}.get(tol.get("interface", ""))
            try:
                value = float(tol.get("maxDeviationRelativeToRange", ""))
            except ValueError:
                value = math.nan
            if key is None or not (math.isfinite(value) and value > 0):
                raise ReferenceResultError(f"{where}: the manifest's tolerance "
                                           f"{ET.tostring(tol, encoding='unicode').strip()} is not "
                                           "an interface (CoSimulation or ModelExchange) with a "
                                           "number > 0")
            out[key] = value
    if not out:
        raise ReferenceResultError(f"{where}: the manifest states no tolerance (annotation "
                                   f"{ANNOTATION_TYPE} of the result)")
    return out


def parse_csv(text: str, where: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """``time`` and the columns of a reference CSV; every value finite, times
    increasing, at least two rows."""
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or not rows[0] or rows[0][0] != "time" or len(rows[0]) < 2:
        raise ReferenceResultError(f"{where}: not a reference CSV (expected a header "
                                   "'time,<output>,...')")
    head = rows[0]
    if len(set(head)) != len(head):
        raise ReferenceResultError(f"{where}: a column name appears twice in the header")
    body = [r for r in rows[1:] if r]
    if len(body) < 2:
        raise ReferenceResultError(f"{where}: fewer than two rows")
    data = np.empty((len(body), len(head)))
    for i, r in enumerate(body, start=2):
        if len(r) != len(head):
            raise ReferenceResultError(f"{where} line {i}: {len(r)} values, the header has "
                                       f"{len(head)}")
        try:
            data[i - 2] = [float(c) for c in r]
        except ValueError:
            raise ReferenceResultError(f"{where} line {i}: not a number in {','.join(r)[:80]!r}"
                                       ) from None
    bad = np.argwhere(~np.isfinite(data))
    if len(bad):
        i, j = bad[0]
        raise ReferenceResultError(f"{where} line {i + 2}: {head[j]} = {body[i][j]} is not finite")
    if not np.all(np.diff(data[:, 0]) > 0):
        raise ReferenceResultError(f"{where}: the times do not increase")
    return data[:, 0], {n: data[:, k] for k, n in enumerate(head) if k}


def deviations(t_ref: np.ndarray, ref: dict[str, np.ndarray], t_run: np.ndarray,
               run: dict[str, np.ndarray]) -> list[OutputCheck]:
    """Per output of ``ref``: the largest |run - ref| at the reference's times
    (the run's last sample at each of them: after an event at that time) and
    that relative to the output's range in the reference."""
    idx = np.searchsorted(t_run, t_ref, side="right") - 1
    ok = (idx >= 0) & (np.abs(t_run[np.clip(idx, 0, None)] - t_ref)
                       <= 1e-9 * np.maximum(1.0, np.abs(t_ref)))
    if not ok.all():
        miss = t_ref[~ok][0]
        raise RuntimeError(f"the run has no sample at t = {miss:g} s of the reference")
    out = []
    for name, r in ref.items():
        if name not in run:
            raise RuntimeError(f"the run has no output {name!r} of the reference")
        y = np.asarray(run[name], dtype=float)[idx]
        span = float(np.ptp(r)) or float(np.max(np.abs(r))) or 1.0
        err = float(np.max(np.abs(y - r))) if np.all(np.isfinite(y)) else math.inf
        out.append(OutputCheck(name, err, err / span))
    return out


def check_fmu(fmu: Path | str, interface: str | None = None) -> list[CheckResult]:
    """Run ``fmu``'s default experiment through FMPy, as its DefaultExperiment
    says, in each interface it has (or ``interface``: "cs" or "me"), and
    compare the outputs with the reference result inside it.

    ReferenceResultError (a ValueError) when the FMU is missing, not an FMU, or has
    no usable reference; RuntimeError when the FMU's run fails."""
    import fmpy

    from loomfmu.verification import fmpy_logger
    from loomfmu.verification.verify import quiet_callbacks
    tolerance, t_ref, cols = read_reference(fmu)
    name = Path(fmu).name
    try:
        md = fmpy.read_model_description(str(fmu), validate=False)
        have = [k for k, a in (("cs", "coSimulation"), ("me", "modelExchange"))
                if getattr(md, a, None) is not None]
        variables = {v.name: v for v in md.modelVariables}
    except Exception as e:  # noqa: BLE001 (lxml and FMPy raise several types)
        raise ReferenceResultError(f"{name}: not an FMU (modelDescription.xml cannot be read: "
                                   f"{' '.join(str(e).split())[:200]})") from None
    if not have:
        raise ReferenceResultError(f"{name}: not an FMU (its modelDescription.xml declares "
                                   "neither co-simulation nor model exchange)")
    if interface is not None:
        if interface not in have:
            raise ReferenceResultError(f"--interface {interface}: {name} has no "
                                       f"{'co-simulation' if interface == 'cs' else 'model exchange'}"
                                       f"; allowed: {', '.join(have)}")
        have = [interface]
    missing = [n for n in cols if n not in variables]
    if missing:
        raise ReferenceResultError(f"{name}: the reference's column {missing[0]!r} is "
                                   "not a variable of the FMU")
    outputs = [n for n, v in variables.items() if v.causality == "output"
               and v.type in ("Real", "Float64", "Float32")]
    unchecked = [n for n in outputs if n not in cols]
    if unchecked:
        raise ReferenceResultError(f"{name}: the reference result has no column for the "
                                   f"output {unchecked[0]!r} (the reference holds every Real "
                                   "output)")
    exp = md.defaultExperiment
    if exp is None or exp.stepSize is None:
        raise ReferenceResultError(f"{name}: no DefaultExperiment with a stepSize")
    step = float(exp.stepSize)
    start = float(exp.startTime or 0.0)
    stop = float(exp.stopTime) if exp.stopTime is not None else None
    if not (math.isfinite(step) and step > 0) or (stop is not None and not (
            math.isfinite(stop) and stop > start)):
        raise ReferenceResultError(f"{name}: the DefaultExperiment (start {start:g}, stop "
                                   f"{stop}, step {step:g}) is not a run")
    if stop is not None:
        grid = experiment_times(start, stop, step)
        if len(t_ref) != len(grid) or not np.allclose(t_ref, grid, rtol=0,
                                                      atol=1e-9 * max(1.0, abs(stop))):
            raise ReferenceResultError(
                f"{name}: the reference result holds {len(t_ref)} rows from t = "
                f"{t_ref[0]:g} to {t_ref[-1]:g} s; the DefaultExperiment's communication "
                f"points are {len(grid)} from {grid[0]:g} to {grid[-1]:g} s")
    results = []
    for k in have:
        if k not in tolerance:
            raise ReferenceResultError(f"{Path(fmu).name}: the manifest states no tolerance for "
                                       f"{'co-simulation' if k == 'cs' else 'model exchange'}")
        log: list[str] = []

        def logger(*args, log=log):
            log.append(args[-1].decode(errors="replace"))
        try:
            with quiet_callbacks():
                res = fmpy_logger.simulate(
                    str(fmu), logger=logger, model_description=md, validate=False,
                    fmi_type="CoSimulation" if k == "cs" else "ModelExchange",
                    output=list(cols), output_interval=step)
        except Exception as e:  # noqa: BLE001 (FMPy raises bare Exceptions)
            raise RuntimeError(f"{Path(fmu).name}: the default experiment failed: {e} "
                               f"({'; '.join(log[-2:]) or 'no log'})") from None
        run = {n: np.asarray(res[n]) for n in cols}
        results.append(CheckResult(str(fmu), k, tolerance[k],
                                   deviations(t_ref, cols, np.asarray(res["time"]), run)))
    return results
