"""From the acausal declaration to the explicit form the solvers integrate.

The equations F(der(x), z, x, u, p, t) = 0 of a :class:`~loomfmu.declare.Model`
are solved for the unknowns w = [der(x); z].  When F is linear in w (mass
matrices, linear algebraic relations) the solution w = -A^{-1} F(0) is formed
symbolically; a model whose equations are nonlinear in w is rejected here with
a message that names the offending equations (the Newton path for nonlinear
algebraic loops lives in the runtime; see the README's roadmap).

The result, :class:`OdeForm`, is shared by the C code generator and the scipy
reference, so both integrate the very same expressions.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from .declare import Model


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
    """Solve the model's equations for der(x) and the algebraic variables."""
    xs, zs = model.of_kind("state"), model.of_kind("algebraic")
    w = ca.vertcat(model.ders(), model.syms("algebraic"))
    F = ca.vertcat(*model.equations) if model.equations else ca.SX(0, 1)
    if F.numel() != w.numel():
        raise ValueError(
            f"model {model.name}: {F.numel()} equations for {w.numel()} unknowns "
            f"({len(xs)} derivatives + {len(zs)} algebraic variables)")
    A = ca.jacobian(F, w)
    nonlinear = [i for i in range(F.numel()) if ca.depends_on(A[i, :], w)]
    if nonlinear:
        raise ValueError(f"model {model.name}: equations {nonlinear} are nonlinear in "
                         "der(x)/algebraic variables; only linear implicit forms are "
                         "supported by explicit_ode")
    b = ca.substitute(F, w, ca.DM.zeros(w.numel()))
    sol = ca.solve(A, -b)
    xdot, z = sol[: len(xs)], sol[len(xs):]
    outs = model.of_kind("output")
    y = ca.vertcat(*[v.expr for v in outs]) if outs else ca.SX(0, 1)
    e = ca.vertcat(*[ev.expr for ev in model.events]) if model.events else ca.SX(0, 1)
    # outputs may refer to other outputs (declared earlier) and algebraic variables
    ysym = model.syms("output")
    for _ in range(len(outs)):
        if not ca.depends_on(y, ysym):
            break
        y = ca.substitute(y, ysym, y)
    y, e = (ca.substitute(v, w, sol) for v in (y, e))  # der(x) and z may appear
    for name, expr in (("outputs", y), ("event indicators", e), ("derivatives", xdot)):
        if ca.depends_on(expr, w) or (ysym.numel() and ca.depends_on(expr, ysym)):
            raise ValueError(f"model {model.name}: {name} still depend on unknowns "
                             "after solving (cyclic definition)")
    return OdeForm(model, model.t, model.syms("state"), model.syms("input"),
                   model.syms("parameter"), xdot, y, z, e)
