"""C code generation: CasADi functions plus the generated model declaration.

A model contributes to the FMU only

* ``<id>_casadi.c/.h``: CasADi-generated functions of (t, x, w, u, p, q, d,
  u_rate, d_rate) (ARGUMENTS):
  the closed-form unknowns w = [der(x); z] and their exact Jacobian
  (explicit models), or the residual F and its exact Jacobians (implicit
  models, solved by Newton in the runtime); the outputs, event indicators,
  mode validity and reinit; the outputs' time derivatives (yder) and the
  validity conditions of Model.require (vld);
* ``model_decl.h/.c``: counts, the value-reference table (names, starts,
  ranges, kinds), the solver names and the runtime settings, all written from
  the Python declaration.

The CasADi code calls the elementary functions of the runtime's lf_math.c
and lf_trig.c (MATH_FUNCTIONS) in place of the C library's: they give the
same bits on every platform, where the C libraries differ in the last bit;
sin and cos of one value share one argument reduction (pair_sin_cos).

Value references of Real variables are laid out in this order, which is also
the order of ``ModelVariables`` in the model description::

    settings | parameters | states | inputs | outputs | algebraic locals

The Enumeration ``solver`` has Integer value reference 0, the modes (Integer
outputs) 1, 2, ..., then ``delay_interpolation`` (models with delays) and
``solver_index`` (the solver as a plain Integer; fmi_xml.SOLVER_INDEX).
"""
from __future__ import annotations

import hashlib
import math
import re
import uuid
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from loomfmu.declare.model import Model, Variable
from loomfmu.declare.solvers import MAX_STEPS_DEFAULT, SETTINGS, SOLVERS
from loomfmu.export.dae import DaeForm
from loomfmu.export.runtime_files import LOG_CATEGORIES, RUNTIME_SYMBOLS


def setting_starts(model: Model) -> dict[str, float]:
    h_max = model.h_max if math.isfinite(model.h_max) else model.stop_time
    return {"solver_rtol": 1e-6, "solver_atol": 1e-9, "solver_h_max": h_max,
            "solver_h_fixed": model.h_fixed, "solver_max_steps": float(MAX_STEPS_DEFAULT)}


@dataclass
class RealVar:
    """One row of the Real value-reference table."""

    vr: int
    name: str
    kind: str  # "setting" or a declare.KINDS entry
    start: float | None
    min: float
    max: float
    unit: str
    description: str
    var: Variable | None = None


def real_table(model: Model) -> list[RealVar]:
    """All Real variables in value-reference order."""
    rows: list[RealVar] = []
    starts = setting_starts(model)
    for s in SETTINGS:
        rows.append(RealVar(len(rows), s.name, "setting", starts[s.name], s.min, s.max,
                            s.unit, s.description))
    for kind in ("parameter", "state", "input", "output", "algebraic"):
        for v in model.of_kind(kind):
            rows.append(RealVar(len(rows), v.name, kind, v.start, v.min, v.max, v.unit,
                                v.description, v))
    return rows


def model_guid(model: Model, dae: DaeForm) -> str:
    """A GUID that changes whenever the declaration or its equations change."""
    h = hashlib.sha256()
    for r in real_table(model):
        h.update(f"{r.name}|{r.kind}|{r.start}|{r.min}|{r.max}|{r.unit};".encode())
    for v in model.of_kind("mode"):
        h.update(f"{v.name}|{model.mode_values[v.name]}|{v.start};".encode())
    for expr in (dae.F, dae.y, dae.e, dae.valid, dae.reinit, dae.init, dae.g, dae.gdot,
                 dae.tau, dae.cons):
        h.update(str(expr).encode())
    h.update(repr(sorted(model.event_modes.items())).encode())
    h.update(repr([(e.name, e.description) for e in model.events]).encode())
    h.update(repr([(d.name, d.max_delay) for d in model.delays]).encode())
    h.update(repr([(v.name, v.message, str(v.expr)) for v in model.validity]).encode())
    h.update(repr(SOLVERS).encode())
    return "{" + str(uuid.UUID(bytes=h.digest()[:16], version=4)) + "}"


