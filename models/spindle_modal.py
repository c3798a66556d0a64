"""Spindle D1201 reduced by modal truncation (seed 003; full model: spindle.py).

q = B eta with B the first ``n_modes`` undamped planar mode shapes of the
non-spinning rotor (x plane, at the default parameters and the film
stiffness at ``basis_rpm``), each used in the x and the y plane: 2 n_modes
modal coordinates.  Every matrix stays symbolic: M_r = B^T M(p) B,
K_r = B^T K(p, Omega) B, ... (a Ritz projection), so parameters can still be
changed in the FMU; the basis itself is numeric, computed at build time, and
is exact only at the default parameters.  Same inputs and outputs as
``spindle``.

static_correction=True (mode-acceleration method, Craig & Kurdila,
"Fundamentals of Structural Dynamics", 2nd ed.): the reduced dynamics stay
as they are, but the displacements used by the outputs are recovered as
q = B eta + R F(t), v = B eta' + R F'(t), with R = K^-1 - B (B^T K B)^-1 B^T
the residual (static) flexibility of the dropped modes (numbers: K at the
default parameters and the film stiffness at ``basis_rpm``, like B) and F the
unbalance forces (13); F' = dF/dphi * Omega is exact at constant speed
(assumption: the speed's rate is not an input).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import scipy.linalg as sla

from loomfmu.declare.checks import check_int, check_number
from loomfmu.declare.model import Model
from loomfmu.models.spindle import RPM, declare_dynamics, declare_rotor, node_labels, spindle_system


def planar_modes(model: Model, sp, basis_rpm: float):
    """Undamped x-plane modes of the non-spinning rotor at the default
    parameters and the film stiffness at ``basis_rpm``: (omega^2 ascending,
    mass-normalised shapes as columns, x-plane DOF indices, y-plane DOF indices)."""
    p = model.syms("parameter")
    f = ca.Function("mk", [p, sp.Omega], [sp.M, sp.K])
    M, K = (np.array(a) for a in f(model.starts("parameter"), basis_rpm * RPM))
    xi, yi = sp.plane_indices()
    Mx, Kx = M[np.ix_(xi, xi)], (K[np.ix_(xi, xi)] + K[np.ix_(xi, xi)].T) / 2
    w2, V = sla.eigh(Kx, Mx)
    return w2, V, xi, yi


def modal_basis(model: Model, sp, n_modes: int, basis_rpm: float) -> np.ndarray:
    """``model``, ``sp``: from spindle_system (free speed symbol).
    The first n_modes x-plane modes, each placed in x and in y (n x 2 n_modes).

    Each mode is scaled to 1 at its largest translation, so a modal coordinate
    eta is that node's displacement in m (mass-normalized modes would give
    eta in m*kg^0.5, a unit FMI 2.0 cannot state)."""
    w2, V, xi, yi = planar_modes(model, sp, basis_rpm)
    if n_modes > len(xi):
        raise ValueError(f"n_modes = {n_modes!r}; allowed: 1..{len(xi)}")
    B = np.zeros((len(sp.dofs), 2 * n_modes))
    for k in range(n_modes):
        shape = V[:, k] / V[_largest_translation(sp, xi, V, k), k]
        B[xi, 2 * k] = shape
        B[yi, 2 * k + 1] = shape
    return B


def _largest_translation(sp, xi, V, k: int) -> int:
    """Row of V (x-plane DOFs xi) with mode k's largest translation."""
    trans = [j for j, i in enumerate(xi) if sp.dofs[i].endswith(".x")]
    return max(trans, key=lambda j: abs(V[j, k]))


