"""Scenes declared in Python: components, connections, values, recorded outputs.

::

    s = Scene("two_mass", stop_time=2.0, step=1e-3)
    s.add("force", model="two_mass_force", parameters={"solver_rtol": 1e-10})
    s.add("disp", model="two_mass_displacement", start={"x2": 0.0})
    s.connect("force.coupling", "disp.coupling")   # port to port, both ways
    s.connect("force.F_c", "disp.F_in")            # or variable to variable
    s.record("force.x1_out", "disp.x2_out")

Every call is checked when it is made, against the components' interfaces
(their model descriptions and ports): a wrong name, causality, kind, unit or
direction, or an input driven twice, raises ValueError naming the
connection and what is allowed.  A scene knows its components' outsides
only: the master drives them through FMI.
"""
from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from loomfmu.declare.checks import MAX_POINTS, check_mapping, check_number, is_real
from loomfmu.scene.interface import (
    AssumedDependencies,
    Interface,
    conversion,
    interface_of_fmu,
    interface_of_model,
)

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
#: the masters' names (loomfmu.scene.master.MASTERS: its keys, in this order)
MASTER_NAMES = ("jacobi", "gauss-seidel")
#: FMI types a run records (as numbers; a Boolean is 0 or 1)
RECORDABLE = ("Real", "Integer", "Enumeration", "Boolean")

def model_names() -> list[str]:
    from loomfmu.registry import MODELS
    return sorted(MODELS)


def declare_model(name, options: dict):
    """The declaration (loomfmu.declare.model.Model) of model ``name`` (a name of
    loomfmu.registry.MODELS) with build options; a Model given itself is
    returned as is (it takes no options)."""
    from loomfmu.declare.model import Model
    from loomfmu.registry import MODELS, load_model
    if isinstance(name, Model):
        if options:
            raise ValueError(f"options = {options!r:.60}: model {name.name!r} is a "
                             "declaration; allowed: no options (declare it with them)")
        return name
    if not isinstance(name, str) or name not in MODELS:
        raise ValueError(f"model = {name!r:.60}; allowed: one of {', '.join(model_names())}"
                         " or a declared loomfmu Model")
    return load_model(name, **options)


@dataclass
class Component:
    """One FMU in the scene: a model with build options, or an FMU file."""

    name: str
    interface: Interface
    model: str | None = None
    options: dict = field(default_factory=dict)
    fmu: Path | None = None
    parameters: dict[str, float] = field(default_factory=dict)
    start: dict[str, float] = field(default_factory=dict)
    declaration: object = None      # a loomfmu Model given to Scene.add(model=...)

    @property
    def source(self) -> str:
        if self.declaration is not None:
            return f"declared model {self.model!r}"
        return f"model {self.model!r}" if self.model else f"FMU {str(self.fmu)!r}"


@dataclass(frozen=True)
class Connection:
    """Output ``src.src_var`` drives input ``dst.dst_var``:
    u = gain * y + bias (unit conversion)."""

    src: str
    src_var: str
    dst: str
    dst_var: str
    gain: float = 1.0
    bias: float = 0.0
    port: str = ""       # "a.port <-> b.port (role)" when made by a port connection

    def __str__(self) -> str:
        return f"{self.src}.{self.src_var} -> {self.dst}.{self.dst_var}"


def _settable(v, what: str) -> bool:
    """Whether ``v`` can take a value of this kind ("parameters" or "start")
    before initialization."""
    if what == "parameters":
        return v.causality == "parameter"
    return (v.causality in ("input", "local") and v.variability == "continuous"
            and v.initial in ("exact", "approx", None))


def _a(word: str) -> str:
    return ("an " if word[:1] in "aeiou" else "a ") + word


def _names(items) -> str:
    items = sorted(items)
    return ", ".join(items) if items else "none"


