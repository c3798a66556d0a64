"""Input extrapolation of order 0, 1, 2 for the masters.

Over a communication step [t, t + h] an input is the polynomial

    u(t + s) = a0 + a1 s + a2 s^2 / 2

through the source output's newest value and its values at the last 1-2
accepted communication points (order 1: a line through 2 samples, order 2:
a parabola through 3; fewer while the run has fewer samples).  The master
sets a0 with fmi2SetReal and a1, a2 with fmi2SetRealInputDerivatives (FMI
2.0: the derivatives of an input at the current communication point), so an
FMU that declares ``canInterpolateInputs`` integrates the polynomial inside
its step instead of a staircase.

Samples are taken at the source's own time: in Jacobi every source is at t;
in Gauss-Seidel a component stepping after its source reads it at t + h (the
polynomial then interpolates over the step).  A sample joins the history
only when its step is accepted: a rejected step (adaptive run) leaves none.

The derivatives can come from the source's output derivatives instead
(``fmi2GetRealOutputDerivatives``, when it declares
``maxOutputDerivativeOrder`` >= the order): a Taylor polynomial at the
source's time, moved to t.
"""
from __future__ import annotations

import math

import numpy as np

#: the extrapolation orders the masters offer
ORDERS = (0, 1, 2)


def taylor(taus, values, order: int) -> np.ndarray:
    """Derivatives 0..order at tau = 0 of the polynomial of degree
    len(taus) - 1 through (taus[j], values[j]) (rows beyond its degree are 0).
    taus: distinct sample times relative to the expansion point."""
    taus = np.asarray(taus, dtype=float)
    values = np.asarray(values, dtype=float)
    k = len(taus) - 1
    if k > order or k < 0:
        raise ValueError(f"taylor: {len(taus)} samples for order {order}; allowed: 1 to "
                         f"{order + 1}")
    scale = float(np.max(np.abs(taus))) or 1.0
    x = taus / scale
    V = np.array([[xj**m / math.factorial(m) for m in range(k + 1)] for xj in x])
    c = np.linalg.solve(V, values)
    out = np.zeros((order + 1,) + values.shape[1:])
    out[:k + 1] = c / np.array([scale**m for m in range(k + 1)]).reshape(
        (-1,) + (1,) * (values.ndim - 1))
    return out


def taylor_many(taus, values, order: int) -> list[list[float]]:
    """``taylor(taus, values[r], order)`` for every row r of ``values`` (the
    rows sampled at the same times), bit for bit: the same matrix (built on
    Python floats: the same IEEE operations and libm pow as numpy's float64
    scalars), and one LAPACK solve per row on the same numbers (a stacked
    np.linalg.solve)."""
    taus = [float(x) for x in taus]
    k = len(taus) - 1
    if k > order or k < 0 or any(len(v) != k + 1 for v in values):
        raise ValueError(f"taylor_many: {len(taus)} samples for order {order}; allowed: 1 "
                         f"to {order + 1} samples, and as many values in every row")
    scale = max(abs(x) for x in taus) or 1.0
    facts = [math.factorial(m) for m in range(k + 1)]
    V = [[(x / scale)**m / facts[m] for m in range(k + 1)] for x in taus]
    c = np.linalg.solve(np.array([V] * len(values)),
                        np.array(values, dtype=float)[:, :, None])[:, :, 0].tolist()
    scales = [scale**m for m in range(k + 1)]
    pad = [0.0] * (order - k)
    return [[cm / sm for cm, sm in zip(row, scales)] + pad for row in c]


def shift_rows(rows: list[list[float]], s: float) -> list[list[float]]:
    """``shift(row, s)`` for every row, bit for bit (the same products,
    quotients and sums in the same order, on Python floats: the same IEEE
    operations as numpy's float64, without its per-call cost on a few
    numbers)."""
    n = len(rows[0]) if rows else 0
    powers = [s**j for j in range(n)]
    facts = [math.factorial(j) for j in range(n)]
    out = []
    for c in rows:
        row = []
        for m in range(n):
            acc = 0
            for j in range(n - m):
                acc = acc + c[m + j] * powers[j] / facts[j]
            row.append(acc)
        out.append(row)
    return out


def shift(c, s: float) -> np.ndarray:
    """The Taylor coefficients ``c`` (derivatives at 0) moved to s: the
    derivatives at s of the same polynomial."""
    c = np.asarray(c, dtype=float)
    n = len(c)
    return np.array([sum(c[m + j] * s**j / math.factorial(j) for j in range(n - m))
                     for m in range(n)])


def value(c, s: float) -> float:
    """The polynomial with Taylor coefficients ``c`` at s."""
    return float(sum(cm * s**m / math.factorial(m) for m, cm in enumerate(c)))


class History:
    """Each connection's accepted samples (time, value) of its source."""

    KEEP = 3

    def __init__(self, n: int):
        self.samples: list[list[tuple[float, float]]] = [[] for _ in range(n)]
        self.pending: dict[int, tuple[float, float]] = {}

    def coefficients(self, i: int, ts: float, y: float, t: float, order: int) -> np.ndarray:
        """The input's Taylor coefficients at ``t`` (order + 1 numbers) from
        connection ``i``'s accepted samples before ``ts`` and the newest
        sample y at ts (which joins the history when the step is accepted)."""
        taus, values = self.points(i, ts, y, t, order)
        return taylor(list(taus), values, order)

    def points(self, i: int, ts: float, y: float, t: float, order: int
               ) -> tuple[tuple[float, ...], list[float]]:
        """The samples :meth:`coefficients` fits: their times relative to t
        and their values (the newest, y at ts, is kept pending)."""
        self.pending[i] = (ts, y)
        tol = 1e-12 * max(1.0, abs(ts))
        past = [s for s in self.samples[i] if s[0] < ts - tol][-order:] if order else []
        pts = [*past, (ts, y)]
        return tuple(tj - t for tj, _ in pts), [yj for _, yj in pts]

    def commit(self) -> None:
        for i, (ts, y) in self.pending.items():
            hist = self.samples[i]
            if not hist or ts > hist[-1][0]:
                hist.append((ts, y))
                del hist[:-self.KEEP]
        self.pending.clear()

    def discard(self) -> None:
        self.pending.clear()
