"""A scene composed at the equation level: one Model, hence one DAE and one FMU.

Every component's declaration (parameters, states, algebraic variables,
inputs, outputs, modes, events, delays, constraints, validity conditions,
named quantities, figures) is copied under its component's name
(``frame_a.h``; names that must be C identifiers, such as events and
delays, as ``frame_a_name``), with the scene's parameter and start values
as the composed model's defaults.  A connection ``src.y -> dst.u`` with its
unit conversion ``u = gain * y + bias`` becomes

* a substitution, when no loop of direct feedthrough runs through it: the
  input is replaced by the source's output expression wherever the
  destination uses it, and kept as an output of the composed model under its
  old name (so the composed FMU records what the co-simulation records);
* an algebraic unknown with the equation ``u = gain * y + bias``, when it is
  part of such a loop (:meth:`Scene.loops`): the coupled quantities are then
  solved with the derivatives, in closed form where the equations are
  linear in them and otherwise by the runtime's Newton iteration with the
  exact Jacobian, never by iterating between components.

The composed model is an ordinary declaration: :func:`loomfmu.build_fmu`,
:func:`loomfmu.verification.reference.reference` and ``loomfmu inspect``
take it as they take any model.  A component given only as an FMU file has
no equations to compose: it can only be co-simulated.
"""
from __future__ import annotations

import casadi as ca

from loomfmu.declare.model import Model, reserved_names
from loomfmu.scene.declare import Connection, Scene, declare_model

#: separator of a component's name and a name that must be a C identifier (CasADi
#: function names refuse two underscores in a row; a clash is refused by Model)
SEP = "_"
#: solve_ivp methods for stiff models: a composed model is stiff if a part is
_STIFF = ("Radau", "BDF", "LSODA")


def composable(scene: Scene) -> None:
    """ValueError unless every component of ``scene`` has a declaration."""
    if not isinstance(scene, Scene):
        raise ValueError(f"scene = {scene!r:.60}; allowed: a loomfmu Scene")
    if not scene.components:
        raise ValueError(f"scene {scene.name!r} has no components; allowed: a scene with at "
                         "least one component declared by a model")
    files = [c.name for c in scene.components.values() if c.model is None]
    if files:
        raise ValueError(f"scene {scene.name!r}: component(s) {', '.join(files)} are given "
                         "as FMU files, without equations to compose; allowed: components "
                         "declared by a model (model=...), or co-simulation (coupling "
                         "'cosim') for a scene with FMU files")


def compose(scene: Scene, *, name: str | None = None) -> Model:
    """The scene as one :class:`~loomfmu.declare.model.Model` named ``name``
    (default: the scene's name), with the scene's stop time and step as its
    default experiment."""
    composable(scene)
    name = scene.name if name is None else name
    loops = {(c.dst, c.dst_var) for block in scene.loops() for c in block}
    parts = {c.name: _declaration(c) for c in scene.components.values()}
    m = Model(name, description=_description(scene), stop_time=scene.stop_time,
              step_size=scene.step,
              h_max=min(p.h_max for p in parts.values()),
              h_fixed=min(min(p.h_fixed for p in parts.values()), scene.step),
              reference_method=_reference_method(parts.values()),
              options={"scene": scene.name,
                       "components": {c.name: {"model": c.model, **c.options}
                                      for c in scene.components.values()}})
    driven = {(c.dst, c.dst_var): c for c in scene.connections}
    sub: dict[str, dict[str, ca.SX]] = {}
    holders: dict[tuple[str, str], ca.SX] = {}   # placeholder per output, input, delay
    for comp, part in parts.items():
        sub[comp] = _declare_unknowns(m, scene.components[comp], part, driven, loops)
        for v in part.variables:
            if v.kind == "output" or (v.kind == "input" and v.name not in sub[comp]):
                holders[(comp, v.name)] = sub[comp][v.name] = ca.SX.sym(f"{comp}.{v.name}")
        for d in part.delays:
            holders[(comp, d.sym.name())] = sub[comp][d.sym.name()] = \
                ca.SX.sym(f"{comp}.{d.sym.name()}")
    # every expression of every component in the composed model's symbols (and
    # the placeholders), substituted in one call so that the subexpressions
    # the parts share stay shared
    items = [(comp, what, e) for comp, part in parts.items() for what, e in _expressions(part)]
    exprs = _substitute([e for _, _, e in items], [
        (part.t if k == "time" else _old_symbol(part, k), sub[comp][k])
        for comp, part in parts.items() for k in sub[comp]])
    got = {(comp, what): e for (comp, what, _), e in zip(items, exprs)}
    values = _resolve(parts, got, holders, driven)
    for comp, part in parts.items():
        for d in part.delays:
            expr, tau = (_substitute([got[(comp, f"delay {d.name} {x}")]], values)[0]
                         for x in ("expr", "tau"))
            values.append((holders[(comp, d.sym.name())], m.delay(
                _ident(comp, d.name), expr, tau, max_delay=d.max_delay,
                description=d.description)))
    final = dict(zip([(c, w) for c, w, _ in items], _substitute(exprs, values)))
    for comp, part in parts.items():
        _declare_outputs(m, comp, part, final, driven, loops)
    for comp, part in parts.items():
        _copy_behaviour(m, comp, part, final, sub[comp], scene.components[comp].start)
    for (dst, var), c in driven.items():
        if (dst, var) in loops:
            m.eq(sub[dst][var], c.gain * final[(c.src, f"output {c.src_var}")] + c.bias)
    _loop_conditions(m, scene, sub, final)
    _initial_starts(m)
    m.connections = list(scene.connections)  # for the documentation page
    return m


