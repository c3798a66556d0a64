"""C code generation: CasADi functions plus the generated model declaration.

A model contributes to the FMU only

* ``<id>_casadi.c/.h``: CasADi-generated right-hand side, its exact Jacobian
  (df/dx and df/dt), the outputs and the event indicators;
* ``model_decl.h/.c``: counts, the value-reference table (names, starts,
  ranges, kinds), the solver names and the runtime settings, all written from
  the Python declaration.

Value references of Real variables are laid out in this order, which is also
the order of ``ModelVariables`` in the model description::

    settings | parameters | states | inputs | outputs | algebraic locals

The Enumeration ``solver`` has Integer value reference 0.
"""
from __future__ import annotations

import hashlib
import math
import uuid
from dataclasses import dataclass
from pathlib import Path

import casadi as ca

from .declare import Model, Variable
from .ode import OdeForm
from .runtime_files import LOG_CATEGORIES

#: Solvers in the order of the runtime registry (lf_methods[] in lf_solvers.c);
#: the FMU's ``solver`` enumeration value is the 1-based position.
SOLVERS = ("dopri5", "rodas4", "rk4")
SOLVER_DESCRIPTIONS = {
    "dopri5": "explicit adaptive Dormand-Prince 5(4) with 4th-order dense output",
    "rodas4": "implicit adaptive Rosenbrock RODAS4 with the exact CasADi Jacobian",
    "rk4": "classical fixed-step Runge-Kutta 4 (step solver_h_fixed), for real time",
}


@dataclass(frozen=True)
class Setting:
    """A runtime setting exposed as a fixed FMU parameter."""

    name: str
    macro: str
    unit: str
    description: str
    min: float
    max: float


SETTINGS = (
    Setting("solver_rtol", "LF_SET_RTOL", "", "relative tolerance of the adaptive solvers",
            1e-14, 0.1),
    Setting("solver_atol", "LF_SET_ATOL", "", "absolute tolerance of the adaptive solvers "
            "(in the states' units)", 1e-16, 1.0),
    Setting("solver_h_max", "LF_SET_H_MAX", "s", "largest internal step of the adaptive "
            "solvers", 1e-9, 1e6),
    Setting("solver_h_fixed", "LF_SET_H_FIXED", "s", "step of the fixed-step solver rk4",
            1e-9, 1e3),
)


def setting_starts(model: Model) -> dict[str, float]:
    h_max = model.h_max if math.isfinite(model.h_max) else model.stop_time
    return {"solver_rtol": 1e-6, "solver_atol": 1e-9, "solver_h_max": h_max,
            "solver_h_fixed": model.h_fixed}


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


def model_guid(model: Model, ode: OdeForm) -> str:
    """A GUID that changes whenever the declaration or its equations change."""
    h = hashlib.sha256()
    for r in real_table(model):
        h.update(f"{r.name}|{r.kind}|{r.start}|{r.min}|{r.max}|{r.unit};".encode())
    for expr in (ode.f, ode.y, ode.e):
        h.update(str(expr).encode())
    return "{" + str(uuid.UUID(bytes=h.digest()[:16], version=4)) + "}"


def casadi_functions(ode: OdeForm) -> list[ca.Function]:
    """The four functions the runtime calls, with fixed argument lists (t, x, u, p)."""
    name = ode.model.name
    J, dfdt = ode.jacobian()
    return [
        ode.function(f"{name}_ode", [ode.f], ["xdot"]),
        ode.function(f"{name}_jac", [J, dfdt], ["J", "dfdt"]),
        ode.function(f"{name}_out", [ca.vertcat(ode.y, ode.z)], ["y"]),
        ode.function(f"{name}_evt", [ode.e], ["e"]),
    ]


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


def declaration_header(model: Model, ode: OdeForm) -> str:
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
        f"#define LF_NE {ode.e.numel()}",
        f"#define LF_N_SOLVERS {len(SOLVERS)}",
    ]
    lines += [f"#define {s.macro} {i}" for i, s in enumerate(SETTINGS)]
    cats = ", ".join(_c_str(name) for name, _ in LOG_CATEGORIES)
    lines.append(f"#define LF_LOG_CATEGORY_NAMES {{{cats}}}")
    lines += ["#endif", ""]
    return "\n".join(lines)


def declaration_source(model: Model, ode: OdeForm, guid: str) -> str:
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
    fns = ", ".join(f"{{{name}_{f}, {name}_{f}_work}}" for f in ("ode", "jac", "out", "evt"))
    out.append(f"""const LfModel lf_model = {{
    {_c_str(name)},
    {_c_str(guid)},
    {len(rows)},
    real_names, real_start, real_min, real_max, real_kind,
    event_names,
    solver_names,
    {{{fns}}}
}};
""")
    return "\n".join(out)


def generate_sources(model: Model, ode: OdeForm, outdir: Path) -> tuple[list[str], str]:
    """Write the model's C files into ``outdir``; return (file names, guid)."""
    outdir.mkdir(parents=True, exist_ok=True)
    guid = model_guid(model, ode)
    cname = f"{model.name}_casadi"
    cg = ca.CodeGenerator(f"{cname}.c", {"with_header": True, "casadi_int": "long long int",
                                         "casadi_real": "double", "with_export": False})
    for f in casadi_functions(ode):
        cg.add(f)
    cg.generate(str(outdir) + "/")
    (outdir / "model_decl.h").write_text(declaration_header(model, ode))
    (outdir / "model_decl.c").write_text(declaration_source(model, ode, guid))
    return [f"{cname}.c", f"{cname}.h", "model_decl.h", "model_decl.c"], guid
