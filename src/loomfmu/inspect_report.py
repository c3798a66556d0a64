"""``loomfmu inspect MODEL``: a model's equations as a machine designer reads them.

Writes one report: the variables with units, the equations (shared
subexpressions named once, see :mod:`loomfmu.readable`), and how the runtime
solves the model: the unknowns, whether they come in closed form or by
Newton, the Jacobian's sparsity, the event indicators and modes, the delays,
the parameter constraints and the size of the generated C.

Formats: ``html`` (MathML, no JavaScript, no network: renders in every
current browser), ``md`` (LaTeX between ``$$`` for GitHub and Jupyter),
``tex`` (a LaTeX document for papers).
"""
from __future__ import annotations

import argparse
import html
import re
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import sympy
from sympy.printing.pretty.pretty_symbology import greek_unicode

from . import readable
from .codegen import generate_sources
from .ode import DaeForm, dae_form
from .registry import MODELS, load_model

FORMATS = ("html", "md", "tex")
KIND_TITLES = {"parameter": "Parameters", "state": "States", "input": "Inputs",
               "output": "Outputs", "algebraic": "Algebraic variables", "mode": "Modes"}


# -- a small document model, rendered three ways -----------------------------

@dataclass
class Math:
    """A SymPy object printed as inline math."""
    expr: object


@dataclass
class Code:
    text: str


@dataclass
class Table:
    head: list[str]
    rows: list[list]


@dataclass
class Equations:
    """Display equations, each with an optional tag (e.g. its number)."""
    lines: list[tuple[object, str]]


@dataclass
class Pre:
    text: str


@dataclass
class Section:
    title: str
    blocks: list = field(default_factory=list)
    level: int = 2


# -- content -------------------------------------------------------------------

def _fmt(v) -> str:
    if v is None:
        return ""
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def _sym(name: str) -> Math:
    return Math(readable.Var(name))


def _eq(lhs, rhs) -> sympy.Eq:
    return sympy.Eq(lhs, rhs, evaluate=False)


def _variables(model) -> list[Section]:
    out = []
    for kind, title in KIND_TITLES.items():
        vs = model.of_kind(kind)
        if not vs:
            continue
        head = ["name", "symbol", "unit", "value" if kind == "parameter" else "start",
                "description"] + (["source"] if kind == "parameter" else [])
        rows = []
        for v in vs:
            start = _fmt(v.start)
            if kind == "mode":
                start += f" (values {', '.join(map(str, model.mode_values[v.name]))})"
            row = [Code(v.name), _sym(v.name), v.unit, start, v.description]
            rows.append(row + ([v.source] if kind == "parameter" else []))
        out.append(Section(f"{title} ({len(vs)})", [Table(head, rows)], level=3))
    return out


def _equations(model, lst: readable.Listing) -> Section:
    sec = Section("Equations")
    if lst.shared:
        sec.blocks += [f"Shared subexpressions, each defined once and used by name below "
                       f"({len(lst.shared)}):",
                       Equations([(_eq(s, d), "") for s, d in lst.shared])]
    sec.blocks += [f"The {len(lst.equations)} equations (terms with the unknowns "
                   "der(x) and the algebraic variables on the left):",
                   Equations([(_eq(lhs, rhs), str(k))
                              for k, (lhs, rhs) in enumerate(lst.equations, 1)])]
    if lst.outputs:
        sec.blocks += [f"The {len(lst.outputs)} outputs:",
                       Equations([(_eq(y, e), "") for y, e in lst.outputs])]
    return sec


def _sparsity(jac: ca.Sparsity, rows: int, cols: int) -> str:
    grid = [["\u00b7"] * cols for _ in range(rows)]
    for r, c in zip(jac.row(), jac.get_col()):
        grid[r][c] = "\u25a0"
    width = len(str(rows))
    return "\n".join(f"{k + 1:>{width}} " + "".join(line) for k, line in enumerate(grid))


