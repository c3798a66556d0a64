"""A model's expressions written with its derivation's named quantities.

A named quantity (``Model.quantity``) is kept for reading; the equations are
built from the same CasADi expressions, so a quantity's expression node
(an energy, a tension, an entry of a stiffness matrix) is very often a node
of an equation too.  :func:`to_sympy_named` converts expressions as
:func:`~loomfmu.inspection.readable.convert.to_sympy` does, but where the
instruction stream computes a node that is a named quantity (a scalar, or
an entry of a matrix quantity small enough that the derivation prints its
entries), the SymPy form takes the quantity's symbol instead of its
expression.  The match is by node identity, not by the form of the
expression: an equation shows a quantity's symbol exactly where the
declaration used that quantity, and substituting the definitions back gives
the declared expression.  (Merging structurally equal nodes first would
be wrong for a reader: the heald frame's M_y2 = M_x2 = m_l/2 would print
as the other plane's mass, a symmetric C_21 in place of C_12.)  Each definition is itself written with the
quantities computed before it.
"""
from __future__ import annotations

import casadi as ca
import sympy
from sympy.core.parameters import distribute

from loomfmu.inspection.readable.convert import _BINARY, _OP_NAMES, OPS, _constant, symbols
from loomfmu.inspection.readable.names import Var
from loomfmu.inspection.readable.quantity_forms import (
    ENTRY_VOCABULARY,
    QuantitySymbol,
    entry_symbol,
)


def named_nodes(model) -> list[tuple[ca.SX, QuantitySymbol]]:
    """(expression node, symbol) of every quantity or small-matrix entry that
    can stand for part of an equation: declaration order, column-major
    entries; a variable, a number or a structural zero is not named."""
    out = []
    for q in model.quantities:
        expr = ca.SX(q.expr)
        n1, n2 = expr.shape
        if expr.numel() != 1 and max(n1, n2) > ENTRY_VOCABULARY:
            continue  # printed as a picture or a table of values: no symbol per entry
        sym = QuantitySymbol(q.name, q.symbol)
        for j in range(n2):
            for i in range(n1):
                e = expr[i, j]
                if e.nnz() == 0 or e.is_constant() or e.is_symbolic():
                    continue
                out.append((e, sym if (n1, n2) == (1, 1) else
                            entry_symbol(sym, i, j, (n1, n2))))
    return out


def to_sympy_named(model, exprs: list) -> tuple[list[sympy.Expr],
                                               list[tuple[QuantitySymbol, sympy.Expr]]]:
    """The SymPy forms of the CasADi expressions ``exprs`` (scalars) of
    ``model``, written with its named quantities, and the definitions of the
    quantity symbols they use (each written with the earlier ones, in the
    order computed): ``(forms, [(symbol, definition), ...])``."""
    if not exprs:
        return [], []
    named = named_nodes(model)
    body = ca.vertcat(*[ca.SX(e) for e in exprs])
    nodes = ca.vertcat(*[e for e, _ in named]) if named else ca.SX(0, 1)
    syms = ca.symvar(ca.vertcat(body, nodes))
    table = symbols(model)
    args = [table.get(s.name()) or Var(s.name()) for s in syms]
    f = ca.Function("named", [ca.vertcat(*syms) if syms else ca.SX(0, 1)], [nodes, body],
                    {"live_variables": False})  # one work slot per node: its identity
    rows = f.sparsity_out(1).row()
    by_slot: dict[int, QuantitySymbol] = {}
    for k in range(f.n_instructions()):
        if f.instruction_id(k) == ca.OP_OUTPUT and f.instruction_output(k)[0] == 0:
            slot, nz = f.instruction_input(k)[0], f.instruction_output(k)[1]
            by_slot.setdefault(slot, named[nz][1])  # two names of one node: the first
    out: list[sympy.Expr] = [sympy.Integer(0)] * body.numel()
    defs: dict[QuantitySymbol, sympy.Expr] = {}
    work: dict[int, sympy.Expr] = {}
    with distribute(False):
        for k in range(f.n_instructions()):
            op, ins, outs = f.instruction_id(k), f.instruction_input(k), \
                f.instruction_output(k)
            if op == ca.OP_INPUT:
                value = args[ins[1]]
            elif op == ca.OP_OUTPUT:
                if outs[0] == 1:
                    out[rows[outs[1]]] = work[ins[0]]
                continue
            elif op == ca.OP_CONST:
                value = _constant(f.instruction_constant(k))
            elif op in OPS:
                value = OPS[op](*(work[i] for i in ins[:2 if op in _BINARY else 1]))
            else:
                raise ValueError(f"CasADi operation {_OP_NAMES.get(op, op)} (code {op}) has "
                                 "no SymPy form in loomfmu.inspection.readable.OPS")
            slot = outs[0]
            if slot in by_slot and op not in (ca.OP_INPUT, ca.OP_CONST):
                defs[by_slot[slot]] = value
                value = by_slot[slot]
            work[slot] = value
    used = _used(out, defs)
    return out, [(s, d) for s, d in defs.items() if s in used]


def _used(forms: list, defs: dict) -> set:
    """The symbols of ``defs`` that ``forms`` use, directly or through other
    definitions."""
    seen: set = set()
    visited: set = set()
    todo = list(forms)
    while todo:  # each node once: a DAG walked as a tree is exponential
        e = todo.pop()
        if e in visited:
            continue
        visited.add(e)
        if e in defs and e not in seen:
            seen.add(e)
            todo.append(defs[e])
        todo += e.args
    return seen
