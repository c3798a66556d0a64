"""The inspect reports' small document model (sections, paragraphs, tables,
display equations, pictures) and its three renderers: HTML with MathML (no
script, no network), Markdown with LaTeX for GitHub and Jupyter, LaTeX."""
from __future__ import annotations

import html
import re
from dataclasses import dataclass, field

import sympy
from sympy.printing.pretty.pretty_symbology import greek_unicode

from loomfmu.inspection import readable

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
class Para:
    """A paragraph of text (str), inline math (:class:`Math`) and code."""
    parts: list


@dataclass
class Def:
    """A display definition ``lhs = rhs`` whose right side SymPy's ``Eq``
    cannot hold (a matrix)."""
    lhs: object
    rhs: object


@dataclass
class Picture:
    """A figure: ``svg`` (inline SVG for HTML) and ``text``, the same picture
    in characters for Markdown and LaTeX; ``caption`` below both."""
    svg: str
    text: str
    caption: str = ""


@dataclass
class Section:
    title: str
    blocks: list = field(default_factory=list)
    level: int = 2



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
    if isinstance(e, Def):
        return readable.to_latex(e.lhs) + " = " + readable.to_latex(e.rhs)
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
    if isinstance(e, Def):
        return ('<math xmlns="http://www.w3.org/1998/Math/MathML" display="block"><mrow>'
                f"{readable.mathml_body(e.lhs)}<mo>=</mo>{readable.mathml_body(e.rhs)}"
                "</mrow></math>")
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
pre{font-size:.8rem;line-height:1;overflow-x:auto}math[display=block]{margin:.2rem 0}
.qty{margin:1rem 0 .2rem}.qty .unit{color:#555}.qty .src{color:#666;font-size:.9em}
nav.toc{margin:.5rem 0 1rem}figure{margin:.5rem 0}figcaption{color:#555;font-size:.9em}
math{font-size:1.12em}"""


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
           f"<h1>{html.escape(title)}</h1>",
           '<nav class="toc">' + " \u00b7 ".join(
               f'<a href="#{_anchor(s.title)}">{html.escape(s.title)}</a>' for s in sections)
           + "</nav>"]
    return "\n".join(out + _html_blocks(sections) + ["</body></html>"]) + "\n"


def _anchor(title: str) -> str:
    """The id of a top-level section's heading (prefixed: the fragment lives in
    other pages too)."""
    return "lf-" + re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-")


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
            anchor = f' id="{_anchor(b.title)}"' if b.level == 2 else ""
            out.append(f"<h{b.level}{anchor}>{html.escape(b.title)}</h{b.level}>")
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
        elif isinstance(b, Para):
            out.append('<p class="qty">' + "".join(_html_cell(c) for c in b.parts) + "</p>")
        elif isinstance(b, Picture):
            out.append(f"<figure>{b.svg}<figcaption>{html.escape(b.caption)}"
                       "</figcaption></figure>")
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
        elif isinstance(b, Para):
            out += ["".join(_md_cell(c) for c in b.parts), ""]
        elif isinstance(b, Picture):
            out += ["```", b.text, "```", "", _md_text(b.caption), ""]
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
        elif isinstance(b, (Pre, Picture)):  # verbatim takes no Unicode: marks as x .
            text = b.text.replace("\u25a0", "x").replace("\u00b7", ".")
            out += [r"{\scriptsize\begin{verbatim}", text, r"\end{verbatim}}"]
            if isinstance(b, Picture) and b.caption:
                out += [_tex_text(b.caption), ""]
        elif isinstance(b, Para):
            out += ["".join(_tex_cell(c) for c in b.parts), ""]
    return "\n".join(out + [r"\end{document}"]) + "\n"


RENDERERS = {"html": render_html, "md": render_md, "tex": render_tex}

