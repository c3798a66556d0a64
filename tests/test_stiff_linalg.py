"""Tests of the stiff linear algebra (src/loomfmu/runtime/lf_schur.c: the Newton
matrix through a Schur complement on the kinematic rows q' = v) and of the
Rosenbrock-W method ros34pw2 with Jacobian reuse (lf_wmethod.c).

The C harness tests/c/stiff_harness.c is compiled with strict warnings (also
with the Schur path switched off, and with the Jacobian renewed at every
step) and driven through its command line; it prints "key value" lines.
"""

import math
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUNTIME = ROOT / "src" / "loomfmu" / "runtime"
HARNESS = ROOT / "tests" / "c" / "stiff_harness.c"
SOURCES = [RUNTIME / f for f in ("lf_solvers.c", "lf_dopri5.c", "lf_rodas4.c", "lf_linalg.c",
                                   "lf_schur.c", "lf_wmethod.c", "lf_rosenbrock.c",
                                   "lf_solver_common.c", "lf_math.c", "lf_trig.c")]
CFLAGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic",
          "-fvisibility=hidden", "-fPIC"]
# builds: default; dense Newton matrices only; ros34pw2 renewing J and its
# factorization at every step (W = J: the plain Rosenbrock method); ros34pw2
# evaluating J at every new factorization (the policy before WM_JAC_AGE)
VARIANTS = {"default": [], "dense": ["-DLF_SCHUR_MIN_ROWS=1000000"],
            "fresh": ["-DWM_MAX_AGE=1"], "jac_every_lu": ["-DWM_JAC_AGE=1"]}