def _solving(model, dae: DaeForm) -> Section:
    nw, nx = dae.w.numel(), dae.nx
    names = [s.name() for s in ca.vertsplit(dae.w)]
    A = ca.jacobian(dae.F, dae.w)
    sec = Section("How the runtime solves the model")
    sec.blocks.append(
        f"Unknowns at each instant: w = [der(x); z], {nx} state derivatives and "
        f"{nw - nx} algebraic variables, from the {nw} equations F(t, x, w, u, p, q, d) = 0.")
    if not dae.implicit:
        sec.blocks.append(
            "F is linear in w: every unknown is in closed form, w = -A\u207b\u00b9 F(w = 0) "
            "with A = \u2202F/\u2202w formed symbolically; no Newton iteration.")
    else:
        second = [i for i in range(nw) if ca.depends_on(A[i, :], dae.w)]
        nonlin = sorted({names[j] for i in second for j in range(nw)
                         if ca.depends_on(A[i, :], dae.w[j])})
        sec.blocks.append(
            f"F is nonlinear in w: the runtime solves all {nw} unknowns together by "
            "Newton's method with the exact Jacobian \u2202F/\u2202w, at every right-hand "
            f"side evaluation. Equations nonlinear in w: {', '.join(str(i + 1) for i in second)}; "
            "unknowns that enter them nonlinearly:")
        sec.blocks.append(Table(["name", "symbol"], [[Code(n), _sym(n)] for n in nonlin]))
    sp = A.sparsity()
    sec.blocks += [f"Sparsity of \u2202F/\u2202w ({nw} \u00d7 {nw}, {sp.nnz()} structural "
                   "non-zeros; rows: equations, columns: unknowns in this order):",
                   Table(["column", "unknown", "symbol"],
                         [[str(j + 1), Code(n), _sym(n)] for j, n in enumerate(names)]),
                   Pre(_sparsity(sp, nw, nw))]
    return sec


def _events(model, lst: readable.Listing) -> Section | None:
    if not model.events and not model.mode_values:
        return None
    sec = Section("Event indicators and modes")
    table = readable.symbols(model)
    if model.events:
        sec.blocks += ["The solvers locate each sign change of an indicator inside the "
                       "step (on the interpolant) and restart there; the indicators, "
                       "written with the shared subexpressions above:",
                       Equations([(_eq(y, e), "") for y, e in lst.events]),
                       Table(["indicator", "symbol", "description", "re-chooses mode"],
                             [[Code(e.name), _sym(e.name), e.description,
                               model.event_modes.get(e.name, "")] for e in model.events])]
    rules = dict((y.name, e) for y, e in lst.modes)
    for v in model.of_kind("mode"):
        sec.blocks += [f"Mode {v.name} ({v.description}): at an event the runtime takes "
                       f"the first value, in the order {model.mode_values[v.name]}, at which "
                       "this validity expression is \u2265 0:",
                       Equations([(_eq(readable.Var(f"valid_{v.name}"), rules[v.name]), "")])]
    if model.reinits:
        sec.blocks += ["States after a mode change:",
                       Equations([(_eq(readable.Var(n), readable.to_sympy(e, table)), "")
                                  for n, e in model.reinits.items()])]
    return sec


def _delays(model, lst: readable.Listing) -> Section | None:
    if not model.delays:
        return None
    table = readable.symbols(model)
    rows = [[Code(d.name), Math(readable.Var(d.sym.name())),
             Math(readable.to_sympy(d.tau, table)), _fmt(d.max_delay), d.description]
            for d in model.delays]
    return Section("Delays", [
        "Each delayed value is its expression taken \u03c4 seconds ago; the runtime keeps "
        "its history (constant at the start value before the start time) and restarts "
        "the step at the breakpoints t\u2080 + k\u03c4.",
        Table(["delay", "symbol", "\u03c4", "longest \u03c4 held (s)", "description"], rows),
        "The delayed expressions (with the shared subexpressions above), each taken at "
        "t \u2212 \u03c4:",
        Equations([(_eq(y, e), "") for y, e in lst.delays])])


def _constraints(model) -> Section | None:
    if not model.constraints:
        return None
    table = readable.symbols(model)
    return Section("Constraints on the parameters", [
        "Checked at initialization (the FMU refuses to start otherwise):",
        Table(["name", "must be \u2265 0", "message"],
              [[Code(c.name), Math(readable.to_sympy(c.expr, table)), c.message]
               for c in model.constraints])])


def _c_size(model, dae: DaeForm) -> Section:
    with tempfile.TemporaryDirectory() as tmp:
        files, _ = generate_sources(model, dae, Path(tmp))
        rows = []
        for f in files:
            text = (Path(tmp) / f).read_text()
            rows.append([Code(f), str(text.count("\n")), str(len(text.encode()))])
    return Section("Generated C", [
        "The model's C files (the shared runtime comes on top):",
        Table(["file", "lines", "bytes"], rows)])