#: The generated functions in the order of the runtime's LfFunctionId.
FUNCTIONS = ("wsol", "wjac", "res", "rjac", "out", "evt", "valid", "reinit", "init",
             "hist", "tau", "cons", "djac", "yder", "vld", "pre", "dirw", "diry",
             "tpre", "tres", "tpost")

#: Models with delays only: one more generated function, after FUNCTIONS,
#: with hist's outputs (g, g_dot) and out's (y) together (model_decl.h:
#: LF_HISTOUT_FN).
HISTOUT = "histout"

#: Names of the generated functions' arguments, in order (the runtime fills
#: c->arg[] in this order, lf_eval_fn).  k: the folded parameter-only
#: subexpressions (output of ``pre``, kept by the runtime).
ARGUMENTS = ("t", "x", "w", "u", "p", "q", "d", "u_rate", "d_rate", "k")


def casadi_functions(dae: DaeForm, *, fold: bool = True) -> list[ca.Function]:
    """The functions the runtime calls, all with arguments ARGUMENTS:
    (t, x, w, u, p, q, d, u_rate, d_rate, k) (d: the delayed values; u_rate:
    the inputs' time derivatives, from fmi2SetRealInputDerivatives, zero
    for held inputs; d_rate: the delayed values' time derivatives, passed
    to ``yder`` only; k: the parameter-only subexpressions, from ``pre``).

    Parameter folding (``fold``, the default): every subexpression of the
    functions' outputs that depends on the parameters p only is taken out
    once, over all functions together (a subexpression shared between
    functions is folded once; CasADi's ``extract_parametric``), and becomes
    an entry of k; ``pre`` -> k computes them from p, and the runtime calls
    it at initialization and after a parameter changes (lf_eval_fn).  With
    ``fold=False`` k is empty and every function computes everything (the
    reference for tests and the before/after benchmark).

    Every partial time derivative the runtime uses is taken with the
    inputs moving at u_rate: d/dt + (d/du) u_rate (rodas4's df/dt, the
    delay history's slope), so that interpolated inputs reach the solvers'
    Jacobian terms too.

    Explicit models: wsol -> w, wjac -> (dw/dx, dw/dt); res/rjac return
    zeros (never called).  Implicit models: res -> F, rjac -> (dF/dw, dF/dx,
    dF/dt); wsol/wjac return zeros (never called).  The stubs keep one
    function table for every model at no build cost.

    djac -> (dw/dd or dF/dd, dg/dx, dg/dt): the chain-rule term of the
    Jacobian for zero delays, where d = g(t, x) now (g taken at fixed w).

    Directional derivatives (lf_dirder.c), with y = [outputs; algebraic
    locals]: dirw -> (dw/du or dF/du, dg/du, dy/dd), diry -> (dy/dx, dy/dw,
    dy/du), partials at fixed w; the runtime chains them with wjac/rjac and
    djac.

    Torn implicit models (:mod:`loomfmu.export.tearing`, ``dae.tearing``):
    tpre -> [w[pre]; h], the unknowns before Newton in closed form and the
    hoisted subexpressions h; tres -> (the torn unknowns' residual, its
    Jacobian in them), reading w[pre], w[torn] and h from its w argument
    [w; h]; tpost -> w[post] from the same.  Empty for the others.

    Every output is densified, so that the generated C writes all of its
    entries (structural zeros included: e.g. dg/dt of a delayed input).
    """
    name = dae.model.name
    ud = ca.SX.sym("u_rate", dae.u.numel())
    dd = ca.SX.sym("d_rate", dae.d.numel())
    outs = _function_outputs(dae, ud, dd)
    names = [f for f in FUNCTIONS if f != "pre"]
    flat = [ca.densify(e) for f in names for e in outs[f][0]]
    if fold and dae.p.numel() and flat:
        flat, ks, kexprs = ca.extract_parametric(flat, dae.p)
    else:
        ks, kexprs = [], []
    k = ca.vertcat(*ks) if ks else ca.SX(0, 1)
    outs["pre"] = ([ca.vertcat(*kexprs) if kexprs else ca.SX(0, 1)], ["k_value"])
    pos = 0
    for f in names:
        n = len(outs[f][0])
        outs[f] = (flat[pos:pos + n], outs[f][1])
        pos += n
    # Every output dense: CasADi's generated C writes only an output's
    # structural nonzeros (a structural zero entry is never written, and the
    # entries after it land in its place), while the runtime reads every
    # output as a dense column-major array.
    # a torn model's tres and tpost read the hoisted subexpressions h after
    # w in their w argument ([w; h], written by tpre: export.tearing)
    tr = dae.tearing
    wh = ca.vertcat(dae.w, tr.h) if tr is not None and tr.h.numel() else dae.w
    args = {f: [*dae.args, ud, dd, k] for f in FUNCTIONS}
    for f in ("tres", "tpost"):
        args[f][2] = wh
    fns = [ca.Function(f"{name}_{f}", args[f],
                       [ca.densify(e) for e in outs[f][0]], list(ARGUMENTS), outs[f][1])
           for f in FUNCTIONS]
    if dae.model.delays:
        # histout: hist's and out's outputs in one function (the same
        # expressions, so the subexpressions they share, such as the drive's
        # cam series, are computed once); the runtime takes it for the
        # history sample at a step's end and keeps the outputs for
        # lf_update_outputs at the same point (lf_delay.c).
        parts = outs["hist"][0] + outs["out"][0]
        fns.append(ca.Function(f"{name}_{HISTOUT}", [*dae.args, ud, dd, k],
                               [ca.densify(e) for e in parts], list(ARGUMENTS),
                               outs["hist"][1] + outs["out"][1]))
    return fns