def mode_labels(model: Model, sp, n_modes: int, basis_rpm: float) -> list[str]:
    """What each column of :func:`modal_basis` is: mode number, plane, natural
    frequency and the node of largest deflection (computed, not typed)."""
    w2, V, xi, _ = planar_modes(model, sp, basis_rpm)
    where = node_labels(model, sp)
    labels = []
    for k in range(n_modes):
        hz = math.sqrt(max(w2[k], 0.0)) / (2 * math.pi)
        node = sp.dofs[xi[_largest_translation(sp, xi, V, k)]].split(".")[0]
        for plane in ("x", "y"):
            labels.append(f"mode {k + 1}, {plane} plane, {hz:.1f} Hz: the {plane} "
                          f"displacement of the {where[node][1]}, where the mode's "
                          "deflection is largest")
    return labels


#: the most planar modes per plane: assumption, the default mesh has about 30
#: planar degrees of freedom per plane, and modes past the 8th lie far above
#: any spindle speed (see the states' frequencies)
MAX_MODES = 12


def build(*, n_modes: int = 4, basis_rpm: float = 16000.0, beam: str = "euler",
          n_turns: int = 4, damper: str = "corrected", n_low: int = 2,
          n_cone: int = 4, static_correction: bool = False) -> Model:
    """The modal spindle; n_modes planar modes (>= 1) kept in each plane;
    static_correction adds the residual flexibility of the dropped modes to
    the recovered displacements (see the module text)."""
    check_int("n_modes", n_modes, lo=1, hi=MAX_MODES)
    if not isinstance(static_correction, bool):
        raise ValueError(f"static_correction = {static_correction!r}; allowed: False, True")
    check_number("basis_rpm", basis_rpm, lo=0.0, hi=40000.0)
    m = Model("spindle_modal", description="D1201 ring-spinning spindle reduced to "
              f"{n_modes} planar modes per plane (Ritz projection of the FE rotor of "
              "seed 003); the modes' frequencies in the states' descriptions are undamped, "
              f"not spinning, with the film stiffness at {basis_rpm:g} rpm and the default "
              "parameters", stop_time=0.02, step_size=2e-4, h_fixed=2e-6,
              options={"n_modes": n_modes, "basis_rpm": basis_rpm, "beam": beam,
                       "n_turns": n_turns, "damper": damper, "n_low": n_low,
                       "n_cone": n_cone, "static_correction": static_correction})
    Omega = m.input("Omega", 16000.0 * RPM, unit="rad/s", display_unit="rpm",
                    description="spin speed, from the drive (default 16 000 rpm)",
                    min=0.0, max=40000.0 * RPM)
    sp = declare_rotor(m, Omega, beam=beam, n_turns=n_turns, damper=damper,
                       n_low=n_low, n_cone=n_cone)
    am, free = spindle_system(beam=beam, n_turns=n_turns, damper=damper, n_low=n_low,
                              n_cone=n_cone)
    B = modal_basis(am, free, n_modes, basis_rpm)
    w2 = planar_modes(am, free, basis_rpm)[0][:n_modes]
    labels = mode_labels(am, free, n_modes, basis_rpm)
    omega = np.sqrt(np.maximum(w2, 0.0))
    residual = None
    if static_correction:
        m.description += ("; static correction: outputs recovered with the residual "
                          "flexibility of the dropped modes (mode-acceleration method)")
        residual = residual_flexibility(am, free, B, basis_rpm)
    declare_dynamics(m, sp, Omega, sp.M, sp.C, sp.G, sp.K, basis=B, basis_labels=labels,
                     basis_omega=omega, residual=residual)
    return m


def residual_flexibility(model: Model, sp, B: np.ndarray, basis_rpm: float) -> np.ndarray:
    """R = K^-1 - B (B^T K B)^-1 B^T, K the full stiffness at the default
    parameters and the film stiffness at ``basis_rpm`` (the basis' K)."""
    p = model.syms("parameter")
    K = np.array(ca.Function("k", [p, sp.Omega], [sp.K])(model.starts("parameter"),
                                                          basis_rpm * RPM))
    return np.linalg.inv(K) - B @ np.linalg.solve(B.T @ K @ B, B.T)