#: a linear loop is regular while |det(I - dG/du)| is at least this fraction
#: of the product of its rows' lengths (Hadamard's bound: 1 for orthogonal rows)
LOOP_REGULARITY = 1e-10
#: loops of more unknowns than this are left to the runtime's own checks
LOOP_CHECK_MAX = 6


def _loop_conditions(m: Model, scene: Scene, sub: dict, final: dict) -> None:
    """A loop of direct feedthrough that is linear in its unknowns is solved in
    closed form with the other unknowns (no Newton, whose singular dF/dw the
    runtime reports): where its matrix I - dG/du is singular the closed form
    returns numbers that solve nothing.  Each such loop gets a condition: a
    constraint where the matrix depends on parameters only (the FMU refuses
    to initialize, naming the loop), else a validity condition (the step
    ends with Discard at the time it fails)."""
    for k, block in enumerate(scene.loops()):
        us = [sub[c.dst][c.dst_var] for c in block]
        if len(us) > LOOP_CHECK_MAX:
            continue
        U = ca.vertcat(*us)
        R = ca.vertcat(*[u - (c.gain * final[(c.src, f"output {c.src_var}")] + c.bias)
                         for u, c in zip(us, block)])
        J = ca.jacobian(R, U)
        if ca.depends_on(J, U):
            continue   # nonlinear: Newton in the runtime
        norms = [ca.norm_2(J[i, :]) for i in range(J.size1())]
        scale = norms[0]
        for n in norms[1:]:
            scale = scale * n
        indicator = ca.fabs(ca.det(J)) - LOOP_REGULARITY * scale
        names = ", ".join(f"{c.dst}.{c.dst_var}" for c in block)
        message = (f"algebraic loop ({names}) is singular: no unique solution (|det(I - "
                   f"dG/du)| below {LOOP_REGULARITY:g} of its rows' lengths' product)")
        others = ca.vertcat(m.t, m.syms("state"), m.syms("input"), m.syms("algebraic"),
                            m.syms("mode"))
        if not ca.symvar(indicator):   # constant gains: decided here
            if float(ca.evalf(indicator)) < 0:
                raise ValueError(f"scene {scene.name}: {message} for every parameter value")
            continue
        if ca.depends_on(indicator, others):
            m.require(f"loop_{k}_regular", indicator, message)
        else:
            m.constraint(f"loop_{k}_regular", indicator, message)


def _old_symbol(part: Model, name: str) -> ca.SX:
    """The symbol ``name`` of declaration ``part`` (a variable, der(x), a delay)."""
    if name in part._by_name:
        return part._by_name[name].sym
    for d in part._der.values():
        if d.name() == name:
            return d
    return next(d.sym for d in part.delays if d.sym.name() == name)


