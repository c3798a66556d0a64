"""From the acausal declaration to the explicit form the solvers integrate.

The equations F(der(x), z, x, u, p, t) = 0 of a :class:`~loomfmu.declare.model.Model`
are solved for the unknowns w = [der(x); z].  When F is linear in w (mass
matrices, linear algebraic relations) the solution w = -A^{-1} F(0) is formed
symbolically; a model whose equations are nonlinear in w is rejected here with
a message that names the offending equations (the Newton path for nonlinear
algebraic loops lives in the runtime; see docs/guides/runtime.md).

The result, :class:`OdeForm`, is shared by the C code generator and the scipy
reference, so both integrate the very same expressions.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as ca

from loomfmu.declare.model import Model
from loomfmu.export.tearing import Tearing, tear


@dataclass
class OdeForm:
    """x' = f(t, x, u, p), outputs y, algebraic z and event indicators e of (t, x, u, p)."""

    model: Model
    t: ca.SX
    x: ca.SX
    u: ca.SX
    p: ca.SX
    f: ca.SX
    y: ca.SX
    z: ca.SX  # algebraic variables, solved
    e: ca.SX

    @property
    def args(self) -> list[ca.SX]:
        return [self.t, self.x, self.u, self.p]

    def function(self, name: str, outs: list[ca.SX], out_names: list[str]) -> ca.Function:
        return ca.Function(name, self.args, outs, ["t", "x", "u", "p"], out_names)

    def jacobian(self) -> tuple[ca.SX, ca.SX]:
        """Exact df/dx (dense) and df/dt, for the implicit solver."""
        return ca.densify(ca.jacobian(self.f, self.x)), ca.densify(ca.jacobian(self.f, self.t))


def explicit_ode(model: Model) -> OdeForm:
    """The explicit form x' = f(t, x, u, p) of a model without modes or delays
    whose equations are linear in der(x) and the algebraic variables (from
    :func:`dae_form`, with w substituted by its closed form)."""
    dae = dae_form(model)
    if dae.implicit:
        nonlinear = [i for i in range(dae.F.numel())
                     if ca.depends_on(ca.jacobian(dae.F[i], dae.w), dae.w)]
        raise ValueError(f"model {model.name}: equations {nonlinear} are nonlinear in "
                         "der(x)/algebraic variables; only linear implicit forms have an "
                         "explicit form (the FMU solves the others by Newton)")
    if dae.q.numel() or dae.d.numel():
        raise ValueError(f"model {model.name}: modes and delays have no explicit ODE form")
    y, e = (ca.substitute(v, dae.w, dae.wsol) for v in (dae.y, dae.e))
    return OdeForm(model, dae.t, dae.x, dae.u, dae.p, dae.wsol[: dae.nx, 0], y,
                   dae.wsol[dae.nx:, 0], e)


@dataclass
class DaeForm:
    """The model as the runtime sees it, every function of (t, x, w, u, p, q, d).

    w = [der(x); z] are the unknowns, F(t, x, w, u, p, q, d) = 0 their equations
    and q the discrete modes.  ``wsol`` is the closed-form solution for w when
    F is linear in w (None otherwise: the runtime then solves F = 0 by
    Newton with the exact dF/dw).  Outputs, algebraic locals, event
    indicators and mode validity may use w; ``reinit`` gives the states after
    a mode change.  d are the delayed values: d_k = g_k(t - tau_k); ``g``,
    its total time derivative ``gdot`` (inputs held) and ``tau`` let the
    runtime keep their history.
    """

    model: Model
    t: ca.SX
    x: ca.SX
    w: ca.SX
    u: ca.SX
    p: ca.SX
    q: ca.SX
    F: ca.SX
    wsol: ca.SX | None
    y: ca.SX
    e: ca.SX
    valid: ca.SX
    reinit: ca.SX
    init: ca.SX  # start of each state from the parameters (itself where not given)
    d: ca.SX
    g: ca.SX
    gdot: ca.SX
    tau: ca.SX
    cons: ca.SX  # constraints on the parameters, each >= 0

    @property
    def args(self) -> list[ca.SX]:
        return [self.t, self.x, self.w, self.u, self.p, self.q, self.d]

    @property
    def nx(self) -> int:
        return self.x.numel()

    @property
    def implicit(self) -> bool:
        return self.wsol is None

    @cached_property
    def tearing(self) -> Tearing | None:
        """The block-triangular split of an implicit model's equations
        (:func:`loomfmu.export.tearing.tear`); None for explicit models and
        where it gains nothing."""
        return tear(self.F, self.w, self.q) if self.implicit else None

    def function(self, name: str, outs: list[ca.SX], out_names: list[str]) -> ca.Function:
        return ca.Function(name, self.args, outs, ["t", "x", "w", "u", "p", "q", "d"],
                           out_names)