def n_folded(fns: list[ca.Function]) -> int:
    """How many parameter-only subexpressions ``pre`` computes (the length of k)."""
    return fns[FUNCTIONS.index("pre")].numel_out(0)


def _function_outputs(dae: DaeForm, ud: ca.SX, dd: ca.SX) -> dict:
    """Per generated function (but ``pre``): its output expressions and names."""
    nw, nx = dae.w.numel(), dae.nx

    def d_dt(e: ca.SX) -> ca.SX:  # partial time derivative, inputs moving at u_rate
        return ca.densify(ca.jacobian(e, dae.t) + ca.jacobian(e, dae.u) @ ud)

    if dae.implicit:
        wsol, wjac = ca.SX.zeros(nw), [ca.SX.zeros(nw, nx), ca.SX.zeros(nw)]
        F = dae.F
        rjac = [ca.densify(ca.jacobian(dae.F, v)) for v in (dae.w, dae.x)] + [d_dt(dae.F)]
    else:
        wsol = dae.wsol
        wjac = [ca.densify(ca.jacobian(wsol, dae.x)), d_dt(wsol)]
        F = ca.SX.zeros(nw)
        rjac = [ca.SX.zeros(nw, nw), ca.SX.zeros(nw, nx), ca.SX.zeros(nw)]
    zloc = dae.w[nx:, 0]
    yz = ca.vertcat(dae.y, zloc)
    tr = dae.tearing
    empty = ca.SX(0, 1)
    return {
        "tpre": ([ca.vertcat(tr.pre_expr, tr.h_expr) if tr else empty], ["w_pre_h"]),
        "tres": ([tr.res, tr.jac] if tr else [empty, ca.SX(0, 0)], ["F_torn", "dF_dw_torn"]),
        "tpost": ([tr.post_expr if tr else empty], ["w_post"]),
        "wsol": ([wsol], ["w_sol"]), "wjac": (wjac, ["dw_dx", "dw_dt"]),
        "res": ([F], ["F"]), "rjac": (rjac, ["dF_dw", "dF_dx", "dF_dt"]),
        "out": ([yz], ["y"]), "evt": ([dae.e], ["e"]),
        "valid": ([dae.valid], ["valid"]), "reinit": ([dae.reinit], ["x_new"]),
        "init": ([dae.init], ["x_start"]),
        "hist": ([dae.g, dae.gdot + ca.jacobian(dae.g, dae.u) @ ud], ["g", "g_dot"]),
        "tau": ([dae.tau], ["tau"]),
        "cons": ([dae.cons], ["c"]),
        "djac": ([ca.densify(ca.jacobian(F if dae.implicit else wsol, dae.d)),
                  ca.densify(ca.jacobian(dae.g, dae.x)), d_dt(dae.g)],
                 ["dW_dd", "dg_dx", "dg_dt"]),
        "yder": (_output_rates(dae, ud, dd), ["y_rate", "dy_dw", "w_rate"]),
        "vld": ([_validity(dae)], ["v"]),
        "dirw": ([ca.jacobian(F if dae.implicit else wsol, dae.u),
                  ca.jacobian(dae.g, dae.u), ca.jacobian(yz, dae.d)],
                 ["dW_du", "dg_du", "dy_dd"]),
        "diry": ([ca.jacobian(yz, v) for v in (dae.x, dae.w, dae.u)],
                 ["dy_dx", "dy_dw", "dy_du"]),
    }