def _expressions(part: Model) -> list[tuple[str, ca.SX]]:
    """Every expression of a declaration, keyed by what it is."""
    out = [(f"output {v.name}", v.expr) for v in part.of_kind("output")]
    out += [(f"equation {k}", e) for k, e in enumerate(part.equations)]
    out += [(f"event {e.name}", e.expr) for e in part.events]
    out += [(f"valid {k}", e) for k, e in part.mode_valid.items()]
    out += [(f"reinit {k}", e) for k, e in part.reinits.items()]
    out += [(f"initial {k}", e) for k, e in part.initials.items()]
    out += [(f"constraint {c.name}", c.expr) for c in part.constraints]
    out += [(f"require {c.name}", c.expr) for c in part.validity]
    out += [(f"quantity {q.name}", q.expr) for q in part.quantities]
    for d in part.delays:
        out += [(f"delay {d.name} expr", d.expr), (f"delay {d.name} tau", d.tau)]
    return out


def _substitute(exprs: list[ca.SX], pairs) -> list[ca.SX]:
    """``exprs`` with each old symbol of ``pairs`` (old, new) replaced, in one
    call (shared subexpressions stay shared)."""
    pairs = list(pairs)
    if not pairs or not exprs:
        return list(exprs)
    return ca.substitute(list(exprs), [o for o, _ in pairs], [n for _, n in pairs])


def _resolve(parts: dict, got: dict, holders: dict, driven: dict) -> list:
    """(placeholder, value) of every output and driven input outside loops,
    the values free of placeholders (delays aside): an output is its
    expression, a driven input ``gain * source output + bias``."""
    keys = [k for k in holders if not k[1].startswith("delay(")]
    raw = []
    for comp, var in keys:
        if parts[comp].var(var).kind == "output":
            raw.append(got[(comp, f"output {var}")])
        else:
            c = driven[(comp, var)]
            raw.append(c.gain * holders[(c.src, c.src_var)] + c.bias)
    P = ca.vertcat(*[holders[k] for k in keys]) if keys else ca.SX(0, 1)
    V = ca.vertcat(*raw) if raw else ca.SX(0, 1)
    for _ in range(len(keys) + 1):
        if not keys or not ca.depends_on(V, P):
            return [(holders[k], V[i]) for i, k in enumerate(keys)]
        V = ca.substitute(V, P, V)
    bad = [f"{c}.{v}" for i, (c, v) in enumerate(keys) if ca.depends_on(V[i], P)]
    raise ValueError(f"outputs and inputs {', '.join(bad)} depend on themselves through "
                     "connections without declared feedthrough; allowed: connections whose "
                     "loops the outputs' dependencies declare")


def _declaration(comp) -> Model:
    if comp.declaration is not None:
        return comp.declaration
    return declare_model(comp.model, comp.options)


def _description(scene: Scene) -> str:
    """The scene's description, its components and its connections (the
    composed FMU's description and the first lines of its page)."""
    text = scene.description or f"scene {scene.name}"
    comps = ", ".join(f"{c.name} ({c.model})" for c in scene.components.values())
    conns = "; ".join(str(c) + (f" (x {c.gain:.6g})" if c.gain != 1.0 else "")
                      + (f" (+ {c.bias:.6g})" if c.bias else "") for c in scene.connections)
    return (f"{text}; composed into one model from components {comps}"
            + (f"; connections {conns}" if conns else ""))


def _reference_method(parts) -> str:
    methods = [p.reference_method for p in parts]
    return next((s for s in _STIFF if s in methods), "Radau" if any(
        m not in ("RK45", "RK23", "DOP853") for m in methods) else "DOP853")


def prefixed(comp: str, var: str) -> str:
    """The composed model's name of variable ``var`` of component ``comp``."""
    return f"{comp}.{var}"


def _ident(comp: str, name: str) -> str:
    return f"{comp}{SEP}{name}"