pytestmark = [pytest.mark.slow,  # compiles the solvers with gcc
              pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not available")]


@pytest.fixture(scope="module")
def exe(tmp_path_factory):
    out = {}
    tmp = tmp_path_factory.mktemp("stiff_harness")
    for name, defs in VARIANTS.items():
        path = tmp / f"stiff_harness_{name}"
        cmd = ["gcc", *CFLAGS, *defs, f"-I{RUNTIME}", str(HARNESS), *map(str, SOURCES), "-lm",
               "-o", str(path)]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        out[name] = path
    return out


def run(path, *args):
    proc = subprocess.run([str(path), *map(str, args)], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, (args, proc.stdout, proc.stderr)
    out = {}
    for line in proc.stdout.splitlines():
        key, _, value = line.partition(" ")
        if key == "message":
            out[key] = value
            continue
        try:
            out[key] = int(value)
        except ValueError:
            out[key] = float(value)
    return out


def integrate(path, method, problem, rtol, atol, t_end, h_max, ncomm=1):
    r = run(path, "run", method, problem, rtol, atol, t_end, h_max, ncomm)
    assert r["status"] == 0, r
    return r


def states(r):
    return [r[k] for k in sorted((k for k in r if k[0] == "x" and k[1:].isdigit()),
                                 key=lambda k: int(k[1:]))]


def observed_orders(errors, ratio=2.0):
    return [math.log(a / b) / math.log(ratio) for a, b in zip(errors, errors[1:])]


def fixed_step_errors(path, method, problem, steps=(20, 40, 80, 160)):
    """Final errors with h = 1/N forced (tolerances too loose to reject)."""
    return [integrate(path, method, problem, 1e3, 1e3, 1.0, 1.0 / n)["err_final"]
            for n in steps]


# --------------------------------------------------------------- Schur complement

@pytest.mark.parametrize("pairs,rest,seed", [(10, 5, 1), (10, 0, 2), (1, 0, 3), (20, 3, 7),
                                             (3, 20, 11)])
def test_schur_solve_equals_dense_solve(exe, pairs, rest, seed):
    """alpha*I - J with kinematic rows (some q' = v, some q' = c v): the Schur
    path eliminates exactly those rows and solves as the dense LU does."""
    r = run(exe["default"], "schur", pairs, rest, seed)
    assert r["rc_dense"] == 0 and r["rc_schur"] == 0
    assert r["eliminated"] == pairs
    assert r["max_rel_diff"] < 1e-12, r
    assert r["rel_residual"] < 1e-12, r


def test_no_kinematic_rows_stays_dense(exe):
    r = run(exe["default"], "schur", 0, 6, 5)
    assert r["eliminated"] == 0 and r["rel_residual"] < 1e-12, r


@pytest.mark.parametrize("method", ["rodas4", "ros34pw2"])
def test_schur_path_integrates_like_dense_path(exe, method):
    """A 12-mass chain (stiff and cubic springs, a first-order drive lag,
    states interleaved q, v): the same steps and the same solution to
    rounding with the Schur path as with the dense path."""
    args = (method, "chain", 1e-6, 1e-9, 0.05, 1.0, 10)
    a = integrate(exe["default"], *args)
    b = integrate(exe["dense"], *args)
    assert (a["steps"], a["rejected"], a["lu"]) == (b["steps"], b["rejected"], b["lu"])
    xa, xb = states(a), states(b)
    scale = max(abs(v) for v in xb)
    assert max(abs(p - q) for p, q in zip(xa, xb)) < 1e-9 * scale, (xa, xb)


# --------------------------------------------------------------- ros34pw2 order

@pytest.mark.parametrize("problem", ["lin2", "kaps"])
def test_ros34pw2_order_3_with_exact_jacobian(exe, problem):
    """Linear stiff (eigenvalues -2, -1000, forced) and Kaps' nonlinear stiff
    problem, both with known solutions: order 3 with W = J."""
    errs = fixed_step_errors(exe["fresh"], "ros34pw2", problem)
    orders = observed_orders(errs)
    assert all(2.7 <= p <= 3.9 for p in orders), (errs, orders)


@pytest.mark.parametrize("problem", ["lin2_w", "kaps_w"])
def test_ros34pw2_keeps_order_3_with_a_wrong_jacobian(exe, problem):
    """A W-method: order 3 with W != df/dx (and a wrong df/dt), where
    rodas4 (a Rosenbrock method, not a W-method) falls to order 1 or 2."""
    errs = fixed_step_errors(exe["fresh"], "ros34pw2", problem)
    orders = observed_orders(errs)
    assert all(2.7 <= p <= 3.9 for p in orders), (errs, orders)
    ro = observed_orders(fixed_step_errors(exe["fresh"], "rodas4", problem))
    assert min(ro) < 2.5, ro


def test_ros34pw2_order_3_with_jacobian_reuse(exe):
    """The default build keeps J and its factors across steps: still order 3
    on the linear stiff problem (J exact, df/dt from the first point)."""
    r = [integrate(exe["default"], "ros34pw2", "lin2", 1e3, 1e3, 1.0, 1.0 / n)
         for n in (20, 40, 80, 160)]
    errs = [x["err_final"] for x in r]
    orders = observed_orders(errs)
    assert all(2.7 <= p <= 3.9 for p in orders), (errs, orders)
    assert all(x["lu"] * 10 <= x["steps"] for x in r), r


@pytest.mark.parametrize("problem", ["kaps", "lin2"])
def test_ros34pw2_adaptive_error_follows_tolerance(exe, problem):
    """Adaptive, 20 communication intervals (restart at each): the error
    follows the tolerance; the Jacobian is not evaluated at every step."""
    errs = []
    for rtol in (1e-4, 1e-6, 1e-8):
        r = integrate(exe["default"], "ros34pw2", problem, rtol, rtol * 1e-3, 1.0, 1.0, 20)
        assert r["err_final"] < 100 * rtol, (rtol, r)
        assert r["jac"] < r["steps"], r
        errs.append(r["err_final"])
    assert errs[0] > 5 * errs[1] and errs[1] > 5 * errs[2], errs


def test_ros34pw2_reuses_factorizations_on_the_chain(exe):
    r = integrate(exe["default"], "ros34pw2", "chain", 1e-6, 1e-9, 0.05, 1.0, 10)
    assert r["lu"] * 2 <= r["steps"], r


def test_ros34pw2_new_step_size_refactors_without_a_new_jacobian(exe):
    """A new step size needs new factors of I/(h*gamma) - J0, not a new J0:
    the default build re-evaluates J0 only when it is WM_JAC_AGE (10)
    accepted steps old, so on the chain it evaluates fewer Jacobians than a
    build that evaluates one for every factorization, in as many steps, with
    the same solution to the tolerance."""
    args = ("ros34pw2", "chain", 1e-6, 1e-9, 0.05, 1.0, 10)
    a = integrate(exe["default"], *args)
    b = integrate(exe["jac_every_lu"], *args)
    assert b["jac"] >= b["lu"] - 5, b  # the old policy: about one J per LU
    assert a["jac"] * 3 <= b["jac"] * 2, (a, b)
    assert a["steps"] <= 1.1 * b["steps"], (a, b)
    xa, xb = states(a), states(b)
    scale = max(abs(v) for v in xb)
    assert max(abs(p - q) for p, q in zip(xa, xb)) < 1e-4 * scale, (xa, xb)
