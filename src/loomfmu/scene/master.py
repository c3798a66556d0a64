"""Master algorithms: how the FMUs of a scene are stepped and their values
exchanged over one communication step.

The contract (like a solver's): a master is made on a :class:`System` and
offers ``step(t, h) -> StepResult``: advance every FMU from ``t`` to
``t + h`` and say whether the step is accepted and how large its error
estimate is.  A subclass writes only ``_advance(t, h)``: the order of value
exchanges and ``fmi2DoStep`` calls.  Inputs are held constant over the step
(``extrapolation=0``, zero-order hold) or follow the polynomial extrapolated
from the source's last 2-3 values (order 1, 2: loomfmu.scene.extrapolation),
for FMUs that declare ``canInterpolateInputs``.  Algebraic loops are
iterated at each communication point (loomfmu.scene.system).

Error estimate (used by the adaptive run): over the step every input
followed the value extrapolated from its source's samples up to the step's
start (or, for Gauss-Seidel, up to when it was set); at the step's end the
source has moved on.  The difference between the extrapolated input at the
step's end and the source's actual value there is the error of the
extrapolation, O(h^(order+1)).  Each connection's difference is scaled by
``atol + rtol * s`` with ``s`` the largest magnitude the signal has had so
far (a signal crossing zero is measured against its amplitude, not against
its value near zero); the step's error is the largest scaled difference.  A
step with error > 1 is rejected when the master is ``adaptive``: every FMU
goes back to the step's start through fmi2SetFMUstate and the step is redone
shorter.  A step an FMU discards with fmi2Terminated true (a validity
condition failed: the model is not valid beyond) is not redone: the run
stops at once with the FMU's message and how far the component's coupled
inputs moved within the step (ModelInvalid; a shorter step or
extrapolation may keep it valid where a held input overshot).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from loomfmu.scene.declare import MASTER_NAMES
from loomfmu.scene.extrapolation import ORDERS, History, shift, shift_rows, taylor_many, value
from loomfmu.scene.system import FMUError, ModelInvalid, System


@dataclass(frozen=True)
class StepResult:
    accepted: bool
    error: float     # scaled error estimate (<= 1: within the tolerances; NaN: not
    #                  estimated, the master is not adaptive)
    message: str = ""


def check_options(*, rtol=1e-3, atol=1e-6, extrapolation=0, output_derivatives=False
                  ) -> None:
    """ValueError naming the first of the master's options that is out of its
    range (run() checks them before it builds any FMU)."""
    if not (isinstance(rtol, (int, float)) and not isinstance(rtol, bool) and 0 < rtol < 1):
        raise ValueError(f"rtol = {rtol!r}; allowed: a number in (0, 1)")
    if not (isinstance(atol, (int, float)) and not isinstance(atol, bool) and atol > 0
            and math.isfinite(atol)):
        raise ValueError(f"atol = {atol!r}; allowed: a finite number > 0")
    if extrapolation not in ORDERS or isinstance(extrapolation, bool):
        raise ValueError(f"extrapolation = {extrapolation!r:.40}; allowed: one of "
                         f"{', '.join(map(str, ORDERS))}")
    if not isinstance(output_derivatives, bool):
        raise ValueError(f"output_derivatives = {output_derivatives!r:.40}; allowed: "
                         "True or False")
    if output_derivatives and not extrapolation:
        raise ValueError("output_derivatives = True with extrapolation = 0: the derivatives "
                         "would not be used; allowed: extrapolation = 1 or 2, or "
                         "output_derivatives = False")


class Master:
    """Base class of the masters.

    system: the running FMUs; rtol, atol: tolerances of the error estimate;
    adaptive: reject a step whose error estimate exceeds 1 (or whose FMU
    step fails) and restore the FMUs' states to its start.
    """

    name = ""

    def __init__(self, system: System, *, rtol: float = 1e-3, atol: float = 1e-6,
                 adaptive: bool = False, extrapolation: int = 0,
                 output_derivatives: bool = False):
        check_options(rtol=rtol, atol=atol, extrapolation=extrapolation,
                      output_derivatives=output_derivatives)
        self.system, self.rtol, self.atol, self.adaptive = system, rtol, atol, adaptive
        self.extrapolation, self.output_derivatives = extrapolation, output_derivatives
        if adaptive:
            bad = [n for n, i in system.instances.items()
                   if not i.md.coSimulation.canGetAndSetFMUstate]
            if bad:
                raise ValueError(f"adaptive = True: components {bad} cannot get and set "
                                 "their state; allowed: adaptive = False")
        if extrapolation:
            self._check_interpolation()
        self.n_accepted = self.n_rejected = 0
        n = len(system.connections)
        self._size = [abs(system.source_value(i)) for i in range(n)]
        self.history = History(n)
        #: each input's polynomial: Taylor coefficients (rows) at _t0
        self._C = [[0.0] * (extrapolation + 1) for _ in range(n)]
        self._t0 = [0.0] * n         # where each input's polynomial is expanded
        self._no_derivatives: set[int] = set()
        #: what the master changed on its own while running (e.g. a fallback)
        self.notes: list[str] = []

    def _check_interpolation(self) -> None:
        k = self.extrapolation
        for c in self.system.connections:
            md = self.system.instances[c.dst].md
            if not md.coSimulation.canInterpolateInputs:
                raise ValueError(f"extrapolation = {k}: component {c.dst} cannot interpolate "
                                 "inputs (its FMU declares canInterpolateInputs = false); "
                                 "allowed: extrapolation = 0")
            src = self.system.instances[c.src].md
            have = int(src.coSimulation.maxOutputDerivativeOrder or 0)
            if self.output_derivatives and have < k:
                raise ValueError(f"output_derivatives = True: component {c.src} declares "
                                 f"maxOutputDerivativeOrder = {have} < extrapolation = {k}; "
                                 "allowed: output_derivatives = False")

    # -- value exchange with extrapolation ---------------------------------------------
    def _set(self, indices, t: float, h: float, *, iterate=None) -> None:
        """Move values along connections ``indices`` at communication point t
        (loops iterated when ``iterate(block)``), then, with extrapolation,
        give each input its polynomial over [t, t + h]."""
        system = self.system
        indices = list(indices)
        system.exchange(indices, t, iterate=iterate)
        k = self.extrapolation
        if not k:      # held: the error estimate reads system.held
            return
        if self.output_derivatives:   # reads between the sets: one connection at a time
            for i in indices:
                self._set_one(i, t)
            return
        held, time, conns = system.held, system.time, system.connections
        groups: dict[tuple, tuple[list[int], list]] = {}   # sample times -> rows
        for i in indices:
            taus, values = self.history.points(i, time[conns[i].src], held[i], t, k)
            rows = groups.setdefault(taus, ([], []))
            rows[0].append(i)
            rows[1].append(values)
        coef, t0 = self._C, self._t0
        for taus, (idx, values) in groups.items():
            C = taylor_many(taus, values, k)
            moved = []
            for i, c in zip(idx, C):
                coef[i], t0[i] = c, t
                if c[0] != held[i]:
                    moved.append(i)
            if moved:
                system.set_inputs_together(moved, [coef[i][0] for i in moved], t)
            system.set_input_derivatives_together(idx, [c[1:] for c in C], t)

    def _set_one(self, i: int, t: float) -> None:
        """Connection ``i``'s polynomial over the step from t (output
        derivatives, else its samples), set."""
        system = self.system
        y = system.held[i]
        ts = system.time[system.connections[i].src]
        coef = self._from_derivatives(i, ts, y, t)
        if coef is None:
            coef = self.history.coefficients(i, ts, y, t, self.extrapolation)
        if coef[0] != y:
            system.set_inputs([i], [float(coef[0])], t)
        system.set_input_derivatives(i, [float(x) for x in coef[1:]], t)
        self._C[i], self._t0[i] = [float(x) for x in coef], t

    def _from_derivatives(self, i: int, ts: float, y: float, t: float):
        """Taylor coefficients at t from the source's output derivatives at ts,
        or None where fmi2GetRealOutputDerivatives fails (that connection then
        uses its samples from here on; the reason is kept in ``notes``)."""
        system, c = self.system, self.system.connections[i]
        if i in self._no_derivatives:
            return None
        inst = system.instances[c.src]
        fmu, vr = inst.fmu, inst.vr[c.src_var]
        try:
            d = [y] + [c.gain * system.call(c.src, "fmi2GetRealOutputDerivatives", ts,
                                            lambda m=m: fmu.getRealOutputDerivatives(
                                                [vr], [m])[0])
                       for m in range(1, self.extrapolation + 1)]
        except FMUError as exc:
            self._no_derivatives.add(i)
            self.notes.append(f"{c}: output derivatives unavailable ({exc}); its "
                              f"extrapolation uses the last values from t = {ts:.9g} s on")
            return None
        self.history.pending[i] = (ts, y)
        return shift(d, t - ts)

    def _end_value(self, i: int, t_end: float) -> float:
        """Connection ``i``'s input at ``t_end`` (its polynomial)."""
        return value(self._C[i], t_end - self._t0[i])

    def _stepped(self, name: str, t_end: float) -> None:
        """After component ``name`` stepped: its extrapolated inputs are set to
        the same polynomial anchored at the step's end (value and derivatives
        there), so an output with direct feedthrough, or an output derivative,
        read now is computed with the input the FMU had there (FMI 2.0 does
        not say what an FMU's input is after fmi2DoStep)."""
        idx = self.system.into[name]
        if not self.extrapolation or not idx:
            return
        coef, t0 = self._C, self._t0
        s = {t_end - t0[i] for i in idx}
        if len(s) == 1:
            C = shift_rows([coef[i] for i in idx], s.pop())
        else:
            C = [shift_rows([coef[i]], t_end - t0[i])[0] for i in idx]
        self.system.set_inputs_together(idx, [c[0] for c in C], t_end)
        self.system.set_input_derivatives_together(idx, [c[1:] for c in C], t_end)

    def _advance(self, t: float, h: float) -> None:
        """Exchange values and step every FMU from t to t + h."""
        raise NotImplementedError

    def step(self, t: float, h: float) -> StepResult:
        system = self.system
        saved = system.get_states() if self.adaptive else None
        held_before = list(system.held) if self.adaptive else None
        try:
            self._advance(t, h)
            error = self._error(t + h)
            message = ""
        except ModelInvalid:     # not redone: stop with the FMU's message
            if saved is not None:
                system.free_states(saved)
            raise
        except FMUError as exc:
            if not self.adaptive:
                raise
            error, message = math.inf, str(exc)
        accepted = not self.adaptive or error <= 1.0
        if not accepted:
            system.set_states(saved, held_before)
            self.history.discard()
        else:
            self.history.commit()
        if saved is not None:
            system.free_states(saved)
        if accepted:
            self.n_accepted += 1
            if self.adaptive:
                self._size = [max(s, abs(u)) for s, u in zip(self._size, system.held)]
        else:
            self.n_rejected += 1
        return StepResult(accepted, error, message)

    def _error(self, t_end: float) -> float:
        """The step's scaled error estimate (module doc); every source (and
        each variable the run records, System.watch) is read here, one
        fmi2GetReal per component, also when the estimate is not needed (a
        fixed step: NaN), so every FMU computes its outputs where it always
        did.  A failed read is repeated one by one, naming the variable."""
        system = self.system
        if not system.read_end():
            return self._estimate(t_end, system.source_value)
        if not self.adaptive:
            return math.nan
        return self._estimate(t_end, system.end_source)

    def _estimate(self, t_end: float, source) -> float:
        err = 0.0
        held = self.system.held
        for i in range(len(self.system.connections)):
            u = self._end_value(i, t_end) if self.extrapolation else held[i]
            y = source(i)
            if not (math.isfinite(y) and math.isfinite(u)):
                return math.inf
            size = max(self._size[i], abs(u), abs(y))
            err = max(err, abs(y - u) / (self.atol + self.rtol * size))
        return err