def document(model) -> tuple[str, list[Section]]:
    """The report's title and sections for a declared model."""
    dae = dae_form(model)
    about = Section("Model", [model.description or model.name])
    if model.options:
        about.blocks.append("Built with " + ", ".join(f"{k} = {v!r}"
                                                       for k, v in model.options.items()))
    lst = readable.listing(model)
    sections = [about, Section("Variables", _variables(model)), _equations(model, lst),
                _solving(model, dae), _events(model, lst), _delays(model, lst),
                _constraints(model), _c_size(model, dae)]
    return f"{model.name}: equations and solution", [s for s in sections if s]


# -- renderers -------------------------------------------------------------------

#: a display equation longer than this (characters of SymPy's plain print, a
#: rough measure of its printed width) is broken after a term of its right side
WRAP = 110


def _rows(e) -> list[list] | None:
    """The right side's terms, in printed order, in rows that fit WRAP; None
    when ``e`` fits on one line (or its right side is not a sum)."""
    if not isinstance(e, sympy.Eq) or not isinstance(e.rhs, sympy.Add) or len(str(e)) <= WRAP:
        return None
    rows, row, width = [], [], len(str(e.lhs)) + 3
    for term in e.rhs.as_ordered_terms():
        w = len(str(term)) + 3
        if row and width + w > WRAP:
            rows.append(row)
            row, width = [], 4
        row.append(term)
        width += w
    rows.append(row)
    return rows if len(rows) > 1 else None


def _signed(term) -> tuple[str, object]:
    """("-", -term) for a negative term, else ("+", term)."""
    return ("-", -term) if term.could_extract_minus_sign() else ("+", term)


def _latex_display(e) -> str:
    rows = _rows(e)
    if rows is None:
        return readable.to_latex(e)
    lines = []
    for k, row in enumerate(rows):
        parts = []
        for j, term in enumerate(row):
            sign, mag = _signed(term)
            first = k == 0 and j == 0
            parts.append(("-" if sign == "-" else "") if first else sign)
            parts.append(readable.to_latex(mag))
        head = readable.to_latex(e.lhs) + " ={}& " if k == 0 else r"&\quad "
        lines.append(head + " ".join(p for p in parts if p))
    return r"\begin{aligned} " + r" \\ ".join(lines) + r" \end{aligned}"


def _mathml_display(e) -> str:
    rows = _rows(e)
    if rows is None:
        return readable.mathml_line(e)
    trs = []
    for k, row in enumerate(rows):
        cells = []
        for j, term in enumerate(row):
            sign, mag = _signed(term)
            if not (k == 0 and j == 0 and sign == "+"):
                cells.append("<mo>%s</mo>" % ("\u2212" if sign == "-" else "+"))
            cells.append(readable.mathml_body(mag))
        left = readable.mathml_body(e.lhs) if k == 0 else ""
        mid = "<mo>=</mo>" if k == 0 else "<mspace width=\"1em\"/>"
        trs.append(f'<mtr><mtd style="text-align:right">{left}</mtd><mtd style="text-align:'
                   f'left"><mrow>{mid}{"".join(cells)}</mrow></mtd></mtr>')
    return ('<math xmlns="http://www.w3.org/1998/Math/MathML" display="block">'
            f'<mtable displaystyle="true">{"".join(trs)}</mtable></math>')


def _flat(sections: list[Section]):
    for s in sections:
        yield s, True
        for b in s.blocks:
            if isinstance(b, Section):
                yield b, True
                yield from ((x, False) for x in b.blocks)
            else:
                yield b, False


_CSS = """body{font-family:system-ui,sans-serif;max-width:70rem;margin:2rem auto;
padding:0 1rem;line-height:1.45;color:#222}
table{border-collapse:collapse;margin:.6rem 0}td,th{border:1px solid #ccc;
padding:.2rem .5rem;vertical-align:top;text-align:left}th{background:#f3f3f3}
.eq{display:flex;align-items:center;overflow-x:auto;overflow-y:hidden;margin:.3rem 0;
padding:.2rem 0}
.eq math{flex:1;text-align:left}.tag{color:#777;padding-left:1rem}
pre{font-size:.8rem;line-height:1;overflow-x:auto}math[display=block]{margin:.2rem 0}"""


def _html_cell(c) -> str:
    if isinstance(c, Math):
        return readable.mathml_line(c.expr, display="inline")
    if isinstance(c, Code):
        return f"<code>{html.escape(c.text)}</code>"
    return html.escape(str(c))