def _outputs_in_w(model: Model) -> ca.SX:
    """Output expressions with references to other outputs resolved."""
    outs = model.of_kind("output")
    y = ca.vertcat(*[v.expr for v in outs]) if outs else ca.SX(0, 1)
    ysym = model.syms("output")
    for _ in range(len(outs) + 1):
        if not ysym.numel() or not ca.depends_on(y, ysym):
            return y
        y = ca.substitute(y, ysym, y)
    raise ValueError(f"model {model.name}: outputs are defined cyclically")


def dae_form(model: Model) -> DaeForm:
    """The unknowns w, their equations and every function the runtime calls."""
    xs, zs = model.of_kind("state"), model.of_kind("algebraic")
    w = ca.vertcat(model.ders(), model.syms("algebraic"))
    F = ca.vertcat(*model.equations) if model.equations else ca.SX(0, 1)
    if F.numel() != w.numel():
        raise ValueError(
            f"model {model.name}: {F.numel()} equations for {w.numel()} unknowns "
            f"({len(xs)} derivatives + {len(zs)} algebraic variables)")
    A = ca.jacobian(F, w)
    wsol = None
    if not ca.depends_on(A, w):
        wsol = ca.solve(A, -ca.substitute(F, w, ca.DM.zeros(w.numel())))
    q = model.syms("mode")
    y = _outputs_in_w(model)
    e = ca.vertcat(*[ev.expr for ev in model.events]) if model.events else ca.SX(0, 1)
    modes = model.of_kind("mode")
    missing = [v.name for v in modes if v.name not in model.mode_valid]
    if missing:
        raise ValueError(f"model {model.name}: modes {missing} have no mode_rule")
    valid = ca.vertcat(*[model.mode_valid[v.name] for v in modes]) if modes else ca.SX(0, 1)
    x = model.syms("state")
    reinit = ca.vertcat(*[model.reinits.get(v.name, v.sym) for v in xs]) if xs else ca.SX(0, 1)
    init = ca.vertcat(*[model.initials.get(v.name, v.sym) for v in xs]) if xs else ca.SX(0, 1)
    for name, expr in (("reinit", reinit), ("initial", init)):
        if ca.depends_on(expr, w):
            raise ValueError(f"model {model.name}: {name} expressions may not use "
                             "derivatives or algebraic variables")
    if model.delays and model.events:
        # the runtime does not yet keep the history across the redone step
        # and the jump of an event
        raise ValueError(f"model {model.name}: delays together with event indicators are "
                         "not supported")
    d, g, gdot, tau = _delays(model, x, w)
    cons = ca.vertcat(*[c.expr for c in model.constraints]) if model.constraints \
        else ca.SX(0, 1)
    return DaeForm(model, model.t, x, w, model.syms("input"), model.syms("parameter"), q,
                   F, wsol, y, e, valid, reinit, init, d, g, gdot, tau, cons)


def _delays(model: Model, x: ca.SX, w: ca.SX):
    dl = model.delays
    if not dl:
        z = ca.SX(0, 1)
        return z, z, z, z
    d = ca.vertcat(*[v.sym for v in dl])
    g = ca.vertcat(*[v.expr for v in dl])
    if ca.depends_on(g, ca.vertcat(w, d, model.syms("mode"))):
        raise ValueError(f"model {model.name}: a delayed expression may use time, states, "
                         "inputs and parameters only")
    gdot = ca.jacobian(g, x) @ w[: x.numel(), 0] + ca.jacobian(g, model.t)
    return d, g, gdot, ca.vertcat(*[v.tau for v in dl])