class Jacobi(Master):
    """All inputs set at the step's start, then every FMU steps (they could
    run in parallel).

    resolve_feedthrough: True (default): the inputs are set in direct-
    feedthrough order, so an output that depends on an input is read after
    that input has its new value (the exchanged values are consistent at t).
    False: every output is read before any input changes, as libcosim's
    fixed-step algorithm does: an output with feedthrough passes on a value
    computed with the previous step's inputs.
    """

    name = "jacobi"

    def __init__(self, system: System, *, resolve_feedthrough: bool = True, **kw):
        if not isinstance(resolve_feedthrough, bool):
            raise ValueError(f"resolve_feedthrough = {resolve_feedthrough!r}; allowed: "
                             "True or False")
        if not resolve_feedthrough and kw.get("extrapolation", 0):
            raise ValueError("resolve_feedthrough = False with extrapolation = "
                             f"{kw['extrapolation']!r}; allowed: extrapolation = 0 (the "
                             "libcosim-like exchange holds what it read)")
        super().__init__(system, **kw)
        self.resolve_feedthrough = resolve_feedthrough

    def _advance(self, t, h):
        system = self.system
        every = range(len(system.connections))
        if self.resolve_feedthrough:
            self._set(every, t, h)
        else:
            system.set_inputs(every, [system.source_value(i) for i in every], t)
        for name in system.instances:
            system.do_step(name, t, h)
        for name in system.instances:
            self._stepped(name, t + h)


