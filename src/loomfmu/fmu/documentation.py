"""``documentation/index.html`` inside an FMU, generated from the declaration.

FMI 2.0 (section 2.1.1) names ``documentation/index.html`` as the entry
point of an FMU's documentation.  The page is written from the same
declaration as the C code and the model description, and from the model
description itself (what the importer sees), so it cannot drift from the
FMU: what the model is, its equations as declared, every variable (unit,
range, start, description and, for parameters, the source), the solver
settings and the tolerance rule, ports, the default experiment, and how the
FMU was verified against the scipy reference.

Plain HTML with inline CSS: no JavaScript, no external files.

    write_documentation(fmu_path, model, verification=verify(fmu_path, model))
"""
from __future__ import annotations

import html
import importlib
import inspect
import math
import os
import re
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import casadi as ca

from loomfmu.declare.model import Model
from loomfmu.declare.solvers import ADAPTIVE_SOLVERS, SETTINGS, SOLVER_DESCRIPTIONS, SOLVERS
from loomfmu.export.fmi_xml import fmi3_text
from loomfmu.fidelity import LEVELS
from loomfmu.registry import MODELS

#: Where FMI 2.0 puts the documentation's entry point.
DOC_MEMBER = "documentation/index.html"
#: A printed expression longer than this is cut (the full one is in the C sources).
MAX_EXPR_CHARS = 1500
#: Zip timestamp of the page, fixed so that the same inputs give the same file.
_ZIP_DATE = (1980, 1, 1, 0, 0, 0)

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;
 color:#1d2327;background:#fff;margin:0;line-height:1.45;font-size:15px}