def _validity(dae: DaeForm) -> ca.SX:
    """The model's validity conditions (Model.require), each >= 0 while valid."""
    conds = dae.model.validity
    if not conds:
        return ca.SX(0, 1)
    v = ca.vertcat(*[c.expr for c in conds])
    ysym = dae.model.syms("output")  # a condition may name outputs: their expressions
    return ca.substitute(v, ysym, dae.y) if ysym.numel() else v


def _output_rates(dae: DaeForm, ud: ca.SX, dd: ca.SX) -> list[ca.SX]:
    """Exact first time derivatives of the outputs and algebraic locals
    (fmi2GetRealOutputDerivatives, order 1) along the trajectory: states
    moving at der(x) = w[:nx], inputs at u_rate, delayed values at d_rate.

    Explicit models: [dy/dt, 0, 0] in closed form (the unknowns' rate is
    the directional derivative of their closed form).  Implicit models:
    [partial rate of y at fixed w, dy/dw, partial rate of F at fixed w]; the
    runtime solves dF/dw w_rate = -F_rate and adds dy/dw w_rate."""
    nx = dae.nx
    y = ca.vertcat(dae.y, dae.w[nx:, 0])
    moving = ca.vertcat(dae.t, dae.x, dae.u, dae.d)
    speed = ca.vertcat(ca.SX(1), dae.w[:nx, 0], ud, dd)
    y_part = ca.jtimes(y, moving, speed)
    if dae.implicit:
        return [y_part, ca.jacobian(y, dae.w), ca.jtimes(dae.F, moving, speed)]
    w_rate = ca.jtimes(dae.wsol, moving, speed)
    return [y_part + ca.jtimes(y, dae.w, w_rate), ca.SX.zeros(1, 1), ca.SX.zeros(1, 1)]


#: Levels of :func:`clock_states` and :func:`event_time_only`.
CLOCK_NONE, CLOCK_PARAMETERS, CLOCK_HELD_INPUTS = 0, 1, 2