class Scene:
    """A co-simulation scene.  name: an identifier; stop_time and step (s),
    master (a name of loomfmu.scene.MASTERS) and extrapolation (the input
    extrapolation's order, 0, 1 or 2): the defaults of a run, the scene's
    recommended settings (a run takes each that its caller does not give)."""

    def __init__(self, name: str, *, description: str = "", stop_time: float = 1.0,
                 step: float = 1e-3, master: str = "jacobi", extrapolation: int = 0):
        from loomfmu.scene.extrapolation import ORDERS
        if not isinstance(name, str) or not _NAME.match(name):
            raise ValueError(f"name = {name!r:.60}; allowed: an identifier")
        if master not in MASTER_NAMES:
            raise ValueError(f"master = {master!r:.40}; allowed: {', '.join(MASTER_NAMES)}")
        if extrapolation not in ORDERS or isinstance(extrapolation, bool):
            raise ValueError(f"extrapolation = {extrapolation!r:.40}; allowed: one of "
                             f"{', '.join(map(str, ORDERS))}")
        self.master, self.extrapolation = master, int(extrapolation)
        self.name, self.description = name, str(description)
        self.stop_time = check_number("stop_time", stop_time, lo=0.0, lo_open=True, unit="s")
        self.step = check_number("step", step, lo=0.0, lo_open=True, hi=self.stop_time,
                                 unit="s")
        if self.stop_time / self.step > MAX_POINTS:
            raise ValueError(f"step = {step!r} s gives {self.stop_time / self.step:.3g} "
                             f"communication points up to stop_time = {self.stop_time:g} s;"
                             f" allowed: a step in [{self.stop_time / MAX_POINTS:.3g}, "
                             f"{self.stop_time:g}] s (at most {MAX_POINTS} points)")
        self.components: dict[str, Component] = {}
        self.connections: list[Connection] = []
        self.recorded: list[tuple[str, str]] = []

    # -- components ----------------------------------------------------------
    def add(self, name: str, *, model: str | None = None, fmu=None, options=None,
            parameters=None, start=None) -> Component:
        """Add component ``name`` (an identifier): ``model`` (a model name, see
        :func:`model_names`, built with ``options``; or a declared
        loomfmu.declare.model.Model, built as declared), or ``fmu`` (a path to an
        FMI 2.0 co-simulation FMU); ``parameters`` and ``start``: values by
        variable name (parameters; states and inputs with a settable start)."""
        if not isinstance(name, str) or not _NAME.match(name):
            raise ValueError(f"component name = {name!r:.60}; allowed: an identifier "
                             "(letters, digits, _)")
        if name in self.components:
            raise ValueError(f"component {name!r} is already in scene {self.name!r}; "
                             "allowed: a new name")
        if (model is None) == (fmu is None):
            raise ValueError(f"component {name!r}: give model= or fmu=, not "
                             f"{'both' if model is not None else 'neither'}")
        options = check_mapping(f"component {name!r}: options", options or {},
                                numbers_only=False)
        if fmu is not None:
            if options:
                raise ValueError(f"component {name!r}: options apply to model=, not fmu=")
            comp = Component(name, interface_of_fmu(fmu), fmu=Path(fmu))
            if comp.interface.assumed:
                warnings.warn(f"component {name} ({comp.source}): outputs "
                              f"{', '.join(comp.interface.assumed)} declare no dependencies "
                              "in the model description; taken to depend directly on every "
                              "input (FMI 2.0, 3.0)", AssumedDependencies, stacklevel=2)
        else:
            from loomfmu.declare.model import Model
            decl = declare_model(model, options)
            comp = Component(name, interface_of_model(decl),
                             model=decl.name if isinstance(model, Model) else model,
                             options=dict(options),
                             declaration=model if isinstance(model, Model) else None)
        self.components[name] = comp
        try:
            self.set(name, parameters=parameters or {}, start=start or {})
        except ValueError:
            del self.components[name]
            raise
        return comp

    def set(self, component: str, *, parameters=None, start=None) -> None:
        """Set parameter and start values of ``component`` (checked: the
        variable exists, can be set before initialization, the value is a
        number inside its range, a start is not of an input a connection drives).
        A Real's value may be text with a unit of the same quantity, e.g.
        ``{"omega_loom": "240 rpm"}`` (or "240rpm"): it is converted to the
        variable's unit (rad/s)."""
        comp = self._component(component, "set")
        iface = comp.interface
        for what, values in (("parameters", parameters or {}), ("start", start or {})):
            values = check_mapping(f"{component}: {what}", values, numbers_only=False)
            for var, value in values.items():
                v = iface.variables.get(var)
                if v is None or not _settable(v, what):
                    allowed = [n for n, x in iface.variables.items() if _settable(x, what)]
                    got = "no such variable" if v is None else f"{_a(v.causality)} variable"
                    raise ValueError(f"{component}.{var} ({what}): {got}; allowed: "
                                     f"{_names(allowed)}")
                driven = [c for c in self.connections if c.dst == component and
                          c.dst_var == var]
                if driven:
                    raise ValueError(f"{component}.{var} (start): driven by connection "
                                     f"{driven[0]}; allowed: a start for an undriven variable")
                if v.type == "Real" and isinstance(value, str):
                    value = self._with_unit(comp, var, value, what)
                if v.type in ("Integer", "Enumeration"):
                    if not isinstance(value, int) or isinstance(value, bool):
                        raise ValueError(f"{component}.{var} = {value!r:.40}; allowed: an "
                                         "integer")
                elif not is_real(value) or not math.isfinite(float(value)):
                    raise ValueError(f"{component}.{var} = {value!r:.40}; allowed: a finite "
                                     "number")
                self._check_range(comp, var, float(value))
                getattr(comp, what)[var] = value

    @staticmethod
    def _with_unit(comp: Component, var: str, value: str, what: str) -> float:
        from loomfmu.declare.units import allowed_units, split_quantity
        parsed = split_quantity(value)
        if parsed is None:
            raise ValueError(f"{comp.name}.{var} ({what}) = {value!r:.40}; allowed: a finite "
                             "number, or text: a number and a unit (e.g. '240 rpm')")
        if not parsed[1]:  # a number without a unit: in the variable's unit
            return parsed[0]
        try:
            return comp.interface.in_unit(var, *parsed)
        except ValueError:
            unit = comp.interface.variables[var].unit
            allowed = allowed_units(unit, comp.interface.display.get(unit))
            raise ValueError(f"{comp.name}.{var} ({what}) = {value!r:.40}: {var} is in "
                             f"{unit or 'no unit'}; allowed units: "
                             f"{', '.join(allowed) if allowed else 'none (a plain number)'}"
                             ) from None

    @staticmethod
    def _check_range(comp: Component, var: str, value: float) -> None:
        lo, hi = comp.interface.variables[var].range
        if not lo <= value <= hi:
            v = comp.interface.variables[var]
            shown = comp.interface.display.get(v.unit, {}).get(v.display_unit)
            extra = (f" {v.unit} = [{shown[0] * lo + shown[1]:g}, {shown[0] * hi + shown[1]:g}]"
                     f" {v.display_unit}" if shown else "")
            raise ValueError(f"{comp.name}.{var} = {comp.interface.show(var, value)}; allowed: "
                             f"a number in [{lo:g}, {hi:g}]{extra}")

    def _component(self, name: str, what: str) -> Component:
        if name not in self.components:
            raise ValueError(f"{what}: no component {name!r} in scene {self.name!r}; "
                             f"allowed: {_names(self.components)}")
        return self.components[name]

    def _split(self, ref, what: str) -> tuple[Component, str]:
        if not isinstance(ref, str) or "." not in ref:
            raise ValueError(f"{what} = {ref!r:.60}; allowed: 'component.variable' or "
                             "'component.port'")
        comp, rest = ref.split(".", 1)
        return self._component(comp, f"{what} {ref!r}"), rest

    # -- connections ---------------------------------------------------------
    def connect(self, a: str, b: str) -> list[Connection]:
        """Connect ``a`` to ``b``: two ports of one kind ("comp.port"; the roles
        the two ports have in common are connected, each an output on one side
        and an input on the other, both ways), or output variable ``a`` to
        input variable ``b`` ("comp.variable").  A loop of direct feedthrough
        is allowed: the masters iterate it at each communication point."""
        ca_, ra = self._split(a, "connect: from")
        cb_, rb = self._split(b, "connect: to")
        label = f"connection {a} -> {b}"
        if ca_.name == cb_.name:
            raise ValueError(f"{label}: both ends are in component {ca_.name!r}; allowed: "
                             "two different components")
        pa, pb = ca_.interface.ports.get(ra), cb_.interface.ports.get(rb)
        if (pa is None) != (pb is None):
            port_end, other = (a, b) if pa is not None else (b, a)
            comp, ref = (cb_, rb) if pa is not None else (ca_, ra)
            if ref not in comp.interface.variables:
                raise ValueError(f"{label}: {comp.name} has no port {ref!r} (it does not "
                                 f"exist); allowed: a port of {comp.name} "
                                 f"({_names(comp.interface.ports)})")
            raise ValueError(f"{label}: {port_end} is a port and {other} is not; allowed: "
                             "port to port, or variable to variable")
        if pa is not None:
            new = self._port_connections(label, ca_, pa, cb_, pb)
        else:
            new = [self._variable_connection(label, ca_, ra, cb_, rb)]
        for c in new:
            self._check_not_driven(label, c)
        self.connections.extend(new)
        return new

    def _port_connections(self, label, ca_, pa, cb_, pb) -> list[Connection]:
        if pa.kind != pb.kind:
            same = [p.name for p in cb_.interface.ports.values() if p.kind == pa.kind]
            raise ValueError(f"{label}: port kinds differ ({pa.kind!r} and {pb.kind!r}); "
                             f"allowed: a port of kind {pa.kind!r} of {cb_.name}: "
                             f"{_names(same)}")
        common = set(pa.roles) & set(pb.roles)
        if not common:
            raise ValueError(f"{label}: the ports share no role ({ca_.name}.{pa.name}: "
                             f"{_names(pa.roles)}; {cb_.name}.{pb.name}: {_names(pb.roles)}); "
                             f"allowed: ports of kind {pa.kind!r} with a role in common")
        out = []
        for role in sorted(common):
            va = ca_.interface.variables[pa.roles[role]]
            vb = cb_.interface.variables[pb.roles[role]]
            pair = {va.causality, vb.causality}
            if pair != {"output", "input"}:
                raise ValueError(
                    f"{label}: role {role!r} is {ca_.name}.{va.name} ({va.causality}) and "
                    f"{cb_.name}.{vb.name} ({vb.causality}); allowed: an output on one side "
                    "and an input on the other")
            (src, sv), (dst, dv) = (((ca_, va), (cb_, vb)) if va.causality == "output"
                                    else ((cb_, vb), (ca_, va)))
            gain, bias = self._units(f"{label} (role {role!r})", src, sv, dst, dv)
            out.append(Connection(src.name, sv.name, dst.name, dv.name, gain, bias,
                                  port=f"{ca_.name}.{pa.name} <-> {cb_.name}.{pb.name} "
                                       f"({role})"))
        return out

    def _variable_connection(self, label, ca_, ra, cb_, rb) -> Connection:
        for comp, ref, want in ((ca_, ra, "output"), (cb_, rb, "input")):
            v = comp.interface.variables.get(ref)
            allowed = [n for n, x in comp.interface.variables.items() if x.causality == want]
            if v is None:
                ports = list(comp.interface.ports)
                raise ValueError(f"{label}: {comp.name} has no variable or port {ref!r}; "
                                 f"allowed: an {want} of {comp.name} ({_names(allowed)})"
                                 + (f" or a port ({_names(ports)})" if ports else ""))
            if v.causality != want:
                raise ValueError(f"{label}: {comp.name}.{ref} is {_a(v.causality)} variable; "
                                 f"allowed: an {want} of {comp.name} ({_names(allowed)})")
        sv, dv = ca_.interface.variables[ra], cb_.interface.variables[rb]
        if sv.type != dv.type:
            raise ValueError(f"{label}: types differ ({sv.type} and {dv.type}); allowed: "
                             "the same FMI type on both ends")
        gain, bias = self._units(label, ca_, sv, cb_, dv)
        return Connection(ca_.name, ra, cb_.name, rb, gain, bias)

    @staticmethod
    def _units(label, src, sv, dst, dv) -> tuple[float, float]:
        conv = conversion(src.interface.unit(sv.unit), dst.interface.unit(dv.unit),
                          sv.unit, dv.unit)
        if conv is None:
            raise ValueError(f"{label}: unit {sv.unit or '1'!r} of {src.name}.{sv.name} "
                             f"cannot be converted to {dv.unit or '1'!r} of "
                             f"{dst.name}.{dv.name}; allowed: units of the same quantity")
        return conv

    def _check_not_driven(self, label: str, c: Connection) -> None:
        for old in self.connections:
            if old.dst == c.dst and old.dst_var == c.dst_var:
                raise ValueError(f"{label}: input {c.dst}.{c.dst_var} is already driven by "
                                 f"{old}; allowed: one connection into each input")
        if c.dst_var in self.components[c.dst].start:
            raise ValueError(f"{label}: input {c.dst}.{c.dst_var} has a start value set; "
                             "allowed: a connection into an input without a start value")

    def loops(self) -> list[list[Connection]]:
        """The algebraic loops: groups of connections that direct feedthrough
        closes into a cycle (the masters iterate each at a communication point)."""
        return [b for b in feedthrough_blocks(self.connections, self.components)
                if len(b) > 1 or _self_loop(b[0], self.components)]

    # -- outputs -------------------------------------------------------------
    def record(self, *refs: str) -> None:
        """Record these variables ("component.variable") in the results
        (default: every output of every component): Real, Integer (a mode),
        Boolean or enumeration variables, each given as a number."""
        for ref in refs:
            comp, var = self._split(ref, "record")
            v = comp.interface.variables.get(var)
            if v is None or v.type not in RECORDABLE:
                able = [n for n, x in comp.interface.variables.items()
                        if x.type in RECORDABLE and x.causality in ("output", "local", "input")]
                raise ValueError(f"record {ref!r}: " + ("no such variable" if v is None else
                                 f"{_a(v.type)} variable") + f"; allowed: a Real, Integer, "
                                 f"Boolean or enumeration variable of {comp.name} "
                                 f"({_names(able)})")
            if (comp.name, var) not in self.recorded:
                self.recorded.append((comp.name, var))

    def recorded_variables(self) -> list[tuple[str, str]]:
        if self.recorded:
            return list(self.recorded)
        return [(c.name, n) for c in self.components.values()
                for n, v in c.interface.variables.items()
                if v.causality == "output" and v.type in RECORDABLE]


