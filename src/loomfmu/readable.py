"""The declaration's CasADi expressions in readable form: SymPy, LaTeX, MathML.

CasADi prints an SX expression as a chain of ``@1=...`` temporaries and has
no LaTeX printer; no maintained CasADi-to-SymPy bridge exists.  This module
reads an expression through CasADi's function instruction interface
(``Function.instruction_id/_input/_output/_constant``) and rebuilds it in
SymPy, one instruction at a time, with the table :data:`OPS` (an op this
table does not know raises ``ValueError`` naming it).

Symbols keep the model's own names (``sympy.Symbol.name`` is the variable's
name, e.g. ``"der(phi)"`` or ``"n3.vax"``) and print the way a machine
designer writes them: ``der(phi)`` as :math:`\\dot{\\phi}`, ``alpha1`` as
:math:`\\alpha_1`, ``T_min`` as :math:`T_{\\mathrm{min}}`, ``n3.vx`` as
:math:`v_{x,\\mathrm{n3}}`, ``delay(u)`` as :math:`u^{\\mathrm{del}}`.

The front door::

    from loomfmu import load_model
    from loomfmu import readable
    m = load_model("backrest")
    readable.equations(m)        # [(lhs, rhs), ...] as SymPy, lhs - rhs = 0
    readable.outputs(m)          # [(y, expr), ...]
    lst = readable.listing(m)    # shared subexpressions named once (sympy.cse)
    print(readable.latex(m))     # one LaTeX line per definition / equation
    html = readable.mathml(m)    # one <math display="block"> per line

:func:`to_sympy` converts any SX expression (e.g. an event indicator).
"""
from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field
from fractions import Fraction
from html.entities import html5

import casadi as ca
import sympy
from sympy.core.parameters import distribute
from sympy.printing.latex import LatexPrinter
from sympy.printing.mathml import MathMLPresentationPrinter
from sympy.printing.pretty.pretty_symbology import greek_unicode

__all__ = ["OPS", "Var", "Shared", "Listing", "latex_name", "to_sympy", "symbols",
           "equations", "outputs", "events", "mode_rules", "delays", "listing", "latex", "mathml",
           "mathml_line", "mathml_body", "to_latex"]

# -- names ---------------------------------------------------------------------

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
        return latex_name(self.name)

    def _mathml_presentation(self, printer):
        return _mathml_name(self.name, printer.dom)


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


# -- the op table ----------------------------------------------------------------

def _constant(v: float) -> sympy.Expr:
    """Rationals (denominator up to 100 000) and their multiples of pi or 1/pi
    that round to this very double print as such; other constants as floats
    (the same double; printed to 15 digits)."""
    if not math.isfinite(v):
        return {math.inf: sympy.oo, -math.inf: -sympy.oo}.get(v, sympy.nan)
    for unit, factor in ((1.0, sympy.Integer(1)), (math.pi, sympy.pi),
                         (1 / math.pi, 1 / sympy.pi)):
        frac = Fraction(v / unit).limit_denominator(100_000)
        if frac and float(frac) * unit == v or (not frac and v == 0.0):
            return sympy.Rational(frac.numerator, frac.denominator) * factor
    return sympy.Float(v, precision=53)  # the same double; prints 15 digits


def _indicator(cond) -> sympy.Expr:
    """CasADi's logical results are the numbers 1 and 0."""
    return sympy.Piecewise((1, cond), (0, True))


def _cond(e: sympy.Expr):
    """The condition a CasADi number stands for (nonzero is true)."""
    cond = _indicator_cond(e)
    return sympy.Ne(e, 0) if cond is None else cond


