"""The scipy reference: the same declaration, integrated by ``solve_ivp``.

Delays are integrated by the method of steps: the integration is split at
multiples of the shortest delay, so that every delayed value comes from
intervals already solved, read from their dense output (for t before the
start, the history is constant at the start value).

The right-hand side is the model's :class:`~loomfmu.export.dae.DaeForm` evaluated
from Python: the unknowns w = [der(x); z] in closed form, or by a Newton
iteration written here (independent of the C runtime's) for models whose
equations are nonlinear in w.  The integration is piecewise: every event
indicator of the model (breakpoints, friction switches) is a terminal
``solve_ivp`` event; at each located event the mode it governs is re-chosen
by the same rule as the FMU's (first value in priority order whose validity
is >= 0 after reinit), written again here, and the integration restarts.
Inputs are held at constant values, as the FMU holds them over a
communication step; ``input_steps`` changes them at given times, where every
mode is made consistent again (the FMU does the same at a communication
point where an input changed); ``input_functions`` makes inputs functions of
time (the exact curve an FMU fed with input derivatives interpolates).

Validity conditions (``Model.require``) are terminal events: where one
crosses below zero the integration stops, as the FMU's step does, and
:attr:`Reference.violation` names it (the output times after it are not in
the result).  After an event, too, every mode made invalid
by the switch is chosen again, round after round, as in the FMU.

At a jump of a delayed expression (an input step), a query from inside an
integration segment at exactly the jump time takes the value before it;
the segment that starts there takes the value after it (the FMU's rule).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

from loomfmu.declare.checks import (
    check_array,
    check_bool,
    check_choice,
    check_mapping,
    check_number,
    check_optional_number,
)
from loomfmu.declare.model import Model
from loomfmu.export import dae as _dae_module
from loomfmu.export.dae import DaeForm, dae_form
from loomfmu.verification import reference_cache
from loomfmu.verification.times import T_ROUND, grid_rows

#: after a located event, integrate this long (relative to max(1, |t|)) in the
#: old mode with no event watched, so that the mode is chosen on the root's new
#: side (the root itself is only known to rounding; an indicator restarting
#: at zero would also count as a root for solve_ivp)
EVENT_GAP = 1e-10
#: solve_ivp methods the reference accepts
METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
#: tightest rtol solve_ivp honours (it raises smaller ones to this with a warning)
RTOL_MIN = 100 * np.finfo(float).eps
#: longest horizon, in multiples of the model's stop time
MAX_HORIZONS = 1e4
#: most output times of one reference
MAX_OUTPUTS = 10**7


def on_times(ref: Reference, t: np.ndarray) -> Reference | None:
    """``ref`` at the times ``t`` if each is one of ``ref.t`` (:func:`grid_rows`)
    and the reference ran to its end, else None. The values are those of the
    same integration (scipy's steps do not depend on the output times), taken
    row by row."""
    k = grid_rows(ref.t, t) if ref.violation is None else None
    if k is None:
        return None
    return Reference(ref.t[k], {n: y[k] for n, y in ref.y.items()}, ref.wall_seconds,
                     ref.n_rhs, ref.n_segments, ref.switches, None, ref.cached)


def check_model(model) -> Model:
    """``model`` if it is a declared :class:`~loomfmu.declare.model.Model`."""
    if not isinstance(model, Model):
        raise ValueError(f"model = {model!r:.60}; allowed: a loomfmu Model (load_model(name))")
    return model


def settable(model: Model) -> list[str]:
    """Names a caller may give start values for: parameters, inputs, states."""
    return [v.name for v in model.variables if v.kind in ("parameter", "input", "state")]


@dataclass
class Reference:
    t: np.ndarray                 # requested output times
    y: dict[str, np.ndarray]      # outputs, states and modes by name
    wall_seconds: float
    n_rhs: int
    n_segments: int
    switches: list[tuple[float, str, int, int]] = field(default_factory=list)
    #: (name, message, time, value) of the validity condition that stopped the
    #: integration (Model.require), or None; ``t`` and ``y`` end before it
    violation: tuple[str, str, float, float] | None = None
    #: taken from the on-disk cache (:mod:`.reference_cache`); ``wall_seconds``
    #: is then the time of the run that computed it
    cached: bool = False


def _values(model: Model, kind: str, overrides: dict[str, float]) -> np.ndarray:
    vals = []
    for v in model.of_kind(kind):
        value = float(overrides.get(v.name, v.start))
        v.check_value(value)
        vals.append(value)
    return np.array(vals)


class _Dae:
    """Numeric evaluation of a DaeForm with the inputs and parameters fixed."""

    def __init__(self, dae: DaeForm, u: np.ndarray, p: np.ndarray, q: np.ndarray):
        self.dae, self.u, self.p, self.q = dae, u, p, q.astype(float)
        self.nx, self.nw = dae.nx, dae.w.numel()
        f = dae.function
        self.wsol = None if dae.implicit else f("wsol", [dae.wsol], ["w_sol"])
        self.F = f("F", [dae.F], ["F"])
        self.Fw = f("Fw", [ca.jacobian(dae.F, dae.w)], ["Fw"])
        self.out = f("out", [ca.vertcat(dae.y, dae.w[dae.nx:, 0])], ["y"])
        self.evt = f("evt", [dae.e], ["e"])
        self.valid = f("valid", [dae.valid], ["v"])
        self.reinit = f("reinit", [dae.reinit], ["x_new"])
        self.init = f("init", [dae.init], ["x_start"])
        self.hist = f("hist", [dae.g], ["g"])
        self.w = np.zeros(self.nw)
        self.d = np.zeros(dae.d.numel())
        self.ufun: dict = {}  # input index -> function of time (input_functions)
        self.tau = np.asarray(f("tau", [dae.tau], ["tau"])(*self.args(0.0, np.zeros(dae.nx)))
                              ).ravel() if dae.d.numel() else np.zeros(0)
        self.segments: list = []  # (t_a, t_b, dense output, inputs) of solved intervals
        self.t_seg = 0.0  # start of the segment being integrated
        self.g0 = None
        self.n_rhs = 0

    def inputs_at(self, t) -> np.ndarray:
        if not self.ufun:
            return self.u
        u = self.u.copy()
        for k, f in self.ufun.items():
            u[k] = f(t)
        return u

    def args(self, t, x, w=None):
        return (t, x, self.w if w is None else w, self.inputs_at(t), self.p, self.q, self.d)

    def solve(self, t, x) -> np.ndarray:
        if self.wsol is not None:
            self.w = np.asarray(self.wsol(*self.args(t, x))).ravel()
            return self.w
        w = self.w.copy()
        for _ in range(50):
            F = np.asarray(self.F(*self.args(t, x, w))).ravel()
            dw = np.linalg.solve(np.asarray(self.Fw(*self.args(t, x, w))), F)
            w -= dw
            if np.all(np.abs(dw) <= 1e-13 + 1e-11 * np.abs(w)):
                self.w = w
                return w
        raise RuntimeError(f"reference: Newton did not converge at t = {t}")

    def delayed(self, t, x):
        """The delayed values d_k = g_k(t - tau_k) from the solved intervals."""
        if not len(self.tau):
            return
        now = np.asarray(self.hist(*self.args(t, x))).ravel()
        left = t > self.t_seg  # inside a segment: the value before a jump at s
        eps = 8 * np.finfo(float).eps * max(1.0, abs(t))  # t - tau is known to rounding
        for k, tau in enumerate(self.tau):
            s = t - tau
            if tau == 0:
                self.d[k] = now[k]
            elif self.g0 is None:
                self.d[k] = now[k]
            elif not self.segments or s <= self.segments[0][0]:
                self.d[k] = self.g0[k]  # constant history before the start
            else:
                ta, tb, sol, u = next(seg for seg in reversed(self.segments)
                                      if (seg[0] < s - eps if left else seg[0] <= s + eps)
                                      or seg is self.segments[0])
                u_s = u if not self.ufun else self.inputs_at(s)
                args = (s, sol(min(s, tb)), self.w, u_s, self.p, self.q, self.d)
                self.d[k] = float(np.asarray(self.hist(*args)).ravel()[k])

    def rhs(self, t, x):
        self.n_rhs += 1
        self.delayed(t, x)
        return self.solve(t, x)[: self.nx]

    def outputs(self, t, x):
        return np.asarray(self.out(*self.args(t, x, self.solve(t, x)))).ravel()

    def is_valid(self, k: int, t, x) -> bool:
        try:
            return float(self.valid(*self.args(t, x, self.solve(t, x)))[k]) >= 0
        except (RuntimeError, np.linalg.LinAlgError):
            return False

    def consistent_modes(self, model: Model, t, x, switches, touched=None) -> np.ndarray:
        """Choose again every mode whose validity is < 0 and, once chosen,
        again in every later round, until a round changes nothing (the FMU's
        consistent_modes, written again).  touched: a mode already chosen."""
        modes = model.of_kind("mode")
        chosen = [k == touched for k in range(len(modes))]
        for _ in range(2 * len(modes) + 3):
            changed = False
            for k in range(len(modes)):
                if not chosen[k] and self.is_valid(k, t, x):
                    continue
                old = int(self.q[k])
                x = self.choose_mode(k, model.mode_values[modes[k].name], t, x)
                chosen[k] = True
                if int(self.q[k]) != old:
                    changed = True
                    switches.append((t, modes[k].name, old, int(self.q[k])))
            if not changed:
                return x
        raise RuntimeError(f"reference: the modes do not settle at t = {t}")

    def choose_mode(self, k: int, values: tuple[int, ...], t, x) -> np.ndarray:
        """First value of mode k, in priority order, consistent after reinit."""
        for value in values:
            self.q[k] = value
            x_try = np.asarray(self.reinit(*self.args(t, x))).ravel()
            try:
                w = self.solve(t, x_try)
            except (RuntimeError, np.linalg.LinAlgError):
                continue
            if float(self.valid(*self.args(t, x_try, w))[k]) >= 0:
                return x_try
        raise RuntimeError(f"reference: no consistent value of mode {k} at t = {t}")


def reference(model: Model, *, t_end: float | None = None, t_eval=None, rtol: float = 1e-10,
              atol: float = 1e-12, method: str = "DOP853",
              values: dict[str, float] | None = None,
              input_steps: list[tuple[float, dict[str, float]]] | None = None,
              input_functions: dict | None = None, cache: bool = True) -> Reference:
    """Integrate ``model`` with scipy from t = 0 to ``t_end``.

    t_end: final time (> 0, at most MAX_HORIZONS x the model's stop time;
        default: the model's stop time).
    t_eval: non-decreasing output times in [0, t_end] (default: the model's
        output step).
    rtol: solve_ivp relative tolerance in [RTOL_MIN, 0.1]; atol: > 0.
    method: one of METHODS.
    values: start values of parameters, inputs (held constant) and states.
    input_steps: [(t_k, {input: value})], times increasing in (0, t_end):
        from t_k on the inputs named hold the new values.
    input_functions: {input: f} with f(t) -> float, a smooth function of time
        (e.g. a ramp), for inputs not in input_steps: the input is f(t).
    cache: take the result from the on-disk cache where the same reference was
        computed before, and keep it there (:mod:`.reference_cache`; never for
        input_functions).
    Every argument is checked: ValueError names the argument and what is allowed.
    A validity condition (Model.require) that fails stops the integration:
    the result ends at the last output time before it and its ``violation``
    says which condition failed, when, with what value.
    """
    check_model(model)
    values = check_mapping("values", values, settable(model),
                           what=f"variables of {model.name} with a start value (parameters, "
                           "inputs, states)")
    t_max = MAX_HORIZONS * model.stop_time
    t_end = check_optional_number("t_end", t_end, lo=0.0, hi=t_max, lo_open=True, unit="s")
    t_end = model.stop_time if t_end is None else t_end
    rtol = check_number("rtol", rtol, lo=RTOL_MIN, hi=0.1)
    atol = check_number("atol", atol, lo=0.0, lo_open=True)
    check_choice("method", method, METHODS)
    for name, value in values.items():
        model.var(name).check_value(value)
    model.check_constraints(values)
    input_names = [v.name for v in model.of_kind("input")]
    steps = []
    if input_steps is not None and (isinstance(input_steps, (str, bytes, dict))
                                    or not hasattr(input_steps, "__iter__")):
        raise ValueError(f"input_steps = {input_steps!r:.60}; allowed: a list of "
                         "(time, {input: value})")
    for i, item in enumerate(input_steps or []):
        try:
            t_k, new = item
        except (TypeError, ValueError):
            raise ValueError(f"input_steps[{i}] = {item!r:.60}; allowed: (time, "
                             "{input: value})") from None
        t_k = check_number(f"input_steps[{i}] time", t_k, lo=0.0, hi=t_end, lo_open=True,
                           hi_open=True, unit="s")
        if steps and t_k <= steps[-1][0]:
            raise ValueError(f"input_steps[{i}] time = {t_k!r}; allowed: increasing, after "
                             f"{steps[-1][0]!r}")
        new = check_mapping(f"input_steps[{i}]", new, input_names,
                            what=f"inputs of {model.name}")
        for name, value in new.items():
            model.var(name).check_value(value)
        steps.append((t_k, new))
    functions = _check_input_functions(model, input_functions, steps)
    if t_eval is None:
        n = int(round(t_end / model.step_size))
        if n + 1 > MAX_OUTPUTS:
            raise ValueError(f"t_end = {t_end!r} s gives {n + 1} output times at the model's "
                             f"step {model.step_size} s; allowed: at most {MAX_OUTPUTS} (pass "
                             "t_eval)")
        t_eval = np.linspace(0.0, t_end, n + 1)
    # a last time past t_end by rounding (e.g. accumulated communication points) is t_end
    t_eval = check_array("t_eval", t_eval, lo=0.0, hi=t_end + T_ROUND * max(1.0, t_end),
                         increasing=True, unit="s")
    t_eval = np.minimum(t_eval, t_end)
    if len(t_eval) > MAX_OUTPUTS:
        raise ValueError(f"t_eval: {len(t_eval)} times; allowed: at most {MAX_OUTPUTS}")
    check_bool("cache", cache)
    key = None
    if cache and not functions:
        key = reference_cache.call_key(model, (__file__, _dae_module.__file__), t_end=t_end,
                                       t_eval=t_eval, rtol=rtol, atol=atol, method=method,
                                       values=values, steps=steps)
        hit = reference_cache.load(key)
        if hit is not None:
            return Reference(**hit)

    dae = dae_form(model)
    modes = model.of_kind("mode")
    d = _Dae(dae, _values(model, "input", values), _values(model, "parameter", values),
             np.array([int(v.start) for v in modes], dtype=float))
    d.ufun = {input_names.index(name): f for name, f in functions.items()}
    x = _values(model, "state", values)
    # states with a start expression start there for these parameters, unless given
    x0 = np.asarray(d.init(*d.args(0.0, x))).ravel()
    for i, v in enumerate(model.of_kind("state")):
        if v.name not in values:
            x[i] = x0[i]
    mode_of_event = [next((i for i, v in enumerate(modes)
                           if model.event_modes.get(ev.name) == v.name), None)
                     for ev in model.events]

    switches: list[tuple[float, str, int, int]] = []
    x = d.consistent_modes(model, 0.0, x, [])  # consistent initial modes

    def make_event(k):
        def ev(t, x):
            return float(d.evt(*d.args(t, x, d.solve(t, x)))[k])
        ev.terminal = True
        return ev

    events = [make_event(k) for k in range(dae.e.numel())]
    conditions = _validity_events(model, dae, d)
    if len(d.tau) and events:
        raise ValueError(f"reference for {model.name}: delays together with events are not "
                         "supported")
    step_limit = min((tau for tau in d.tau if tau > 0), default=np.inf)
    if len(d.tau):
        d.g0 = np.asarray(d.hist(*d.args(0.0, x))).ravel()
    xs = np.empty((len(t_eval), len(x)))
    qs = np.empty((len(t_eval), len(modes)))
    us = np.empty((len(t_eval), len(d.u)))
    t0, segments, pending, violation = 0.0, 0, None, None
    wall = time.perf_counter()
    while True:
        if steps and t0 >= steps[0][0]:  # the inputs step here
            for name, value in steps.pop(0)[1].items():
                d.u[input_names.index(name)] = value
            n_switches = len(switches)
            x = d.consistent_modes(model, t0, x, switches)
            if len(switches) > n_switches:  # indicators may restart at 0: cross the gap
                pending = -1
        t_next_step = steps[0][0] if steps else np.inf
        d.t_seg = t0
        if pending is None:  # up to the next event, input step, delay multiple or the end
            t1_seg, active = min(t_end, t0 + step_limit, t_next_step), events
        else:  # across the root, in the old mode, with no event watched
            t1_seg, active = min(t0 + EVENT_GAP * max(1.0, abs(t0)), t_end, t_next_step), []
        bad = next((c for c in conditions if c(t0, x) < 0), None)
        if bad is not None:  # already violated where this segment starts
            violation = (bad.name, bad.message, t0, bad(t0, x))
            break
        sol = solve_ivp(d.rhs, (t0, t1_seg), x, method=method, rtol=rtol, atol=atol,
                        events=(active + conditions) or None, dense_output=True)
        if sol.status < 0:
            raise RuntimeError(f"reference for {model.name} failed at t = {sol.t[-1]}: "
                               f"{sol.message}")
        segments += 1
        t1 = sol.t[-1]
        if sol.status == 0 and not np.isclose(t1, t1_seg, rtol=1e-12, atol=1e-15):
            raise RuntimeError(f"reference for {model.name} ({method}): the segment "
                               f"[{t0}, {t1_seg}] ended at {t1} without an event")
        if not np.all(np.isfinite(sol.y[:, -1])):
            raise RuntimeError(f"reference for {model.name} ({method}): non-finite state at "
                               f"t = {t1}")
        sel = (t_eval >= t0) & (t_eval <= t1)
        if sel.any():
            xs[sel] = sol.sol(t_eval[sel]).T
            qs[sel] = d.q
            us[sel] = d.u
        x = sol.y[:, -1]
        if len(d.tau):
            d.segments.append((t0, t1, sol.sol, d.u.copy()))
        if pending is not None:  # on the new side now: re-choose the mode
            j = mode_of_event[pending] if pending >= 0 else None
            if j is not None:
                old = int(d.q[j])
                x = d.choose_mode(j, model.mode_values[modes[j].name], t1, x)
                if int(d.q[j]) != old:
                    switches.append((t1, modes[j].name, old, int(d.q[j])))
            x = d.consistent_modes(model, t1, x, switches, touched=j)
            pending = None
        elif sol.status == 1:
            fired = next(k for k, te in enumerate(sol.t_events) if len(te))
            if fired >= len(active):  # a validity condition crossed zero: stop here
                c = conditions[fired - len(active)]
                t_v = float(sol.t_events[fired][0])
                violation = (c.name, c.message, t_v, c(t_v, sol.sol(t_v)))
                break
            pending = events.index(active[fired])
        if t1 >= t_end:
            break
        t0 = t1
    wall = time.perf_counter() - wall
    if violation is not None:  # the result ends before the condition failed
        keep = t_eval < violation[2]
        t_eval, xs, qs, us = t_eval[keep], xs[keep], qs[keep], us[keep]

    out = {v.name: xs[:, i] for i, v in enumerate(model.of_kind("state"))}
    out.update({v.name: qs[:, i] for i, v in enumerate(modes)})
    names = [v.name for v in model.of_kind("output") + model.of_kind("algebraic")]
    ys = []
    for t, xi, qi, ui in zip(t_eval, xs, qs, us):
        d.q[:], d.u[:], d.t_seg = qi, ui, t
        d.delayed(t, xi)
        ys.append(d.outputs(t, xi))
    ys = np.array(ys).reshape(len(t_eval), len(names))
    out.update({name: ys[:, i] for i, name in enumerate(names)})
    result = Reference(t_eval, out, wall, d.n_rhs, segments, switches, violation)
    if key is not None:
        reference_cache.store(key, result)
    return result


def _check_input_functions(model: Model, input_functions, steps) -> dict:
    """input_functions checked: {input name: callable of t}, none also stepped."""
    if input_functions is None:
        return {}
    names = [v.name for v in model.of_kind("input")]
    if not isinstance(input_functions, dict):
        raise ValueError(f"input_functions = {input_functions!r:.60}; allowed: a dict "
                         f"{{input: function of t}} with inputs of {model.name}: {names}")
    stepped = {name for _, new in steps for name in new}
    for name, f in input_functions.items():
        if name not in names:
            raise ValueError(f"input_functions: {name!r} is not an input of {model.name}; "
                             f"allowed: {names}")
        if not callable(f):
            raise ValueError(f"input_functions[{name!r}] = {f!r:.60}; allowed: a function "
                             "of t returning a float")
        if name in stepped:
            raise ValueError(f"input_functions[{name!r}]: the input is also in input_steps; "
                             "allowed: one of the two per input")
        value = f(0.0)
        if not isinstance(value, (int, float, np.floating)) or not np.isfinite(value):
            raise ValueError(f"input_functions[{name!r}](0.0) = {value!r:.60}; allowed: a "
                             "finite float")
    return dict(input_functions)


class _Condition:
    """A validity condition as a terminal solve_ivp event (falling through 0)."""

    terminal = True
    direction = -1.0

    def __init__(self, name: str, message: str, f, d: _Dae):
        self.name, self.message, self.f, self.d = name, message, f, d

    def __call__(self, t, x) -> float:
        return float(self.f(*self.d.args(t, x, self.d.solve(t, x))))


def _validity_events(model: Model, dae: DaeForm, d: _Dae) -> list[_Condition]:
    ysym = model.syms("output")
    out = []
    for c in model.validity:
        expr = ca.substitute(c.expr, ysym, dae.y) if ysym.numel() else c.expr
        out.append(_Condition(c.name, c.message, dae.function(f"v_{c.name}", [expr], ["v"]),
                              d))
    return out
