"""A model's equations, outputs, events, modes and delays in SymPy, with
shared subexpressions named once (:func:`listing`)."""
from __future__ import annotations

import itertools
import re
from dataclasses import dataclass, field

import casadi as ca
import sympy
from sympy.core.parameters import distribute

from loomfmu.inspection.readable.convert import symbols, to_sympy
from loomfmu.inspection.readable.named import _used, to_sympy_named
from loomfmu.inspection.readable.names import Shared, Var
from loomfmu.inspection.readable.quantity_forms import entry_symbols, quantities_written


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
    derivation's named quantities (``named``) and the shared names."""

    shared: list[tuple[Shared, sympy.Expr]]
    equations: list[tuple[sympy.Expr, sympy.Expr]]
    outputs: list[tuple[Var, sympy.Expr]]
    events: list[tuple[Var, sympy.Expr]] = field(default_factory=list)
    modes: list[tuple[Var, sympy.Expr]] = field(default_factory=list)
    delays: list[tuple[Var, sympy.Expr]] = field(default_factory=list)
    #: the derivation's quantity symbols these use, with their definitions
    #: (each written with the earlier ones; the reports print them in the
    #: derivation, the round-trip test evaluates them)
    named: list[tuple[sympy.Symbol, sympy.Expr]] = field(default_factory=list)


#: a named subexpression shorter than this (characters of ``str``) is not worth a name
_MIN_LIFT = 40
#: characters of a line besides its right side ("Eq(xi123, " and ")"): a line
#: fits max_len when its right side fits max_len less this
_EQ_ROOM = 20


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


def listing(model, *, min_ops: int = 3, max_len: int | None = 240,
            named: bool = True) -> Listing:
    """The model's equations, outputs, event indicators, mode rules and
    delayed expressions, with shared subexpressions named once (sympy.cse).

    min_ops: a repeated subexpression with fewer operations than this (e.g.
    ``sin(phi)``) is written out where it is used rather than named.
    max_len: a line longer than this (characters of SymPy's ``str``, a rough
    measure of printed width) has its longest subexpressions named too, even
    when used once, so that it fits a page; None keeps long lines whole.
    named: write the expressions with the derivation's named quantities
    where the declaration used them (:mod:`.named`; their definitions are
    ``Listing.named``); the shared subexpressions name only what is left.
    """
    if not isinstance(min_ops, int) or min_ops < 0:
        raise ValueError(f"min_ops = {min_ops!r}; allowed: an integer >= 0")
    if max_len is not None and (not isinstance(max_len, int) or max_len < 2 * _MIN_LIFT):
        raise ValueError(f"max_len = {max_len!r}; allowed: None or an integer >= "
                         f"{2 * _MIN_LIFT}")
    outs = model.of_kind("output")
    modes = [v for v in model.of_kind("mode") if v.name in model.mode_valid]
    heads = [[Var(v.name) for v in outs], [Var(e.name) for e in model.events],
             [Var(v.name) for v in modes], [Var(d.sym.name()) for d in model.delays]]
    eq_rows = _rows(model.equations)  # a vector equation is one equation per row
    exprs = eq_rows + [v.expr for v in outs] + [e.expr for e in model.events] \
        + [model.mode_valid[v.name] for v in modes] + [d.expr for d in model.delays]
    if named and model.quantities:
        forms, defs = to_sympy_named(model, exprs)
    else:
        forms, defs = _convert(model, exprs), []
    dmap = dict(defs)
    unknowns, memo = _unknowns(model), {}
    for sym, d in defs:  # in the order computed: a symbol's definition uses earlier ones
        if _depends(d, unknowns, memo):
            unknowns.add(sym)
    n_eq = len(eq_rows)
    opener = _Opener(model, dmap)
    with distribute(False):
        eqs = [_equation(r, opener, unknowns, memo) for r in forms[:n_eq]]
        rest = iter(forms[n_eq:])
        named_groups = [[(y, _opened(y, next(rest), opener)) for y in ys] for ys in heads]
    flat = [e for pair in eqs for e in pair] + [e for g in named_groups for _, e in g]
    with distribute(False):  # rebuilding c*(a + b) must not expand it
        kept, reduced = _shared(flat, min_ops, max_len)
    names = {sym: Shared(f"xi{k}") for k, (sym, _) in enumerate(kept, 1)}
    with distribute(False):
        shared = [(names[s], d.xreplace(names)) for s, d in kept]
        reduced = [e.xreplace(names) for e in reduced]
    n = 2 * len(eqs)
    rest = iter(reduced[n:])
    groups = [[(y, next(rest)) for y, _ in group] for group in named_groups]
    used = _used(reduced + [d for _, d in shared], {**dmap, **opener.written})
    named = [(s, d) for s, d in opener.written.items() if s in used]
    named += [(s, d) for s, d in defs if s in used and s not in opener.written]
    return Listing(shared, list(zip(reduced[0:n:2], reduced[1:n:2])), *groups, named=named)


def _rows(exprs: list) -> list:
    """The scalar rows of a list of CasADi columns (structural zeros as 0)."""
    if not exprs:
        return []
    return ca.vertsplit(ca.densify(ca.vertcat(*[ca.SX(e) for e in exprs])))


class _Opener:
    """A quantity symbol's definition, for a line that would be just that
    symbol: the shorter (fewest operations) of the form the derivation prints
    (:func:`~.quantity_forms.quantities_written`, computed when first needed)
    and the declared one written with the quantities it uses."""

    def __init__(self, model, dmap: dict):
        self.model, self.dmap = model, dmap
        self.written: dict = {}  # the derivation's forms, once one is taken

    def single(self, e):
        """The named symbol that ``e`` is (times a number), else None."""
        if not isinstance(e, sympy.Expr):
            return None
        c, rest = e.as_coeff_Mul()
        return rest if rest in self.dmap and c.is_Number else None

    def open(self, e, sym):
        declared = self.dmap[sym]
        with distribute(True):  # simplify needs SymPy's usual rules
            forms = dict(entry_symbols(quantities_written(self.model)))
        derivation = forms.get(sym)
        if derivation is not None and sympy.count_ops(derivation) < sympy.count_ops(declared):
            self.written = forms
            declared = derivation
        return e.xreplace({sym: declared})


def _equation(residual, opener: _Opener, unknowns: set, memo: dict):
    """lhs = rhs of a residual written with named quantities; a side that is
    just one quantity's symbol (the whole equation a Lagrange row, a joint's
    friction law) is opened to its definition, which says what the equation is."""
    for _ in range(4):
        lhs, rhs = _split(residual, unknowns, memo)
        sym = opener.single(lhs) or opener.single(rhs)
        if sym is None:
            break
        residual = opener.open(residual, sym)
    return lhs, rhs


def _opened(y, e, opener: _Opener):
    """An output's (or indicator's) expression; opened one level where it is
    just a quantity that prints as the output itself (S_1 = S_1 says nothing)."""
    sym = opener.single(e)
    if sym is not None and _plain(sympy.latex(sym)) == _plain(sympy.latex(y)):
        return opener.open(e, sym)
    return e


def _plain(tex: str) -> str:
    return re.sub(r"[{}\s]|\\,", "", tex)


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
    room = max_len - _EQ_ROOM
    for sym, definition in kept:
        definition = _lift(definition, room, defs, lifted)
        defs.append((sym, definition))
    out = [_lift(e, room, defs, lifted) for e in reduced]
    return defs, out

