"""The two-mass benchmark: its scene and the exact co-simulation map.

Two masses on wall springs, coupled by a spring-damper, split into two FMUs
(models/two_mass.py): "force" holds mass 1 and the coupling element (inputs
x2, v2; output F, with direct feedthrough), "disp" holds mass 2 (input F;
outputs x2, v2).  With each input held constant over a communication step H
and each FMU integrating exactly, one step of a master is a linear map of
z = (x1, v1, x2, v2) (derivation: docs/guides/scenes.md):

    subsystem i:  z_i' = A_i z_i + B_i u_i,   over a step with u_i held:
                  z_i(t + H) = Phi_i z_i(t) + Gam_i u_i,
                  Phi_i = exp(A_i H),  Gam_i = int_0^H exp(A_i s) ds B_i
    coupling:     u_1 = z_2,   F = C_1 z_1 + D_1 u_1,   u_2 = F

    Jacobi:                 [[Phi1, Gam1], [Gam2 C1, Phi2 + Gam2 D1]]
    Gauss-Seidel, force first:
                            [[Phi1, Gam1], [Gam2 C1 Phi1, Phi2 + Gam2 (C1 Gam1 + D1)]]
    Gauss-Seidel, disp first:
                            [[Phi1 + Gam1 Gam2 C1, Gam1 (Phi2 + Gam2 D1)],
                             [Gam2 C1, Phi2 + Gam2 D1]]

libcosim's fixed-step master reads each output right after the step,
before the inputs change, so the force it passes on was computed with the
previous step's position: its map acts on w = (z1, z2, z2 of the step before),

    libcosim:   z1+ = Phi1 z1 + Gam1 z2,   z2+ = Phi2 z2 + Gam2 (C1 z1 + D1 z2_old)

The co-simulation is stable when the map's spectral radius is below 1.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from scipy.optimize import brentq

from loomfmu.scene.declare import Scene, declare_model
from loomfmu.scene.extrapolation import taylor

#: the exact-integration settings of the FMUs in the benchmark
TIGHT = {"solver_rtol": 1e-12, "solver_atol": 1e-14}
#: the algorithms the map is derived for
ALGORITHMS = ("jacobi", "gauss-seidel:force-first", "gauss-seidel:disp-first", "libcosim")


@dataclass(frozen=True)
class Params:
    """The benchmark's parameters (defaults: the models' declared values)."""

    m1: float
    k1: float
    d1: float
    kc: float
    dc: float
    m2: float
    k2: float
    d2: float

    @classmethod
    def declared(cls, **overrides) -> "Params":
        values = {}
        for side in ("force", "displacement"):
            model = declare_model(f"two_mass_{side}", {})
            values.update({v.name: v.start for v in model.of_kind("parameter")})
        values.update(overrides)
        return cls(**{f.name: float(values[f.name]) for f in fields(cls)})

    def force_side(self) -> dict:
        return {k: getattr(self, k) for k in ("m1", "k1", "d1", "kc", "dc")}

    def disp_side(self) -> dict:
        return {k: getattr(self, k) for k in ("m2", "k2", "d2")}


#: the master the scene recommends (docs/guides/scenes.md, the two-mass
#: verdict): 1 % over a second at H <= 4.26 ms, 14 times fewer steps than
#: Gauss-Seidel holding its inputs; its stability limit is 21 ms
RECOMMENDED = {"master": "gauss-seidel", "extrapolation": 2}


def scene(params: Params | None = None, *, x1_0: float = 0.1, stop_time: float = 2.0,
          step: float = 1e-3, tight: bool = True) -> Scene:
    """The two-mass scene: mass 1 starts displaced by ``x1_0`` (m) at rest;
    ``tight``: the FMUs integrate at rtol 1e-12 (exact for the theory).  A
    run takes the RECOMMENDED master and extrapolation unless given others
    (the co-simulation maps of this module are derived for each)."""
    p = params or Params.declared()
    s = Scene("two_mass", description="two masses coupled by a spring-damper, split "
              "into two FMUs with force-displacement coupling", stop_time=stop_time,
              step=step, **RECOMMENDED)
    settings = TIGHT if tight else {}
    s.add("force", model="two_mass_force", parameters={**settings, **p.force_side()},
          start={"x1": x1_0})
    s.add("disp", model="two_mass_displacement", parameters={**settings, **p.disp_side()})
    s.connect("force.coupling", "disp.coupling")
    s.record("force.x1_out", "force.v1_out", "disp.x2_out", "disp.v2_out", "force.F_c")
    return s


# -- the exact co-simulation map --------------------------------------------------
def expm(M: np.ndarray) -> np.ndarray:
    """exp(M) of a small matrix: scaling and squaring of a Taylor series
    (30 terms on a norm <= 1/2: error below 1e-16 relative).  Used instead of
    scipy.linalg.expm, whose LAPACK calls take ~20 ms each for a 4 x 4 matrix
    when a multi-threaded OpenBLAS competes for busy cores."""
    M = np.asarray(M, dtype=float)
    norm = np.abs(M).sum(axis=1).max()
    s = max(0, int(np.ceil(np.log2(norm / 0.5)))) if norm > 0.5 else 0
    A = M / 2.0**s
    term = np.eye(len(M))
    E = term.copy()
    for k in range(1, 30):
        term = term @ A / k
        E = E + term
    for _ in range(s):
        E = E @ E
    return E



def matrices(p: Params):
    """(A1, B1, C1, D1, A2, B2): subsystem 1 (force side) z1' = A1 z1 + B1 u1,
    F = C1 z1 + D1 u1 with u1 = (x2, v2); subsystem 2 z2' = A2 z2 + B2 F."""
    A1 = np.array([[0.0, 1.0], [-(p.k1 + p.kc) / p.m1, -(p.d1 + p.dc) / p.m1]])
    B1 = np.array([[0.0, 0.0], [p.kc / p.m1, p.dc / p.m1]])
    C1 = np.array([[p.kc, p.dc]])
    D1 = np.array([[-p.kc, -p.dc]])
    A2 = np.array([[0.0, 1.0], [-p.k2 / p.m2, -p.d2 / p.m2]])
    B2 = np.array([[0.0], [1.0 / p.m2]])
    return A1, B1, C1, D1, A2, B2


