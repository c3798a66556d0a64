"""CasADi SX -> SymPy, one instruction at a time (the op table :data:`OPS`).

The expression is read through CasADi's function instruction interface
(``Function.instruction_id/_input/_output/_constant``); an op the table does
not know raises ``ValueError`` naming it.  :func:`to_sympy` takes a scalar or
a column, :func:`to_sympy_matrix` any shape.
"""
from __future__ import annotations

import math
from fractions import Fraction

import casadi as ca
import sympy
from sympy.core.parameters import distribute

from loomfmu.inspection.readable.names import Var


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


def _indicator_cond(e):
    """The condition of ``Piecewise((1, c), (0, True))`` (CasADi's 1/0 of a
    comparison), else None."""
    if isinstance(e, sympy.Piecewise) and len(e.args) == 2 and e.args[0].expr == 1 \
            and e.args[1].expr == 0 and e.args[1].cond is sympy.true:
        return e.args[0].cond
    return None



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
                             f"SymPy form in loomfmu.inspection.readable.OPS; supported: "
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



def to_sympy_matrix(expr, symbols_by_name: dict[str, sympy.Symbol] | None = None, *,
                    ops: dict[int, callable] | None = None) -> sympy.Matrix:
    """The SymPy matrix of a CasADi SX of any shape (same rows and columns;
    structural zeros are 0).  Arguments as :func:`to_sympy`."""
    expr = ca.SX(expr)
    n1, n2 = expr.size1(), expr.size2()
    if expr.numel() == 0:
        return sympy.zeros(n1, n2)
    flat = to_sympy(ca.vec(expr), symbols_by_name, ops=ops)
    flat = flat if isinstance(flat, list) else [flat]
    return sympy.Matrix(n1, n2, lambda i, j: flat[j * n1 + i])  # CasADi is column-major
