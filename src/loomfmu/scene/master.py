"""Master algorithms: how the FMUs of a scene are stepped and their values
exchanged over one communication step.

The contract (like a solver's): a master is made on a :class:`System` and
offers ``step(t, h) -> StepResult``: advance every FMU from ``t`` to
``t + h`` and say whether the step is accepted and how large its error
estimate is.  A subclass writes only ``_advance(t, h)``: the order of value
exchanges and ``fmi2DoStep`` calls.  Inputs are held constant over the step
(extrapolation order 0, zero-order hold).

Error estimate (used by the adaptive run): over the step every input held
the value its source had at the step's start (or, for Gauss-Seidel, when it
was set); at the step's end the source has moved on.  The difference between
the held input and the source's new value is the error of the zero-order
hold at the step's end, O(h).  Each connection's difference is scaled by
``atol + rtol * s`` with ``s`` the largest magnitude the signal has had so
far (a signal crossing zero is measured against its amplitude, not against
its value near zero); the step's error is the largest scaled difference.  A
step with error > 1 is rejected when the master is ``adaptive``: every FMU
goes back to the step's start through fmi2SetFMUstate and the step is redone
shorter.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .system import FMUError, System


@dataclass(frozen=True)
class StepResult:
    accepted: bool
    error: float     # scaled error estimate (<= 1: within the tolerances)
    message: str = ""


class Master:
    """Base class of the masters.

    system: the running FMUs; rtol, atol: tolerances of the error estimate;
    adaptive: reject a step whose error estimate exceeds 1 (or whose FMU
    step fails) and restore the FMUs' states to its start.
    """

    name = ""
    #: order of the input extrapolation (0: zero-order hold)
    order = 0

    def __init__(self, system: System, *, rtol: float = 1e-3, atol: float = 1e-6,
                 adaptive: bool = False):
        if not (isinstance(rtol, (int, float)) and 0 < rtol < 1):
            raise ValueError(f"rtol = {rtol!r}; allowed: a number in (0, 1)")
        if not (isinstance(atol, (int, float)) and atol > 0 and math.isfinite(atol)):
            raise ValueError(f"atol = {atol!r}; allowed: a finite number > 0")
        self.system, self.rtol, self.atol, self.adaptive = system, rtol, atol, adaptive
        if adaptive:
            bad = [n for n, i in system.instances.items()
                   if not i.md.coSimulation.canGetAndSetFMUstate]
            if bad:
                raise ValueError(f"adaptive = True: components {bad} cannot get and set "
                                 "their state; allowed: adaptive = False")
        self.n_accepted = self.n_rejected = 0
        self._size = [abs(system.source_value(i)) for i in range(len(system.connections))]

    def _advance(self, t: float, h: float) -> list[float]:
        """Exchange values and step every FMU from t to t + h; return, per
        connection, the value the input held over the step."""
        raise NotImplementedError

    def step(self, t: float, h: float) -> StepResult:
        system = self.system
        saved = system.get_states() if self.adaptive else None
        held_before = list(system.held)
        try:
            held = self._advance(t, h)
            error = self._error(held)
            message = ""
        except FMUError as exc:
            if not self.adaptive:
                raise
            error, message = math.inf, str(exc)
        accepted = not self.adaptive or error <= 1.0
        if not accepted:
            system.set_states(saved, held_before)
        if saved is not None:
            system.free_states(saved)
        if accepted:
            self.n_accepted += 1
            self._size = [max(s, abs(u)) for s, u in zip(self._size, system.held)]
        else:
            self.n_rejected += 1
        return StepResult(accepted, error, message)

    def _error(self, held: list[float]) -> float:
        err = 0.0
        for i, u in enumerate(held):
            y = self.system.source_value(i)
            if not math.isfinite(y):
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
        super().__init__(system, **kw)
        self.resolve_feedthrough = resolve_feedthrough

    def _advance(self, t, h):
        system = self.system
        every = range(len(system.connections))
        if self.resolve_feedthrough:
            system.exchange(every, t)
        else:
            system.set_inputs(every, [system.source_value(i) for i in every], t)
        held = list(system.held)
        for name in system.instances:
            system.do_step(name, t, h)
        return held


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
        for name in self.order_of_components:
            system.exchange(system.into[name], t)
            system.do_step(name, t, h)
        return list(system.held)


#: master name -> class
MASTERS = {"jacobi": Jacobi, "gauss-seidel": GaussSeidel}


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