#: CasADi op code -> function of the SymPy arguments.  Names: casadi.OP_*.
OPS: dict[int, callable] = {
    ca.OP_ASSIGN: lambda a: a,
    ca.OP_ADD: lambda a, b: a + b,
    ca.OP_SUB: lambda a, b: a - b,
    ca.OP_MUL: lambda a, b: a * b,
    ca.OP_DIV: lambda a, b: a / b,
    ca.OP_NEG: lambda a: -a,
    ca.OP_TWICE: lambda a: 2 * a,
    ca.OP_SQ: lambda a: a**2,
    ca.OP_INV: lambda a: 1 / a,
    ca.OP_POW: lambda a, b: a**b,
    ca.OP_CONSTPOW: lambda a, b: a**b,
    ca.OP_SQRT: sympy.sqrt,
    ca.OP_EXP: sympy.exp,
    ca.OP_LOG: sympy.log,
    ca.OP_SIN: sympy.sin,
    ca.OP_COS: sympy.cos,
    ca.OP_TAN: sympy.tan,
    ca.OP_ASIN: sympy.asin,
    ca.OP_ACOS: sympy.acos,
    ca.OP_ATAN: sympy.atan,
    ca.OP_ATAN2: sympy.atan2,
    ca.OP_SINH: sympy.sinh,
    ca.OP_COSH: sympy.cosh,
    ca.OP_TANH: sympy.tanh,
    ca.OP_ASINH: sympy.asinh,
    ca.OP_ACOSH: sympy.acosh,
    ca.OP_ATANH: sympy.atanh,
    ca.OP_ERF: sympy.erf,
    ca.OP_FABS: sympy.Abs,
    ca.OP_SIGN: sympy.sign,
    ca.OP_FLOOR: sympy.floor,
    ca.OP_CEIL: sympy.ceiling,
    ca.OP_FMIN: sympy.Min,
    ca.OP_FMAX: sympy.Max,
    ca.OP_HYPOT: lambda a, b: sympy.sqrt(a**2 + b**2),
    ca.OP_LT: lambda a, b: _indicator(sympy.Lt(a, b)),
    ca.OP_LE: lambda a, b: _indicator(sympy.Le(a, b)),
    ca.OP_EQ: lambda a, b: _indicator(sympy.Eq(a, b)),
    ca.OP_NE: lambda a, b: _indicator(sympy.Ne(a, b)),
    ca.OP_NOT: lambda a: _indicator(sympy.Not(_cond(a))),
    ca.OP_AND: lambda a, b: _indicator(sympy.And(_cond(a), _cond(b))),
    ca.OP_OR: lambda a, b: _indicator(sympy.Or(_cond(a), _cond(b))),
    ca.OP_IF_ELSE_ZERO: lambda c, x: sympy.Piecewise((x, _cond(c)), (0, True)),
}

_OP_NAMES = {getattr(ca, n): n for n in dir(ca) if n.startswith("OP_")}


# -- conversion ------------------------------------------------------------------

def to_sympy(expr, symbols_by_name: dict[str, sympy.Symbol] | None = None, *,
             ops: dict[int, callable] | None = None):
    """The SymPy form of a CasADi SX expression.

    expr: a scalar SX (returns a ``sympy.Expr``) or a column (returns a list,
    one entry per row).  symbols_by_name: CasADi symbol name -> SymPy symbol;
    a name not in it becomes ``Var(name)``.  ops: the op table (default
    :data:`OPS`).  Raises ValueError naming an op the table does not cover.
    """
    expr = ca.SX(expr)
    if expr.size2() != 1:
        raise ValueError(f"expr: a {expr.size1()}x{expr.size2()} matrix; allowed: a "
                         "scalar or a column")
    ops = OPS if ops is None else ops
    syms = ca.symvar(expr)
    table = dict(symbols_by_name or {})
    args = [table.get(s.name()) or Var(s.name()) for s in syms]
    f = ca.Function("readable", [ca.vertcat(*syms) if syms else ca.SX(0, 1)], [expr])
    rows = f.sparsity_out(0).row()
    out: list[sympy.Expr] = [sympy.Integer(0)] * expr.size1()
    with distribute(False):  # keep c*(a + b) as CasADi has it (no expansion cascade)
        _run(f, ops, args, rows, out)
    return out[0] if expr.size1() == 1 else out


def _run(f: ca.Function, ops, args, rows, out) -> None:
    work: dict[int, sympy.Expr] = {}
    for k in range(f.n_instructions()):
        op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
        if op == ca.OP_INPUT:
            work[outs[0]] = args[ins[1]]
        elif op == ca.OP_OUTPUT:
            out[rows[outs[1]]] = work[ins[0]]
        elif op == ca.OP_CONST:
            work[outs[0]] = _constant(f.instruction_constant(k))
        elif op in ops:
            fn = ops[op]
            n_args = 2 if op in _BINARY else 1
            work[outs[0]] = fn(*(work[i] for i in ins[:n_args]))
        else:
            raise ValueError(f"CasADi operation {_OP_NAMES.get(op, op)} (code {op}) has no "
                             f"SymPy form in loomfmu.readable.OPS; supported: "
                             f"{', '.join(sorted(_OP_NAMES[o] for o in ops))}")


_BINARY = {ca.OP_ADD, ca.OP_SUB, ca.OP_MUL, ca.OP_DIV, ca.OP_POW, ca.OP_CONSTPOW,
           ca.OP_ATAN2, ca.OP_FMIN, ca.OP_FMAX, ca.OP_HYPOT, ca.OP_LT, ca.OP_LE,
           ca.OP_EQ, ca.OP_NE, ca.OP_AND, ca.OP_OR, ca.OP_IF_ELSE_ZERO, ca.OP_FMOD,
           ca.OP_COPYSIGN}