def render_html(title: str, sections: list[Section]) -> str:
    """A standalone HTML page: MathML, inline CSS, no script, no link."""
    out = ['<!DOCTYPE html>', '<html lang="en"><head><meta charset="utf-8">',
           f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
           f"<h1>{html.escape(title)}</h1>"]
    return "\n".join(out + _html_blocks(sections) + ["</body></html>"]) + "\n"


#: the sections of the report that another page (the FMU's documentation)
#: takes over; it has its own about and variables sections
DERIVATION_SECTIONS = ("Equations", "How the runtime solves the model",
                       "Event indicators and modes", "Delays",
                       "Constraints on the parameters")


def html_fragment(model, *, level: int = 3) -> str:
    """The equations, how the runtime solves them, events, delays and
    constraints of ``model`` as an HTML fragment (MathML, its own scoped
    style, no script) for embedding in another page, headings from <h{level}>."""
    _, sections = document(model)
    kept = [Section(s.title, s.blocks, level) for s in sections
            if s.title in DERIVATION_SECTIONS]
    return (f'<div class="lf-derivation"><style>{_scoped_css(".lf-derivation")}</style>'
            + "\n".join(_html_blocks(kept)) + "</div>")


def _scoped_css(scope: str) -> str:
    """_CSS's rules (but the page's body rule) with every selector under ``scope``."""
    rules = []
    for rule in _CSS.replace("\n", "").split("}"):
        if "{" not in rule:
            continue
        selectors, body = rule.split("{", 1)
        if selectors.strip() == "body":
            continue
        scoped = ",".join(f"{scope} {sel.strip()}" for sel in selectors.split(","))
        rules.append(f"{scoped}{{{body}}}")
    return "".join(rules)


def _html_blocks(sections: list[Section]) -> list[str]:
    out = []
    for b, is_head in _flat(sections):
        if is_head:
            out.append(f"<h{b.level}>{html.escape(b.title)}</h{b.level}>")
        elif isinstance(b, str):
            out.append(f"<p>{html.escape(b)}</p>")
        elif isinstance(b, Table):
            out.append("<table><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in b.head)
                       + "</tr>")
            out += ["<tr>" + "".join(f"<td>{_html_cell(c)}</td>" for c in row) + "</tr>"
                    for row in b.rows]
            out.append("</table>")
        elif isinstance(b, Equations):
            out += [f'<div class="eq">{_mathml_display(e)}'
                    + (f'<span class="tag">({tag})</span>' if tag else "") + "</div>"
                    for e, tag in b.lines]
        elif isinstance(b, Pre):
            out.append(f"<pre>{html.escape(b.text)}</pre>")
    return out


def _md_text(s: str) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


def _md_cell(c) -> str:
    if isinstance(c, Math):
        return "$" + readable.to_latex(c.expr).replace("|", r"\vert ") + "$"
    if isinstance(c, Code):
        return f"`{c.text}`"
    return _md_text(c)


def render_md(title: str, sections: list[Section]) -> str:
    """Markdown with LaTeX math ($...$, $$...$$) for GitHub and Jupyter."""
    out = [f"# {title}", ""]
    for b, is_head in _flat(sections):
        if is_head:
            out += ["#" * b.level + " " + b.title, ""]
        elif isinstance(b, str):
            out += [b, ""]
        elif isinstance(b, Table):
            out += ["| " + " | ".join(b.head) + " |", "|" + "---|" * len(b.head)]
            out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b.rows]
            out.append("")
        elif isinstance(b, Equations):
            for e, tag in b.lines:
                out += ["$$", _latex_display(e) + (f" \\tag{{{tag}}}" if tag else ""), "$$", ""]
        elif isinstance(b, Pre):
            out += ["```", b.text, "```", ""]
    return "\n".join(out)


_TEX_SPECIAL = re.compile(r"([\\&%$#_{}~^])")
_TEX_REPL = {"\\": r"\textbackslash{}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}"}


#: characters of our text that pdflatex's utf8 input does not know, as LaTeX
_TEX_CHARS = {"\u2265": r"$\geq$", "\u2264": r"$\leq$", "\u2202": r"$\partial$",
              "\u207b\u00b9": r"$^{-1}$", "\u00d7": r"$\times$", "\u2212": "$-$",
              "\u2080": "$_0$", "\u00b7": r"$\cdot$", "\u2248": r"$\approx$",
              "\u00b1": r"$\pm$", "\u00b0": r"$^\circ$", "\u2192": r"$\to$",
              **{greek_unicode[n]: f"$\\{n}$" for n in greek_unicode
                 if n.isalpha() and n != "lamda" and len(greek_unicode[n]) == 1}}
