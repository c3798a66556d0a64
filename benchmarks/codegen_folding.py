"""Parameter folding, before and after: ns per call of each model's generated
right-hand side (wsol, or res for implicit models) and Jacobian (wjac or
rjac), and their CasADi instruction counts, unfolded (``fold=False``) and
folded (the default: parameter-only subexpressions computed once by ``pre``).

The generated C is compiled with the FMU's flags (-O2) into a small driver
that calls each function N times at the model's start point (t = 0.1,
states at their starts, w = 0, inputs and parameters at their starts) and
reports the median of REPEATS timings.

    python benchmarks/codegen_folding.py [model ...]
"""
from __future__ import annotations

import math
import subprocess
import sys
import tempfile
from pathlib import Path

import casadi as ca

from loomfmu.export.codegen import FUNCTIONS, casadi_functions, n_folded, real_table
from loomfmu.export.dae import dae_form
from loomfmu.fmu.builder import GENERATED_FLAGS
from loomfmu.registry import MODELS, load_model

REPEATS = 7
TARGET_SECONDS = 0.05  # per timing: calls = TARGET_SECONDS / (a first estimate)

DRIVER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "gen.h"
#define REPEATS %(repeats)d
static double now(void) { struct timespec s; clock_gettime(CLOCK_MONOTONIC, &s);
  return s.tv_sec + 1e-9 * s.tv_nsec; }
static int cmp(const void *a, const void *b) { double x = *(const double *)a,
  y = *(const double *)b; return x < y ? -1 : x > y; }
%(data)s
static double bench(int (*f)(const casadi_real **, casadi_real **, casadi_int *,
                             casadi_real *, int), const casadi_real **arg, casadi_real **res,
                    casadi_int *iw, casadi_real *w) {
  double t[REPEATS], t0; long n = 1, i; int r;
  for (;;) { t0 = now(); for (i = 0; i < n; i++) f(arg, res, iw, w, 0);
             if (now() - t0 > %(target)g / 10) break; n *= 2; }
  n = (long)(n * 10.0);
  for (r = 0; r < REPEATS; r++) { t0 = now(); for (i = 0; i < n; i++) f(arg, res, iw, w, 0);
                                  t[r] = (now() - t0) / n; }
  qsort(t, REPEATS, sizeof(double), cmp);
  return t[REPEATS / 2] * 1e9;
}
int main(void) {
  static casadi_real out[3][%(nout)d], work[%(nw)d];
  static casadi_int iw[%(niw)d];
  const casadi_real *arg[%(narg)d] = {&t_, x_, w_, u_, p_, q_, d_, ur_, dr_, k_};
  casadi_real *res[%(nres)d] = {out[0], out[1], out[2]};
  if (%(has_pre)d) { res[0] = k_; %(name)s_pre(arg, res, iw, work, 0); res[0] = out[0]; }
  printf("%%.1f %%.1f\n", bench(%(name)s_%(rhs)s, arg, res, iw, work),
         bench(%(name)s_%(jac)s, arg, res, iw, work));
  return 0;
}
"""


def _c_vec(name: str, values) -> str:
    vals = [repr(float(v)) for v in values] or ["0.0"]
    return f"static casadi_real {name}[] = {{{', '.join(vals)}}};"


def measure(name: str, fold: bool) -> dict:
    """ns per call of the RHS and Jacobian function, and their instructions."""
    model = load_model(name)
    dae = dae_form(model)
    fns = casadi_functions(dae, fold=fold)
    rhs, jac = ("res", "rjac") if dae.implicit else ("wsol", "wjac")
    rows = real_table(model)
    start = {r.name: (r.start if r.start is not None and math.isfinite(r.start) else 0.1)
             for r in rows}

    def of(kind):
        return [start[v.name] for v in model.of_kind(kind)]

    nk = n_folded(fns)
    data = "\n".join([
        "static casadi_real t_ = 0.1;",
        _c_vec("x_", of("state")), _c_vec("w_", [0.0] * dae.w.numel()),
        _c_vec("u_", of("input")), _c_vec("p_", of("parameter")),
        _c_vec("q_", [v.start for v in model.of_kind("mode")]),
        _c_vec("d_", [0.0] * dae.d.numel()), _c_vec("ur_", [0.0] * dae.u.numel()),
        _c_vec("dr_", [0.0] * dae.d.numel()), _c_vec("k_", [0.0] * nk)])
    sizes = [(f.sz_arg(), f.sz_res(), f.sz_iw(), f.sz_w()) for f in fns]
    with tempfile.TemporaryDirectory() as tmp:
        cg = ca.CodeGenerator("gen.c", {"with_header": True, "casadi_int": "long long int",
                                        "casadi_real": "double", "with_export": False})
        for f in fns:
            cg.add(f)
        cg.generate(tmp + "/")
        nout = max(f.numel_out(i) for f in fns for i in range(f.n_out()))
        src = DRIVER % dict(repeats=REPEATS, data=data, target=TARGET_SECONDS,
                            nout=max(nout, nk, 1), nw=max(s[3] for s in sizes) + 1,
                            niw=max(s[2] for s in sizes) + 1,
                            narg=max(max(s[0] for s in sizes), 10),
                            nres=max(max(s[1] for s in sizes), 3), has_pre=int(nk > 0),
                            name=model.name, rhs=rhs, jac=jac)
        Path(tmp, "main.c").write_text(src)
        exe = Path(tmp, "bench")
        proc = subprocess.run(["gcc", *GENERATED_FLAGS, "-o", str(exe), "main.c", "gen.c",
                               "-lm"], cwd=tmp, capture_output=True, text=True)
        if proc.returncode:
            raise RuntimeError(f"gcc failed for {name}:\n{proc.stderr[-2000:]}")
        out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    ns_rhs, ns_jac = (float(v) for v in out.split())
    i_rhs = fns[FUNCTIONS.index(rhs)].n_instructions()
    i_jac = fns[FUNCTIONS.index(jac)].n_instructions()
    return {"rhs": rhs, "jac": jac, "ns_rhs": ns_rhs, "ns_jac": ns_jac, "i_rhs": i_rhs,
            "i_jac": i_jac, "nk": nk}


def main(argv: list[str]) -> int:
    names = argv or list(MODELS)
    print("| model | RHS fn | RHS ns before -> after | instr. | Jacobian ns before -> after "
          "| instr. | k |")
    print("|---|---|---|---|---|---|---|")
    for name in names:
        a, b = measure(name, False), measure(name, True)
        print(f"| {name} | {a['rhs']} | {a['ns_rhs']:.0f} -> {b['ns_rhs']:.0f} "
              f"({a['ns_rhs'] / b['ns_rhs']:.1f}x) | {a['i_rhs']} -> {b['i_rhs']} "
              f"| {a['ns_jac']:.0f} -> {b['ns_jac']:.0f} ({a['ns_jac'] / b['ns_jac']:.1f}x) "
              f"| {a['i_jac']} -> {b['i_jac']} | {b['nk']} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
