"""A model's equations, outputs, events, modes and delays in SymPy, with
shared subexpressions named once (:func:`listing`)."""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import casadi as ca
import sympy
from sympy.core.parameters import distribute

from loomfmu.inspection.readable.convert import symbols, to_sympy
from loomfmu.inspection.readable.names import Shared, Var


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

