"""Optimal spindle-speed law n0(t) and its Fourier series (seed 001, (2), (5)-(8)).

Linear law in the winding diameter, (5):  n0(d) = n1 + K_n d.
Winding, (2):  d dd/dt = g n, g = +g2 in the interlayer (d: D_B -> D_N),
g = -g1 in the layer (d: D_N -> D_B).  Substituting d = (n - n1)/K_n gives
F(n) = n - n1 ln n = const + g K_n^2 t, hence with Delta = n_max - n_min
- n1 ln(n_max/n_min) and the actual stroke times T_n, T_c (defect D12):

* interlayer (7), 0 <= t < T_n:   F(n) = F(n_min) + Delta t / T_n
* layer (6, corrected D6), T_n <= t < P:  F(n) = F(n_max) - Delta (t - T_n) / T_c

Convention: t = 0 at the start of the interlayer (n = n_min, d = D_B),
period P = T_n + T_c.  F'(n) = 1 - n1/n > 0 on [n_min, n_max] (n_min - n1 =
K_n D_B > 0), so the root is unique; it is found by a vectorised Newton
iteration kept inside the bracket [n_min, n_max] (bisection fallback).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from loomfmu.declare.checks import check_array, check_int, check_number
from loomfmu.mechanics.drive_params import DriveParams, check_params

#: Newton/bisection stopping tolerance on n, relative to n_max
_REL_TOL = 1e-15
_MAX_ITER = 100
#: most harmonics :func:`fourier` computes (the cam tables use <= 512)
MAX_HARMONICS = 1000
#: most harmonics x quadrature panels of one :func:`fourier` call (its arrays
#: hold 16 x this many numbers: 256 MB)
MAX_WORK = 2_000_000


def check_times(name: str, t) -> np.ndarray:
    """Times as a float array of any shape, every one finite."""
    return check_array(name, t, ndim=None, min_size=0, unit="s")


@dataclass(frozen=True)
class LawConstants:
    """Constants of the linear law (5) and the winding (2), SI, speeds in rev/s."""

    n1: float       #: rev/s, intercept of (5); may be negative
    K_n: float      #: rev/s per m, slope of (5)
    Delta: float    #: rev/s, n_max - n_min - n1 ln(n_max/n_min) > 0
    g1: float       #: m^2 (per spindle rev), layer winding constant, Delta/(K_n^2 T_c)
    g2: float       #: m^2 (per spindle rev), interlayer winding constant, Delta/(K_n^2 T_n)
    n_mean: float   #: rev/s, mean speed over a stroke = C0/2
    P: float        #: s, period of one double stroke T_n + T_c
    omega: float    #: rad/s, 2 pi / P
    revs_per_period: float  #: spindle revolutions per double stroke, n_mean P


def law_constants(p: DriveParams) -> LawConstants:
    """n1, K_n (5), Delta, g1, g2, mean speed, period (see module docstring)."""
    check_params(p)
    K_n = (p.n_max - p.n_min) / (p.D_N - p.D_B)
    n1 = (p.D_N * p.n_min - p.D_B * p.n_max) / (p.D_N - p.D_B)
    Delta = p.n_max - p.n_min - n1 * np.log(p.n_max / p.n_min)
    P = p.T_n + p.T_c
    n_mean = (p.n_max + p.n_min - 2 * n1) * (p.n_max - p.n_min) / (2 * Delta)
    return LawConstants(n1=float(n1), K_n=float(K_n), Delta=float(Delta),
                        g1=float(Delta / (K_n**2 * p.T_c)), g2=float(Delta / (K_n**2 * p.T_n)),
                        n_mean=float(n_mean), P=float(P), omega=float(2 * np.pi / P),
                        revs_per_period=float(n_mean * P))


def _F(n, n1):
    return n - n1 * np.log(n)


def _phase(t, p: DriveParams):
    """Time within the period and a mask 'in the interlayer'."""
    P = p.T_n + p.T_c
    tl = np.mod(np.asarray(t, dtype=float), P)
    return tl, tl < p.T_n


def invert_increasing(f, df, y, lo, hi, *, tol: float, x0=None):
    """x in [lo, hi] with f(x) = y for an increasing f, vectorised.

    Newton steps that leave the current bracket are replaced by bisection,
    so it converges for any increasing f with f(lo) <= y <= f(hi).  lo, hi
    and x0 broadcast against y; tol is the absolute tolerance on x (> 0)."""
    if not callable(f) or not callable(df):
        raise ValueError(f"f = {f!r:.40}, df = {df!r:.40}; allowed: callables")
    check_number("tol", tol, lo=0.0, lo_open=True)
    y = check_array("y", y, ndim=None, min_size=0)
    check_array("lo", lo, ndim=None, min_size=0)
    check_array("hi", hi, ndim=None, min_size=0)
    if np.any(np.asarray(lo, dtype=float) > np.asarray(hi, dtype=float)):
        raise ValueError(f"lo = {lo!r:.40}, hi = {hi!r:.40}; allowed: lo <= hi")
    a = np.broadcast_to(np.asarray(lo, dtype=float), y.shape).copy()
    b = np.broadcast_to(np.asarray(hi, dtype=float), y.shape).copy()
    x = 0.5 * (a + b) if x0 is None else np.clip(np.broadcast_to(x0, y.shape), a, b)
    for _ in range(_MAX_ITER):
        r = f(x) - y
        a = np.where(r < 0, x, a)
        b = np.where(r > 0, x, b)
        new = x - r / df(x)
        new = np.where((new <= a) | (new >= b) | ~np.isfinite(new), 0.5 * (a + b), new)
        done = (np.abs(new - x) <= tol) | (r == 0)
        x = np.where(r == 0, x, new)
        if np.all(done):
            return x
    raise RuntimeError(f"invert_increasing: no convergence in {_MAX_ITER} iterations "
                       f"(max residual {np.max(np.abs(f(x) - y)):.3e})")


def _solve_F(c, n1, lo, hi):
    """Root of F(n) = n - n1 ln n = c on [lo, hi] (F' = 1 - n1/n > 0 there)."""
    return invert_increasing(lambda n: _F(n, n1), lambda n: 1 - n1 / n, c, lo, hi,
                             tol=_REL_TOL * hi, x0=c if n1 == 0 else None)


def speed_law(t, p: DriveParams) -> np.ndarray:
    """n0(t) in rev/s, P-periodic, t = 0 at the start of the interlayer (n_min).

    Solves (7) in the interlayer and the corrected (6) in the layer; t may be
    any array shape (negative times wrap)."""
    t = check_times("t", t)
    c_ = law_constants(p)
    tl, inter = _phase(t, p)
    c = np.where(inter, _F(p.n_min, c_.n1) + c_.Delta * tl / p.T_n,
                 _F(p.n_max, c_.n1) - c_.Delta * (tl - p.T_n) / p.T_c)
    return _solve_F(c, c_.n1, p.n_min, p.n_max)


def speed_slope(t, p: DriveParams) -> np.ndarray:
    """dn0/dt in rev/s^2 (exact): +-(Delta/T_stroke) n/(n - n1) = g K_n n/d.

    At the reversals (t = 0, T_n mod P) the right-hand limit is returned."""
    t = check_times("t", t)
    c_ = law_constants(p)
    tl, inter = _phase(t, p)
    n = speed_law(t, p)
    rate = np.where(inter, c_.Delta / p.T_n, -c_.Delta / p.T_c)
    return rate * n / (n - c_.n1)


def revolutions(t, p: DriveParams) -> np.ndarray:
    """Cumulative spindle revolutions int_0^t n0 dt' (exact, t may be negative)."""
    c_ = law_constants(p)
    t = check_times("t", t)
    tl, inter = _phase(t, p)
    n = speed_law(t, p)
    q = lambda x: (x - c_.n1) ** 2
    D = 2 * c_.Delta
    N_inter = p.T_n / D * (q(p.n_max) - q(p.n_min))
    within = np.where(inter, p.T_n / D * (q(n) - q(p.n_min)),
                      N_inter + p.T_c / D * (q(p.n_max) - q(n)))
    return np.floor(t / c_.P) * c_.revs_per_period + within


def _gauss_nodes(p: DriveParams, m: int, panels: int | None, order: int = 16):
    """Composite Gauss-Legendre nodes/weights on [n_min, n_max]."""
    if panels is None:
        panels = max(16, 2 * m)
    x, w = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(p.n_min, p.n_max, panels + 1)
    h = np.diff(edges) / 2
    mid = (edges[:-1] + edges[1:]) / 2
    nodes = (mid[:, None] + h[:, None] * x[None, :]).ravel()
    weights = (h[:, None] * w[None, :]).ravel()
    return nodes, weights


def fourier(p: DriveParams, m: int, *, panels: int | None = None):
    """Fourier coefficients (8) of n0(t) over one period, in rev/s.

    Returns (C0, a, b) with a, b of length m (a[k-1] = a_k) and
    n0(t) = C0/2 + sum_k a_k cos k w t + b_k sin k w t.  Quadrature in n
    instead of t (dt = (T_stroke/Delta)(1 - n1/n) dn): the integrands are
    smooth, no corners, no root finding; composite Gauss-Legendre with
    ``panels`` x 16 nodes (default max(16, 2m) panels).  m: 0 ... MAX_HARMONICS;
    panels: >= 1, with m x panels <= MAX_WORK.
    """
    check_params(p)
    try:
        m = check_int("m", m, lo=0, hi=MAX_HARMONICS)
    except ValueError:
        raise ValueError(f"fourier: m must be an integer in [0, {MAX_HARMONICS}], got "
                         f"{m!r:.40}") from None
    if panels is not None:
        panels = check_int("panels", panels, lo=1, hi=MAX_WORK)
        if m * panels > MAX_WORK:
            raise ValueError(f"panels = {panels!r} with m = {m}: m x panels = {m * panels}; "
                             f"allowed: m x panels <= {MAX_WORK}")
    c_ = law_constants(p)
    n, wq = _gauss_nodes(p, m, panels)
    t_i = p.T_n * (n - p.n_min - c_.n1 * np.log(n / p.n_min)) / c_.Delta
    t_l = p.T_n + p.T_c * (p.n_max - n - c_.n1 * np.log(p.n_max / n)) / c_.Delta
    base = wq * n * (1 - c_.n1 / n) / c_.Delta * (2 / c_.P)
    C0 = float(np.sum(base * (p.T_n + p.T_c)))
    k = np.arange(1, m + 1)[:, None]
    x_i, x_l = k * c_.omega * t_i, k * c_.omega * t_l
    a = (p.T_n * np.cos(x_i) + p.T_c * np.cos(x_l)) @ base
    b = (p.T_n * np.sin(x_i) + p.T_c * np.sin(x_l)) @ base
    return C0, a, b


def trig_eval(t, mean, a, b, omega: float) -> np.ndarray:
    """mean + sum_k a_k cos k omega t + b_k sin k omega t (any shape of t)."""
    t = check_times("t", t)
    check_number("mean", mean)
    check_number("omega", omega)
    a, b = check_coefficients(a, b)
    x = np.multiply.outer(t, np.arange(1, len(a) + 1) * omega)
    return mean + np.cos(x) @ a + np.sin(x) @ b


def check_coefficients(a, b, names=("a", "b")) -> tuple[np.ndarray, np.ndarray]:
    """Two 1-D finite coefficient arrays of equal length."""
    a = check_array(names[0], a, min_size=0)
    b = check_array(names[1], b, min_size=0)
    if len(a) != len(b):
        raise ValueError(f"{names[0]}, {names[1]}: lengths {len(a)} and {len(b)}; allowed: "
                         "equal lengths")
    return a, b


def series(t, C0, a, b, *, omega: float) -> np.ndarray:
    """m-term series (8) of n0: C0/2 + sum a_k cos k w t + b_k sin k w t."""
    return trig_eval(t, check_number("C0", C0) / 2, a, b, omega)


def amplitude_phase(a, b):
    """(C_k, psi_k) of (8) with the four-quadrant phase (defect D8):
    a cos x + b sin x = C sin(x + psi), C = hypot(a, b), psi = atan2(a, b)."""
    a, b = check_coefficients(a, b)
    return np.hypot(a, b), np.arctan2(a, b)