def symbols(model) -> dict[str, Var]:
    """Every symbol a model's expressions may use, by CasADi name: its
    variables, der(x) of each state, the delayed values and ``time``."""
    names = [v.name for v in model.variables]
    names += [f"der({v.name})" for v in model.of_kind("state")]
    names += [d.sym.name() for d in model.delays] + [model.t.name()]
    return {n: Var(n) for n in names}


def _unknowns(model) -> set[Var]:
    return {Var(f"der({v.name})") for v in model.of_kind("state")} | \
        {Var(v.name) for v in model.of_kind("algebraic")}


def _depends(e: sympy.Basic, targets: set, memo: dict) -> bool:
    """Whether ``e`` uses any of ``targets``, visiting each shared node once
    (``free_symbols`` walks the expression as a tree: exponential on a DAG)."""
    if e in memo:
        return memo[e]
    found = e in targets if e.is_Symbol else any(_depends(a, targets, memo) for a in e.args)
    memo[e] = found
    return found


def _split(residual: sympy.Expr, unknowns: set, memo: dict) -> tuple[sympy.Expr, sympy.Expr]:
    """lhs = rhs with the terms holding unknowns on the left, leading term positive."""
    terms = sympy.Add.make_args(residual)
    left = [t for t in terms if _depends(t, unknowns, memo)]
    right = [-t for t in terms if not _depends(t, unknowns, memo)]
    lhs, rhs = sympy.Add(*left), sympy.Add(*right)
    if left and all(t.could_extract_minus_sign() for t in left):
        lhs, rhs = -lhs, -rhs
    return lhs, rhs


def _convert(model, exprs: list) -> list[sympy.Expr]:
    """Each CasADi expression of the model in SymPy (one conversion pass)."""
    if not exprs:
        return []
    out = to_sympy(ca.vertcat(*[ca.SX(e) for e in exprs]), symbols(model))
    return out if isinstance(out, list) else [out]


def equations(model) -> list[tuple[sympy.Expr, sympy.Expr]]:
    """The model's equations as (lhs, rhs), lhs - rhs being the declared
    residual; terms with der(x) or algebraic unknowns are on the left."""
    unknowns, memo = _unknowns(model), {}
    return [_split(r, unknowns, memo) for r in _convert(model, model.equations)]


def outputs(model) -> list[tuple[Var, sympy.Expr]]:
    """Each output and its defining expression (which may use other outputs)."""
    outs = model.of_kind("output")
    return [(Var(v.name), e) for v, e in zip(outs, _convert(model, [v.expr for v in outs]))]


def events(model) -> list[tuple[Var, sympy.Expr]]:
    """Each event indicator (a symbol named as the event) and its expression."""
    exprs = _convert(model, [e.expr for e in model.events])
    return [(Var(e.name), x) for e, x in zip(model.events, exprs)]


def mode_rules(model) -> list[tuple[Var, sympy.Expr]]:
    """Each mode and its validity expression (>= 0 where the mode's value holds)."""
    modes = [v for v in model.of_kind("mode") if v.name in model.mode_valid]
    exprs = _convert(model, [model.mode_valid[v.name] for v in modes])
    return [(Var(v.name), x) for v, x in zip(modes, exprs)]


def delays(model) -> list[tuple[Var, sympy.Expr]]:
    """Each delayed value's symbol and the expression it delays (taken tau ago)."""
    exprs = _convert(model, [d.expr for d in model.delays])
    return [(Var(d.sym.name()), x) for d, x in zip(model.delays, exprs)]


@dataclass
class Listing:
    """What the reports print: ``shared`` subexpressions (:class:`Shared`
    symbol, definition; each defined before its first use), then the
    ``equations`` (lhs, rhs), the ``outputs``, the ``events`` (indicator
    expressions), the ``modes`` (validity expressions) and the ``delays``
    (delayed expressions), each (symbol, expression), all written with the
    shared names."""

    shared: list[tuple[Shared, sympy.Expr]]
    equations: list[tuple[sympy.Expr, sympy.Expr]]
    outputs: list[tuple[Var, sympy.Expr]]
    events: list[tuple[Var, sympy.Expr]] = field(default_factory=list)
    modes: list[tuple[Var, sympy.Expr]] = field(default_factory=list)
    delays: list[tuple[Var, sympy.Expr]] = field(default_factory=list)


#: a named subexpression shorter than this (characters of ``str``) is not worth a name
_MIN_LIFT = 40