def _depends(c: Connection, drives: dict, components: dict) -> list[Connection]:
    """The connections whose input value ``c``'s source output depends on directly."""
    return [drives[(c.src, inp)] for inp in components[c.src].interface.feedthrough.get(
        c.src_var, ()) if (c.src, inp) in drives]


def _self_loop(c: Connection, components: dict) -> bool:
    return c.dst == c.src and c.dst_var in components[c.src].interface.feedthrough.get(
        c.src_var, ())


def feedthrough_blocks(connections: list[Connection], components: dict[str, Component]
                       ) -> list[list[Connection]]:
    """The connections in blocks, ordered so that an output with direct
    feedthrough is read only after the inputs it depends on are set: a block
    is one connection, or an algebraic loop (connections that direct
    feedthrough closes into a cycle: a strongly connected component, Tarjan)."""
    drives = {(c.dst, c.dst_var): c for c in connections}
    index: dict[Connection, int] = {}
    low: dict[Connection, int] = {}
    stack: list[Connection] = []
    on: set[Connection] = set()
    blocks: list[list[Connection]] = []

    def strong(c: Connection) -> None:
        index[c] = low[c] = len(index)
        stack.append(c)
        on.add(c)
        for d in _depends(c, drives, components):
            if d not in index:
                strong(d)
                low[c] = min(low[c], low[d])
            elif d in on:
                low[c] = min(low[c], index[d])
        if low[c] == index[c]:
            block = []
            while True:
                d = stack.pop()
                on.discard(d)
                block.append(d)
                if d is c:
                    break
            pos = {x: k for k, x in enumerate(connections)}
            blocks.append(sorted(block, key=pos.__getitem__))

    for c in connections:
        if c not in index:
            strong(c)
    return blocks   # Tarjan emits a block after every block it depends on


def feedthrough_order(connections: list[Connection], components: dict[str, Component]
                      ) -> list[Connection]:
    """The connections of :func:`feedthrough_blocks`, flattened."""
    return [c for b in feedthrough_blocks(connections, components) for c in b]
