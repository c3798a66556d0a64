"""Tests of the embedded C ODE solvers (src/loomfmu/runtime/lf_solvers.c, lf_dopri5.c,
lf_rodas4.c, lf_wmethod.c; the stiff linear algebra: tests/test_stiff_linalg.py).

The C harness tests/c/solver_harness.c is compiled with strict warnings and
driven through its command line; it prints "key value" lines.
"""

import math
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUNTIME = ROOT / "src" / "loomfmu" / "runtime"
HARNESS = ROOT / "tests" / "c" / "solver_harness.c"
SOURCES = [RUNTIME / f for f in ("lf_solvers.c", "lf_dopri5.c", "lf_rodas4.c", "lf_linalg.c",
                                   "lf_schur.c", "lf_wmethod.c", "lf_rosenbrock.c",
                                   "lf_solver_common.c", "lf_math.c", "lf_trig.c")]
CFLAGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic",
          "-fvisibility=hidden", "-fPIC"]

pytestmark = [pytest.mark.slow,  # compiles the solvers with gcc
              pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not available")]


@pytest.fixture(scope="module")
def harness(tmp_path_factory):
    exe = tmp_path_factory.mktemp("solver_harness") / "solver_harness"
    cmd = ["gcc", *CFLAGS, f"-I{RUNTIME}", str(HARNESS), *map(str, SOURCES), "-lm",
           "-o", str(exe)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return exe


def run(exe, *args):
    proc = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, (args, proc.stdout, proc.stderr)
    out = {}
    for line in proc.stdout.splitlines():
        key, _, value = line.partition(" ")
        if key == "message" or key.endswith(("_bad_tol", "_bad_hmax", "_no_jac", "_backwards")):
            out[key] = value
            continue
        try:
            out[key] = int(value)
        except ValueError:
            out[key] = float(value)
    return out


def solve(exe, method, problem, rtol=1e-6, atol=None, t_end=10.0, ncomm=1, h_fixed=0.01,
          h_max=1e9):
    if atol is None:
        atol = rtol * 1e-3
    return run(exe, "run", method, problem, rtol, atol, t_end, ncomm, h_fixed, h_max)


def observed_orders(errors, ratio=2.0):
    return [math.log(a / b) / math.log(ratio) for a, b in zip(errors, errors[1:])]


# --------------------------------------------------------------- compilation

def test_library_compiles_with_strict_flags(tmp_path):
    for src in SOURCES:
        obj = tmp_path / (src.stem + ".o")
        proc = subprocess.run(["gcc", *CFLAGS, f"-I{RUNTIME}", "-c", str(src), "-o", str(obj)],
                              capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr


# --------------------------------------------------------------- linear algebra

def test_lu_solve_and_singularity_detection(harness):
    r = run(harness, "linalg")
    assert r["max_rel_residual"] < 1e-13
    assert r["perm_ok"] == 1
    assert r["singular_rc"] == 2   # second column dependent on the first
    assert r["zero_rc"] == 1
    assert r["nan_rc"] == 2 and r["inf_rc"] == 2 and r["nan0_rc"] == 1


# --------------------------------------------------------------- accuracy

@pytest.mark.parametrize("method", ["dopri5", "rodas4", "ros34pw2"])
@pytest.mark.parametrize("problem", ["decay", "osc"])
def test_adaptive_error_scales_with_tolerance(harness, method, problem):
    errs = []
    for rtol in (1e-4, 1e-6, 1e-8):
        r = solve(harness, method, problem, rtol=rtol)
        assert r["status"] == 0, r
        assert r["landed"] == 1 and r["t"] == 10.0
        # global error over 10 time units (about 1.6 periods): within a few rtol
        assert r["err_max"] < 10 * rtol, (rtol, r)
        assert r["err_final"] < 10 * rtol, (rtol, r)
        errs.append(r["err_max"])
    # tighter tolerance -> clearly smaller error (not just a lucky constant)
    assert errs[0] > 30 * errs[1] > 900 * errs[2], errs


@pytest.mark.parametrize("method,problem,order,lo,hi", [
    # steps forced by h_max with a loose tolerance: observed order of the tableau
    ("dopri5", "osc", 5, 4.6, 5.4),
    ("dopri5", "cos", 5, 4.6, 5.4),
    ("rodas4", "osc", 4, 3.7, 4.3),
    ("rodas4", "decay", 4, 3.7, 4.3),
    ("ros34pw2", "osc", 3, 2.7, 3.5),
    ("ros34pw2", "decay", 3, 2.7, 3.5),
    ("rk4", "osc", 4, 3.7, 4.3),
    ("rk4", "decay", 4, 3.7, 4.3),
])
def test_convergence_order(harness, method, problem, order, lo, hi):
    errs = []
    for h in (0.2, 0.1, 0.05):
        r = solve(harness, method, problem, rtol=1.0, atol=1.0, h_fixed=h, h_max=h)
        assert r["status"] == 0, r
        errs.append(r["err_final"])
    orders = observed_orders(errs)
    assert all(lo <= p <= hi for p in orders), (errs, orders)


def test_rk4_fixed_step_order_and_landing(harness):
    """Classical RK4: halving h divides the error by ~16; communication points
    that are no multiple of h are still hit exactly."""
    errs = []
    for h in (0.1, 0.05, 0.025, 0.0125):
        r = solve(harness, "rk4", "osc", h_fixed=h, ncomm=7)
        assert r["status"] == 0 and r["landed"] == 1 and r["t"] == 10.0
        errs.append(r["err_final"])
    orders = observed_orders(errs)
    assert all(3.7 <= p <= 4.3 for p in orders), (errs, orders)
    r = solve(harness, "rk4", "decay", h_fixed=0.3, t_end=1.0)
    assert r["steps"] == 4  # 0.3, 0.3, 0.3, 0.1
    assert r["rhs"] == 4 * 4 + 1  # 4 stages per step, f at the end reused (FSAL)


# --------------------------------------------------------------- dense output

@pytest.mark.parametrize("method", ["dopri5", "rodas4", "rk4", "ros34pw2"])
def test_dense_output_reproduces_step_ends(harness, method):
    r = solve(harness, method, "osc", rtol=1e-6)
    assert r["dense_end_err"] <= 1e-15


@pytest.mark.parametrize("problem", ["decay", "osc"])
def test_dopri5_dense_output_accuracy(harness, problem):
    errs = []
    for rtol in (1e-4, 1e-6, 1e-8):
        r = solve(harness, "dopri5", problem, rtol=rtol, ncomm=3)
        assert r["status"] == 0
        assert r["dense_err"] < 10 * rtol, (rtol, r)
        # interior points not much worse than the step ends
        assert r["dense_err"] < 5 * r["err_max"], r
        errs.append(r["dense_err"])
    assert errs[0] > 30 * errs[1] > 900 * errs[2], errs


@pytest.mark.parametrize("method,lo,hi", [
    ("dopri5", 4.6, 5.4),  # 4th-order interpolant: local error O(h^5)
    ("rodas4", 3.6, 4.4),  # 3rd-order interpolant: local error O(h^4)
    ("rk4", 3.6, 4.4),     # cubic Hermite: O(h^4)
    # cubic Hermite, O(h^4), on a 3rd-order solution: its O(h^3) error shows
    ("ros34pw2", 2.7, 3.5),
])
def test_dense_output_order(harness, method, lo, hi):
    # x' = cos(t): the step-end values are very accurate (quadrature), so the
    # interior error is dominated by the interpolant
    errs = []
    for h in (0.2, 0.1, 0.05):
        r = solve(harness, method, "cos", rtol=1.0, atol=1.0, h_fixed=h, h_max=h)
        assert r["status"] == 0
        errs.append(r["dense_err"])
    orders = observed_orders(errs)
    assert all(lo <= p <= hi for p in orders), (errs, orders)


def test_rodas4_dense_output_accuracy(harness):
    for rtol in (1e-4, 1e-7):
        r = solve(harness, "rodas4", "osc", rtol=rtol)
        assert r["dense_err"] < 10 * rtol, r


# --------------------------------------------------------------- stiffness

def test_rodas4_stiff_far_fewer_steps(harness):
    ro = solve(harness, "rodas4", "stiff", rtol=1e-6)
    dp = solve(harness, "dopri5", "stiff", rtol=1e-6)
    assert ro["status"] == 0 and dp["status"] == 0
    assert ro["err_max"] < 1e-5 and dp["err_max"] < 1e-5, (ro, dp)
    assert ro["steps"] * 10 < dp["steps"], (ro["steps"], dp["steps"])
    # one Jacobian per accepted step point, one LU per attempt
    assert ro["jac"] == ro["steps"]
    assert ro["lu"] == ro["steps"] + ro["rejected"]


@pytest.mark.parametrize("ncomm", [1, 100])
def test_dopri5_step_control_is_stabilized_on_the_stability_boundary(harness, tmp_path, ncomm):
    """dopri5 on a stiff problem sits on its stability boundary, where the
    classical controller h*0.9*err^-1/5 (the build with -DLF_DP_BETA=0
    -DLF_DP_SWITCH=0)
    oscillates and rejects about one step in six; Hairer's controller with
    Lund stabilization (beta = 0.04, the default) keeps the step steady:
    almost no rejections, fewer RHS calls, the same accuracy.  With 100
    communication intervals the steps shortened to land on them must not
    unsettle it (their errors are not remembered)."""
    exe = tmp_path / "solver_harness_classical"
    cmd = ["gcc", *CFLAGS, "-DLF_DP_BETA=0", "-DLF_DP_SWITCH=0", f"-I{RUNTIME}", str(HARNESS),
           *map(str, SOURCES), "-lm", "-o", str(exe)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    pi = solve(harness, "dopri5", "stiff", rtol=1e-6, ncomm=ncomm)
    classical = solve(exe, "dopri5", "stiff", rtol=1e-6, ncomm=ncomm)
    assert pi["status"] == 0 and classical["status"] == 0
    assert classical["rejected"] > 1000, classical       # the oscillation exists
    assert pi["rejected"] * 100 < classical["rejected"], (pi, classical)
    assert pi["rhs"] < 0.9 * classical["rhs"], (pi["rhs"], classical["rhs"])
    assert pi["err_max"] < 1e-5 and classical["err_max"] < 1e-5, (pi, classical)


def test_dopri5_takes_stronger_gains_where_stability_bounds_the_step(harness, tmp_path):
    """A lightly damped stiff oscillator (eigenvalues near the imaginary
    axis, |lambda| = 2000): dopri5's step sits on its stability boundary and
    Hairer's controller alone (the build with -DLF_DP_SWITCH=0) still rejects
    one attempt in 27; where the stiffness estimate h|lambda| exceeds 1 the
    step takes Gustafsson's gains (beta = 0.08) and rejects far fewer, for
    no more right-hand sides and the same solution."""
    exe = tmp_path / "solver_harness_hairer"
    cmd = ["gcc", *CFLAGS, "-DLF_DP_SWITCH=0", f"-I{RUNTIME}", str(HARNESS),
           *map(str, SOURCES), "-lm", "-o", str(exe)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    for ncomm in (1, 100):
        switch = solve(harness, "dopri5", "stiffosc", rtol=1e-6, t_end=2.0, ncomm=ncomm)
        hairer = solve(exe, "dopri5", "stiffosc", rtol=1e-6, t_end=2.0, ncomm=ncomm)
        assert switch["status"] == 0 and hairer["status"] == 0
        assert hairer["rejected"] > 400, hairer  # the oscillation exists
        assert switch["rejected"] < 0.7 * hairer["rejected"], (switch, hairer)
        assert switch["rhs"] <= hairer["rhs"], (switch["rhs"], hairer["rhs"])
        assert abs(switch["x0"] - hairer["x0"]) < 1e-5, (switch, hairer)


def test_rodas4_stiff_nonautonomous(harness):
    """Prothero-Robinson x' = L(x - sin t) + cos t, L = -1e4."""
    ro = solve(harness, "rodas4", "pr", rtol=1e-6)
    assert ro["status"] == 0
    assert ro["err_max"] < 1e-4 and ro["err_final"] < 1e-5, ro
    assert ro["steps"] < 500


def test_rodas4_uses_time_derivative(harness):
    """x' = cos t (J = 0): with the exact df/dt RODAS4 is 4th order (or
    better); if the Jacobian callback claims df/dt = 0 accuracy collapses."""
    good, bad = [], []
    for h in (0.2, 0.1, 0.05):
        good.append(solve(harness, "rodas4", "cos", rtol=1.0, atol=1.0, h_max=h)["err_final"])
        bad.append(solve(harness, "rodas4", "cos_nodfdt", rtol=1.0, atol=1.0,
                         h_max=h)["err_final"])
    assert all(p >= 3.7 for p in observed_orders(good)), good
    assert all(b > 1e3 * g for g, b in zip(good, bad)), (good, bad)
    r = solve(harness, "rodas4", "cos", rtol=1e-6)
    assert r["status"] == 0 and r["err_max"] < 1e-5, r


def test_no_states(harness):
    for method in ("dopri5", "rodas4", "rk4", "ros34pw2"):
        r = solve(harness, method, "empty", t_end=2.0, ncomm=4, h_fixed=0.1)
        assert r["status"] == 0 and r["t"] == 2.0 and r["landed"] == 1


# --------------------------------------------------------------- failures

@pytest.mark.parametrize("method", ["dopri5", "rodas4", "rk4", "ros34pw2"])
def test_nonfinite_rhs_discards_at_last_accepted_point(harness, method):
    r = solve(harness, method, "nan_after", t_end=2.0, h_fixed=0.03)
    assert r["status"] == 2, r
    assert r["message"] and "t=" in r["message"]
    assert "non-finite" in r["message"]
    # t is the last accepted point: before the NaN region, close to it
    assert 0.45 < r["t"] <= 0.5, r
    assert r["x_finite"] == 1 and r["err_at_t"] < 1e-5
    assert r["live_blocks"] == 0
    # the dense output after the failure is not made of the failed
    # attempts' stages: dopri5, which computes it from the stages kept in
    # its work buffer when it is read, shrinks the interval to the point
    assert r["dense_mid_err"] < 1e-6, r
    if method == "dopri5":
        assert r["last_interval"] == 0.0, r


@pytest.mark.parametrize("method", ["dopri5", "rodas4", "ros34pw2"])
def test_blowup_discards(harness, method):
    r = solve(harness, method, "blowup", t_end=2.0)
    assert r["status"] == 2, r
    assert "step size underflow" in r["message"] and "t=" in r["message"]
    # the numerical solution's own pole is within the tolerance of t = 1
    assert 0.99 < r["t"] < 1.0 + 1e-3, r
    assert r["x_finite"] == 1


@pytest.mark.parametrize("problem", ["jump5", "jump17"])
@pytest.mark.parametrize("method", ["dopri5", "rodas4", "ros34pw2"])
def test_stage_arguments_that_overflow_are_never_passed_to_f(harness, method, problem):
    """Five and seventeen states (dopri5's vectorized steps, SSE2 and AVX2, and
    their tail elements): at t = 30 a derivative jumps to 1.7e308 where the
    steps are long, so the next stage arguments overflow; the harness's f
    answers a non-finite argument with an error, so a Discard (not an Error)
    means every stage's argument was checked before the call."""
    r = solve(harness, method, problem, t_end=100.0, rtol=1e-6, atol=1e-9)
    assert r["status"] == 2, r
    assert 29.0 < r["t"] <= 30.0 + 1e-6 and r["x_finite"] == 1, r


@pytest.mark.parametrize("method", ["dopri5", "rodas4", "rk4", "ros34pw2"])
def test_rhs_error_is_passed_through(harness, method):
    r = solve(harness, method, "error_after", t_end=2.0, ncomm=4)
    assert r["status"] == 3, r
    assert r["t"] == 0.5 and r["message"]
    # the attempt that failed wrote stages: not read as the last step's
    assert r["dense_mid_err"] < 1e-6, r
    if method == "dopri5":
        assert r["last_interval"] == 0.0, r


@pytest.mark.parametrize("method", ["rodas4", "ros34pw2"])
def test_nonfinite_jacobian_discards(harness, method):
    r = solve(harness, method, "nanjac", t_end=1.0)
    assert r["status"] == 2 and r["t"] == 0.0 and "Jacobian" in r["message"], r


def test_invalid_options(harness):
    r = run(harness, "badopt")
    assert r["ok"] == 1, r


# --------------------------------------------------------------- state handling

@pytest.mark.parametrize("method", ["dopri5", "rodas4", "rk4", "ros34pw2"])
def test_state_is_struct_plus_work_buffer(harness, method):
    r = run(harness, "snapshot", method, "osc", 1e-6, 1e-9, 10, 7, 0.05, 1e9)
    assert r["status"] == 0 and r["identical"] == 1 and r["steps"] > 10


@pytest.mark.parametrize("method", ["dopri5", "rodas4", "rk4", "ros34pw2"])
def test_solvers_side_by_side(harness, method):
    r = run(harness, "side", method, "decay", 1e-6, 1e-9, 10, 1, 0.05, 1e9)
    assert r["status"] == 0 and r["identical"] == 1 and r["err_other"] < 1e-4
    assert r["live_blocks"] == 0


@pytest.mark.parametrize("method", ["dopri5", "rodas4", "rk4", "ros34pw2"])
def test_reset_restarts_at_discontinuity(harness, method):
    r = run(harness, "reset", method, 1e-7, 1e-10, 0.01)
    assert r["reset_ok"] == 1
    assert r["h_after_reset"] <= 0.2
    assert r["dense_at_reset_err"] == 0.0
    assert r["status"] == 0 and r["t"] == 2.0
    assert r["err_final"] < 1e-6, r


def test_dopri5_tiny_error_threshold_is_below_its_bound():
    """lf_dopri5.c skips log and exp below DP_ERR_TINY, a literal for the
    default beta: it must not exceed half the error below which the step
    factor is at its cap for every err_old >= 1e-4 (else the shortcut would
    change the step sizes)."""
    import re

    src = (RUNTIME / "lf_dopri5.c").read_text()
    beta = float(re.search(r"#define LF_DP_BETA ([0-9.eE+-]+)", src).group(1))
    tiny = float(re.search(r"#define DP_ERR_TINY ([0-9.eE+-]+)", src).group(1))
    def bound(b):
        return math.exp((math.log(0.09) + b * math.log(1e-4)) / (0.2 - 0.75 * b))

    assert 0 < tiny <= 0.5 * bound(beta)
    # the stronger gains where stability bounds the step
    beta_s = float(re.search(r"#define DP_BETA_S ([0-9.eE+-]+)", src).group(1))
    tiny_s = float(re.search(r"#define DP_ERR_TINY_S ([0-9.eE+-]+)", src).group(1))
    assert 0 < tiny_s <= 0.5 * bound(beta_s)


def test_dopri5_avx2_step_is_bit_for_bit_the_sse2_one(harness, tmp_path):
    """From sixteen states dopri5 takes a build of its step for AVX2 where the
    processor has it (lf_dopri5.c); it must do the same arithmetic in the
    same order as the SSE2 build (-DLF_DP_AVX2=0): every state, step and
    right-hand side the same, on a nonlinear 17-state problem over several
    communication grids, and on one that ends in a Discard."""
    import platform

    if platform.machine() not in ("x86_64", "AMD64"):
        pytest.skip("the AVX2 build is for x86-64")
    obj = tmp_path / "lf_dopri5.o"
    proc = subprocess.run(["gcc", *CFLAGS, f"-I{RUNTIME}", "-c", str(RUNTIME / "lf_dopri5.c"),
                           "-o", str(obj)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    dis = subprocess.run(["objdump", "-d", str(obj)], capture_output=True, text=True)
    if dis.returncode == 0:
        assert "ymm" in dis.stdout  # the AVX2 build is there
    def same(a, b):  # equal, NaN (no exact solution) included
        return {k: repr(v) for k, v in a.items()} == {k: repr(v) for k, v in b.items()}

    exe = tmp_path / "solver_harness_sse2"
    cmd = ["gcc", *CFLAGS, "-DLF_DP_AVX2=0", f"-I{RUNTIME}", str(HARNESS),
           *map(str, SOURCES), "-lm", "-o", str(exe)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    for rtol, ncomm in ((1e-6, 1), (1e-8, 7), (1e-4, 200)):
        a = solve(harness, "dopri5", "chain17", rtol=rtol, t_end=20.0, ncomm=ncomm)
        b = solve(exe, "dopri5", "chain17", rtol=rtol, t_end=20.0, ncomm=ncomm)
        assert a["status"] == 0 and a["steps"] > 50, a
        assert same(a, b), (a, b)
    a = solve(harness, "dopri5", "jump17", t_end=100.0, rtol=1e-6, atol=1e-9)
    b = solve(exe, "dopri5", "jump17", t_end=100.0, rtol=1e-6, atol=1e-9)
    assert a["status"] == 2 and same(a, b), (a, b)


def test_dopri5_step_after_a_landing_follows_its_error(harness, tmp_path):
    """A step shortened to land on a communication point hands the next
    step the size proposed before the shortening, unless its own error
    predicts that size would fail (lf_dopri5.c, dp_land_keeps).  On a chirp
    x' = cos(t^2), whose step sizes shrink all the way, the proposal kept
    regardless (the build with -DLF_DP_LAND_PREDICT=0) was rejected after
    the landings: the prediction rejects far fewer steps for no more
    right-hand sides and the same solution."""
    exe = tmp_path / "solver_harness_keep"
    cmd = ["gcc", *CFLAGS, "-DLF_DP_LAND_PREDICT=0", f"-I{RUNTIME}", str(HARNESS),
           *map(str, SOURCES), "-lm", "-o", str(exe)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    for t_end, ncomm in ((10.0, 100), (30.0, 1000)):
        new = solve(harness, "dopri5", "chirp", rtol=1e-6, atol=1e-9, t_end=t_end, ncomm=ncomm)
        old = solve(exe, "dopri5", "chirp", rtol=1e-6, atol=1e-9, t_end=t_end, ncomm=ncomm)
        assert new["status"] == 0 and old["status"] == 0 and new["landed"] == 1
        assert old["rejected"] > 15, old  # the rejections after landings exist
        assert new["rejected"] < 0.6 * old["rejected"], (new, old)
        assert new["rhs"] <= old["rhs"], (new["rhs"], old["rhs"])
        assert abs(new["x0"] - old["x0"]) < 1e-6, (new, old)
