"""Spindle D1201 reduced by modal truncation (seed 003; full model: spindle.py).

q = B eta with B the first ``n_modes`` undamped planar mode shapes of the
non-spinning rotor (x plane, at the default parameters and the film
stiffness at ``basis_rpm``), each used in the x and the y plane: 2 n_modes
modal coordinates.  Every matrix stays symbolic: M_r = B^T M(p) B,
K_r = B^T K(p, Omega) B, ... (a Ritz projection), so parameters can still be
changed in the FMU; the basis itself is numeric, computed at build time, and
is exact only at the default parameters.  Same inputs and outputs as
``spindle``.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.linalg as sla

from loomfmu.declare import Model
from loomfmu.models.spindle import RPM, declare_dynamics, declare_rotor, spindle_system


def modal_basis(model: Model, sp, n_modes: int, basis_rpm: float) -> np.ndarray:
    """``model``, ``sp``: from spindle_system (free speed symbol).
    The first n_modes x-plane modes, each placed in x and in y (n x 2 n_modes)."""
    p = model.syms("parameter")
    f = ca.Function("mk", [p, sp.Omega], [sp.M, sp.K])
    M, K = (np.array(a) for a in f(model.starts("parameter"), basis_rpm * RPM))
    xi, yi = sp.plane_indices()
    Mx, Kx = M[np.ix_(xi, xi)], (K[np.ix_(xi, xi)] + K[np.ix_(xi, xi)].T) / 2
    w2, V = sla.eigh(Kx, Mx)
    if n_modes > len(xi):
        raise ValueError(f"n_modes = {n_modes!r}; allowed: 1..{len(xi)}")
    B = np.zeros((M.shape[0], 2 * n_modes))
    for k in range(n_modes):
        B[xi, 2 * k] = V[:, k]
        B[yi, 2 * k + 1] = V[:, k]
    return B


def build(*, n_modes: int = 4, basis_rpm: float = 16000.0, beam: str = "euler",
          n_turns: int = 4, damper: str = "corrected", n_low: int = 2,
          n_cone: int = 4) -> Model:
    """The modal spindle; n_modes planar modes (>= 1) kept in each plane."""
    if not (isinstance(n_modes, int) and n_modes >= 1):
        raise ValueError(f"n_modes = {n_modes!r}; allowed: integer >= 1")
    m = Model("spindle_modal", description="D1201 ring-spinning spindle reduced to "
              f"{n_modes} planar modes per plane (Ritz projection of the FE rotor of "
              "seed 003)", stop_time=0.02, step_size=2e-4, h_fixed=2e-6,
              options={"n_modes": n_modes, "basis_rpm": basis_rpm, "beam": beam,
                       "n_turns": n_turns, "damper": damper, "n_low": n_low,
                       "n_cone": n_cone})
    n_rpm = m.input("n_rpm", 16000.0, unit="rpm", description="spin speed, from the drive",
                    min=0.0, max=40000.0)
    Omega = n_rpm * RPM
    sp = declare_rotor(m, Omega, beam=beam, n_turns=n_turns, damper=damper,
                       n_low=n_low, n_cone=n_cone)
    am, free = spindle_system(beam=beam, n_turns=n_turns, damper=damper, n_low=n_low,
                              n_cone=n_cone)
    B = modal_basis(am, free, n_modes, basis_rpm)
    declare_dynamics(m, sp, Omega, sp.M, sp.C, sp.G, sp.K, basis=B)
    return m