_TEX_UNICODE = re.compile("|".join(re.escape(k) for k in sorted(_TEX_CHARS, key=len,
                                                                 reverse=True)))
_TEX_OTHER = re.compile(r"[^\x00-\xff]+")


def _tex_text(s: str) -> str:
    """Text with LaTeX's special characters escaped and symbols as math;
    other characters outside Latin-1 (e.g. CJK in a description: pdflatex
    has no font for them) are shown as [...]."""
    s = _TEX_SPECIAL.sub(lambda m: _TEX_REPL.get(m.group(1), "\\" + m.group(1)), str(s))
    s = _TEX_UNICODE.sub(lambda m: _TEX_CHARS[m.group(0)], s)
    s = re.sub(r"(\\_|\.)(?=[A-Za-z])", r"\1\\allowbreak{}", s)  # long dotted names wrap
    return _TEX_OTHER.sub(r"[\\ldots]", s)


def _tex_cell(c) -> str:
    if isinstance(c, Math):
        return f"${readable.to_latex(c.expr)}$"
    if isinstance(c, Code):
        return r"\texttt{%s}" % _tex_text(c.text)
    return _tex_text(c)


def render_tex(title: str, sections: list[Section]) -> str:
    """A LaTeX document (article, amsmath, longtable; needs pdflatex or lualatex)."""
    out = [r"\documentclass[10pt]{article}", r"\usepackage[margin=2cm]{geometry}",
           r"\usepackage{amsmath,amssymb,longtable}", r"\usepackage[T1]{fontenc}",
           r"\usepackage[utf8]{inputenc}", r"\allowdisplaybreaks",
           r"\title{%s}" % _tex_text(title), r"\date{}", r"\begin{document}", r"\maketitle"]
    for b, is_head in _flat(sections):
        if is_head:
            out.append(r"\%ssection*{%s}" % ("sub" * (b.level - 2), _tex_text(b.title)))
        elif isinstance(b, str):
            out += [_tex_text(b), ""]
        elif isinstance(b, Table):
            wide = len(b.head) - 3  # columns past the third wrap, sharing 60 % of the line
            wrap = (r"p{%.3f\linewidth}" % (0.6 / wide)) * wide if wide > 0 else ""
            out += [r"\begin{longtable}{%s}" % ("l" * min(len(b.head), 3) + wrap),
                    " & ".join(r"\textbf{%s}" % _tex_text(h) for h in b.head) + r" \\ \hline"]
            out += [" & ".join(_tex_cell(c) for c in row) + r" \\" for row in b.rows]
            out.append(r"\end{longtable}")
        elif isinstance(b, Equations):
            for e, tag in b.lines:
                out += [r"\begin{equation*}", _latex_display(e)
                        + (f" \\tag{{{tag}}}" if tag else ""), r"\end{equation*}"]
        elif isinstance(b, Pre):  # verbatim takes no Unicode: the sparsity's marks as x .
            text = b.text.replace("\u25a0", "x").replace("\u00b7", ".")
            out += [r"{\scriptsize\begin{verbatim}", text, r"\end{verbatim}}"]
    return "\n".join(out + [r"\end{document}"]) + "\n"


RENDERERS = {"html": render_html, "md": render_md, "tex": render_tex}


def report(model, fmt: str = "html") -> str:
    """The report of a declared model in format ``fmt`` (one of FORMATS)."""
    if fmt not in RENDERERS:
        raise ValueError(f"fmt = {fmt!r}; allowed: {', '.join(FORMATS)}")
    return RENDERERS[fmt](*document(model))


def main(argv=None, prog: str = "loomfmu inspect") -> int:
    ap = argparse.ArgumentParser(prog=prog, description="A model's equations as a machine "
                                 "designer reads them: HTML with MathML, Markdown with "
                                 "LaTeX, or LaTeX.")
    ap.add_argument("model", metavar="MODEL", choices=sorted(MODELS),
                    help=f"one of {', '.join(sorted(MODELS))}")
    ap.add_argument("--format", choices=FORMATS, default="html",
                    help="html (MathML), md (Markdown with LaTeX) or tex (default: html)")
    ap.add_argument("--out", type=Path, default=None,
                    help="file to write (default: MODEL.FORMAT in the working directory; "
                         "'-' prints to standard output)")
    args = ap.parse_args(argv)
    text = report(load_model(args.model), args.format)
    if str(args.out) == "-":
        sys.stdout.write(text)
        return 0
    path = args.out or Path(f"{args.model}.{args.format}")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    print(f"written: {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
