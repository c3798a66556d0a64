"""The scipy reference: the same declaration, integrated by ``solve_ivp``.

The right-hand side is the model's :class:`~loomfmu.ode.OdeForm` evaluated
from Python (a CasADi function per call).  The integration is piecewise:
every event indicator of the model (e.g. the heald frame's dwell boundaries)
is a terminal ``solve_ivp`` event, and the integration restarts at each
located breakpoint, so no step straddles a kink of the right-hand side.
Inputs are held at constant values, as the FMU holds them over a
communication step.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

from .declare import Model
from .ode import explicit_ode


@dataclass
class Reference:
    t: np.ndarray                 # requested output times
    y: dict[str, np.ndarray]      # outputs and states by name
    wall_seconds: float
    n_rhs: int
    n_segments: int


def _values(model: Model, kind: str, overrides: dict[str, float]) -> np.ndarray:
    vals = []
    for v in model.of_kind(kind):
        value = float(overrides.get(v.name, v.start))
        v.check_value(value)
        vals.append(value)
    return np.array(vals)


def reference(model: Model, *, t_end: float | None = None, t_eval=None, rtol: float = 1e-10,
              atol: float = 1e-12, method: str = "DOP853",
              values: dict[str, float] | None = None) -> Reference:
    """Integrate ``model`` with scipy from t = 0 to ``t_end``.

    t_end: final time (> 0; default: the model's stop time).
    t_eval: output times in [0, t_end] (default: the model's output step).
    rtol, atol: solve_ivp tolerances (> 0).
    method: a solve_ivp method name.
    values: start values of parameters, inputs (held constant) and states.
    """
    values = dict(values or {})
    t_end = model.stop_time if t_end is None else float(t_end)
    if not t_end > 0:
        raise ValueError(f"t_end = {t_end!r}; allowed: > 0")
    for name, tol in (("rtol", rtol), ("atol", atol)):
        if not tol > 0:
            raise ValueError(f"{name} = {tol!r}; allowed: > 0")
    unknown = set(values) - {v.name for v in model.variables}
    if unknown:
        raise ValueError(f"values: {sorted(unknown)} are not variables of {model.name}")
    if t_eval is None:
        n = int(round(t_end / model.step_size))
        t_eval = np.linspace(0.0, t_end, n + 1)
    t_eval = np.asarray(t_eval, dtype=float)

    ode = explicit_ode(model)
    p, u = _values(model, "parameter", values), _values(model, "input", values)
    x0 = _values(model, "state", values)
    f = ode.function("f", [ode.f], ["xdot"])
    g = ode.function("g", [ca.vertcat(ode.y, ode.z)], ["y"])
    e = ode.function("e", [ode.e], ["e"])
    counter = [0]

    def rhs(t, x):
        counter[0] += 1
        return np.asarray(f(t, x, u, p)).ravel()

    def make_event(k):
        def ev(t, x):
            return float(e(t, x, u, p)[k])
        ev.terminal = True
        return ev

    events = [make_event(k) for k in range(ode.e.numel())]
    xs = np.empty((len(t_eval), len(x0)))
    t0, x, skip, segments = 0.0, x0.copy(), None, 0
    wall = time.perf_counter()
    while True:
        active = [ev for k, ev in enumerate(events) if k != skip]
        sol = solve_ivp(rhs, (t0, t_end), x, method=method, rtol=rtol, atol=atol,
                        events=active or None, dense_output=True)
        if sol.status < 0:
            raise RuntimeError(f"reference for {model.name} failed at t = {sol.t[-1]}: "
                               f"{sol.message}")
        segments += 1
        t1 = sol.t[-1]
        sel = (t_eval >= t0) & (t_eval <= t1)
        if sel.any():
            xs[sel] = sol.sol(t_eval[sel]).T
        if sol.status == 0:
            break
        fired = [k for k, te in enumerate(sol.t_events) if len(te)]
        skip = [i for i, ev in enumerate(events) if ev is active[fired[0]]][0]
        t0, x = t1, sol.y[:, -1]
    wall = time.perf_counter() - wall

    ys = np.array([np.asarray(g(t, xi, u, p)).ravel() for t, xi in zip(t_eval, xs)])
    out = {v.name: xs[:, i] for i, v in enumerate(model.of_kind("state"))}
    names = [v.name for v in model.of_kind("output") + model.of_kind("algebraic")]
    out.update({name: ys[:, i] for i, name in enumerate(names)})
    return Reference(t_eval, out, wall, counter[0], segments)