def monolithic(p: Params) -> np.ndarray:
    """The coupled system's matrix: z' = A z, z = (x1, v1, x2, v2)."""
    A1, B1, C1, D1, A2, B2 = matrices(p)
    return np.block([[A1, B1], [B2 @ C1, A2 + B2 @ D1]])


def hold(A: np.ndarray, B: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(Phi, Gam): the exact step of z' = A z + B u over h with u held."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = expm(M * h)
    return E[:n, :n], E[:n, n:]


def cosim_map(p: Params, h: float, algorithm: str) -> np.ndarray:
    """The matrix of one communication step of ``algorithm`` (ALGORITHMS):
    4 x 4 on z = (x1, v1, x2, v2); 6 x 6 for "libcosim", on (z, x2 and v2 of
    the step before)."""
    if algorithm not in ALGORITHMS:
        raise ValueError(f"algorithm = {algorithm!r}; allowed: {', '.join(ALGORITHMS)}")
    A1, B1, C1, D1, A2, B2 = matrices(p)
    P1, G1 = hold(A1, B1, h)
    P2, G2 = hold(A2, B2, h)
    if algorithm == "jacobi":
        return np.block([[P1, G1], [G2 @ C1, P2 + G2 @ D1]])
    if algorithm == "libcosim":
        Z = np.zeros((2, 2))
        return np.block([[P1, G1, Z], [G2 @ C1, P2, G2 @ D1], [Z, np.eye(2), Z]])
    if algorithm == "gauss-seidel:force-first":
        return np.block([[P1, G1], [G2 @ C1 @ P1, P2 + G2 @ (C1 @ G1 + D1)]])
    return np.block([[P1 + G1 @ G2 @ C1, G1 @ (P2 + G2 @ D1)], [G2 @ C1, P2 + G2 @ D1]])


def spectral_radius(p: Params, h: float, algorithm: str, order: int = 0) -> float:
    """Spectral radius of one step of ``algorithm`` with input extrapolation
    of ``order`` (0: the zero-order hold's map :func:`cosim_map`)."""
    M = cosim_map(p, h, algorithm) if order == 0 else extrapolated_map(p, h, algorithm, order)
    return float(max(abs(np.linalg.eigvals(M))))


# -- input extrapolation of order 1, 2 --------------------------------------------
#: the algorithms the extrapolated map is derived for (libcosim holds its inputs)
EXTRAPOLATED = ALGORITHMS[:3]


def hold_poly(A: np.ndarray, B: np.ndarray, h: float, order: int):
    """(Phi, [Gam_0, ..., Gam_order]): the exact step of z' = A z + B u over h
    with u(s) = a_0 + a_1 s + a_2 s^2 / 2 (a_m: the input's m-th derivative at
    the step's start): z(h) = Phi z(0) + sum_m Gam_m a_m.  One exponential of
    the chain z' = A z + B u, u' = u_1, u_1' = u_2, u_2' = 0."""
    n, m = B.shape
    N = n + m * (order + 1)
    M = np.zeros((N, N))
    M[:n, :n], M[:n, n:n + m] = A, B
    for j in range(order):
        M[n + j * m:n + (j + 1) * m, n + (j + 1) * m:n + (j + 2) * m] = np.eye(m)
    E = expm(M * h)
    return E[:n, :n], [E[:n, n + j * m:n + (j + 1) * m] for j in range(order + 1)]


def _coefficients(hist, ts: float, y, t: float, order: int) -> np.ndarray:
    """The master's rule (loomfmu.scene.extrapolation.History): the polynomial
    through the last ``order`` samples before ts and the newest (ts, y), as
    derivatives at t (rows 0..order)."""
    past = [s for s in hist if s[0] < ts - 1e-12 * max(1.0, abs(ts))][-order:] if order else []
    pts = [*past, (ts, np.atleast_1d(np.asarray(y, dtype=float)))]
    return taylor([tj - t for tj, _ in pts], np.array([v for _, v in pts]), order)


def _one_step(ops, z1, z2, hist1, hist2, t, h, algorithm, order):
    """One communication step of ``algorithm`` with extrapolation ``order``
    exactly as the master does it.  hist1: samples (time, (x2, v2)) of the
    force side's input, hist2: samples (time, F) of the displacement side's.
    Returns z1, z2 at t + h and the new samples of the two inputs."""
    P1, G1, P2, G2, C1, D1 = ops
    adv1 = lambda a: P1 @ z1 + sum(G @ am for G, am in zip(G1, a))   # noqa: E731
    adv2 = lambda a: P2 @ z2 + sum(G @ am for G, am in zip(G2, a))   # noqa: E731
    at_end = lambda a: sum(am * h**m / math.factorial(m) for m, am in enumerate(a))  # noqa
    if algorithm == "jacobi":
        a1 = _coefficients(hist1, t, z2, t, order)
        F = C1 @ z1 + D1 @ a1[0]
        a2 = _coefficients(hist2, t, F, t, order)
        return adv1(a1), adv2(a2), (t, z2.copy()), (t, F)
    if algorithm == "gauss-seidel:force-first":
        a1 = _coefficients(hist1, t, z2, t, order)
        z1n = adv1(a1)
        F = C1 @ z1n + D1 @ at_end(a1)      # the force side's input at t + h
        a2 = _coefficients(hist2, t + h, F, t, order)
        return z1n, adv2(a2), (t, z2.copy()), (t + h, F)
    if algorithm == "gauss-seidel:disp-first":
        F = C1 @ z1 + D1 @ z2               # the force side holds z2 at t
        a2 = _coefficients(hist2, t, F, t, order)
        z2n = adv2(a2)
        a1 = _coefficients(hist1, t + h, z2n, t, order)
        return adv1(a1), z2n, (t + h, z2n.copy()), (t, F)
    raise ValueError(f"algorithm = {algorithm!r}; allowed: {', '.join(EXTRAPOLATED)}")


def _ops(p: Params, h: float, order: int):
    A1, B1, C1, D1, A2, B2 = matrices(p)
    P1, G1 = hold_poly(A1, B1, h, order)
    P2, G2 = hold_poly(A2, B2, h, order)
    return P1, G1, P2, G2, C1, D1


def extrapolated_trajectory(p: Params, h: float, n: int, z0, algorithm: str,
                            order: int) -> np.ndarray:
    """z at t = 0, h, ..., n h (n + 1 rows) of ``algorithm`` with input
    extrapolation of ``order``, from its first step (where the history is
    shorter and the order lower, as in the master)."""
    return extrapolated_run(p, [h] * n, z0, algorithm, order)


def extrapolated_run(p: Params, steps, z0, algorithm: str, order: int) -> np.ndarray:
    """z after each of the communication ``steps`` (len + 1 rows, from z0):
    the steps of an adaptive run's accepted steps, the polynomials through
    samples at their unequal times."""
    z = np.zeros((len(steps) + 1, 4))
    z[0] = z0
    z1, z2 = np.array(z0[:2], dtype=float), np.array(z0[2:], dtype=float)
    hist1: list = []
    hist2: list = []
    ops: dict[float, tuple] = {}
    t = 0.0
    for k, h in enumerate(steps):
        h = float(h)
        if h not in ops:
            ops[h] = _ops(p, h, order)
        z1, z2, s1, s2 = _one_step(ops[h], z1, z2, hist1, hist2, t, h, algorithm, order)
        for hist, smp in ((hist1, s1), (hist2, s2)):
            if not hist or smp[0] > hist[-1][0]:
                hist.append(smp)
                del hist[:-3]
        t += h
        z[k + 1] = np.concatenate([z1, z2])
    return z


def _history_times(algorithm: str, order: int, h: float) -> tuple[list, list]:
    """The times of the samples the two inputs' histories hold at a step's
    start t = 0 once the run is past its first ``order`` steps."""
    back = [-(order - j) * h for j in range(order)]          # -order h ... -h
    upto = [-(order - 1 - j) * h for j in range(order)]      # -(order-1) h ... 0
    if algorithm == "jacobi":
        return back, back
    if algorithm == "gauss-seidel:force-first":
        return back, upto
    return upto, back


def extrapolated_map(p: Params, h: float, algorithm: str, order: int) -> np.ndarray:
    """The matrix of one step of ``algorithm`` with extrapolation ``order``
    (once the histories are full): a linear map of the stacked vector
    w = (x1, v1, x2, v2, the force side's last ``order`` input samples
    (x2, v2), the displacement side's last ``order`` force samples), oldest
    first; built column by column from :func:`_one_step`."""
    if algorithm not in EXTRAPOLATED:
        raise ValueError(f"algorithm = {algorithm!r}; allowed: {', '.join(EXTRAPOLATED)}")
    ops = _ops(p, h, order)
    T1, T2 = _history_times(algorithm, order, h)
    N = 4 + 3 * order
    M = np.zeros((N, N))
    for col in range(N):
        w = np.zeros(N)
        w[col] = 1.0
        hist1 = [(T1[j], w[4 + 2 * j:6 + 2 * j]) for j in range(order)]
        hist2 = [(T2[j], w[4 + 2 * order + j:5 + 2 * order + j]) for j in range(order)]
        z1n, z2n, s1, s2 = _one_step(ops, w[:2], w[2:4], hist1, hist2, 0.0, h, algorithm,
                                     order)
        h1 = [v for _, v in hist1][1:] + [s1[1]] if order else []
        h2 = [v for _, v in hist2][1:] + [s2[1]] if order else []
        M[:, col] = np.concatenate([z1n, z2n, *h1, *[np.atleast_1d(v) for v in h2]])
    return M


def exact_radius(p: Params, h: float) -> float:
    """Spectral radius of the exact step exp(A H) (below 1: the system is damped)."""
    return float(max(abs(np.linalg.eigvals(expm(monolithic(p) * h)))))


def trajectory(p: Params, h: float, n: int, z0, algorithm: str) -> np.ndarray:
    """z at t = 0, h, ..., n h under the co-simulation map (n + 1 rows)."""
    M = cosim_map(p, h, algorithm)
    w = np.zeros((n + 1, M.shape[0]))
    w[0, :4] = z0
    if M.shape[0] > 4:      # libcosim starts with consistent inputs
        w[0, 4:] = w[0, 2:4]
    for k in range(n):
        w[k + 1] = M @ w[k]
    return w[:, :4]


def exact_solution(p: Params, t, z0) -> np.ndarray:
    """The monolithic solution z(t) (rows) at increasing times ``t`` (from
    t[0], where z = z0), stepped by exp(A dt) (one matrix per distinct dt)."""
    A = monolithic(p)
    t = np.asarray(t, dtype=float)
    z = np.zeros((len(t), 4))
    z[0] = z0
    cache: dict[float, np.ndarray] = {}
    for k in range(1, len(t)):
        dt = float(t[k] - t[k - 1])
        key = round(dt, 15)
        if key not in cache:
            cache[key] = expm(A * dt)
        z[k] = cache[key] @ z[k - 1]
    return z


def stability_limit(p: Params, algorithm: str, *, h_lo: float = 1e-5,
                    h_hi: float = 1.0, n: int = 120, order: int = 0) -> float:
    """The smallest communication step at which the spectral radius reaches 1
    (scanned on a log grid from h_lo to h_hi, then located by brentq);
    inf when it stays below 1."""
    hs = np.geomspace(h_lo, h_hi, n)
    rho = np.array([spectral_radius(p, h, algorithm, order) for h in hs]) - 1.0
    above = np.nonzero(rho >= 0)[0]
    if above.size == 0:
        return float("inf")
    k = int(above[0])
    if k == 0:
        raise ValueError(f"{algorithm}: unstable already at h_lo = {h_lo:g} s; allowed: a "
                         "smaller h_lo")
    return float(brentq(lambda h: spectral_radius(p, h, algorithm, order) - 1.0, hs[k - 1],
                        hs[k],
                        xtol=1e-14, rtol=1e-12))