def _declare_unknowns(m: Model, comp, part: Model, driven: dict, loops: set) -> dict:
    """Declare the parameters, states, undriven inputs, algebraic variables,
    modes and looped inputs of one component; the map old name -> new symbol
    (time and der(x) included)."""
    sub: dict[str, ca.SX] = {"time": m.t}
    values = {**comp.parameters, **comp.start}
    for v in part.variables:
        new = prefixed(comp.name, v.name)
        start = values.get(v.name, v.start)
        kw = {"unit": v.unit, "description": v.description, "display_unit": v.display_unit}
        if v.kind == "parameter":
            sub[v.name] = m.parameter(new, float(start), source=v.source, min=v.min,
                                      max=v.max, **kw)
        elif v.kind == "state":
            sub[v.name] = m.state(new, float(start), nominal=v.nominal, min=v.min,
                                  max=v.max, **kw)
            sub[part._der[v.name].name()] = m.der(sub[v.name])
        elif v.kind == "algebraic":
            sub[v.name] = m.algebraic(new, **kw)
        elif v.kind == "mode":
            sub[v.name] = m.mode(new, int(start), part.mode_values[v.name],
                                 description=v.description)
        elif v.kind == "input" and (comp.name, v.name) in loops:
            sub[v.name] = m.algebraic(new, unit=v.unit, display_unit=v.display_unit,
                                      description=f"{v.description} "
                                      f"(coupled: {driven[(comp.name, v.name)]})")
        elif v.kind == "input" and (comp.name, v.name) not in driven:
            sub[v.name] = m.input(new, float(start), min=v.min, max=v.max, **kw)
    ignored = set(values) & set(reserved_names())
    if ignored:  # a component's solver settings: the composed FMU has one solver
        m.options.setdefault("ignored", {})[comp.name] = sorted(ignored)
    return sub


def _declare_outputs(m: Model, comp: str, part: Model, final: dict, driven: dict,
                     loops: set) -> None:
    """The component's outputs, and its inputs driven by a connection outside a
    loop (as outputs under their own names, for the records)."""
    for v in part.variables:
        if v.kind == "output":
            m.output(prefixed(comp, v.name), final[(comp, f"output {v.name}")], unit=v.unit,
                     display_unit=v.display_unit, description=v.description)
        elif v.kind == "input" and (comp, v.name) in driven and (comp, v.name) not in loops:
            c: Connection = driven[(comp, v.name)]
            src = final[(c.src, f"output {c.src_var}")]
            m.output(prefixed(comp, v.name), c.gain * src + c.bias, unit=v.unit,
                     display_unit=v.display_unit, description=f"{v.description} (from {c})")


def _copy_behaviour(m: Model, comp: str, part: Model, final: dict, sub: dict,
                    started) -> None:
    """Equations, events, mode rules, reinits, initial values, constraints,
    validity conditions, quantities and figures of one component."""
    E = lambda what: final[(comp, what)]  # noqa: E731
    for k in range(len(part.equations)):
        m.eq(E(f"equation {k}"))
    for ev in part.events:
        m.event(_ident(comp, ev.name), E(f"event {ev.name}"), description=ev.description)
    for mode in part.mode_valid:
        events = [_ident(comp, e) for e, md in part.event_modes.items() if md == mode]
        m.mode_rule(sub[mode], E(f"valid {mode}"), events=events)
    for state in part.reinits:
        m.reinit(sub[state], E(f"reinit {state}"))
    for state in part.initials:
        if state not in started:  # a start the scene gives is kept as given
            m.initials[prefixed(comp, state)] = E(f"initial {state}")
    for c in part.constraints:
        m.constraint(_ident(comp, c.name), E(f"constraint {c.name}"), f"{comp}: {c.message}")
    for c in part.validity:
        m.require(_ident(comp, c.name), E(f"require {c.name}"), f"{comp}: {c.message}")
    for q in part.quantities:
        m.quantity(_ident(comp, q.name), E(f"quantity {q.name}"), unit=q.unit,
                   description=q.description, symbol=q.symbol, source=q.source,
                   group=f"{comp}: {q.group}" if q.group else comp)
    for f in part.figures:
        m.figure(_ident(comp, f.name), f.svg, caption=f"{comp}: {f.caption}")


def _initial_starts(m: Model) -> None:
    """The start values of states computed at initialization (a static
    equilibrium, a periodic solution), written for the composed model's
    defaults: the scene's parameter values."""
    if not m.initials:
        return
    known = [v for v in m.variables if v.kind in ("parameter", "state", "input")]
    names = list(m.initials)
    exprs = ca.vertcat(*[m.initials[n] for n in names])
    args = ca.vertcat(*[v.sym for v in known])
    free = [s.name() for s in ca.symvar(exprs) if not ca.depends_on(s, args)]
    if free:
        raise ValueError(f"model {m.name}: the initial values of {names} depend on "
                         f"{sorted(set(free))}; allowed: parameters, states and inputs")
    f = ca.Function("starts", [args], [exprs])
    values = f(ca.DM([v.start for v in known])).full().ravel()
    for n, value in zip(names, values):
        var = m.var(n)
        var.check_value(float(value))
        var.start = float(value)
