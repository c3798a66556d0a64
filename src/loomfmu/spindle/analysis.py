"""Rotor analyses on numeric matrices M, C, G, K (seed 003, section IV).

* :func:`undamped_frequencies`: K X = w^2 M X (no damping, no spin);
* :func:`complex_modes`: the first-order eigenproblem (18),
  [[-K^-1 C, -K^-1 M], [I, 0]] [X; Y] = (1/s) [X; Y], Y = s X, solved by QR
  (LAPACK); C here is the damping plus Omega G;
* :func:`whirl_modes`: complex modes sorted by frequency and labelled forward
  or backward whirl; :func:`campbell` over spin speed;
* :func:`unbalance_response`: (15), the real 2n system for q = A1 sin wt +
  A2 cos wt under F = P1 sin wt + P2 cos wt;
* :func:`dynamic_compliance`: (19)-(21) from right and left eigenvectors.

All speeds inside are rad/s; rpm only at the edges (:data:`RPM`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from loomfmu.declare.checks import check_array, check_bool, check_int, check_number

#: rad/s per rpm
RPM = 2 * np.pi / 60
#: most modes :func:`campbell` tracks
MAX_MODES = 1000


def check_matrices(**mats) -> list[np.ndarray]:
    """Square, finite matrices of one size, in the order given."""
    out = []
    for name, value in mats.items():
        a = check_array(name, value, ndim=2)
        if a.shape[0] != a.shape[1]:
            raise ValueError(f"{name}: shape {a.shape}; allowed: a square matrix")
        if out and a.shape != out[0].shape:
            raise ValueError(f"{name}: shape {a.shape}; allowed: {out[0].shape} like "
                             f"{next(iter(mats))}")
        out.append(a)
    return out


def check_vector(name: str, value, n: int) -> np.ndarray:
    v = check_array(name, value)
    if v.shape != (n,):
        raise ValueError(f"{name}: shape {v.shape}; allowed: ({n},), one per DOF")
    return v


def check_indices(name: str, value, n: int) -> np.ndarray:
    """DOF indices (integers in [0, n))."""
    idx = check_array(name, value, lo=0, hi=n - 1, ndim=None)
    if np.any(idx != np.round(idx)):
        raise ValueError(f"{name}: {value!r:.40}; allowed: integer DOF indices in [0, {n})")
    return idx.astype(int)


def undamped_frequencies(M: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Natural frequencies (rad/s, ascending) of M q'' + K q = 0; K's
    symmetric part is used (cross-coupling does not store energy)."""
    M, K = check_matrices(M=M, K=K)
    Ks = (K + K.T) / 2
    w2 = sla.eigh(Ks, (M + M.T) / 2, eigvals_only=True)
    return np.sqrt(np.clip(w2, 0, None))


def complex_modes(M, C, K):
    """Eigenvalues s and right eigenvectors X of (s^2 M + s C + K) X = 0 via (18).

    K must be regular (the rotor must be supported).  Returns (s, X) with
    X of shape (n, 2n), one column per eigenvalue.
    """
    M, C, K = check_matrices(M=M, C=C, K=K)
    n = M.shape[0]
    KiC = np.linalg.solve(K, C)
    KiM = np.linalg.solve(K, M)
    A = np.block([[-KiC, -KiM], [np.eye(n), np.zeros((n, n))]])
    mu, V = sla.eig(A)
    s = 1 / mu
    return s, V[:n, :]


@dataclass
class WhirlMode:
    s: complex          # eigenvalue (1/s)
    freq: float         # |Im s| (rad/s)
    zeta: float         # damping ratio -Re s / |s|
    forward: bool       # whirls in the spin direction
    X: np.ndarray       # right eigenvector (displacements)


def whirl_direction(X: np.ndarray, x_idx, y_idx) -> bool:
    """True for forward whirl: for s = i w, x + i y ~ e^{+i w t} dominates.
    With x = Re(X_x e^{iwt}), y = Re(X_y e^{iwt}), the forward amplitude is
    |X_x + i X_y| and the backward one |X_x - i X_y| (summed over nodes)."""
    fw = np.sum(np.abs(X[x_idx] + 1j * X[y_idx]) ** 2)
    bw = np.sum(np.abs(X[x_idx] - 1j * X[y_idx]) ** 2)
    return bool(fw >= bw)


def whirl_modes(M, C, K, x_idx, y_idx) -> list[WhirlMode]:
    """Modes with Im s > 0, ascending in frequency, labelled by whirl direction.

    x_idx, y_idx: indices of the x and y DOF (translations and slopes, paired).
    """
    M, C, K = check_matrices(M=M, C=C, K=K)
    x_idx, y_idx = (check_indices(n, v, M.shape[0]) for n, v in (("x_idx", x_idx),
                                                                 ("y_idx", y_idx)))
    if x_idx.shape != y_idx.shape:
        raise ValueError(f"x_idx, y_idx: shapes {x_idx.shape} and {y_idx.shape}; allowed: "
                         "paired indices of equal length")
    s, X = complex_modes(M, C, K)
    out = []
    for k in np.argsort(np.abs(s.imag)):
        if s[k].imag <= 1e-9 * max(1.0, abs(s[k])):
            continue
        out.append(WhirlMode(s[k], float(s[k].imag), float(-s[k].real / abs(s[k])),
                             whirl_direction(X[:, k], x_idx, y_idx), X[:, k]))
    return out


