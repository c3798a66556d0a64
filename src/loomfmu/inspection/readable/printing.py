"""SymPy objects as LaTeX and presentation MathML (CasADi's 1/0 comparisons as
Iverson brackets, Piecewise as cases, entities as characters)."""
from __future__ import annotations

import re
from html.entities import html5

import sympy
from sympy.printing.latex import LatexPrinter
from sympy.printing.mathml import MathMLPresentationPrinter

from loomfmu.inspection.readable.convert import _indicator_cond
from loomfmu.inspection.readable.listing import Listing, listing


def _lines(lst: Listing) -> list[sympy.Eq]:
    pairs = lst.shared + lst.equations + lst.outputs + lst.events + lst.modes + lst.delays
    return [sympy.Eq(a, b, evaluate=False) for a, b in pairs]


def latex(model, *, min_ops: int = 3) -> str:
    """The model's :func:`listing` as LaTeX, one ``lhs = rhs`` per line
    (shared subexpressions, equations, outputs, event indicators, mode
    validity)."""
    return "\n".join(to_latex(line) for line in _lines(listing(model, min_ops=min_ops)))


class _Latex(LatexPrinter):
    """SymPy's LaTeX, with CasADi's 1/0 comparisons as Iverson brackets [c]."""

    def _print_Piecewise(self, expr):
        cond = _indicator_cond(expr)
        if cond is not None:
            return r"\left[%s\right]" % self._print(cond)
        rows = [r"%s & \text{if } %s" % (self._print(e), self._print(c))
                if c is not sympy.true else r"%s & \text{otherwise}" % self._print(e)
                for e, c in expr.args]
        return r"\begin{cases} %s \end{cases}" % r" \\ ".join(rows)


_LEFT = "text-align:left"  # MathML Core has no columnalign; browsers follow CSS


class _MathML(MathMLPresentationPrinter):
    """SymPy's presentation MathML, with Piecewise as cases and CasADi's 1/0
    comparisons as Iverson brackets [c]."""

    def _el(self, tag, *children, text=None, **attrs):
        el = self.dom.createElement(tag)
        for k, v in attrs.items():
            el.setAttribute(k, v)
        if text is not None:
            el.appendChild(self.dom.createTextNode(text))
        for c in children:
            el.appendChild(c)
        return el

    def _print_MatrixBase(self, m):
        """Entries in display style (SymPy's mtable inherits the script style:
        fractions came out at two thirds of the text's size)."""
        el = super()._print_MatrixBase(m)
        for table in el.getElementsByTagName("mtable"):
            table.setAttribute("displaystyle", "true")
        return el

    def _print_Piecewise(self, expr):
        cond = _indicator_cond(expr)
        if cond is not None:
            return self._el("mrow", self._el("mo", text="["), self._print(cond),
                            self._el("mo", text="]"))
        rows = []
        for e, c in expr.args:
            when = (self._el("mtext", text="otherwise") if c is sympy.true else
                    self._el("mrow", self._el("mtext", text="if\u00a0"), self._print(c)))
            rows.append(self._el("mtr", self._el("mtd", self._print(e), style=_LEFT),
                                 self._el("mtd", when, style=_LEFT)))
        return self._el("mrow", self._el("mo", text="{", stretchy="true", fence="true"),
                        self._el("mtable", *rows, columnalign="left"))


def to_latex(expr) -> str:
    """LaTeX of a SymPy object (model symbols as written, CasADi's 1/0
    comparisons as Iverson brackets)."""
    return _Latex().doprint(expr)


_ENTITY = re.compile(r"&([A-Za-z][A-Za-z0-9]*);")
_XML_ENTITIES = {"amp", "lt", "gt", "quot", "apos"}


def _entity_char(m: re.Match) -> str:
    """HTML named entities (``&InvisibleTimes;``, ``&pi;``) as the characters
    themselves, so each line is well-formed XML as well as HTML."""
    name = m.group(1)
    if name in _XML_ENTITIES or f"{name};" not in html5:
        return m.group(0)
    return html5[f"{name};"]


def mathml_body(expr) -> str:
    """The presentation MathML of a SymPy object, without the ``<math>`` element
    (minus signs as U+2212: SymPy writes the hyphen, which browsers draw short)."""
    return _ENTITY.sub(_entity_char, _MathML().doprint(expr)).replace("<mo>-</mo>",
                                                                     "<mo>\u2212</mo>")


def mathml_line(expr, *, display: str = "block") -> str:
    """One SymPy expression or equation as a MathML ``<math>`` element;
    display: "block" (a line of its own) or "inline" (within text)."""
    if display not in ("block", "inline"):
        raise ValueError(f"display = {display!r}; allowed: 'block', 'inline'")
    return (f'<math xmlns="http://www.w3.org/1998/Math/MathML" display="{display}">'
            f"{mathml_body(expr)}</math>")


def mathml(model, *, min_ops: int = 3) -> str:
    """The model's :func:`listing` as presentation MathML, one
    ``<math display="block">`` element per line."""
    return "\n".join(mathml_line(line) for line in _lines(listing(model, min_ops=min_ops)))
