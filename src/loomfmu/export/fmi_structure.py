"""The model structure's dependencies, by variable name, from the symbolic
sparsity of the declaration (the same for FMI 2.0 and 3.0; fmi_xml spells
them as indices or value references).

Each entry maps an unknown to the names it depends on, or to None (depends
on everything known, no ``dependencies`` attribute):

* outputs: an output on the inputs (direct feedthrough) and, in model
  exchange (where the importer sets the states), on the states (FMI 2.0
  section 3.3.2: the knowns of model exchange are the inputs and states); a
  mode on nothing (discrete: changes only at events);
* derivatives (model exchange): der(x_k) on the states and inputs;
* initial: outputs, and in model exchange the states with a computed start
  and every der(x), on the parameters, the states with an exact start and
  the inputs (a computed start stands in for its state); modes: None;
* indicators (FMI 3.0 model exchange): event indicator j on the states and
  inputs.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca

from loomfmu.declare.model import Model
from loomfmu.export.dae import DaeForm

Deps = dict[str, "list[str] | None"]


@dataclass
class Structure:
    outputs: Deps = field(default_factory=dict)
    derivatives: Deps = field(default_factory=dict)
    initial: Deps = field(default_factory=dict)
    indicators: Deps = field(default_factory=dict)


def depends(expr: ca.SX, syms: ca.SX) -> list[list[int]]:
    """For each row of ``expr``, the columns of ``syms`` it structurally depends on."""
    if expr.numel() == 0 or syms.numel() == 0:
        return [[] for _ in range(expr.numel())]
    sp = ca.jacobian(expr, syms).sparsity()
    rows: list[list[int]] = [[] for _ in range(expr.numel())]
    for r, c in zip(*sp.get_triplet()):
        rows[r].append(c)
    return rows


def resolved(dae: DaeForm, expr: ca.SX) -> ca.SX:
    """``expr`` with the unknowns w and the delayed values d eliminated, for
    the dependency analysis.  w: substituted for explicit models; for
    implicit ones replaced by a stand-in that depends on everything F
    depends on.  d: by the delayed expression itself (a delay may be zero:
    direct feedthrough)."""
    if dae.implicit:
        known = ca.vertsplit(ca.vertcat(dae.x, dae.u, dae.p))
        stand_in = sum((k for k in known if ca.depends_on(dae.F, k)), ca.SX(0))
        expr = ca.substitute(expr, dae.w, ca.repmat(stand_in, dae.w.numel(), 1))
    else:
        expr = ca.substitute(expr, dae.w, dae.wsol)
    if dae.d.numel():
        expr = ca.substitute(expr, dae.d, dae.g)
    return expr


def _named(expr: ca.SX, syms: ca.SX, names: list[str]) -> list[list[str]]:
    return [[names[c] for c in cols] for cols in depends(expr, syms)]


def model_structure(model: Model, dae: DaeForm, *, interface: str = "cs",
                    indicators: list[str] = ()) -> Structure:
    """The dependencies of ``model``'s unknowns; ``interface`` "me" or "both"
    adds the derivatives, the states with a computed start and the event
    indicators (named ``indicators``, one per row of dae.e, FMI 3.0 only)."""
    me = interface in ("me", "both")
    names = {k: [v.name for v in model.of_kind(k)] for k in ("parameter", "state", "input",
                                                             "output")}
    modes = [v.name for v in model.of_kind("mode")]
    s = Structure()
    y = resolved(dae, dae.y)
    xu = ca.vertcat(dae.x, dae.u)
    xu_names = names["state"] + names["input"]
    s.outputs = dict(zip(names["output"], _named(y, xu, xu_names) if me
                         else _named(y, dae.u, names["input"])))
    s.outputs.update({m: [] for m in modes})
    # at initialization, states with a computed start are unknowns: their
    # start expressions stand in for them
    known = ca.vertcat(dae.p, dae.x, dae.u)
    known_names = names["parameter"] + names["state"] + names["input"]

    def at_start(e: ca.SX) -> ca.SX:
        return ca.substitute(e, dae.x, dae.init)

    s.initial = dict(zip(names["output"], _named(at_start(y), known, known_names)))
    s.initial.update({m: None for m in modes})
    if not me:
        return s
    der = resolved(dae, dae.w[: dae.nx, 0])
    der_names = [f"der({x})" for x in names["state"]]
    s.derivatives = dict(zip(der_names, _named(der, xu, xu_names)))
    s.initial.update(zip(der_names, _named(at_start(der), known, known_names)))
    computed = set(model.initials)
    starts = _named(dae.init, known, known_names)
    s.initial.update({x: [n for n in deps if n != x]
                      for x, deps in zip(names["state"], starts) if x in computed})
    if indicators:
        s.indicators = dict(zip(indicators, _named(resolved(dae, dae.e), xu, xu_names)))
    return s