def campbell(matrices, speeds_rpm, x_idx, y_idx, n_modes: int = 6, damped=True):
    """Whirl frequencies (rpm) over spin speed.

    matrices(Omega) -> (M, C, G, K) numeric at spin speed Omega (rad/s).
    Returns {"speed_rpm", "forward", "backward"}: arrays (len(speeds), n_modes)
    of the lowest forward / backward whirl frequencies in rpm (nan if fewer).
    """
    if not callable(matrices):
        raise ValueError(f"matrices = {matrices!r:.60}; allowed: a function Omega -> "
                         "(M, C, G, K)")
    speeds_rpm = check_array("speeds_rpm", speeds_rpm, unit="rpm")
    n_modes = check_int("n_modes", n_modes, lo=1, hi=MAX_MODES)
    damped = check_bool("damped", damped)
    fw = np.full((len(speeds_rpm), n_modes), np.nan)
    bw = np.full((len(speeds_rpm), n_modes), np.nan)
    for i, n in enumerate(speeds_rpm):
        M, C, G, K = matrices(n * RPM)
        modes = whirl_modes(M, (C if damped else 0 * C) + n * RPM * G, K, x_idx, y_idx)
        f = [m.freq / RPM for m in modes if m.forward][:n_modes]
        b = [m.freq / RPM for m in modes if not m.forward][:n_modes]
        fw[i, :len(f)] = f
        bw[i, :len(b)] = b
    return {"speed_rpm": np.asarray(speeds_rpm, float), "forward": fw, "backward": bw}


def unbalance_response(M, C, K, w, P1, P2):
    """Solve (15) for A1, A2: q = A1 sin wt + A2 cos wt (C includes w G)."""
    M, C, K = check_matrices(M=M, C=C, K=K)
    w = check_number("w", w, unit="rad/s")
    P1, P2 = check_vector("P1", P1, M.shape[0]), check_vector("P2", P2, M.shape[0])
    D = K - w**2 * M
    A = np.block([[D, -w * C], [w * C, D]])
    sol = np.linalg.solve(A, np.concatenate([P1, P2]))
    n = M.shape[0]
    return sol[:n], sol[n:]


def amplitude(A1, A2, idx) -> float:
    """Largest excursion of a DOF whose motion is A1 sin wt + A2 cos wt."""
    A1 = check_array("A1", A1)
    A2 = check_vector("A2", A2, len(A1))
    idx = check_int("idx", idx, lo=0, hi=len(A1) - 1)
    return float(np.hypot(A1[idx], A2[idx]))


def orbit_radius(A1, A2, ix, iy) -> float:
    """Largest radius sqrt(x^2 + y^2) over one period of a node's orbit."""
    A1 = check_array("A1", A1)
    A2 = check_vector("A2", A2, len(A1))
    ix = check_int("ix", ix, lo=0, hi=len(A1) - 1)
    iy = check_int("iy", iy, lo=0, hi=len(A1) - 1)
    t = np.linspace(0, 2 * np.pi, 721)
    x = A1[ix] * np.sin(t) + A2[ix] * np.cos(t)
    y = A1[iy] * np.sin(t) + A2[iy] * np.cos(t)
    return float(np.max(np.hypot(x, y)))


def left_modes(M, C, K, s):
    """Left eigenvectors H_i of H^T (s^2 M + s C + K) = 0, matched to ``s``."""
    s_t, H = complex_modes(M.T, C.T, K.T)
    order = [int(np.argmin(np.abs(s_t - si))) for si in s]
    return H[:, order]


def dynamic_compliance(M, C, K, w, a, b=None):
    """(21): u0/P0 = sum_i (b^T X_i)(H_i^T a) / (m_i (i w - s_i)), with
    m_i = H_i^T (2 s_i M + C) X_i (19).  a: force direction; b: response
    direction (default a, as printed).  Returns a complex number."""
    M, C, K = check_matrices(M=M, C=C, K=K)
    w = check_number("w", w, unit="rad/s")
    a = check_vector("a", a, M.shape[0])
    b = a if b is None else check_vector("b", b, M.shape[0])
    s, X = complex_modes(M, C, K)
    H = left_modes(M, C, K, s)
    total = 0j
    for i in range(len(s)):
        m_i = H[:, i] @ (2 * s[i] * M + C) @ X[:, i]
        total += (b @ X[:, i]) * (H[:, i] @ a) / (m_i * (1j * w - s[i]))
    return total


def direct_compliance(M, C, K, w, a, b=None):
    """b^T (K + i w C - w^2 M)^-1 a: the oracle for :func:`dynamic_compliance`."""
    M, C, K = check_matrices(M=M, C=C, K=K)
    w = check_number("w", w, unit="rad/s")
    a = check_vector("a", a, M.shape[0])
    b = a if b is None else check_vector("b", b, M.shape[0])
    return complex(b @ np.linalg.solve(K + 1j * w * C - w**2 * M, a))
