"""Model variable names as a machine designer writes them: LaTeX, MathML.

``der(phi)`` prints as :math:`\\dot{\\phi}`, ``alpha1`` as :math:`\\alpha_1`,
``T_min`` as :math:`T_{\\mathrm{min}}`, ``n3.vx`` as :math:`v_{x,\\mathrm{n3}}`,
``delay(u)`` as :math:`u^{\\mathrm{del}}`.  :class:`Var` is a SymPy symbol
that prints so; :class:`Shared` names a shared subexpression.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import sympy
from sympy.printing.pretty.pretty_symbology import greek_unicode

_GREEK = {n for n in greek_unicode if n.isalpha() and n.lower() != "lamda"}
_ALIAS = {"eps": "epsilon"}
_ACCENTS = {"dot": 1, "ddot": 2}
_LATEX_ACCENT = {1: r"\dot", 2: r"\ddot", 3: r"\dddot"}
_MATHML_ACCENT = {1: "\u02d9", 2: "\u00a8", 3: "\u20db"}


@dataclass(frozen=True)
class _Name:
    """A variable name taken apart for printing: ``base`` (letters, or
    ``d`` + a Greek name), ``accent`` (time derivatives), subscripts and
    superscripts (each a string)."""

    base: str
    accent: int = 0
    subs: tuple[str, ...] = ()
    sups: tuple[str, ...] = ()


def _parse(name: str) -> _Name:
    if name == "time":
        return _Name("t")
    m = re.fullmatch(r"der\((.+)\)", name)
    if m:
        inner = _parse(m.group(1))
        return _Name(inner.base, inner.accent + 1, inner.subs, inner.sups)
    m = re.fullmatch(r"delay\((.+)\)", name)
    if m:
        inner = _parse(m.group(1))
        return _Name(inner.base, inner.accent, inner.subs, inner.sups + ("del",))
    if "." in name:  # a node's variable: "n3.vax" -> v_{ax,n3}
        owner, last = name.rsplit(".", 1)
        inner = _parse(last)
        return _Name(inner.base, inner.accent, inner.subs + (owner,), inner.sups)
    head, *subs = name.split("_")
    accent = 0
    while subs and subs[-1] in _ACCENTS:          # "h_ddot" -> h with two dots
        accent += _ACCENTS[subs.pop()]
    m = re.fullmatch(r"([A-Za-z]+?)(\d\w*)", head)  # "alpha1", "M1f", "x1"
    if m and (_is_word(m.group(1)) or len(m.group(1)) <= 2):
        head, subs = m.group(1), [m.group(2), *subs]
    m = re.fullmatch(r"v(a?[xy])", head)           # velocities "vx", "vay"
    if m:
        head, subs = "v", [m.group(1), *subs]
    return _Name(_ALIAS.get(head, head), accent, tuple(s for s in subs if s))


def _is_word(s: str) -> bool:
    """A Greek name, an alias of one, or ``d`` + a Greek name (``dphi``)."""
    return s in _GREEK or s in _ALIAS or (s[:1] == "d" and s[1:] in _GREEK)


def _latex_word(s: str, *, sub: bool) -> str:
    s = _ALIAS.get(s, s)
    if s in _GREEK:
        return "\\" + ("varepsilon" if s == "epsilon" else s)
    if len(s) > 1 and s[0] == "d" and s[1:] in _GREEK:
        return "d\\" + s[1:]
    if len(s) <= 1 or s.isdigit():
        return s
    if sub or not s.isalpha():
        return r"\mathrm{%s}" % s
    return r"\mathit{%s}" % s


def latex_name(name: str) -> str:
    """LaTeX for a model variable name (e.g. ``der(phi)`` -> ``\\dot{\\phi}``)."""
    n = _parse(name)
    out = _latex_word(n.base, sub=False)
    if n.accent:
        out = "%s{%s}" % (_LATEX_ACCENT[min(n.accent, 3)], out)
    if n.subs:
        out += "_{%s}" % ",".join(_latex_word(s, sub=True) for s in n.subs)
    if n.sups:
        out += "^{%s}" % ",".join(_latex_word(s, sub=True) for s in n.sups)
    return out


def _unicode_word(s: str) -> str:
    s = _ALIAS.get(s, s)
    if s in _GREEK:
        return greek_unicode[s]
    if len(s) > 1 and s[0] == "d" and s[1:] in _GREEK:
        return "d" + greek_unicode[s[1:]]
    return s


def _mathml_name(name: str, dom):
    def mi(text, *, sub):
        el = dom.createElement("mi")
        word = _unicode_word(text)
        if len(word) > 1 and not sub and not word.isdigit():
            el.setAttribute("mathvariant", "italic")
        el.appendChild(dom.createTextNode(word))
        return el

    def joined(words):
        if len(words) == 1:
            return mi(words[0], sub=True)
        row = dom.createElement("mrow")
        for k, w in enumerate(words):
            if k:
                comma = dom.createElement("mo")
                comma.setAttribute("separator", "true")
                comma.appendChild(dom.createTextNode(","))
                row.appendChild(comma)
            row.appendChild(mi(w, sub=True))
        return row

    n = _parse(name)
    base = mi(n.base, sub=False)
    if n.accent:
        over = dom.createElement("mover")
        over.setAttribute("accent", "true")
        mark = dom.createElement("mo")
        mark.appendChild(dom.createTextNode(_MATHML_ACCENT[min(n.accent, 3)]))
        over.appendChild(base)
        over.appendChild(mark)
        base = over
    tag = {(False, False): None, (True, False): "msub", (False, True): "msup",
           (True, True): "msubsup"}[(bool(n.subs), bool(n.sups))]
    if tag is None:
        return base
    el = dom.createElement(tag)
    el.appendChild(base)
    for words in (n.subs, n.sups):
        if words:
            el.appendChild(joined(words))
    return el


class Var(sympy.Symbol):
    """A model variable as a SymPy symbol: ``name`` is the model's name (so
    symbols stay distinct however they print); LaTeX and MathML print it the
    way the equations are written (see :func:`latex_name`)."""

    def _latex(self, printer):
        if _is_long_word(self.name):  # "fill m_y", not "fillm_y"
            return r"{\,%s\,}" % latex_name(self.name)
        return latex_name(self.name)

    def _mathml_presentation(self, printer):
        el = _mathml_name(self.name, printer.dom)
        if not _is_long_word(self.name):
            return el
        row = printer.dom.createElement("mrow")
        for child in ("mspace", el, "mspace"):
            if child == "mspace":
                child = printer.dom.createElement("mspace")
                child.setAttribute("width", "0.25em")
            row.appendChild(child)
        return row


def _is_long_word(name: str) -> bool:
    """Whether the name's base prints as a word of several Latin letters
    (``fill``, ``letoff``): it gets a thin space either side, so that a
    product of names reads as one."""
    base = _parse(name).base
    return len(base) > 1 and base.isalpha() and not _is_word(base)


class Shared(sympy.Symbol):
    """A named shared subexpression (:math:`\\xi_k`) of a :class:`Listing`."""

    def _latex(self, printer):
        return r"\xi_{%s}" % self.name.removeprefix("xi")

    def _mathml_presentation(self, printer):
        dom = printer.dom
        el, base, sub = (dom.createElement(t) for t in ("msub", "mi", "mn"))
        base.appendChild(dom.createTextNode(greek_unicode["xi"]))
        sub.appendChild(dom.createTextNode(self.name.removeprefix("xi")))
        el.appendChild(base)
        el.appendChild(sub)
        return el