class GaussSeidel(Master):
    """FMUs step one after the other (``order``: component names, default the
    scene's order); each sets its inputs from the latest outputs just before
    it steps, so later FMUs see the earlier ones' values at t + h."""

    name = "gauss-seidel"

    def __init__(self, system: System, *, order: list[str] | None = None, **kw):
        super().__init__(system, **kw)
        names = list(system.instances)
        order = list(order) if order is not None else names
        if sorted(order) != sorted(names):
            raise ValueError(f"order = {order!r}; allowed: every component once, e.g. "
                             f"{names}")
        self.order_of_components = order

    def _advance(self, t, h):
        system = self.system
        stepped: set[str] = set()

        def fresh(block) -> bool:   # a loop is iterated while all its members are at t
            return not any({system.connections[i].src, system.connections[i].dst} & stepped
                           for i in block)

        for name in self.order_of_components:
            self._set(system.into[name], t, h, iterate=fresh)
            system.do_step(name, t, h)
            stepped.add(name)
            self._stepped(name, t + h)


#: master name -> class
MASTERS = {"jacobi": Jacobi, "gauss-seidel": GaussSeidel}
assert tuple(MASTERS) == MASTER_NAMES   # a scene checks its master by these names


def make_master(name: str, system: System, **kw) -> Master:
    """Master ``name`` (a key of MASTERS) on ``system`` with keyword options."""
    import inspect
    if name not in MASTERS:
        raise ValueError(f"master = {name!r:.40}; allowed: {', '.join(MASTERS)}")
    allowed = {p for cls in MASTERS[name].__mro__[:-1] if "__init__" in vars(cls)
               for p in inspect.signature(cls.__init__).parameters} - {"self", "system", "kw"}
    unknown = sorted(set(kw) - allowed)
    if unknown:
        raise ValueError(f"master {name!r}: unknown options {unknown}; allowed: "
                         f"{sorted(allowed)}")
    return MASTERS[name](system, **kw)
