"""Start values that put a spindle FMU on its periodic (steady unbalance) solution.

At a constant spin speed w the unbalance forces (13) of seed 003 are
F = P1 sin wt + P2 cos wt, and the steady response is q = A1 sin wt + A2 cos wt
with A1, A2 from (15).  Started with q(0) = A2 and q'(0) = w A1 (and the
rotation angle phi(0) that the forces were written for), the FMU has no
transient: the spindle runs on the periodic solution from t = 0.  Without it,
the lightly damped first mode (1.7 % with the default film, 31 Hz) rings
with a decay time 1/(zeta w1) of about 0.3 s, i.e. seconds to die out.

    from loomfmu.spindle.start import periodic_start
    start = periodic_start("spindle_modal", n_rpm=16000.0)
    scene.add("spindle", model="spindle_modal", start=start)    # loomfmu.scene
    fmpy.simulate_fmu(path, start_values={**start, "Omega": 16000.0 * RPM})  # rad/s

For ``spindle_modal`` the periodic solution is that of the reduced
(Ritz-projected) equations, so it is exact for that FMU too.
"""
from __future__ import annotations

import inspect
import math

import casadi as ca
import numpy as np

from loomfmu.declare.checks import check_choice, check_int, check_mapping, check_number
from loomfmu.spindle.analysis import RPM, unbalance_response

#: models this module knows, and the build options that are not the rotor's
#: (static_correction changes only how the outputs are recovered, not the states)
MODELS = {"spindle": (), "spindle_modal": ("n_modes", "basis_rpm", "static_correction")}
#: parameters of the unbalance forcing (declared by models/spindle.py's
#: unbalance_force, not by the rotor)
PHASES = ("phase_b", "phase_w")
#: limits of the spin speed (rpm; the FMU's input Omega in rad/s) and of
#: the FMU's inputs e_b, e_w (m)
MAX_RPM, MAX_ECC = 40000.0, 1e-3


def periodic_start(model: str = "spindle", *, n_rpm: float, e_b: float = 5e-6,
                   e_w: float = 5e-6, parameters: dict | None = None,
                   options: dict | None = None, phi0: float = 0.0) -> dict[str, float]:
    """Start values {state name: value} on the periodic solution of (15).

    model: "spindle" or "spindle_modal".  n_rpm: the constant spin speed
    (rpm, 0 ... 40000) the FMU will run at (its input ``Omega`` =
    n_rpm 2 pi / 60 in rad/s, shown in rpm).  e_b, e_w:
    eccentricities of the bobbin and the whorl (m, 0 ... 1e-3; the FMU's
    inputs of those names, default their start values).  parameters: the
    FMU's parameters that differ from their defaults (the rotor's, e.g.
    ``fill`` or ``eta``, and ``phase_b``, ``phase_w``).  options: the build
    options the FMU was made with (as for ``load_model`` or
    ``Scene.add(options=...)``).  phi0: start of the rotation angle ``phi``
    (rad).

    Returns every state: ``phi`` and the DOF and rates of the full model
    (``n3.x``, ``n3.vx``, ``h0.x``, ...) or the modal coordinates and rates
    (``eta0``, ``deta0``, ...).  The inputs Omega, e_b, e_w are the caller's
    to set (to the values given here): in a scene they come from other
    components.
    """
    from loomfmu.models.spindle import declare_rotor, spindle_system
    from loomfmu.models.spindle_modal import MAX_MODES, modal_basis

    model = check_choice("model", model, tuple(MODELS))
    n_rpm = check_number("n_rpm", n_rpm, lo=0.0, hi=MAX_RPM, unit="rpm")
    e_b = check_number("e_b", e_b, lo=0.0, hi=MAX_ECC, unit="m")
    e_w = check_number("e_w", e_w, lo=0.0, hi=MAX_ECC, unit="m")
    phi0 = check_number("phi0", phi0, unit="rad")
    rotor_opts = [p.name for p in inspect.signature(declare_rotor).parameters.values()
                  if p.kind is inspect.Parameter.KEYWORD_ONLY and p.name != "bobbin_node"]
    options = check_mapping("options", options, rotor_opts + list(MODELS[model]),
                            what=f"build options of {model}", numbers_only=False)
    m, sp = spindle_system(**{k: v for k, v in options.items() if k in rotor_opts})
    names = [v.name for v in m.of_kind("parameter")]
    values = check_mapping("parameters", parameters, names + list(PHASES),
                           what=f"parameters of {model}")
    for name, value in values.items():
        if name in PHASES:
            check_number(f"parameters[{name!r}]", value, lo=-10.0, hi=10.0, unit="rad")
        else:
            m.var(name).check_value(value)
    p = {**dict(zip(names, m.starts("parameter"))), **values}
    w = n_rpm * RPM
    f = ca.Function("mats", [m.syms("parameter"), sp.Omega], [sp.M, sp.C, sp.G, sp.K])
    M, C, G, K = (np.array(a) for a in f([p[n] for n in names], w))
    P1, P2 = unbalance_amplitudes(sp, p, w, e_b, e_w, phi0)
    if model == "spindle":
        A1, A2 = unbalance_response(M, C + w * G, K, w, P1, P2)
        start = {"phi": phi0}
        for i, d in enumerate(sp.dofs):
            node, comp = d.split(".")
            start[d] = float(A2[i])
            start[f"{node}.v{comp}"] = float(w * A1[i])
        return start
    n_modes = check_int("options['n_modes']", options.get("n_modes", 4), lo=1, hi=MAX_MODES)
    basis_rpm = check_number("options['basis_rpm']", options.get("basis_rpm", 16000.0),
                             lo=0.0, hi=MAX_RPM, unit="rpm")
    B = modal_basis(m, sp, n_modes, basis_rpm)
    A1, A2 = unbalance_response(B.T @ M @ B, B.T @ (C + w * G) @ B, B.T @ K @ B, w,
                                B.T @ P1, B.T @ P2)
    start = {"phi": phi0}
    start.update({f"eta{i}": float(a) for i, a in enumerate(A2)})
    start.update({f"deta{i}": float(w * a) for i, a in enumerate(A1)})
    return start


def unbalance_amplitudes(sp, p: dict, w: float, e_b: float, e_w: float, phi0: float = 0.0):
    """(P1, P2) of (13), F = P1 sin wt + P2 cos wt, for the forces of
    models/spindle.py's unbalance_force with phi = phi0 + w t:
    F_x = m e w^2 cos(phi + phase), F_y = m e w^2 sin(phi + phase) at the
    bobbin's and the whorl's node.  sp: a SpindleRotor; p: parameter values."""
    n = len(sp.dofs)
    P1, P2 = np.zeros(n), np.zeros(n)
    masses = {"bobbin": p["m_b"] + p["fill"] * p["m_y"], "whorl": p["m_w"]}
    for role, e, ph in (("bobbin", e_b, p.get("phase_b", 0.0)),
                        ("whorl", e_w, p.get("phase_w", 0.0))):
        node, amp, a = sp.nodes[role], masses[role] * e * w**2, phi0 + ph
        ix, iy = sp.idx(f"n{node}.x"), sp.idx(f"n{node}.y")
        # cos(wt + a) = cos a cos wt - sin a sin wt; sin(wt + a) = sin a cos wt + cos a sin wt
        P2[ix] += amp * math.cos(a)
        P1[ix] -= amp * math.sin(a)
        P2[iy] += amp * math.sin(a)
        P1[iy] += amp * math.cos(a)
    return P1, P2