def clock_states(dae: DaeForm) -> list[int]:
    """Per state, whether it advances linearly in time, x_j(t) = x_j(t0) +
    der(x_j) (t - t0) exactly (a phase at a fixed speed):

    * 1 (CLOCK_PARAMETERS): der(x_j) depends on the parameters only;
    * 2 (CLOCK_HELD_INPUTS): on parameters and inputs only, so x_j is
      linear while the inputs are held (within a communication step whose
      inputs have no time derivatives set);
    * 0: it depends on t, x, w, q or d.

    Explicit models: from the closed form.  Implicit models: where one
    equation F_i involves no unknown but der(x_j), linearly, besides
    parameters (and inputs)."""
    nx = dae.nx
    moving = ca.vertcat(dae.t, dae.x, dae.q, dae.d)

    def level(e: ca.SX) -> int:
        if ca.depends_on(e, moving):
            return CLOCK_NONE
        return CLOCK_HELD_INPUTS if ca.depends_on(e, dae.u) else CLOCK_PARAMETERS

    if not dae.implicit:
        return [CLOCK_NONE if ca.depends_on(dae.wsol[j], dae.w) else level(dae.wsol[j])
                for j in range(nx)]
    clock = [CLOCK_NONE] * nx
    for i in range(dae.F.numel()):
        Fi = dae.F[i]
        used = [j for j in range(dae.w.numel()) if ca.depends_on(Fi, dae.w[j])]
        if len(used) == 1 and used[0] < nx and \
                not ca.depends_on(ca.jacobian(Fi, dae.w[used[0]]), dae.w):
            clock[used[0]] = level(Fi)
    return clock


def event_time_only(dae: DaeForm) -> list[int]:
    """Per event indicator, whether its zeros are known ahead of a step:

    * 1: it depends on time, the parameters and clock states of level 1
      only (:func:`clock_states`): predictable at any time;
    * 2: also on inputs or clock states of level 2: predictable while the
      inputs are held (advance the clock states linearly, inputs fixed);
    * 0: it depends on other states, w, q or d.

    The step loop can then land a step on such an indicator's zeros instead
    of rejecting steps across them."""
    clock = clock_states(dae)
    others = [dae.x[j] for j, c in enumerate(clock) if c == CLOCK_NONE]
    held = [dae.x[j] for j, c in enumerate(clock) if c == CLOCK_HELD_INPUTS]
    moving = ca.vertcat(*others, dae.w, dae.q, dae.d)
    inputs = ca.vertcat(*held, dae.u)
    return [CLOCK_NONE if ca.depends_on(dae.e[k], moving) else
            CLOCK_HELD_INPUTS if ca.depends_on(dae.e[k], inputs) else CLOCK_PARAMETERS
            for k in range(dae.e.numel())]


def _c_double(v: float | None) -> str:
    if v is None:
        return "NAN"
    if math.isinf(v):
        return "INFINITY" if v > 0 else "-INFINITY"
    return repr(float(v))


def _c_array(ctype: str, name: str, items: list[str]) -> str:
    body = ",\n    ".join(items) if items else "0"
    return f"static const {ctype} {name}[] = {{\n    {body}\n}};\n"


def _c_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


_KIND_C = {"setting": "LF_KIND_SETTING", "parameter": "LF_KIND_PARAMETER",
           "state": "LF_KIND_STATE", "input": "LF_KIND_INPUT", "output": "LF_KIND_OUTPUT",
           "algebraic": "LF_KIND_LOCAL"}