main{max-width:1120px;margin:0 auto;padding:24px 28px 48px}
h1{font-size:26px;margin:0 0 4px} h2{font-size:20px;margin:34px 0 10px;
 border-bottom:2px solid #d0d7de;padding-bottom:4px} h3{font-size:16px;margin:22px 0 6px}
.lead{font-size:16px;margin:4px 0 12px} .meta{color:#57606a;font-size:13px}
.meta code{font-size:12px}
nav{background:#f6f8fa;border:1px solid #d0d7de;border-radius:6px;padding:8px 14px;
 margin:16px 0;font-size:14px} nav a{margin-right:14px;white-space:nowrap}
a{color:#0550ae;text-decoration:none} a:hover{text-decoration:underline}
code,pre,.mono{font-family:ui-monospace,SFMono-Regular,Menlo,Consolas,monospace}
code{font-size:13px;background:#f6f8fa;padding:0 3px;border-radius:3px}
table{border-collapse:collapse;width:100%;margin:6px 0 14px;font-size:13.5px}
th,td{border:1px solid #d0d7de;padding:4px 7px;text-align:left;vertical-align:top}
th{background:#f0f3f6;font-weight:600} tr:nth-child(even) td{background:#fafbfc}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
td.name{font-family:ui-monospace,Menlo,Consolas,monospace;font-size:12.5px;
 white-space:nowrap} td.small{font-size:12.5px;color:#424a53}
tr.worst td{background:#fff4d6 !important}
pre.cmd{white-space:pre-wrap;overflow-wrap:anywhere;background:#f6f8fa;padding:8px 10px;
 border:1px solid #d0d7de;border-radius:6px;font-size:12.5px}
table.compact{width:auto;min-width:50%}
.solvers{display:flex;flex-wrap:wrap;gap:0 18px} .solvers>div{flex:1 1 340px}
.solvers h3{font-size:14.5px}
.rule{background:#eef6ff;border-left:4px solid #0969da;padding:8px 14px;margin:10px 0}
.warn{background:#fff8e6;border-left:4px solid #bf8700;padding:8px 14px;margin:10px 0}
.doc p{margin:6px 0} .doc ul.items{margin:4px 0 8px;padding-left:18px}
.doc ul.items li{margin:3px 0} .doc pre.code{background:#f6f8fa;padding:8px 12px;
 border-radius:6px;font-size:13px;overflow-x:auto}
.eq{border:1px solid #d0d7de;border-radius:6px;margin:8px 0;overflow:hidden}
.eq .head{background:#f6f8fa;padding:4px 10px;font-size:13px;color:#57606a}
.eq pre{margin:0;padding:6px 10px;font-size:12.5px;white-space:pre-wrap;
 overflow-wrap:anywhere}
.eq pre.main{font-size:14px;color:#0a3069;font-weight:600}
.eq pre.where{color:#424a53;border-top:1px dashed #d0d7de}
.eq details summary{cursor:pointer;padding:2px 10px;font-size:12.5px;color:#57606a;
 border-top:1px dashed #d0d7de}
.cut{color:#8c6d1f;font-style:italic}
footer{margin-top:40px;color:#57606a;font-size:12.5px;border-top:1px solid #d0d7de;
 padding-top:8px}
"""


# ------------------------------------------------------------------ the FMU
def write_documentation(fmu_path, model: Model, *, verification: dict | None = None,
                        readable: bool = False) -> None:
    """(Re)write ``documentation/index.html`` inside the FMU at ``fmu_path``.

    model: the declaration the FMU was built from (its name must match the
    model description's modelName).  verification: the dict returned by
    :func:`loomfmu.verification.verify.verify` (optionally with "rtol", "atol", "ref_rtol",
    "ref_atol"), or None: the page then says the FMU was not verified at
    build.  readable: print the equations with ``loomfmu.inspection.readable`` (MathML,
    shared subexpressions named; seconds of CPU for the spindle) instead of
    CasADi's text.  Any earlier page is replaced; every other member is kept
    byte-identical.
    """
    fmu_path = Path(fmu_path)
    if not zipfile.is_zipfile(fmu_path):
        raise ValueError(f"fmu_path = {str(fmu_path)!r}: not an existing .fmu (zip) file")
    with zipfile.ZipFile(fmu_path) as z:
        names = z.namelist()
        if "modelDescription.xml" not in names:
            raise ValueError(f"fmu_path = {str(fmu_path)!r}: no modelDescription.xml inside")
        xml = z.read("modelDescription.xml").decode("utf-8")
        kept = [(info, z.read(info.filename)) for info in z.infolist()
                if info.filename != DOC_MEMBER]
    page = html_for(model, verification, model_description_xml=xml, members=names,
                    readable=readable)
    tmp = fmu_path.with_name(fmu_path.name + ".doc.tmp")
    try:
        with zipfile.ZipFile(tmp, "w") as z:
            for info, data in kept:
                z.writestr(info, data)
            info = zipfile.ZipInfo(DOC_MEMBER, date_time=_ZIP_DATE)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            z.writestr(info, page.encode("utf-8"))
        os.replace(tmp, fmu_path)
    finally:
        tmp.unlink(missing_ok=True)


def html_for(model: Model, verification: dict | None = None, *,
             model_description_xml: str | None = None,
             members: list[str] | None = None, readable: bool = False) -> str:
    """The documentation page of ``model`` as one self-contained HTML string.

    model_description_xml: the FMU's modelDescription.xml (default: generated
    from ``model`` as the builder does).  members: the FMU's file names, to
    point at the generated sources.
    """
    if verification is not None and not (isinstance(verification, dict) and
                                         isinstance(verification.get("solvers"), dict)):
        raise ValueError("verification: expected the dict of loomfmu.verification.verify.verify "
                         "(with a 'solvers' mapping) or None")
    if model_description_xml is None:
        model_description_xml = _generated_xml(model)
    md = ET.fromstring(model_description_xml)
    if md.get("modelName") != model.name:
        raise ValueError(f"model = {model.name!r} does not match the model description's "
                         f"modelName {md.get('modelName')!r}")
    csrc = next((n for n in members or [] if n.endswith("_casadi.c")),
                f"sources/{model.name}_casadi.c")
    sections = [  # what an importer needs first; solver and verification after
        ("about", "What it is", _about(model)),
        ("interfaces", "Interfaces", _interfaces(model, md)),
        ("validity", "Where it is valid and what it leaves out", _validity(model)),
        ("ports", "Ports", _ports(model)),
        ("build", "Rebuilding from sources/", _build(model, md, members)),
        ("solver", *_integration(model, md)),
        ("experiment", "Default experiment", _experiment(md) + _reference_result(md, members)),
        ("verification", "Verification", _verification(model, verification)),
        ("variables", "Variables", _variables(model, md)),
        ("equations", "Derivation and equations" if readable and model.quantities
         else "Equations", _readable_equations(model) if readable
         else _equations(model, csrc)),
    ]
    nav = "".join(f'<a href="#{a}">{t}</a>' for a, t, _ in sections)
    body = "".join(f'<section id="{a}"><h2>{t}</h2>{s}</section>' for a, t, s in sections)
    tool = html.escape(md.get("generationTool", "loomfmu"))
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{_e(model.name)}: FMU documentation</title><style>{_CSS}</style>"
            f"</head><body><main>{_header(model, md)}<nav>{nav}</nav>{body}"
            f"<footer>Generated by {tool} from the declaration in "
            f"<code>models/{_e(_module(model))}.py</code> and this FMU's "
            f"modelDescription.xml. Numbers are rounded to 6 significant digits; the "
            f"exact values are in modelDescription.xml.</footer></main></body></html>\n")


def _generated_xml(model: Model) -> str:
    from loomfmu.export.codegen import model_guid
    from loomfmu.export.dae import dae_form
    from loomfmu.export.fmi_xml import model_description
    dae = dae_form(model)
    return model_description(model, dae, model_guid(model, dae), [])


# ------------------------------------------------------------------ helpers
def _e(s) -> str:
    return html.escape(str(s), quote=True)


def _fmt(v) -> str:
    if v is None or v == "":
        return ""
    try:
        x = float(v)
    except ValueError:
        return str(v)
    return "" if math.isinf(x) else f"{x:.6g}"


def _module(model: Model) -> str:
    return MODELS.get(model.name, (model.name,))[0]


def _table(head: list[str], rows: list[str]) -> str:
    th = "".join(f"<th>{h}</th>" for h in head)
    return f"<table><thead><tr>{th}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _cell_table(head: list[str], rows: list[list[tuple[str, str]]]) -> str:
    """A table of (css class, escaped text) cells, without the columns that
    are empty in every row."""
    keep = [j for j in range(len(head)) if any(r[j][1] for r in rows)]
    body = ["<tr>" + "".join(f'<td class="{r[j][0]}">{r[j][1]}</td>' if r[j][0] else
                             f"<td>{r[j][1]}</td>" for j in keep) + "</tr>" for r in rows]
    return _table([head[j] for j in keep], body)


#: A list item's marker: a defect label followed by two spaces ("D1  ..."), or a bullet.
_MARKER = re.compile(r"^(?:([A-Z]\d+)\s{2,}|([-*])\s+)")


def _inline(text: str) -> str:
    return re.sub(r"``(.+?)``", r"<code>\1</code>", _e(" ".join(text.split())))


def _paragraph(para: str) -> str:
    """One docstring paragraph: prose, an indented code block, or a list of
    marked items (D1, B1, -, *) whose continuation lines are indented."""
    lines = para.splitlines()
    if all(ln.startswith(" ") for ln in lines):
        return f'<pre class="code">{_e(inspect.cleandoc(para))}</pre>'
    if not any(_MARKER.match(ln) for ln in lines):
        return f"<p>{_inline(para)}</p>"
    out, items, prose = [], [], []
    for ln in lines:
        m = _MARKER.match(ln)
        if m:
            if prose:
                out.append(f"<p>{_inline(' '.join(prose))}</p>")
                prose = []
            items.append([m.group(1) or m.group(2), ln[m.end():]])
        elif ln.startswith(" ") and items:
            items[-1][1] += " " + ln.strip()
        else:
            if items:
                out.append(_items(items))
                items = []
            prose.append(ln)
    if prose:
        out.append(f"<p>{_inline(' '.join(prose))}</p>")
    if items:
        out.append(_items(items))
    return "".join(out)


def _items(items: list) -> str:
    return '<ul class="items">' + "".join(
        f"<li><b>{_e(k)}</b> {_inline(t)}</li>" if k not in "-*" else f"<li>{_inline(t)}</li>"
        for k, t in items) + "</ul>"


def _docstring(model: Model) -> str:
    try:
        doc = importlib.import_module(f"loomfmu.models.{_module(model)}").__doc__ or ""
    except ImportError:
        return ""
    paras = re.split(r"\n\s*\n", inspect.cleandoc(doc))
    return '<div class="doc">' + "".join(_paragraph(p) for p in paras
                                         if p.strip() and _built_with(model, p)) + "</div>"


def _built_with(model: Model, para: str) -> bool:
    """False for a docstring paragraph about a build option's value this
    build does not have (it opens with ``option=value``)."""
    m = re.match(r"(\w+)=(\S+?)[\s:,]", para)
    if not m or m.group(1) not in model.options:
        return True
    return repr(model.options[m.group(1)]) == m.group(2) or \
        str(model.options[m.group(1)]) == m.group(2)


def _for_build(model: Model, text: str) -> str:
    """``text`` without its clauses (split at "; " and ", or ") about a build
    option's value this build does not have (``option=value`` in them)."""
    def other_build(clause):
        return any(str(v) != val and repr(v) != val
                   for k, val in re.findall(r"\b(\w+)=([\w.]+)", clause)
                   for v in [model.options.get(k, _MISSING)] if v is not _MISSING)
    kept = []
    for part in text.split("; "):
        alts = [a for a in re.split(r", or ", part) if not other_build(a)]
        if alts:
            kept.append(", or ".join(alts))
    return "; ".join(kept)


_MISSING = object()


def _validity(model: Model) -> str:
    """The fidelity level (what the model leaves out, where it suffices) and
    the validity conditions checked while it runs."""
    out = []
    lv = LEVELS.get(model.registry_name)
    if lv is not None:
        def items(texts):
            return "<br>".join(_e(t) for t in (_for_build(model, x) for x in texts) if t)
        out.append(f"<p>Fidelity level of the {_e(lv.mechanism)} mechanism. "
                   f"<strong>Suffices:</strong> {_e(_for_build(model, lv.suffices))}.</p>")
        out.append(_table(["leaves out", "represents"], [
            f"<tr><td>{items(lv.leaves_out) or 'nothing'}</td>"
            f"<td>{items(lv.represents)}</td></tr>"]))
        if lv.sources:
            out.append(f"<p>Evidence: {', '.join(_e(x) for x in lv.sources)}.</p>")
    else:
        out.append("<p>No fidelity level is declared for this model.</p>")
    if model.validity:
        rows = [f'<tr><td class="name">{_e(c.name)}</td><td>{_e(c.message)}</td></tr>'
                for c in model.validity]
        out.append("<p>Validity conditions, checked while the model runs on every "
                   "accepted step like an event indicator: where one turns negative the "
                   "step ends there with a discard status and a log line naming it.</p>"
                   + _table(["condition", "meaning when violated"], rows))
    else:
        out.append("<p>No validity condition is checked while it runs.</p>")
    if model.constraints:
        rows = [f'<tr><td class="name">{_e(c.name)}</td><td>{_e(c.message)}</td></tr>'
                for c in model.constraints]
        out.append("<p>Parameter constraints, checked at initialization (the FMU refuses "
                   "to start otherwise):</p>" + _table(["constraint", "message"], rows))
    return "".join(out)


#: Every platform the page names: (label, FMI 2.0 folder, FMI 3.0 folder,
#: library suffix, how loomfmu builds it or None, where its tests run it)
_PLATFORMS = [
    ("x86-64 Linux", "linux64", "x86_64-linux", ".so", "gcc", "natively"),
    ("x86-64 Windows", "win64", "x86_64-windows", ".dll", "mingw-w64 gcc (libgcc linked in)",
     "wine"),
    ("aarch64 Linux", None, "aarch64-linux", ".so", "aarch64-linux-gnu-gcc", "qemu-aarch64"),
    ("macOS (Apple silicon)", "darwin64", "aarch64-darwin", ".dylib", None, None),
    ("macOS (Intel)", "darwin64", "x86_64-darwin", ".dylib", None, None),
]


def _build(model: Model, md: ET.Element, members: list[str] | None) -> str:
    """The binaries this FMU holds, and how to compile sources/ into the
    binary of another platform."""
    v3 = md.get("fmiVersion", "").startswith("3")
    files = sorted(n for n in members or [] if n.startswith("sources/"))
    c_files = [n for n in files if n.endswith(".c")]
    srcs = " ".join(c_files) if c_files else "sources/*.c"
    name = model.name
    hdr = "&lt;FMI headers&gt;"
    held = {n.split("/")[1] for n in members or [] if n.startswith("binaries/")
            and n.count("/") == 2}
    rows = []
    for label, p2, p3, ext, built, runs in _PLATFORMS:
        folder = p3 if v3 else p2
        if folder is None:
            where = "none in FMI 2.0: rebuild (below), or use the FMI 3.0 build"
        elif folder in held:
            where = f"<code>binaries/{folder}/{_e(name)}{ext}</code>"
        else:
            where = f"not in this FMU (<code>binaries/{folder}/</code>): rebuild (below)"
        if built and folder is None:
            built = f"{built}, for FMI 3.0"
        rows.append(f"<tr><td>{label}</td><td>{where}</td><td>{built or 'not built by loomfmu'}"
                    f"</td><td>{runs or 'not run by loomfmu'}</td></tr>")
    flags = "-std=c99 -O2 -fvisibility=hidden -ffp-contract=off"
    f_arm = "aarch64-linux" if v3 else "linux64"
    mac = "aarch64-darwin" if v3 else "darwin64"
    lines = [
        f"gcc {flags} -shared -fPIC -I sources -I {hdr} {srcs} "
        f"-o binaries/{'x86_64-linux' if v3 else 'linux64'}/{name}.so -lm",
        f"x86_64-w64-mingw32-gcc {flags} -shared -static-libgcc -I sources -I {hdr} {srcs} "
        f"-o binaries/{'x86_64-windows' if v3 else 'win64'}/{name}.dll -lm",
        f"clang {flags} -dynamiclib -I sources -I {hdr} {srcs} -o binaries/{mac}/{name}.dylib",
        f"cl /O2 /LD /I sources /I {hdr} {srcs} "
        f"/Febinaries/{'x86_64-windows' if v3 else 'win64'}/{name}.dll",
    ]
    listing = ("<p>Files in sources/: " + ", ".join(f"<code>{_e(f)}</code>" for f in files)
               + ".</p>") if files else ""
    arm = ("On an ARM Linux machine the gcc line (the machine's own gcc) writes "
           f"<code>binaries/{f_arm}/{_e(name)}.so</code>"
           + ("." if v3 else ": FMI 2.0 names no folder for ARM, so put the library where "
              "the importer looks (FMPy: <code>binaries/linux64</code>, in place of the "
              "x86-64 library), or use the FMI 3.0 build, which carries "
              "<code>aarch64-linux</code>."))
    return ("<p>Binaries, each compiled from sources/ by gcc (C99) with the flags below; "
            "loomfmu's tests run binaries built this way for each platform through the FMI "
            "functions (natively, under wine, under qemu-aarch64) and compare their outputs "
            "with the native run's: bit for bit on every platform, since the runtime "
            "computes sin, exp, pow, ... itself (<code>lf_math.c</code>) where the C math "
            "libraries differ in the last bit; this FMU's own binaries were not run at "
            "build:</p>"
            + _table(["platform", "in this FMU", "compiled by", "tested under"], rows)
            + "<p>sources/ holds everything a binary needs: the generated model, the runtime "
            "and <code>lf_build.h</code>, which fixes the FMI version and the interfaces (no "
            "defines on the command line). Compile every C file with sources/ and the FMI "
            f"{'3.0' if v3 else '2.0'} headers (fmi{'3' if v3 else '2'}Functions.h and the "
            "headers it includes, from the FMI standard) on the include path, link the C "
            "math library, and put the library where the FMI standard expects it."
            + (" sources/buildDescription.xml says the same for FMI 3.0 tools." if v3 else "")
            + " <code>-ffp-contract=off</code> keeps a * b + c two roundings, as on x86-64 "
            "(clang contracts by default, gcc under -std=c99 does not): with it, the "
            "numbers match the other platforms'.</p>" + listing
            + "<p>The builder runs the gcc and mingw-w64 lines (with warnings on). The clang "
            "line (macOS; for an Intel Mac add <code>-arch x86_64</code>"
            + (" and write <code>binaries/x86_64-darwin</code>" if v3 else "")
            + ") and the MSVC line are the equivalent commands and were not run. "
            + arm + "</p>"
            + "".join(f'<pre class="cmd">{line}</pre>' for line in lines))


# ------------------------------------------------------------------ sections
def _header(model: Model, md: ET.Element) -> str:
    a = md.attrib
    opts = ", ".join(f"{k} = {v!r}" for k, v in model.options.items()) or "none"
    return (f"<h1>{_e(model.name)}</h1><p class=\"lead\">{_e(model.description)}</p>"
            f'<p class="meta">FMI {_e(a.get("fmiVersion"))} '
            f'{_e(" and ".join(interfaces(md)))} · '
            f'{"GUID" if a.get("guid") else "instantiation token"} '
            f'<code>{_e(a.get("guid") or a.get("instantiationToken"))}</code> · '
            f'{_e(a.get("generationTool", ""))}<br>'
            f'Author: {_e(a.get("author", ""))} · Version {_e(a.get("version", ""))} · '
            f'{_e(a.get("copyright", ""))} · License: {_e(a.get("license", ""))}<br>'
            f"Build options: <code>{_e(opts)}</code></p>")


def _interfaces(model: Model, md: ET.Element) -> str:
    """What each declared interface does, and the FMU variants one build makes."""
    v = md.get("fmiVersion", "")
    rows = []
    if md.find("CoSimulation") is not None:
        rows.append(("Co-Simulation", "the FMU integrates itself between communication "
                     "points with its embedded solver (parameter <code>solver</code>); events "
                     "are located inside the step" + (
                         "; with event mode enabled the importer is told of them"
                         if v.startswith("3") else "")))
    if md.find("ModelExchange") is not None:
        events = ", ".join(f"<code>{_e(e.name)}</code>" for e in model.events)
        modes = ", ".join(f"<code>{_e(q.name)}</code>" for q in model.of_kind("mode"))
        rows.append(("Model Exchange", "the importer's solver integrates the "
                     f"{_count(len(model.of_kind('state')), 'state')} from their derivatives"
                     + "; the FMU solves its algebraic equations itself (closed form or "
                       "Newton, as in co-simulation)"
                     + (f"; event indicators: {events}" if events else "; no event indicators")
                     + (f"; the modes {modes} change in event mode" if modes else "")
                     + ". The importer must call completedIntegratorStep after every "
                       "accepted step" + (": the delay history is built from those steps only"
                                          if model.delays else "")))
    body = "".join(f"<tr><td>{_e(n)}</td><td>{d}</td></tr>" for n, d in rows)
    command = ("loomfmu scene build" if "scene" in model.options else "loomfmu build")
    return (f"<p>FMI {_e(v)}. One declaration builds four variants: <code>{command} "
            f"{_e(model.name)} --fmi-version 2|3 --interface cs|me|both</code> writes "
            f"<code>{_e(model.name)}.fmu</code> for FMI 2.0 co-simulation and "
            f"<code>{_e(model.name)}_fmi&lt;version&gt;_&lt;interface&gt;.fmu</code> for the "
            "others (e.g. <code>_fmi3_me</code>).</p>"
            + _table(["interface", "what it does"], [body]))


def _about(model: Model) -> str:
    counts = {k: len(model.of_kind(k)) for k in ("parameter", "state", "input", "output",
                                                 "algebraic", "mode")}
    counts.update({"equation": len(model.equations), "event indicator": len(model.events),
                   "delay": len(model.delays)})
    summary = ", ".join(_count(n, k) for k, n in counts.items() if n)
    figures = "".join(f'<figure>{f.svg}<figcaption>{_e(f.caption)}</figcaption></figure>'
                      for f in model.figures)
    if "scene" in model.options:
        return f"{_composition(model)}{figures}<p>Composed: {summary}.</p>"
    return (f"{_docstring(model)}{figures}<p>Declared in <code>models/"
            f"{_e(_module(model))}.py</code>: {summary}.</p>")


def _composition(model: Model) -> str:
    """A scene composed into one model (loomfmu.scene.compose): its components
    and its connections, each substituted or an algebraic unknown."""
    comps = model.options.get("components", {})
    rows = "".join(
        f"<tr><td><code>{_e(name)}</code></td><td><code>{_e(str(o.get('model')))}</code></td>"
        f"<td>{_e(', '.join(f'{k}={v}' for k, v in o.items() if k != 'model') or '-')}</td>"
        "</tr>" for name, o in comps.items())
    conn_rows = []
    for c in getattr(model, "connections", []):
        dst = model.var(f"{c.dst}.{c.dst_var}")
        how = ("algebraic unknown (a loop of direct feedthrough): solved with the "
               "derivatives" if dst.kind == "algebraic" else "substituted: the input is the "
               "source's expression, kept as an output under its name")
        conv = (f"x {c.gain:.6g}" if c.gain != 1.0 else "") + (
            f" + {c.bias:.6g}" if c.bias else "")
        conn_rows.append(f"<tr><td><code>{_e(str(c))}</code></td><td>{_e(conv or '-')}</td>"
                         f"<td>{_e(how)}</td></tr>")
    ignored = model.options.get("ignored", {})
    note = ("<p>Solver settings the scene gave a component (ignored: the composed FMU has "
            "one solver, set by its own parameters): " + _e("; ".join(
                f"{k}: {', '.join(v)}" for k, v in ignored.items())) + ".</p>"
            if ignored else "")
    return (f"<p>The scene <code>{_e(str(model.options['scene']))}</code> composed at the "
            "equation level into one model (loomfmu.scene.compose; <code>loomfmu scene build "
            f"{_e(str(model.options['scene']))}</code>): every component's variables, "
            "equations, events, delays and conditions under its name (<code>comp.var</code>"
            "; names that must be identifiers as <code>comp_name</code>).</p>"
            + _table(["component", "model", "build options"], [rows])
            + (_table(["connection", "unit conversion", "in the composed model"],
                      ["".join(conn_rows)]) if conn_rows else "") + note)


def _count(n: int, what: str) -> str:
    return f"{n} {what}{'' if n == 1 else 's'}"


def _split_cse(s: str) -> tuple[list[str], str]:
    """CasADi prints shared subexpressions first: "@1=..., @2=..., final"."""
    parts = _top_split(s)
    defs = parts[:-1]
    if not all(re.match(r"^@\d+=", d) for d in defs):
        return [], s
    return [re.sub(r"^(@\d+)=", r"\1 = ", d) for d in defs], parts[-1]


def _strip(s: str) -> str:
    """Drop one pair of parentheses around the whole expression."""
    if s.startswith("(") and s.endswith(")"):
        depth = 0
        for i, ch in enumerate(s):
            depth += ch == "("
            depth -= ch == ")"
            if depth == 0 and i < len(s) - 1:
                return s
        return s[1:-1]
    return s


def _top_split(s: str) -> list[str]:
    """Split ``s`` at the commas outside any bracket."""
    parts, depth, start = [], 0, 0
    for i, ch in enumerate(s):
        if ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(s[start:i].strip())
            start = i + 1
    return parts + [s[start:].strip()]


def _printed(lhs, rhs: ca.SX) -> tuple[list[str], str, int]:
    """(shared subexpressions, "lhs = rhs", printed length).  lhs: a name, or an
    SX printed together with rhs so that both sides share the @k names."""
    if isinstance(lhs, str):
        defs, final = _split_cse(str(rhs))
        return defs, f"{lhs} = {_strip(final)}", len(str(rhs))
    text = str(ca.vertcat(lhs, rhs))
    defs, final = _split_cse(text)
    sides = _top_split(final[1:-1]) if final.startswith("[") else [final, "?"]
    return defs, f"{_strip(sides[0])} = {_strip(sides[-1])}", len(text)


def _expr_block(title: str, lhs, rhs: ca.SX, csrc: str) -> str:
    defs, main, total = _printed(lhs, rhs)
    where, used = [], len(main)
    for d in defs:
        if used + len(d) > MAX_EXPR_CHARS:
            break
        where.append(d)
        used += len(d)
    cut = len(main) > MAX_EXPR_CHARS or len(where) < len(defs)
    if len(main) > MAX_EXPR_CHARS:
        main = main[:MAX_EXPR_CHARS] + " …"
    out = [f'<div class="eq"><div class="head">{title}</div>',
           f'<pre class="main">{_e(main)}</pre>']
    if where:
        out.append(f"<details><summary>where: {_count(len(defs), 'shared subexpression')}"
                   f'</summary><pre class="where">{_e(chr(10).join(where))}</pre></details>')
    if cut:
        out.append(f'<pre class="where cut">… cut: {len(defs) - len(where)} shared '
                   f"subexpressions not shown ({total} characters in all); the full "
                   f"expression is in {_e(csrc)}</pre>")
    return "".join(out) + "</div>"


def _equations(model: Model, csrc: str) -> str:
    out = ["<p>As declared (residual form <code>lhs = rhs</code>), printed by CasADi: "
           "<code>@k</code> names a shared subexpression, listed under <em>where</em> "
           "(click to open); "
           "<code>sq(x)</code> is x², <code>der(x)</code> the time derivative, "
           "<code>delay(u)</code> a delayed value. Long expressions are cut.</p>"]
    for k, eqs in enumerate(model.equations, 1):
        rows = ca.vertsplit(ca.vec(eqs))
        for j, e in enumerate(rows, 1):
            lhs, rhs = _sides(e)
            title = f"equation {k}" + (f", row {j} of {len(rows)}" if len(rows) > 1 else "")
            out.append(_expr_block(title, lhs, rhs, csrc))
    sub = [("Outputs", [(f"output {v.name} [{v.unit or '1'}]", v.name, ca.SX(v.expr))
                        for v in model.of_kind("output")]),
           ("Start values computed at initialization (unless the state is set)",
            [(f"start of {n}", f"{n}(start)", ca.SX(x)) for n, x in model.initials.items()]),
           ("Delays", [(f"delay {d.name}: {d.description} (max {d.max_delay:g} s)",
                        f"delay({d.name})", ca.SX(d.expr)) for d in model.delays]),
           ("Event indicators (the solvers stop where they change sign)",
            [(f"event {ev.name}: {ev.description}", ev.name, ev.expr) for ev in model.events]),
           ("Constraints on the parameters (must be ≥ 0)",
            [(f"{c.name}: {c.message}", c.name, c.expr) for c in model.constraints])]
    for title, items in sub:
        if items:
            out.append(f"<h3>{title}</h3>")
            out += [_expr_block(_e(t), lhs, rhs, csrc) for t, lhs, rhs in items]
    if model.delays:
        out.append(_table(["delay", "tau (s)"], [
            f'<tr><td class="name">{_e(d.name)}</td><td class="mono">{_e(str(d.tau))}</td></tr>'
            for d in model.delays]))
    if model.mode_values:
        out.append("<h3>Modes</h3>" + _table(["mode", "values (priority order)",
                                                "re-chosen at the events"], [
            f'<tr><td class="name">{_e(n)}</td><td>{_e(", ".join(map(str, vals)))}</td>'
            f"<td>{_e(', '.join(e for e, m in model.event_modes.items() if m == n))}</td>"
            "</tr>" for n, vals in model.mode_values.items()]))
    return "".join(out)


def _readable_equations(model: Model) -> str:
    """The derivation part of ``loomfmu inspect``'s report: the named
    quantities of the derivation, the equations in MathML, how the runtime
    solves them, events, delays and constraints."""
    from loomfmu.inspection.report import html_fragment
    return ("<p>Printed from the declaration by <code>loomfmu.inspection.readable</code> "
            "(the printed form evaluates as the generated code, tested); the whole "
            f"report: <code>loomfmu inspect {_e(model.name)}</code>.</p>"
            + html_fragment(model))


def _is_der(x: ca.SX) -> bool:
    return x.is_symbolic() and x.name().startswith("der(")


def _sides(e: ca.SX) -> tuple[ca.SX, ca.SX]:
    """(lhs, rhs) of a scalar residual: m.eq(lhs, rhs) stored lhs - rhs;
    der(x) + r (CasADi's form of der(x) - (-r)) is shown as der(x) = -r;
    anything else as "residual = 0"."""
    if e.op() == ca.OP_SUB:
        return e.dep(0), e.dep(1)
    if e.op() == ca.OP_ADD:
        for a, b in ((0, 1), (1, 0)):
            if _is_der(e.dep(a)):
                return e.dep(a), -e.dep(b)
    return e, ca.SX(0)


_GROUPS = (("Parameters", lambda v, kind: v.get("causality") == "parameter"),
           ("Inputs", lambda v, kind: v.get("causality") == "input"),
           ("Outputs", lambda v, kind: v.get("causality") == "output"),
           ("States", lambda v, kind: kind == "state"),
           ("Other local variables", lambda v, kind: v.get("causality") == "local"
            and kind != "state"))


def _model_variables(md: ET.Element) -> list[tuple[ET.Element, ET.Element]]:
    """(variable, type element) of every variable: FMI 2.0's ScalarVariable
    and its Real/Integer/Enumeration child; FMI 3.0's Float64/Int32/
    Enumeration element twice (its tag is the type)."""
    mv = md.find("ModelVariables")
    if md.get("fmiVersion", "").startswith("3"):
        return [(v, v) for v in mv]
    return [(sv, next(iter(sv))) for sv in mv.findall("ScalarVariable")]


def interfaces(md: ET.Element) -> list[str]:
    """The interfaces the model description declares, in words."""
    return [words for tag, words in (("CoSimulation", "Co-Simulation"),
                                     ("ModelExchange", "Model Exchange"))
            if md.find(tag) is not None]


def _variables(model: Model, md: ET.Element) -> str:
    kinds = {v.name: v.kind for v in model.variables}
    settings = {s.name for s in SETTINGS}
    svs = _model_variables(md)
    out = [f"<p>Every variable of modelDescription.xml ({len(svs)} in all), as the "
           "importer sees them. Ranges are enforced by the FMU: a parameter or state set "
           f"outside its range is refused ({_fn(md, 'Error')} and a log line); an input "
           "outside its "
           "range is taken with a warning (the model may not be valid there).</p>"]
    enums = {st.get("name"): {it.get("value"): it.get("name") for it in st.iter("Item")}
             for st in (*md.iter("SimpleType"), *md.iter("EnumerationType"))}
    for title, pick in _GROUPS:
        rows = []
        for sv, typ in svs:
            name = sv.get("name")
            if not pick(sv, kinds.get(name)):
                continue
            start, unit = typ.get("start", ""), typ.get("unit", "")
            if typ.tag == "Enumeration":
                items = enums.get(typ.get("declaredType"), {})
                start = f"{start} = {items.get(start, '?')}"
            else:
                start = _fmt(start)
            lo, hi = _fmt(typ.get("min")), _fmt(typ.get("max"))
            rng = f"[{lo or '−∞'}, {hi or '∞'}]" if (lo or hi) else ""
            shown = typ.get("displayUnit")
            if shown:  # the same values in the display unit
                from loomfmu.declare.units import display_factor
                f = display_factor(unit, shown)
                if typ.get("start") is not None:
                    start += f" ({_fmt(f * float(typ.get('start')))} {shown})"
                if typ.get("min") is not None and typ.get("max") is not None:
                    rng += (f" ([{_fmt(f * float(typ.get('min')))}, "
                            f"{_fmt(f * float(typ.get('max')))}] {shown})")
                unit += f" (shown in {shown})"
            if name in settings or typ.tag == "Enumeration":
                src = "loomfmu runtime setting"
            elif kinds.get(name) == "parameter":
                src = model.var(name).source
            else:
                src = ""
            rows.append([("name", _e(name)),
                         ("small", f'{_e(sv.get("causality"))}/{_e(sv.get("variability"))}'),
                         ("num", _e(start)), ("", _e(unit)), ("num", _e(rng)),
                         ("", _e(_fmi(md, sv.get("description") or ""))),
                         ("small", _e(src))])
        if rows:
            head = ["name", "causality/variability", "start", "unit", "range", "description",
                    "source"]
            out.append(f"<h3>{title} ({len(rows)})</h3>" + _cell_table(head, rows))
    return "".join(out)


def _fmi(md: ET.Element, text: str) -> str:
    """``text`` (written with FMI 2.0 names: fmi2DoStep, fmi2Discard, ...)
    with the names of the FMU's FMI version."""
    if not md.get("fmiVersion", "").startswith("3"):
        return text
    return fmi3_text(text)


def _fn(md: ET.Element, name: str) -> str:
    """The FMI function or constant ``name`` (FMI 2.0 spelling without its
    prefix, e.g. "DoStep", "GetReal", "Discard") in the FMU's version."""
    return _fmi(md, f"fmi2{name}")


def _adaptive() -> list[str]:
    """The adaptive embedded solvers (loomfmu.declare.solvers.ADAPTIVE_SOLVERS)."""
    return list(ADAPTIVE_SOLVERS)


def _fixed() -> list[str]:
    return [s for s in SOLVERS if s not in ADAPTIVE_SOLVERS]


def _words(items: list[str]) -> str:
    return ", ".join(items[:-1]) + (" and " if len(items) > 1 else "") + items[-1] \
        if items else ""


def _integration(model: Model, md: ET.Element) -> tuple[str, str]:
    """(title, body) of the section on who integrates: the embedded solvers
    in co-simulation, the importer in model exchange."""
    cs, me = md.find("CoSimulation") is not None, md.find("ModelExchange") is not None
    if cs and me:
        return ("Solvers and tolerances", _solver(md)
                + "<h3>Model exchange: what the importer must do</h3>"
                + _model_exchange(model, md, both=True))
    if me:
        return "Integration by the importer", _model_exchange(model, md, both=False)
    return "Solvers and tolerances", _solver(md)



def _nominals_text(model, f) -> str:
    """What GetNominalsOfContinuousStates gives, for the importer's page."""
    states = model.of_kind("state")
    given = [v for v in states if v.nominal is not None]
    if not given:
        return (f"<strong>Nominals:</strong> {f('GetNominalsOfContinuousStates')} gives 1.0 "
                "for every state: an importer that scales its absolute tolerance by the "
                "nominals (FMPy's CVode: atol = rtol × nominal) resolves states much smaller "
                "than 1 coarsely; give it an absolute tolerance of its own if it allows one.")
    return (f"<strong>Nominals:</strong> {f('GetNominalsOfContinuousStates')} gives each "
            "state's <code>nominal</code> of the model description (declared for "
            f"{len(given)} of the {len(states)} states, 1.0 for the others): an importer that "
            "scales its absolute tolerance by the nominals (FMPy's CVode: atol = rtol × "
            "nominal) resolves each state on its own scale.")

def _model_exchange(model: Model, md: ET.Element, *, both: bool) -> str:
    """What a model-exchange importer must do (docs/guides/runtime.md, Model exchange)."""
    f = lambda name: f"<code>{_e(_fn(md, name))}</code>"  # noqa: E731
    settings = ", ".join(f"<code>{_e(n)}</code>" for n in ("solver", *(s.name for s in SETTINGS)))
    items = [
        f"<strong>Call {f('CompletedIntegratorStep')} after every accepted step</strong> "
        "(<code>completedIntegratorStepNotNeeded=\"false\"</code>): the validity conditions "
        f"are checked there and in {f('NewDiscreteStates')} (where one fails, the log names "
        "it and <code>terminateSimulation</code> is true)"
        + ("; the delays build their history from these steps only" if model.delays else "")
        + ".",
        "<strong>Event iteration.</strong> After " + f("ExitInitializationMode")
        + " the instance is in event mode; call " + f("NewDiscreteStates")
        + " there and after every event: it re-chooses the mode of every event indicator "
          "that changed sign and reinitializes the states for it "
          "(<code>valuesOfContinuousStatesChanged</code>; the modes settle in one call). "
        + f("CompletedIntegratorStep") + " returns <code>enterEventMode</code> true when an "
          "indicator changed sign since the last event, so an importer without root "
          "finding still learns of the switch (at its step's resolution)."
        + ("" if model.events else " This model declares no event indicators."),
        _nominals_text(model, f),
        f"Equations that cannot be solved at the importer's point give {f('Discard')} with "
        "the time in the log (retry with a shorter step); calls out of order, wrong array "
        f"sizes, non-finite states or time give {f('Error')} with a log line.",
    ]
    if model.delays:
        taus = ", ".join(f"<code>{_e(d.name)}</code>: tau = {_e(_tau(model, d.tau))}"
                         for d in model.delays)
        tau_min = min(_tau_value(model, d.tau) for d in model.delays)
        items.append(
            f"<strong>Delays ({taus}): the importer's steps between completed integrator "
            "steps must not be longer than tau</strong>, counting its internal steps: a "
            "derivative, event indicator or output needs the delayed value at t − tau, and "
            "where that lies beyond the last completed step the call returns "
            f"{f('Discard')} with a log line giving the delay, t − tau and the end of the "
            "history (nothing is extrapolated). FMPy completes a step at every output point, "
            "and its CVode takes internal steps up to (stop − start)/50: both must stay "
            "below tau. Usage: <code>fmpy.simulate_fmu(path, fmi_type=\"ModelExchange\", "
            "stop_time=..., output_interval=...)</code> with <code>output_interval</code> "
            f"well below tau (e.g. {_fmt(tau_min / 10)} s) and <code>stop_time</code> below "
            f"50 × tau = {_fmt(50 * tau_min)} s (longer runs: in pieces, or with an "
            "importer whose largest step can be limited). An input set in event mode, or a "
            "mode re-chosen at an event, jumps the "
            "history; the delayed value jumps tau later, announced as the next time event "
            "(<code>nextEventTimeDefined</code>).")
    head = ("<p>Model exchange: the importer's own solver integrates the states from their "
            f"derivatives ({f('GetDerivatives')}); the FMU evaluates at the time and states "
            "the importer set.</p>")
    unused = (f'<div class="warn">The parameters {settings} are those of the embedded '
              "co-simulation solvers" + (" and are unused in model exchange"
                                         if both else ": unused in model exchange (this FMU "
                                         "has no co-simulation)")
              + ". The importer's own tolerance governs the integration.</div>")
    return head + "<ul>" + "".join(f"<li>{i}</li>" for i in items) + "</ul>" + unused


def _tau_value(model: Model, tau) -> float:
    """tau (an expression of parameters) at the parameters' start values."""
    params = model.of_kind("parameter")
    f = ca.Function("tau", [ca.vertcat(*(p.sym for p in params))] if params else [],
                    [ca.SX(tau)])
    return float(f(*([[float(p.start) for p in params]] if params else [])))


def _tau(model: Model, tau) -> str:
    """tau printed: its value at the start values, and its expression if it
    is not a number."""
    value = _fmt(_tau_value(model, tau))
    text = str(tau)
    return f"{value} s" if text == value else f"{value} s ({text} at its start value)"


def _solver(md: ET.Element) -> str:
    rtol = next(s for s in SETTINGS if s.name == "solver_rtol")
    exp = md.find("DefaultExperiment")
    tol = exp.get("tolerance") if exp is not None else None
    rows = [f'<tr><td class="name">{i}</td><td class="name">{_e(s)}</td>'
            f"<td>{_e(SOLVER_DESCRIPTIONS[s])}</td></tr>" for i, s in enumerate(SOLVERS, 1)]
    starts = {sv.get("name"): typ.get("start") for sv, typ in _model_variables(md)}
    srows = [f'<tr><td class="name">{_e(s.name)}</td><td class="num">{_fmt(starts.get(s.name))}'
             f'</td><td>{_e(s.unit)}</td><td class="num">[{_fmt(s.min)}, {_fmt(s.max)}]</td>'
             f"<td>{_e(_fmi(md, s.description))}</td></tr>" for s in SETTINGS]
    fmpy_note = (f" FMPy's <code>simulate_fmu</code> always passes one (the default "
                 f"experiment's {_fmt(tol)} unless <code>relative_tolerance</code> is given), "
                 "so with FMPy set <code>relative_tolerance</code>, not "
                 "<code>solver_rtol</code>.") if tol else ""
    f = lambda name: f"<code>{_e(_fn(md, name))}</code>"  # noqa: E731
    setup = f("SetupExperiment")
    fixed = _fixed()
    return ("<p>In co-simulation the FMU integrates itself between communication points "
            "with the solver chosen by the parameter <code>solver</code>; events are located "
            "inside the step and the solver restarts there.</p>"
            + _table(["value", "solver", "method"], rows)
            + '<div class="rule"><strong>Tolerance rule: the importer\'s tolerance overrides '
            f"<code>solver_rtol</code>.</strong> When the importer calls {setup} with "
            f"<code>toleranceDefined = {_e(_fn(md, 'True'))}</code>, "
            "its <code>tolerance</code> is the relative tolerance of the adaptive solvers "
            f"({_e(_words(_adaptive()))}) and <code>solver_rtol</code> is not used (it keeps "
            "its value); if the importer set <code>solver_rtol</code> to another value, "
            f"{f('ExitInitializationMode')} returns {_e(_fn(md, 'Warning'))} with a log line "
            "(logStatusWarning) naming both. A tolerance outside "
            f"[{_fmt(rtol.min)}, {_fmt(rtol.max)}] is limited to that range, with a warning. "
            "<code>solver_rtol</code> applies only when the "
            "importer defines no tolerance." + fmpy_note + " <code>solver_atol</code> "
            f"always applies; {_e(_words(fixed))} "
            f"take{'s' if len(fixed) == 1 else ''} fixed steps of "
            f"<code>solver_h_fixed</code> and use{'s' if len(fixed) == 1 else ''} "
            "neither.</div>"
            + "<h3>Settings (fixed parameters)</h3>"
            + _table(["name", "start", "unit", "range", "description"], srows))


def _ports(model: Model) -> str:
    if not model.ports:
        return "<p>No ports declared.</p>"
    rows = [f'<tr><td class="name">{_e(p.name)}</td><td>{_e(p.kind)}</td><td class="name">'
            + "<br>".join(f"{_e(r)}: {_e(n)}" for r, n in p.variables.items())
            + f"</td><td>{_e(p.description)}</td></tr>" for p in model.ports]
    return ("<p>Named groups of variables that a scene connects to other FMUs.</p>"
            + _table(["port", "kind", "variables (role: name)", "description"], rows))


def _experiment(md: ET.Element) -> str:
    exp = md.find("DefaultExperiment")
    if exp is None:
        return "<p>None declared.</p>"
    what = {"startTime": ("s", "start time"), "stopTime": ("s", "stop time"),
            "stepSize": ("s", "communication step"),
            "tolerance": ("", "relative tolerance the importer is asked to pass")}
    rows = [f'<tr><td class="name">{_e(k)}</td><td class="num">{_fmt(v)}</td>'
            f"<td>{what.get(k, ('', ''))[0]}</td><td>{what.get(k, ('', ''))[1]}</td></tr>"
            for k, v in exp.attrib.items()]
    return _table(["attribute", "value", "unit", "meaning"], rows)


def _reference_result(md: ET.Element, members: list[str] | None) -> str:
    """Where the FMU carries its reference result (FMI-LS-REF) and how to check it."""
    from loomfmu.fmu.reference_results import LS_DIR, LS_DOC, LS_MANIFEST, csv_name
    if LS_MANIFEST not in (members or []):
        return ""
    name = md.get("modelName", "")
    return (f'<div class="rule"><strong>Reference result inside.</strong> '
            f"<code>{LS_DIR}/{_e(csv_name(name))}</code> holds the outputs of this default "
            "experiment computed by the scipy reference at a tight tolerance, listed with "
            f"the experiment and the tolerance the FMU is checked to in "
            f"<code>{LS_MANIFEST}</code> (the layered standard FMI-LS-REF); "
            f"<code>{LS_DOC}</code> says how it was made. Check the FMU against it: "
            "<code>loomfmu check FMU</code>, or run the default experiment with "
            "<code>fmpy.simulate_fmu</code> and compare each output at the CSV's times, "
            "relative to its range.</div>")


def _verification(model: Model, ver: dict | None) -> str:
    if ver is None:
        return ('<div class="warn"><strong>Not verified at build</strong>; run '
                "<code>loomfmu verify</code> on this FMU to compare it with the scipy "
                "reference.</div>")
    from loomfmu.verification.verify import verify
    defaults = {k: p.default for k, p in inspect.signature(verify).parameters.items()
                if p.default is not inspect.Parameter.empty}

    def tol(key):
        if key in ver:
            return _fmt(ver[key])
        return f"{_fmt(defaults[key])} (verify's default)"

    units = {v.name: v.unit for v in model.of_kind("output")}
    how = [("reference", f"scipy <code>solve_ivp</code>, method {_e(model.reference_method)}, "
                         f"rtol {tol('ref_rtol')}, atol {tol('ref_atol')}; "
                         f"{_sig(ver.get('reference_wall_seconds'))} s, "
                         f"{_e(ver.get('reference_rhs_calls', '?'))} right-hand-side calls"),
           ("FMU runs", _runs_text(ver, tol)),
           ("compared", "at every communication point of the default experiment; per "
                        "output the largest absolute difference, and that divided by the "
                        "output's range over the run (its magnitude if the range is zero)")]
    out = ["<table><tbody>" + "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in how)
           + "</tbody></table>"]
    summary, tables = [], []
    for solver, res in ver["solvers"].items():
        errs = res.get("errors") or {}
        wall = _sig(res.get("wall_seconds"))
        if not errs or res.get("error"):
            msg = res.get("error") or "; ".join(res.get("log", [])) or "no errors recorded"
            summary.append(f'<tr><td class="name">{_e(solver)}</td><td colspan="3">'
                           f"{_e(msg)}</td></tr>")
            continue
        worst = max(errs, key=lambda n: errs[n]["max_rel_range"])
        summary.append(f'<tr><td class="name">{_e(solver)}</td><td class="num">'
                       f"{errs[worst]['max_rel_range']:.3g}</td><td class=\"name\">"
                       f"{_e(worst)}</td><td class=\"num\">{wall} s</td></tr>")
        rows = [f'<tr{" class=worst" if n == worst else ""}><td class="name">{_e(n)}</td>'
                f"<td class=\"num\">{errs[n]['max_abs']:.3g}</td><td>{_e(units.get(n, ''))}"
                f"</td><td class=\"num\">{errs[n]['max_rel_range']:.3g}</td></tr>"
                for n in errs]
        tables.append(f'<div><h3>{_e(solver)}: worst relative error '
                      f"{errs[worst]['max_rel_range']:.3g} ({_e(worst)})</h3>"
                      + _table(["output", "max abs error", "unit", "relative to range"], rows)
                      + "</div>")
    out.append('<table class="compact"><thead><tr><th>solver</th><th>worst relative '
               "error</th><th>in output</th><th>FMU run (wall)</th></tr></thead><tbody>"
               + "".join(summary) + "</tbody></table>")
    out.append('<div class="solvers">' + "".join(tables) + "</div>")
    out.append("<p>Highlighted: the output with the worst relative error.</p>")
    return "".join(out)


def _runs_text(ver: dict, tol) -> str:
    """How the FMU was run: the embedded solvers in co-simulation, FMPy's
    CVode in model exchange (rows labelled by verify.ME_LABEL)."""
    cs = [s for s, r in ver["solvers"].items() if r.get("interface", "cs") == "cs"]
    me = [s for s, r in ver["solvers"].items() if r.get("interface") == "me"]
    out = []
    if cs:
        out.append(f"FMPy co-simulation with the embedded solver{'s' if len(cs) > 1 else ''} "
                   f"{_e(_words(cs))}, rtol {tol('rtol')} (passed as the importer's "
                   f"tolerance), atol {tol('atol')}")
    if me:
        out.append(f"FMPy model exchange, once: FMPy's CVode integrates at rtol {tol('rtol')} "
                   "(absolute tolerance rtol × each state's nominal); the embedded "
                   "solver and its settings are not used")
    return "; ".join(out)


def _sig(v) -> str:
    """Three significant digits (times, counts)."""
    return "?" if v is None else f"{float(v):.3g}"
