"""The model declaration layer: variables with full metadata and acausal
equations as CasADi expressions.

A mechanism module in ``models/`` builds a :class:`Model` by declaring

* parameters (``causality="parameter"``, with a ``source``: seed file and
  equation, or ``"assumption: ..."`` with the reason),
* continuous states (``der(x)`` appears in the equations),
* algebraic variables (unknowns without derivative),
* inputs and outputs (the causality chosen at the FMU boundary),
* equations in residual form ``lhs == rhs`` (no assignments),
* event indicators (breakpoints where the solver must restart),
* ports: named groups of variables (e.g. a shaft with speed and torque) that a
  scene can connect.

This one declaration is the only source for the generated C, the model
description, the scipy reference right-hand side and the parameter tables in
the docs (see :mod:`loomfmu.export.codegen`, :mod:`loomfmu.export.fmi_xml`,
:mod:`loomfmu.verification.reference`).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from loomfmu.declare.checks import (
    check_choice,
    check_number,
    check_optional_number,
    check_text,
    is_real,
)
from loomfmu.declare.solvers import SETTINGS, SOLVER_INDEX
from loomfmu.declare.units import check_display_unit, check_unit

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_SCALAR = "a scalar (1x1) CasADi SX expression or a finite number"


def reserved_names() -> tuple[str, ...]:
    """Variable names every FMU already uses: the solver settings
    (loomfmu.declare.solvers.SETTINGS), the ``solver`` and ``delay_interpolation`` enumerations, the
    ``solver_index`` Integer, and ``time`` (the first column of FMPy's result)."""
    return ("solver", SOLVER_INDEX, *(s.name for s in SETTINGS), "delay_interpolation",
            "time")


def as_sx(what: str, expr, *, column: bool = False) -> ca.SX:
    """``expr`` (a CasADi SX expression or a number) as a dense 1x1 SX; with
    ``column``, an n x 1 column (n >= 1) is allowed too.  Otherwise
    ValueError naming ``what``: a vector output would overrun the FMU's
    buffers, an empty one would never be written."""
    allowed = _SCALAR + (" (or a column of them, n x 1)" if column else "")
    if expr is None or isinstance(expr, (bool, np.bool_, str, bytes, ca.MX)):
        raise ValueError(f"{what} = {expr!r:.60}; allowed: {allowed}")
    try:
        sx = ca.SX(expr)
    except Exception:  # noqa: BLE001 (CasADi raises NotImplementedError, TypeError, ...)
        raise ValueError(f"{what} = {type(expr).__name__} {expr!r:.60}; allowed: {allowed}"
                         ) from None
    rows, cols = sx.shape
    if cols != 1 or rows < 1 or (rows != 1 and not column):
        raise ValueError(f"{what}: a {rows}x{cols} expression; allowed: {allowed}")
    sx = ca.densify(sx)
    for k in range(rows):
        if sx[k].is_constant() and not math.isfinite(float(sx[k])):
            raise ValueError(f"{what} = {float(sx[k])!r}; allowed: {allowed}")
    return sx


def as_symbol(what: str, sym, names, kind: str = "state") -> str:
    """The name of ``sym``, a scalar symbol of a declared ``kind`` (``names``)."""
    if not isinstance(sym, ca.SX) or sym.shape != (1, 1) or not sym.is_symbolic():
        raise ValueError(f"{what} = {sym!r:.60}; allowed: a scalar symbol returned by "
                         "the declaration")
    if sym.name() not in names:
        raise ValueError(f"{what}: {sym.name()!r} is not a declared {kind}; allowed: "
                         f"one of {sorted(names)}"[:300])
    return sym.name()

#: Variable kinds in the order the value references are laid out
#: (modes are Integer variables, the others Real).
KINDS = ("parameter", "state", "input", "output", "algebraic", "mode")


@dataclass
class Variable:
    """One scalar variable, named and described as FMI names things."""

    name: str
    kind: str  # one of KINDS
    sym: ca.SX
    start: float | None
    unit: str = ""
    description: str = ""
    min: float = -math.inf
    max: float = math.inf
    nominal: float | None = None
    source: str = ""  # parameters: seed file + equation, or "assumption: why"
    # a unit of UNITS measuring the same quantity that people read it in
    # (FMI displayUnit), e.g. "rpm" for a speed in rad/s; "" none
    display_unit: str = ""

    @property
    def causality(self) -> str:
        return {"parameter": "parameter", "input": "input", "output": "output"}.get(
            self.kind, "local")

    def check_value(self, value: float) -> None:
        """Raise ValueError when ``value`` is outside this variable's range."""
        if not is_real(value) or not math.isfinite(value):
            raise ValueError(f"{self.name} = {value!r:.60} is not finite; allowed: a number "
                             f"in the range [{self.min}, {self.max}] {self.unit}")
        if not self.min <= value <= self.max:
            raise ValueError(f"{self.name} = {value!r} {self.unit} is outside the "
                             f"allowed range [{self.min}, {self.max}]")


@dataclass
class Port:
    """A named connector: ``kind`` (e.g. "shaft", "warp") and its variables by role."""

    name: str
    kind: str
    variables: dict[str, str]
    description: str = ""


@dataclass
class Delay:
    """``sym`` stands for ``expr`` evaluated ``tau`` seconds ago."""

    name: str
    sym: ca.SX
    expr: ca.SX
    tau: ca.SX
    max_delay: float
    description: str = ""


@dataclass
class Constraint:
    """``expr`` >= 0 must hold for the parameters (checked at initialization)."""

    name: str
    expr: ca.SX
    message: str


@dataclass
class Quantity:
    """A named intermediate quantity of the derivation (an energy, a
    generalized force, a stiffness matrix): kept for the reports and
    :func:`loomfmu.inspect`, never used by the generated code."""

    name: str
    expr: ca.SX          # any shape; numbers are constant SX
    unit: str = ""
    description: str = ""
    symbol: str = ""     # LaTeX for the report, e.g. r"T" or r"\delta_{11}"
    source: str = ""     # seed file and equation, or "derived: how"
    group: str = ""      # the step of the derivation it belongs to, e.g. "energies"


@dataclass
class Figure:
    """A sketch of the model's frame (inline SVG) for the reports and the
    FMU's page; ``caption`` says what it shows."""

    name: str
    svg: str
    caption: str


@dataclass
class EventIndicator:
    """A function whose sign change marks a breakpoint inside a step."""

    name: str
    expr: ca.SX
    description: str = ""


@dataclass
class Model:
    """A mechanism declared as an acausal DAE."""

    @property
    def registry_name(self) -> str:
        """The name under which loomfmu's registry knows this model (the
        default build's name for a variant)."""
        return self.variant_of or self.name

    name: str
    description: str = ""
    stop_time: float = 1.0
    step_size: float = 1e-3
    h_max: float = math.inf     # default largest internal solver step
    h_fixed: float = 1e-4       # default step of the fixed-step solver
    reference_method: str = "DOP853"  # solve_ivp method of the scipy reference (stiff: Radau)
    variables: list[Variable] = field(default_factory=list)
    equations: list[ca.SX] = field(default_factory=list)
    events: list[EventIndicator] = field(default_factory=list)
    ports: list[Port] = field(default_factory=list)
    options: dict = field(default_factory=dict)  # build options the model was made with
    # The registry's name of the model this declaration is a variant of, when
    # its build options differ from the defaults (``name`` then carries them:
    # heald_frame_warp_tension_input); empty for a default build.
    variant_of: str = ""
    mode_values: dict[str, tuple[int, ...]] = field(default_factory=dict)
    mode_valid: dict[str, ca.SX] = field(default_factory=dict)
    reinits: dict[str, ca.SX] = field(default_factory=dict)
    event_modes: dict[str, str] = field(default_factory=dict)
    initials: dict[str, ca.SX] = field(default_factory=dict)
    delays: list[Delay] = field(default_factory=list)
    constraints: list[Constraint] = field(default_factory=list)
    validity: list[Constraint] = field(default_factory=list)  # must hold while running
    quantities: list[Quantity] = field(default_factory=list)
    figures: list[Figure] = field(default_factory=list)
    t: ca.SX = field(default_factory=lambda: ca.SX.sym("time"))

    def __post_init__(self):
        if not isinstance(self.name, str) or not re.match(r"^[A-Za-z_][A-Za-z0-9_]*$",
                                                          self.name):
            raise ValueError(f"name = {self.name!r}; allowed: a C identifier (model name)")
        self.stop_time = check_number("stop_time", self.stop_time, lo=0.0, lo_open=True,
                                      unit="s")
        self.step_size = check_number("step_size", self.step_size, lo=0.0, lo_open=True,
                                      hi=self.stop_time, unit="s")
        if self.h_max != math.inf:
            self.h_max = check_number("h_max", self.h_max, lo=0.0, lo_open=True, unit="s")
        self.h_fixed = check_number("h_fixed", self.h_fixed, lo=0.0, lo_open=True,
                                    hi=self.step_size, unit="s")
        check_choice("reference_method", self.reference_method,
                     ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"))
        check_text("description", self.description)
        self._by_name: dict[str, Variable] = {}
        self._der: dict[str, ca.SX] = {}

    # -- declaration ------------------------------------------------------
    def _add(self, name, kind, start, unit, description, **kw) -> ca.SX:
        if not isinstance(name, str) or not _NAME.match(name):
            raise ValueError(f"name = {name!r}; allowed: an identifier (dots between parts)")
        if name in self._by_name:
            raise ValueError(f"name = {name!r}: variable {name!r} declared twice in model "
                             f"{self.name}; allowed: a name not yet declared")
        if name in reserved_names():
            raise ValueError(f"name = {name!r} is reserved (every FMU has it); reserved: "
                             f"{', '.join(reserved_names())}")
        check_unit(unit)
        if kw.get("display_unit"):
            check_display_unit(kw["display_unit"], unit, f"{name}: display_unit")
        else:
            kw.pop("display_unit", None)
        if not description or not isinstance(description, str):
            raise ValueError(f"variable {name!r} needs a description (a non-empty string)")
        check_text(f"{name}: description", description)
        if kw.get("source"):
            kw["source"] = check_text(f"{name}: source", kw["source"])
        lo = check_number(f"{name}: min", kw.get("min", -math.inf)) if kw.get(
            "min", -math.inf) != -math.inf else -math.inf
        hi = check_number(f"{name}: max", kw.get("max", math.inf)) if kw.get(
            "max", math.inf) != math.inf else math.inf
        if lo > hi:
            raise ValueError(f"{name}: min = {lo!r}, max = {hi!r}; allowed: min <= max")
        if kw.get("nominal") is not None:
            kw["nominal"] = check_optional_number(f"{name}: nominal", kw["nominal"], lo=0.0,
                                                  lo_open=True)
        if start is not None:
            start = check_number(f"{name}: start", start, unit=unit)
        sym = ca.SX.sym(name)
        var = Variable(name, kind, sym, start, unit, description, **kw)
        if start is not None:
            var.check_value(var.start)
        self.variables.append(var)
        self._by_name[name] = var
        return sym

    def _expr(self, what: str, expr, *, column: bool = False) -> ca.SX:
        """:func:`as_sx`, and every symbol in it declared in this model (a
        symbol made elsewhere would be a free variable of the generated code)."""
        sx = as_sx(what, expr, column=column)
        self._check_symbols(what, sx)
        return sx

    def _check_symbols(self, what: str, sx: ca.SX) -> None:
        known = {v.name: v.sym for v in self.variables}
        known.update({s.name(): s for s in self._der.values()})
        known.update({d.sym.name(): d.sym for d in self.delays})
        known[self.t.name()] = self.t
        for sym in ca.symvar(sx):
            mine = known.get(sym.name())
            if mine is None or not ca.is_equal(sym, mine):
                which = "not declared" if mine is None else "a symbol of that name made " \
                    "elsewhere, not the one declared"
                raise ValueError(f"{what}: symbol {sym.name()!r} is {which} in model "
                                 f"{self.name}; allowed: expressions of this model's "
                                 "variables, der(), delays and time")

    @staticmethod
    def _new_name(what: str, name, taken) -> str:
        """``name`` for a new ``what`` (event, delay, ...): a C identifier (it is
        written into the FMU's C sources and log lines), not in ``taken``."""
        if not isinstance(name, str) or not _IDENT.match(name):
            raise ValueError(f"{what} name = {name!r:.60}; allowed: an identifier "
                             "(letters, digits, _; not starting with a digit)")
        if name in taken:
            raise ValueError(f"{what} name = {name!r} declared twice; allowed: a name not "
                             f"yet used by another {what}")
        return name

    def parameter(self, name, value, *, unit="", description="", source,
                  min=-math.inf, max=math.inf, display_unit="") -> ca.SX:
        """Declare a parameter; ``source`` is mandatory (seed + equation or
        assumption).  display_unit (here and for the other kinds): a unit
        measuring the same quantity that people read the value in (FMI
        ``displayUnit``, e.g. "rpm" for rad/s); values stay in ``unit``."""
        if not source:
            raise ValueError(f"parameter {name!r} needs a source (seed/equation or assumption)")
        return self._add(name, "parameter", value, unit, description,
                         min=min, max=max, source=source, display_unit=display_unit)

    def state(self, name, start, *, unit="", description="", nominal=None,
              min=-math.inf, max=math.inf, display_unit="") -> ca.SX:
        """Declare a continuous state ``name`` with its start value; its
        derivative is ``der(sym)`` in the equations."""
        sym = self._add(name, "state", start, unit, description, nominal=nominal,
                        min=min, max=max, display_unit=display_unit)
        self._der[name] = ca.SX.sym(f"der({name})")
        return sym

    def input(self, name, start, *, unit="", description="", min=-math.inf,
              max=math.inf, display_unit="") -> ca.SX:
        """Declare a Real input ``name`` (held or interpolated by the
        importer) with its start value and range."""
        return self._add(name, "input", start, unit, description, min=min, max=max,
                         display_unit=display_unit)

    def algebraic(self, name, *, unit="", description="", display_unit="") -> ca.SX:
        """Declare an algebraic unknown ``name`` of the DAE (solved with the
        derivatives, by Newton where the equations are implicit in it)."""
        return self._add(name, "algebraic", None, unit, description,
                         display_unit=display_unit)

    def delay(self, name, expr, tau, *, max_delay: float, description="") -> ca.SX:
        """A symbol for ``expr`` delayed by ``tau`` (an expression of parameters).

        expr may use time, states, inputs and parameters (not derivatives,
        algebraic variables or other delays).  Before the start time the
        history is constant at the start value.  max_delay: the longest tau
        the FMU's history is built to hold; a larger tau is rejected at
        initialization.
        """
        self._new_name("delay", name, {d.name for d in self.delays})
        check_number(f"delay {name!r}: max_delay", max_delay, lo=0.0, lo_open=True, unit="s")
        check_text(f"delay {name!r}: description", description)
        expr = self._expr(f"delay {name!r}: expr", expr)
        tau = self._expr(f"delay {name!r}: tau", tau)
        others = [self.t, self.syms("state"), self.syms("input"), self.syms("mode"),
                  self.syms("algebraic"), *(d.sym for d in self.delays),
                  *(s for s in self._der.values() if isinstance(s, ca.SX))]
        if ca.depends_on(tau, ca.vertcat(*others)):
            raise ValueError(f"delay {name!r}: tau must depend on parameters only")
        sym = ca.SX.sym(f"delay({name})")
        self.delays.append(Delay(name, sym, expr, tau, float(max_delay), description))
        return sym

    def constraint(self, name: str, expr, message: str) -> None:
        """Require ``expr`` >= 0, an expression of parameters only: a condition
        no single parameter range can express (e.g. the slats' mass must not
        exceed the frame's).  The FMU refuses to initialize with fmi2Error and
        a log line; Python raises ValueError (``check_constraints``)."""
        self._new_name("constraint", name, {c.name for c in self.constraints})
        expr = self._expr(f"constraint {name!r}: expr", expr)
        check_text(f"constraint {name!r}: message", message, c_string=True)
        if ca.depends_on(expr, ca.vertcat(self.t, self.syms("state"), self.syms("input"))):
            raise ValueError(f"constraint {name!r} must depend on parameters only")
        self.constraints.append(Constraint(name, expr, message))

    def check_constraints(self, values: dict[str, float] | None = None) -> None:
        """Raise ValueError naming every violated constraint at these parameters."""
        if not self.constraints:
            return
        ps = self.of_kind("parameter")
        p = [float(dict(values or {}).get(v.name, v.start)) for v in ps]
        f = ca.Function("c", [self.syms("parameter")],
                        [ca.vertcat(*[c.expr for c in self.constraints])])
        got = f(p).full().ravel()
        bad = [f"{c.name}: {c.message} (value {v:g}, must be >= 0)"
               for c, v in zip(self.constraints, got) if not v >= 0]
        if bad:
            raise ValueError(f"model {self.name}: " + "; ".join(bad))

    def require(self, name: str, expr, message: str) -> None:
        """Require ``expr`` >= 0 while the model runs (an expression of the
        model's variables and time, like an output): a state the model is not
        valid for, e.g. a warp in compression.  The FMU checks it on every
        accepted step; where it fails, the step ends with fmi2Discard at the
        last valid time and a log line naming ``message``, the value and the
        time."""
        self._new_name("validity condition", name, {c.name for c in self.validity})
        expr = self._expr(f"require {name!r}: expr", expr)
        check_text(f"require {name!r}: message", message, c_string=True)
        self.validity.append(Constraint(name, expr, message))

    def quantity(self, name: str, expr, *, unit: str = "", description: str,
                 symbol: str = "", source: str = "", group: str = ""):
        """Keep the intermediate quantity ``name`` of the derivation (a scalar,
        vector or matrix expression of this model's variables, or numbers) for
        the reports; returns ``expr`` unchanged, so a model writes
        ``T = m.quantity("T", 0.5 * J * w**2, ...)``.  The generated code never
        uses it: the equations are what runs."""
        self._new_name("quantity", name, {q.name for q in self.quantities})
        check_unit(unit)
        if not description or not isinstance(description, str):
            raise ValueError(f"quantity {name!r} needs a description (a non-empty string)")
        for what, text in (("description", description), ("symbol", symbol),
                           ("source", source), ("group", group)):
            check_text(f"quantity {name!r}: {what}", text)
        try:
            sx = ca.SX(np.asarray(expr, dtype=float)) if isinstance(
                expr, (list, tuple, np.ndarray)) else ca.SX(expr)
        except Exception:  # noqa: BLE001 (CasADi raises several types)
            raise ValueError(f"quantity {name!r}: expr = {type(expr).__name__}; allowed: a "
                             "CasADi SX/DM expression, a number or a numpy array") from None
        if sx.numel() == 0:
            raise ValueError(f"quantity {name!r}: an empty expression; allowed: at least "
                             "one element")
        self._check_symbols(f"quantity {name!r}", sx)  # this model's symbols
        for k in range(sx.numel()):  # constant elements finite
            if sx[k].is_constant() and not math.isfinite(float(sx[k])):
                raise ValueError(f"quantity {name!r}[{k}] = {float(sx[k])!r}; allowed: "
                                 "finite numbers")
        self.quantities.append(Quantity(name, sx, unit, description, symbol, source, group))
        return expr

    def figure(self, name: str, svg: str, *, caption: str) -> None:
        """Keep a sketch of the model's frame (an ``<svg>`` element as text)
        for the reports and the FMU's page."""
        self._new_name("figure", name, {f.name for f in self.figures})
        if not isinstance(svg, str) or not svg.lstrip().startswith("<svg"):
            raise ValueError(f"figure {name!r}: svg = {svg!r:.40}; allowed: an <svg> "
                             "element as text")
        if not caption or not isinstance(caption, str):
            raise ValueError(f"figure {name!r} needs a caption (a non-empty string)")
        self.figures.append(Figure(name, svg, caption))

    def mode(self, name, start: int, values, *, description="") -> ca.SX:
        """Declare a discrete mode (an Integer output of the FMU).

        values: the allowed values in priority order; at an event the runtime
        takes the first value whose validity expression (see ``mode_rule``)
        is >= 0.
        """
        from loomfmu.declare.checks import check_int
        values = tuple(check_int(f"mode {name!r}: values", v) for v in values)
        if not values or len(set(values)) != len(values):
            raise ValueError(f"mode {name!r}: values = {values!r}; allowed: distinct integers, "
                             "at least one")
        if check_int(f"mode {name!r}: start", start) not in values:
            raise ValueError(f"mode {name!r}: start = {start!r}; allowed: {values}")
        sym = self._add(name, "mode", int(start), "", description,
                        min=min(values), max=max(values))
        self.mode_values[name] = values
        return sym

    def mode_rule(self, mode: ca.SX, valid, *, events: list[str]) -> None:
        """``valid`` >= 0 where the current value of ``mode`` is consistent;
        ``events``: the event indicators at whose zero this mode is re-chosen."""
        name = as_symbol("mode_rule: mode", mode, self.mode_values, "mode")
        valid = self._expr(f"mode_rule {name!r}: valid", valid)
        if isinstance(events, (str, bytes)) or not isinstance(events, (list, tuple)):
            raise ValueError(f"mode_rule {name!r}: events = {events!r:.60}; allowed: a list "
                             "of declared event names")
        known = {e.name for e in self.events}
        for ev in events:
            if ev not in known:
                raise ValueError(f"mode_rule: event {ev!r} is not declared")
            if self.event_modes.get(ev, name) != name:
                raise ValueError(f"mode_rule: event {ev!r} already re-chooses mode "
                                 f"{self.event_modes[ev]!r}; allowed: one mode per event")
            self.event_modes[ev] = name
        self.mode_valid[name] = valid

    def reinit(self, state: ca.SX, expr) -> None:
        """The value of ``state`` right after a mode change (default: unchanged)."""
        name = as_symbol("reinit: state", state, self._der)
        self.reinits[name] = self._expr(f"reinit {name!r}: expr", expr)

    def output(self, name, expr, *, unit="", description="", display_unit="") -> ca.SX:
        """Declare an output defined by ``expr``, a scalar expression of the
        model's variables."""
        expr = self._expr(f"output {name!r}: expr", expr)
        sym = self._add(name, "output", None, unit, description, display_unit=display_unit)
        self._by_name[name].expr = expr  # type: ignore[attr-defined]
        return sym

    def der(self, x: ca.SX) -> ca.SX:
        """The time derivative of state ``x`` (an unknown of the equations)."""
        return self._der[as_symbol("der: x", x, self._der)]

    def eq(self, lhs, rhs=0.0) -> None:
        """Add the equation ``lhs == rhs``: scalars, or columns of the same
        length (one equation per element; a scalar rhs applies to each)."""
        lhs = self._expr("eq: lhs", lhs, column=True)
        rhs = self._expr("eq: rhs", rhs, column=True)
        if rhs.shape[0] not in (1, lhs.shape[0]):
            raise ValueError(f"eq: lhs has {lhs.shape[0]} rows, rhs {rhs.shape[0]}; allowed: "
                             "the same number of rows, or a scalar rhs")
        self.equations.append(lhs - rhs)

    def event(self, name, expr, *, description="") -> None:
        """An event indicator: a breakpoint where scalar ``expr`` changes sign."""
        self._new_name("event", name, {e.name for e in self.events})
        expr = self._expr(f"event {name!r}: expr", expr)
        check_text(f"event {name!r}: description", description)
        self.events.append(EventIndicator(name, expr, description))

    def port(self, name, kind, *, description="", **roles: str) -> None:
        """Declare port ``name`` of ``kind`` (a key of loomfmu.declare.ports.PORT_KINDS):
        ``role=variable`` for some of the kind's roles.  Each variable is an
        input or an output in a unit of the role's quantity; the roles of the
        kind's two groups have opposite causality (e.g. a warp port's
        elongation is an input where its tension is an output)."""
        from loomfmu.declare.ports import port_kind
        from loomfmu.declare.units import same_quantity
        self._new_name("port", name, {p.name for p in self.ports})
        pk = port_kind(kind)
        check_text(f"port {name!r}: description", description)
        if not roles:
            raise ValueError(f"port {name!r}: no roles; allowed: some of "
                             f"{', '.join(pk.roles)}")
        by_group: dict[int, set[str]] = {}
        for role, var in roles.items():
            if role not in pk.roles:
                raise ValueError(f"port {name!r}: role {role!r} is not a role of kind "
                                 f"{kind!r}; allowed: {', '.join(pk.roles)}")
            if not isinstance(var, str) or var not in self._by_name:
                raise ValueError(f"port {name!r}: {role}={var!r} is not a declared variable")
            v = self._by_name[var]
            if v.kind not in ("input", "output"):
                raise ValueError(f"port {name!r}: {role}={var!r} is {v.kind} variable; "
                                 "allowed: an input or an output")
            if not same_quantity(v.unit, pk.roles[role].unit):
                raise ValueError(f"port {name!r}: {role}={var!r} has unit {v.unit or '1'!r}; "
                                 f"allowed: a unit of the quantity of {pk.roles[role].unit!r}")
            by_group.setdefault(pk.roles[role].group, set()).add(v.kind)
        if any(len(k) > 1 for k in by_group.values()) or (
                len(by_group) == 2 and by_group[0] == by_group[1]):
            raise ValueError(f"port {name!r} of kind {kind!r}: roles "
                             f"{', '.join(f'{r}={roles[r]}' for r in roles)} do not "
                             "alternate; allowed: " + " / ".join(
                                 ", ".join(r for r, x in pk.roles.items() if x.group == g)
                                 for g in (0, 1)) + " with opposite causality")
        self.ports.append(Port(name, kind, dict(roles), description))

    def set_starts_from(self, states: ca.SX, exprs: ca.SX) -> None:
        """Start ``states`` at ``exprs`` (e.g. a static equilibrium).

        The start values written to the model description are ``exprs`` at
        the default parameters; the FMU and the reference recompute them at
        initialization from the parameters actually set, unless the state
        itself was set.
        """
        states = as_sx("set_starts_from: states", states, column=True)
        exprs = self._expr("set_starts_from: exprs", exprs, column=True)
        if exprs.shape != states.shape:
            raise ValueError(f"set_starts_from: {states.shape[0]} states, {exprs.shape[0]} exprs; "
                             "allowed: one expression per state")
        for k in range(states.shape[0]):
            as_symbol(f"set_starts_from: states[{k}]", states[k], self._der)
        known = [v for v in self.variables if v.kind in ("parameter", "state", "input")]
        f = ca.Function("starts", [ca.vertcat(*[v.sym for v in known])], [exprs])
        values = f(ca.DM([v.start for v in known])).full().ravel()
        for sym, value in zip(ca.vertsplit(states), values):
            var = self.var(sym.name())
            var.check_value(float(value))
            var.start = float(value)
        for sym, expr in zip(ca.vertsplit(states), ca.vertsplit(exprs)):
            self.initials[sym.name()] = expr

    # -- queries ------------------------------------------------------------
    def var(self, name: str) -> Variable:
        """The declared variable ``name`` (ValueError listing the names if none)."""
        try:
            return self._by_name[name]
        except KeyError:
            raise ValueError(f"model {self.name} has no variable {name!r}") from None

    def of_kind(self, kind: str) -> list[Variable]:
        """The variables of ``kind`` ("parameter", "state", "input", "output",
        "algebraic"), in declaration order."""
        return [v for v in self.variables if v.kind == kind]

    def syms(self, kind: str) -> ca.SX:
        vs = self.of_kind(kind)
        return ca.vertcat(*[v.sym for v in vs]) if vs else ca.SX(0, 1)

    def ders(self) -> ca.SX:
        xs = self.of_kind("state")
        return ca.vertcat(*[self._der[v.name] for v in xs]) if xs else ca.SX(0, 1)

    def starts(self, kind: str) -> list[float]:
        return [v.start for v in self.of_kind(kind)]