def declaration_header(model: Model, dae: DaeForm, n_k: int = 0) -> str:
    """model_decl.h: the counts; n_k: the length of k (:func:`n_folded`)."""
    n = {k: len(model.of_kind(k)) for k in ("parameter", "state", "input", "output",
                                            "algebraic")}
    lines = [
        "/* Generated by loomfmu from models/%s.py -- do not edit. */" % model.name,
        "#ifndef LF_MODEL_DECL_H", "#define LF_MODEL_DECL_H",
        f"#define LF_MODEL_IDENTIFIER {model.name}",
        f"#define LF_NSET {len(SETTINGS)}",
        f"#define LF_NP {n['parameter']}",
        f"#define LF_NX {n['state']}",
        f"#define LF_NU {n['input']}",
        f"#define LF_NY {n['output']}",
        f"#define LF_NZ {n['algebraic']}",
        f"#define LF_NE {dae.e.numel()}",
        f"#define LF_NW {dae.w.numel()}",
        f"#define LF_NQ {len(model.of_kind('mode'))}",
        f"#define LF_IMPLICIT {1 if dae.implicit else 0}",
        # the torn form of an implicit model (export.tearing): Newton on
        # LF_NT_TORN unknowns, LF_NT_PRE before it and LF_NT_POST after it
        # in closed form
        f"#define LF_TORN {int(dae.tearing is not None)}",
        f"#define LF_NT_PRE {len(dae.tearing.pre) if dae.tearing else 0}",
        f"#define LF_NT_TORN {len(dae.tearing.torn) if dae.tearing else 0}",
        f"#define LF_NT_POST {len(dae.tearing.post) if dae.tearing else 0}",
        # hoisted subexpressions: written by tpre after w[pre], read by tres
        # and tpost after w
        f"#define LF_NT_HOIST {dae.tearing.h.numel() if dae.tearing else 0}",
        f"#define LF_ND {len(model.delays)}",
        f"#define LF_NC {len(model.constraints)}",
        f"#define LF_NV {len(model.validity)}",
        f"#define LF_N_SOLVERS {len(SOLVERS)}",
        f"#define LF_NK {n_k}",
        # 1 if a state has a finite declared range (the runtime checks it
        # after each accepted step; without one, only the magnitude)
        f"#define LF_X_RANGED {int(any(math.isfinite(v.min) or math.isfinite(v.max) for v in model.of_kind('state')))}",
    ]
    if model.delays:  # the combined history and output function (codegen.HISTOUT)
        lines.append(f"#define LF_HISTOUT_FN {model.name}_lf_{HISTOUT}")
    lines += [f"#define {s.macro} {i}" for i, s in enumerate(SETTINGS)]
    cats = ", ".join(_c_str(name) for name, _ in LOG_CATEGORIES)
    lines.append(f"#define LF_LOG_CATEGORY_NAMES {{{cats}}}")
    lines += ["#endif", ""]
    return "\n".join(lines)