def _lift(e, max_len: int, defs: list, temps) -> sympy.Basic:
    """``e`` with its longest subexpressions named (appended to ``defs``,
    innermost first) until every line is at most ``max_len`` characters of
    ``str`` where that can be done."""
    if e.is_Atom or len(str(e)) <= max_len:
        return e
    args = [_lift(a, max_len, defs, temps) for a in e.args]
    if args != list(e.args):
        e = e.func(*args)
    while len(str(e)) > max_len:
        candidates = [a for a in e.args if isinstance(a, sympy.Expr) and not a.is_Atom
                      and len(str(a)) > _MIN_LIFT]
        if not candidates:
            break
        big = max(candidates, key=lambda a: len(str(a)))
        t = next(temps)
        defs.append((t, big))
        e = e.xreplace({big: t})
    return e


def listing(model, *, min_ops: int = 3, max_len: int | None = 240) -> Listing:
    """The model's equations, outputs, event indicators, mode rules and
    delayed expressions, with shared subexpressions named once (sympy.cse).

    min_ops: a repeated subexpression with fewer operations than this (e.g.
    ``sin(phi)``) is written out where it is used rather than named.
    max_len: a line longer than this (characters of SymPy's ``str``, a rough
    measure of printed width) has its longest subexpressions named too, even
    when used once, so that it fits a page; None keeps long lines whole.
    """
    if not isinstance(min_ops, int) or min_ops < 0:
        raise ValueError(f"min_ops = {min_ops!r}; allowed: an integer >= 0")
    if max_len is not None and (not isinstance(max_len, int) or max_len < 2 * _MIN_LIFT):
        raise ValueError(f"max_len = {max_len!r}; allowed: None or an integer >= "
                         f"{2 * _MIN_LIFT}")
    eqs = equations(model)
    named = [outputs(model), events(model), mode_rules(model), delays(model)]
    flat = [e for pair in eqs for e in pair] + [e for group in named for _, e in group]
    with distribute(False):  # rebuilding c*(a + b) must not expand it
        kept, reduced = _shared(flat, min_ops, max_len)
    names = {sym: Shared(f"xi{k}") for k, (sym, _) in enumerate(kept, 1)}
    with distribute(False):
        shared = [(names[s], d.xreplace(names)) for s, d in kept]
        reduced = [e.xreplace(names) for e in reduced]
    n = 2 * len(eqs)
    rest = iter(reduced[n:])
    groups = [[(y, next(rest)) for y, _ in group] for group in named]
    return Listing(shared, list(zip(reduced[0:n:2], reduced[1:n:2])), *groups)


def _shared(flat: list, min_ops: int, max_len: int | None):
    """(definitions in order of use, reduced expressions), with temporary symbols."""
    temps = (sympy.Symbol(f"_cse{k}") for k in itertools.count())
    repl, reduced = sympy.cse(flat, symbols=temps, order="none")
    inline: dict = {}
    kept = []
    for sym, definition in repl:
        definition = definition.xreplace(inline)
        if sympy.count_ops(definition) < min_ops:
            inline[sym] = definition
        else:
            kept.append((sym, definition))
    reduced = [e.xreplace(inline) for e in reduced]
    if max_len is None:
        return kept, reduced
    lifted = (sympy.Symbol(f"_lift{k}") for k in itertools.count())
    defs: list = []
    for sym, definition in kept:
        definition = _lift(definition, max_len, defs, lifted)
        defs.append((sym, definition))
    out = [_lift(e, max_len, defs, lifted) for e in reduced]
    return defs, out


def _lines(lst: Listing) -> list[sympy.Eq]:
    pairs = lst.shared + lst.equations + lst.outputs + lst.events + lst.modes + lst.delays
    return [sympy.Eq(a, b, evaluate=False) for a, b in pairs]


def latex(model, *, min_ops: int = 3) -> str:
    """The model's :func:`listing` as LaTeX, one ``lhs = rhs`` per line
    (shared subexpressions, equations, outputs, event indicators, mode
    validity)."""
    return "\n".join(to_latex(line) for line in _lines(listing(model, min_ops=min_ops)))


def _indicator_cond(e):
    """The condition of ``Piecewise((1, c), (0, True))`` (CasADi's 1/0 of a
    comparison), else None."""
    if isinstance(e, sympy.Piecewise) and len(e.args) == 2 and e.args[0].expr == 1 \
            and e.args[1].expr == 0 and e.args[1].cond is sympy.true:
        return e.args[0].cond
    return None


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
    """The presentation MathML of a SymPy object, without the ``<math>`` element."""
    return _ENTITY.sub(_entity_char, _MathML().doprint(expr))


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
