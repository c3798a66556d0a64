"""``loomfmu.inspect(model)``: a model's derivation for a notebook.

The named quantities a model keeps (``Model.quantity``: energies, generalized
forces, stiffness and mass matrices, ...) as SymPy objects and as numpy
arrays at chosen parameter values, beside the equations and the variables;
the same objects the reports (``loomfmu inspect MODEL``) print.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import sympy

from loomfmu.declare.model import Model, Quantity, Variable
from loomfmu.inspection import readable

__all__ = ["Inspection", "inspect", "evaluate"]


def _model(model) -> Model:
    if isinstance(model, Model):
        return model
    from loomfmu.registry import MODELS, load_model
    if isinstance(model, str) and model in MODELS:
        return load_model(model)
    raise ValueError(f"model = {model!r:.60}; allowed: a declared loomfmu.Model or a model "
                     f"name, one of {', '.join(sorted(MODELS))}")


def _symbol_names(model: Model) -> list[str]:
    return list(readable.symbols(model))


def _check_values(model: Model, values: dict) -> dict[str, float]:
    """``values`` checked: known symbol names, finite numbers within range."""
    allowed = _symbol_names(model)
    out = {}
    for name, v in values.items():
        if name not in allowed:
            raise ValueError(f"{name} = {v!r:.40}: not a symbol of model {model.name!r}; "
                             f"allowed: {', '.join(allowed)}")
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise ValueError(f"{name} = {v!r:.40}; allowed: a finite number") from None
        if name in (var.name for var in model.variables):
            model.var(name).check_value(x)
        elif not math.isfinite(x):
            raise ValueError(f"{name} = {v!r}; allowed: a finite number")
        out[name] = x
    return out


def evaluate(model: Model, expr, values: dict[str, float] | None = None) -> np.ndarray:
    """``expr`` (a CasADi SX of ``model``'s symbols, any shape) as a numpy
    array of its shape at ``values`` (symbol name -> number; a variable not
    given takes its start value).  Raises ValueError naming the symbols that
    have neither (e.g. ``der(x)``, an algebraic variable, ``time``)."""
    expr = ca.SX(expr)
    values = dict(values or {})
    syms = ca.symvar(expr)
    point, missing = [], []
    for s in syms:
        name = s.name()
        if name in values:
            point.append(values[name])
            continue
        var: Variable | None = next((v for v in model.variables if v.name == name), None)
        if var is None or var.start is None:
            missing.append(name)
        else:
            point.append(float(var.start))
    if missing:
        first = missing[0]
        how = f"{first}=..." if first.isidentifier() else f"**{{{first!r}: ...}}"
        raise ValueError(f"values: no value for {', '.join(missing)} (no start value); "
                         f"allowed: give each by keyword, e.g. {how}")
    f = ca.Function("evaluate", [ca.vertcat(*syms) if syms else ca.SX(0, 1)],
                    [ca.densify(expr)])
    return np.array(f(point).full(), dtype=float).reshape(expr.shape)


class Inspection:
    """A model's derivation: its quantities, equations and variables.

    Made by :func:`inspect`.  ``names``: the quantities' names in declaration
    order; ``quantities``: name -> ``loomfmu.declare.model.Quantity`` (unit,
    description, symbol, source, group); ``variables``: the declared
    variables; ``values``: the values given at construction (the rest take
    their start values).
    """

    def __init__(self, model: Model, values: dict[str, float]):
        self.model = model
        self.values = dict(values)
        self.quantities: dict[str, Quantity] = {q.name: q for q in model.quantities}
        self.names = list(self.quantities)
        self.variables: list[Variable] = list(model.variables)
        self._sympy: dict[str, object] = {}
        self._equations: list[sympy.Eq] | None = None

    def __repr__(self) -> str:
        return (f"<loomfmu.inspect of {self.model.name!r}: {len(self.names)} quantities, "
                f"{len(self.model.equations)} equations, {len(self.variables)} variables>")

    def _quantity(self, name: str) -> Quantity:
        if name not in self.quantities:
            raise ValueError(f"name = {name!r:.60}: not a quantity of model "
                             f"{self.model.name!r}; allowed: "
                             f"{', '.join(self.names) or '(the model declares none)'}")
        return self.quantities[name]

    def sympy(self, name: str):
        """Quantity ``name`` as SymPy: an expression (1x1) or a ``sympy.Matrix``;
        its symbols are ``loomfmu.inspection.readable.Var`` named as the model's variables."""
        q = self._quantity(name)
        if name not in self._sympy:
            self._sympy[name] = readable.quantity(self.model, q)
        return self._sympy[name]

    def latex(self, name: str) -> str:
        """LaTeX of quantity ``name`` (its definition, without the symbol)."""
        return readable.to_latex(self.sympy(name))

    def value(self, name: str, **values):
        """Quantity ``name`` at the construction's values updated by
        ``values``: a float (1x1), a 1-D array (a column) or a 2-D array."""
        q = self._quantity(name)
        given = {**self.values, **_check_values(self.model, values)}
        out = evaluate(self.model, q.expr, given)
        bad = np.argwhere(~np.isfinite(out))
        if bad.size:
            raise ValueError(f"{name} is not finite at these values (entries "
                             f"{', '.join(map(str, map(tuple, bad[:5])))}); given: {given}")
        if out.shape == (1, 1):
            return float(out[0, 0])
        return out[:, 0] if out.shape[1] == 1 else out

    @property
    def equations(self) -> list[sympy.Eq]:
        """The equations as ``sympy.Eq(lhs, rhs)`` (terms with the unknowns
        der(x) and the algebraic variables on the left)."""
        if self._equations is None:
            self._equations = [sympy.Eq(lhs, rhs, evaluate=False)
                               for lhs, rhs in readable.equations(self.model)]
        return self._equations

    @property
    def symbols(self) -> dict[str, readable.Var]:
        """Every SymPy symbol the expressions may use, by the model's name."""
        return readable.symbols(self.model)


def inspect(model, **values) -> Inspection:
    """The derivation of ``model`` (a model name or a declared
    ``loomfmu.Model``) for use in Python, evaluated at ``values`` (parameter,
    state or input name -> number; the others take their start values).

    Example (a model declared here; ``inspect("heald_frame")`` works the
    same for the shipped ones)::

        >>> from loomfmu import Model, inspect
        >>> m = Model("springs", description="two springs in series")
        >>> k1 = m.parameter("k1", 100.0, unit="N/m", description="first spring",
        ...                  min=0.0, source="assumption: example")
        >>> k2 = m.parameter("k2", 300.0, unit="N/m", description="second spring",
        ...                  min=0.0, source="assumption: example")
        >>> _ = m.quantity("k", k1 * k2 / (k1 + k2), unit="N/m", symbol=r"k_{\\mathrm{s}}",
        ...                description="series stiffness", source="derived: 1/k = 1/k1 + 1/k2")
        >>> info = inspect(m, k2=100.0)
        >>> info.sympy("k")
        k1*k2/(k1 + k2)
        >>> info.value("k")
        50.0
        >>> info.value("k", k1=300.0)
        75.0
        >>> info.latex("k")
        '\\\\frac{k_{1} k_{2}}{k_{1} + k_{2}}'

    Raises ValueError for a model that is neither, and for a value whose name
    is not a symbol of the model or that is outside the variable's range.
    """
    m = _model(model)
    return Inspection(m, _check_values(m, values))