def declaration_source(model: Model, dae: DaeForm, guid: str) -> str:
    rows = real_table(model)
    name = model.name
    out = [f"/* Generated by loomfmu from models/{name}.py -- do not edit. */",
           "#include <math.h>", '#include "lf_model.h"', f'#include "{name}_casadi.h"', ""]
    out.append(_c_array("char *const", "real_names", [_c_str(r.name) for r in rows]))
    out.append(_c_array("double", "real_start", [_c_double(r.start) for r in rows]))
    out.append(_c_array("double", "real_min", [_c_double(r.min) for r in rows]))
    out.append(_c_array("double", "real_max", [_c_double(r.max) for r in rows]))
    out.append(_c_array("LfKind", "real_kind", [_KIND_C[r.kind] for r in rows]))
    out.append(_c_array("char *const", "event_names",
                        [_c_str(e.name) for e in model.events]))
    out.append(_c_array("char *const", "solver_names", [_c_str(s) for s in SOLVERS]))
    modes = model.of_kind("mode")
    out.append(_c_array("char *const", "mode_names", [_c_str(v.name) for v in modes]))
    out.append(_c_array("int", "mode_start", [str(int(v.start)) for v in modes]))
    values = [model.mode_values[v.name] for v in modes]
    offsets = [sum(len(v) for v in values[:i]) for i in range(len(values) + 1)]
    out.append(_c_array("int", "mode_value_offset", [str(o) for o in offsets]))
    out.append(_c_array("double", "mode_values", [repr(float(x)) for v in values for x in v]))
    mode_index = {v.name: i for i, v in enumerate(modes)}
    out.append(_c_array("int", "event_mode", [
        str(mode_index.get(model.event_modes.get(e.name), -1)) for e in model.events]))
    out.append(_c_array("int", "event_time_only",
                        [str(v) for v in event_time_only(dae)]))
    out.append(_c_array("int", "clock_state", [str(v) for v in clock_states(dae)]))
    out.append(_c_array("double", "delay_max", [repr(v.max_delay) for v in model.delays]))
    out.append(_c_array("int", "x_computed", ["1" if v.name in model.initials else "0"
                                              for v in model.of_kind("state")]))
    out.append(_c_array("double", "x_nominal", [_c_double(1.0 if v.nominal is None else v.nominal)
                                                for v in model.of_kind("state")]))
    out.append(_c_array("char *const", "constraint_messages",
                        [_c_str(f"{c.name}: {c.message}") for c in model.constraints]))
    out.append(_c_array("char *const", "delay_names", [_c_str(v.name) for v in model.delays]))
    out.append(_c_array("char *const", "validity_names", [_c_str(v.name) for v in model.validity]))
    out.append(_c_array("char *const", "validity_messages",
                        [_c_str(v.message) for v in model.validity]))
    tr = dae.tearing
    for part in ("pre", "torn", "post"):
        out.append(_c_array("int", f"tear_{part}", [str(j) for j in getattr(tr, part)]
                            if tr else []))
    fns = ", ".join(f"{{{name}_{f}, {name}_{f}_work}}" for f in FUNCTIONS)
    out.append(f"""const LfModel lf_model = {{
    {_c_str(name)},
    {_c_str(guid)},
    {len(rows)},
    real_names, real_start, real_min, real_max, real_kind,
    event_names, event_mode, event_time_only, clock_state,
    mode_names, mode_start, mode_value_offset, mode_values,
    delay_names, delay_max,
    constraint_messages, x_computed, x_nominal,
    solver_names,
    validity_names, validity_messages,
    tear_pre, tear_torn, tear_post,
    {{{fns}}}
}};
""")
    if model.delays:
        out.append(f"const LfFunction {name}_lf_{HISTOUT} = "
                   f"{{{name}_{HISTOUT}, {name}_{HISTOUT}_work}};\n")
    return "\n".join(out)


def prefix_header(model: Model) -> str:
    """Rename the runtime's global symbols to <modelIdentifier>_<symbol>."""
    lines = [f"/* Generated by loomfmu for {model.name} -- do not edit. */",
             "#ifndef LF_PREFIX_H", "#define LF_PREFIX_H"]
    lines += [f"#define {s} {model.name}_{s}" for s in RUNTIME_SYMBOLS]
    return "\n".join(lines + ["#endif", ""])


#: The C library's functions CasADi's code may call and the runtime's own
#: (lf_math.h) that replace them. sqrt, fabs, floor, ceil, fmod, fmin and
#: fmax are exactly rounded on every platform and stay; so does erf (no
#: runtime version: a model calling it may differ across platforms in the
#: last bits). CasADi's erfinv has no C library function at all.
MATH_FUNCTIONS = {f: f"lf_{f}" for f in (
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp",
    "expm1", "log1p", "log10", "pow", "hypot", "asinh", "acosh", "atanh")} | {"log": "lf_ln"}
_MATH_CALL = re.compile(r"\b(" + "|".join(MATH_FUNCTIONS) + r")\(")


def use_runtime_math(source: str, pair: bool = True) -> str:
    """CasADi's C code with every call of MATH_FUNCTIONS made to the
    runtime's function, sin and cos of one value paired (pair_sin_cos; pair
    False leaves them apart), and lf_math.h included after math.h."""
    source = _MATH_CALL.sub(lambda m: MATH_FUNCTIONS[m.group(1)] + "(", source)
    if pair:
        source = pair_sin_cos(source)
    return source.replace("#include <math.h>\n", '#include <math.h>\n#include "lf_math.h"\n', 1)


_FUNCTION_START = re.compile(r"^static int casadi_f\d+\(.*\{$")
_SCALAR = re.compile(r"^  (a\d+)=(.*);$")
_TRIG = re.compile(r"^lf_(sin|cos)\((a\d+)\)$")
_VAR = re.compile(r"\ba\d+\b")
_OUTPUT = re.compile(r"^  if \(res\[\d+\]!=0\) res\[\d+\]\[\d+\]=a\d+;$")


def pair_sin_cos(source: str) -> str:
    """Where a generated function takes lf_sin and lf_cos of the same value,
    the first call becomes one lf_sincos (one argument reduction, the same
    bits) and the second reads its other result: CasADi writes cos(j phi) and
    sin(j phi) apart, each of its own copy of j phi, so the values are
    numbered (local value numbering over CasADi's straight-line statements
    ``aN=EXPR;``; any other statement forgets everything)."""
    lines = source.split("\n")
    out: list[str] = []
    start = None  # index in out of the current function's opening line
    n_tmp = 0
    value: dict[str, int] = {}     # scalar -> the number of its value
    numbers: dict[str, int] = {}   # expression over value numbers -> its number
    pending: dict[int, tuple[str, int, str]] = {}  # value -> (function, out index, target)

    def number(expr: str) -> int:
        key = _VAR.sub(lambda m: f"#{value.setdefault(m.group(0), -len(value) - 1)}", expr)
        return numbers.setdefault(key, len(numbers))

    def forget():
        value.clear(), numbers.clear(), pending.clear()

    for line in lines:
        if _FUNCTION_START.match(line):
            forget()
            start, n_tmp = len(out), 0
            out.append(line)
            continue
        if start is None:
            out.append(line)
            continue
        if line == "}":
            if n_tmp:
                out.insert(start + 1, "  casadi_real " + ", ".join(
                    f"lf_sc{i}" for i in range(n_tmp)) + ";")
            start = None
            out.append(line)
            continue
        m = _SCALAR.match(line)
        if not m:
            if not _OUTPUT.match(line) and line.strip() and not line.startswith("  casadi_real "):
                forget()
            out.append(line)
            continue
        target, expr = m.groups()
        t = _TRIG.match(expr)
        if t:
            fn, x = t.groups()
            v = number(x)
            other = pending.get(v)
            if other and other[0] != fn:
                _, i, first_target = pending.pop(v)
                tmp = f"lf_sc{n_tmp}"
                n_tmp += 1
                s_ptr, c_ptr = ((f"&{first_target}", f"&{tmp}") if other[0] == "sin"
                                else (f"&{tmp}", f"&{first_target}"))
                arg = _TRIG.match(_SCALAR.match(out[i]).group(2)).group(2)
                out[i] = f"  lf_sincos({arg}, {s_ptr}, {c_ptr});"
                out.append(f"  {target}={tmp};")
            else:
                pending.setdefault(v, (fn, len(out), target))
                out.append(line)
        else:
            out.append(line)
        value[target] = number(expr)
    return "\n".join(out)


def generate_sources(model: Model, dae: DaeForm, outdir: Path) -> tuple[list[str], str]:
    """Write the model's C files into ``outdir``; return (file names, guid)."""
    outdir.mkdir(parents=True, exist_ok=True)
    guid = model_guid(model, dae)
    cname = f"{model.name}_casadi"
    cg = ca.CodeGenerator(f"{cname}.c", {"with_header": True, "casadi_int": "long long int",
                                         "casadi_real": "double", "with_export": False})
    fns = casadi_functions(dae)
    for f in fns:
        cg.add(f)
    cg.generate(str(outdir) + "/")
    csource = outdir / f"{cname}.c"
    csource.write_text(use_runtime_math(csource.read_text()))
    (outdir / "model_decl.h").write_text(declaration_header(model, dae, n_folded(fns)))
    (outdir / "lf_prefix.h").write_text(prefix_header(model))
    (outdir / "model_decl.c").write_text(declaration_source(model, dae, guid))
    return [f"{cname}.c", f"{cname}.h", "model_decl.h", "model_decl.c", "lf_prefix.h"], guid
