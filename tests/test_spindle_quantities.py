"""The spindle's named quantities evaluate to what its equations
use: the element matrices are the Hermite beam's closed forms, the assembled
M, C, G, K are the elements, disks and supports placed, the equations of
motion are M a = F - (C + Omega G) v - K q with exactly those matrices (and
B^T M B ... for the modal model), the support-force formulas are the
outputs, the film layers are (4) and (5)."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import quad

from loomfmu import load_model
from loomfmu.declare.model import Model
from loomfmu.declare.units import UNITS
from loomfmu.export.dae import explicit_ode
from loomfmu.models.spindle import RPM, declare_rotor, spindle_system
from loomfmu.models.spindle_derivation import DEFECTS

SEED_RNG = 20261123


@pytest.fixture(scope="module")
def full():
    return load_model("spindle")


@pytest.fixture(scope="module")
def modal():
    return load_model("spindle_modal")


@pytest.fixture(scope="module")
def analysis():
    """The analysis model (free speed): its rotor's element matrices, numerically."""
    return spindle_system()


def _point(m, rng):
    """Random parameters (defaults scaled by up to +-20 %, cross terms and fill
    drawn in their ranges), inputs and states: dict name -> value."""
    vals = {}
    for v in m.of_kind("parameter"):
        x = v.start * (1 + rng.uniform(-0.2, 0.2))
        vals[v.name] = min(max(x, v.min), v.max)
    vals.update(fill=rng.uniform(0, 1), k_u_xy=0.1 * vals["k_u"] * rng.uniform(-1, 1),
                k_f_xy=0.1 * vals["k_f"] * rng.uniform(-1, 1), c_u_xy=rng.uniform(-5, 5),
                c_f_xy=rng.uniform(-5, 5), phase_b=rng.uniform(-3, 3))
    vals.update(Omega=rng.uniform(2000, 30000) * RPM, e_b=rng.uniform(1e-6, 1e-5),
                e_w=rng.uniform(1e-6, 1e-5))
    for v in m.of_kind("state"):
        vals[v.name] = rng.normal() * (1.0 if v.name == "phi" else
                                       1e-5 if v.unit in ("m", "rad") else 1e-2)
    return vals


def _args(m):
    return [m.syms("state"), m.syms("input"), m.syms("parameter"), m.t]


def _values(m, vals):
    return [[vals[v.name] for v in m.of_kind(k)] for k in ("state", "input", "parameter")] \
        + [0.0]


def quantity(m, name, vals) -> np.ndarray:
    """Quantity ``name`` of model ``m`` evaluated at ``vals``."""
    q = next(q for q in m.quantities if q.name == name)
    f = ca.Function("q", _args(m), [q.expr])
    return np.array(f(*_values(m, vals)))


def scalar(m, name, vals) -> float:
    return quantity(m, name, vals).item()


def _close(a, b, rtol=1e-10):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    assert np.max(np.abs(a - b)) <= rtol * max(np.max(np.abs(b)), 1e-300), (a, b)


def test_element_1_is_the_hermite_beam_in_closed_form(full):
    rng = np.random.default_rng(SEED_RNG)
    v = _point(full, rng)
    Q = {n: quantity(full, n, v) for n in ("l_e", "A_e", "I_e", "K_e", "M_t", "M_r",
                                           "M_r_printed", "G_e", "C_e")}
    l, A, I = (Q[n].item() for n in ("l_e", "A_e", "I_e"))
    d = v["k_d"] * v["d_low"]
    assert l == pytest.approx(v["L_s"] / full.options["n_low"], rel=1e-14)
    assert A == pytest.approx(math.pi * d**2 / 4, rel=1e-14)
    assert I == pytest.approx(math.pi * d**4 / 64, rel=1e-14)
    EI, rA, rI = v["E"] * I, v["rho"] * A, v["rho"] * I
    _close(Q["K_e"], EI / l**3 * np.array([[12, 6 * l, -12, 6 * l],
                                           [6 * l, 4 * l**2, -6 * l, 2 * l**2],
                                           [-12, -6 * l, 12, -6 * l],
                                           [6 * l, 2 * l**2, -6 * l, 4 * l**2]]))
    _close(Q["M_t"], rA * l / 420 * np.array([[156, 22 * l, 54, -13 * l],
                                              [22 * l, 4 * l**2, 13 * l, -3 * l**2],
                                              [54, 13 * l, 156, -22 * l],
                                              [-13 * l, -3 * l**2, -22 * l, 4 * l**2]]))
    Mr = rI / (30 * l) * np.array([[36, 3 * l, -36, 3 * l], [3 * l, 4 * l**2, -3 * l, -l**2],
                                   [-36, -3 * l, 36, -3 * l], [3 * l, -l**2, -3 * l, 4 * l**2]])
    _close(Q["M_r"], Mr)
    _close(Q["G_e"], 2 * Mr)
    _close(Q["C_e"], v["beta"] * Q["K_e"])
    # the printed form (defect S1) differs in entry (4,2) only, and is not symmetric
    diff = Q["M_r_printed"] - Q["M_r"]
    assert np.count_nonzero(diff) == 1 and diff[3, 1] == pytest.approx(2 * rI * l / 30)
    assert Q["M_r_printed"][3, 1] == -Q["M_r_printed"][1, 3] != 0  # not symmetric


def _place(m, sp, analysis, v):
    """M, C, G, K assembled here from the analysis rotor's element matrices,
    the disks and the support quantities, placed by DOF name."""
    am, asp = analysis
    pa = [v[x.name] for x in am.of_kind("parameter")]
    dofs = sp.dofs
    ix = {d: i for i, d in enumerate(dofs)}
    n = len(dofs)
    M, C, G, K = (np.zeros((n, n)) for _ in range(4))
    beta = v["beta"]
    for e in range(len(asp.rotor.elements)):
        Ke, Mt, Mr = (np.array(ca.Function("e", [am.syms("parameter")], [ca.vertcat(
            *[ca.horzcat(*[ca.SX(x) for x in row]) for row in mat])])(pa))
            for mat in asp.rotor.element_matrices(e))
        for plane, other, sign in (("x", "y", 1.0), ("y", "x", -1.0)):
            a = [ix[f"n{e}.{plane}"], ix[f"n{e}.a{plane}"], ix[f"n{e + 1}.{plane}"],
                 ix[f"n{e + 1}.a{plane}"]]
            b = [ix[f"n{e}.{other}"], ix[f"n{e}.a{other}"], ix[f"n{e + 1}.{other}"],
                 ix[f"n{e + 1}.a{other}"]]
            K[np.ix_(a, a)] += Ke
            C[np.ix_(a, a)] += beta * Ke
            M[np.ix_(a, a)] += Mt + Mr
            G[np.ix_(a, b)] += sign * 2 * Mr
    disks = [(sp.nodes["whorl"], v["m_w"], v["Id_w"], v["Ip_w"]),
             (sp.nodes["bobbin"], *(scalar(m, q, v) for q in ("m_bob", "Id_bob",
                                                                         "Ip_bob")))]
    for node, mass, Id, Ip in disks:
        x, y, ax, ay = (ix[f"n{node}.{c}"] for c in ("x", "y", "ax", "ay"))
        M[x, x] += mass
        M[y, y] += mass
        M[ax, ax] += Id
        M[ay, ay] += Id
        G[ax, ay] += Ip
        G[ay, ax] -= Ip
    bol = [ix[f"n{sp.nodes['bolster']}.x"], ix[f"n{sp.nodes['bolster']}.y"]]
    K[np.ix_(bol, bol)] += quantity(m, "K_u", v)
    C[np.ix_(bol, bol)] += quantity(m, "C_u", v)
    foot, h = [ix["n0.x"], ix["n0.y"]], [ix["h0.x"], ix["h0.y"]]
    for mat, name in ((K, "K_f"), (C, "C_f")):
        c1 = quantity(m, name, v)
        mat[np.ix_(foot, foot)] += c1
        mat[np.ix_(h, h)] += c1
        mat[np.ix_(foot, h)] -= c1
        mat[np.ix_(h, foot)] -= c1
    K[np.ix_(h, h)] += scalar(m, "K_2", v) * np.eye(2)
    C[np.ix_(h, h)] += scalar(m, "C_film", v) * np.eye(2)
    M[np.ix_(h, h)] += v["m_p"] * np.eye(2)
    return M, C, G, K


def test_assembled_matrices_are_the_elements_disks_and_supports_placed(full, analysis):
    sp = _probe(full)  # DOF layout only
    rng = np.random.default_rng(SEED_RNG + 1)
    for _ in range(3):
        v = _point(full, rng)
        placed = _place(full, sp, analysis, v)
        for name, mat in zip("MCGK", placed):
            _close(quantity(full, name, v), mat, rtol=1e-12)
    # element 1 of the quantities is the analysis rotor's element 1
    am, asp = analysis
    pa = [v[x.name] for x in am.of_kind("parameter")]
    Ke = ca.Function("k", [am.syms("parameter")], [ca.vertcat(*[ca.horzcat(
        *[ca.SX(x) for x in r]) for r in asp.rotor.element_matrices(0)[0]])])(pa)
    _close(quantity(full, "K_e", v), np.array(Ke))


def _linear_parts(m, v, coords, rates):
    """(a0, A_q, A_v) of the accelerations a = a0 + A_q q + A_v v that the
    model's equations give (exactly linear: columns by unit perturbation)."""
    ode = explicit_ode(m)
    names = [x.name for x in m.of_kind("state")]
    f = ode.function("f", [ode.f], ["f"])
    u = [v[x.name] for x in m.of_kind("input")]
    p = [v[x.name] for x in m.of_kind("parameter")]
    x0 = np.array([v["phi"] if s == "phi" else 0.0 for s in names])
    rows = [names.index(s) for s in rates]

    def acc(x):
        return np.array(f(0.0, x, u, p)).ravel()[rows]

    a0 = acc(x0)
    cols = []
    for group in (coords, rates):
        A = np.zeros((len(rates), len(group)))
        for j, s in enumerate(group):
            x = x0.copy()
            x[names.index(s)] = 1.0
            A[:, j] = acc(x) - a0
        cols.append(A)
    return a0, cols[0], cols[1]


def test_equations_of_motion_use_exactly_M_C_G_K_and_F(full):
    rng = np.random.default_rng(SEED_RNG + 2)
    v = _point(full, rng)
    names = [x.name for x in full.of_kind("state")]
    q = [s for s in names if s != "phi" and ".v" not in s]
    rates = [s for s in names if ".v" in s]
    a0, Aq, Av = _linear_parts(full, v, q, rates)
    M, C, G, K, F = (quantity(full, n, v) for n in ("M", "C", "G", "K", "F"))
    W = v["Omega"]
    _close(M @ Aq, -K, rtol=1e-8)
    _close(M @ Av, -(C + W * G), rtol=1e-8)
    _close(M @ a0, F.ravel(), rtol=1e-8)
    # F is (13): m e Omega^2 (cos, sin)(phi + phase) at the bobbin's and whorl's x, y
    assert np.count_nonzero(F) == 4
    for role, mass, e, ph in (("bobbin", v["m_b"] + v["fill"] * v["m_y"], v["e_b"],
                               v["phase_b"]), ("whorl", v["m_w"], v["e_w"], v["phase_w"])):
        amp, ang = mass * e * W**2, v["phi"] + ph
        assert F.ravel()[_dof(full, role, "x")] == pytest.approx(amp * math.cos(ang),
                                                                 rel=1e-12)
        assert F.ravel()[_dof(full, role, "y")] == pytest.approx(amp * math.sin(ang),
                                                                 rel=1e-12)


def _dof(m, role, comp):
    """Index of the ``role`` node's DOF ``comp`` in q (from the state descriptions)."""
    q = [x for x in m.of_kind("state") if x.name != "phi" and ".v" not in x.name]
    tag = {"bobbin": "bobbin seat", "whorl": "(whorl;", "top": "top of the blade"}[role]
    return next(i for i, x in enumerate(q) if x.name.endswith(f".{comp}")
                and tag in x.description)


def test_modal_matrices_are_the_projection_the_equations_use(modal, full):
    rng = np.random.default_rng(SEED_RNG + 3)
    v = _point(modal, rng)
    B = quantity(modal, "B", v)
    M, C, G, K, F = (quantity(modal, n, v) for n in ("M", "C", "G", "K", "F"))
    Mm, Cm, Gm, Km, Fm = (quantity(modal, n, v) for n in ("M_m", "C_m", "G_m", "K_m",
                                                           "F_m"))
    for red, mat in ((Mm, M), (Cm, C), (Gm, G), (Km, K), (Fm, F)):
        _close(red, B.T @ mat, rtol=1e-12) if red.shape[1] == 1 else \
            _close(red, B.T @ mat @ B, rtol=1e-12)
    r = B.shape[1]
    a0, Aq, Av = _linear_parts(modal, v, [f"eta{i}" for i in range(r)],
                               [f"deta{i}" for i in range(r)])
    W = v["Omega"]
    _close(Mm @ Aq, -Km, rtol=1e-8)
    _close(Mm @ Av, -(Cm + W * Gm), rtol=1e-8)
    _close(Mm @ a0, Fm.ravel(), rtol=1e-8)
    # B's columns are the x-plane modes at the defaults (film at basis_rpm):
    # K_x b = omega^2 M_x b, scaled to 1 at the largest translation
    d = {x.name: x.start for x in modal.variables if x.kind == "parameter"}
    d.update(Omega=modal.options["basis_rpm"] * RPM, phi=0.0, e_b=0.0, e_w=0.0)
    d.update({x.name: 0.0 for x in modal.of_kind("state")})
    M0, K0 = quantity(modal, "M", d), quantity(modal, "K", d)
    w = quantity(modal, "omega_k", d).ravel()
    trans = [i for i, s in enumerate(_dof_names(modal)) if s.endswith(".x")]
    for k in range(r // 2):
        b = B[:, 2 * k]
        _close(K0 @ b, w[k] ** 2 * (M0 @ b), rtol=1e-8)
        assert np.max(np.abs(b[trans])) == pytest.approx(1.0, rel=1e-14)
    assert np.all(np.diff(w) > 0)


@pytest.mark.parametrize("name", ["spindle", "spindle_modal"])
def test_support_force_formulas_are_the_outputs_at_random_states(name, full, modal):
    m = full if name == "spindle" else modal
    ode = explicit_ode(m)
    outs = [x.name for x in m.of_kind("output")]
    g = ode.function("y", [ode.y], ["y"])
    rng = np.random.default_rng(SEED_RNG + 4)
    for _ in range(3):
        v = _point(m, rng)
        x = [v[s.name] for s in m.of_kind("state")]
        y = dict(zip(outs, np.array(g(0.0, x, [v[s.name] for s in m.of_kind("input")],
                                      [v[s.name] for s in m.of_kind("parameter")])).ravel()))
        q, qd = _displacements(m, v)
        sp = _probe(m)
        ix = {s: i for i, s in enumerate(sp.dofs)}
        b = [ix[f"n{sp.nodes['bolster']}.x"], ix[f"n{sp.nodes['bolster']}.y"]]
        Fu = -(quantity(m, "K_u", v) @ q[b] + quantity(m, "C_u", v) @ qd[b])
        hh, f0 = [ix["h0.x"], ix["h0.y"]], [ix["n0.x"], ix["n0.y"]]
        Fl = -(quantity(m, "K_f", v) @ (q[f0] - q[hh]) + quantity(m, "C_f", v)
               @ (qd[f0] - qd[hh]))
        Fd = -(scalar(m, "K_2", v) * q[hh] + scalar(m, "C_film", v) * qd[hh])
        _close([y["F_upper_x"], y["F_upper_y"]], Fu)
        _close([y["F_lower_x"], y["F_lower_y"]], Fl)
        _close(quantity(m, "F_d", v).ravel(), Fd)
        _close(quantity(m, "F_u", v).ravel(), Fu)


def _probe(m):
    """A SpindleRotor with ``m``'s build options (its DOF layout and nodes)."""
    return declare_rotor(Model("probe"), ca.SX.sym("W"), quantities=False, **{
        k: m.options[k] for k in ("beam", "n_turns", "damper", "n_low", "n_cone")})


def _dof_names(m):
    return _probe(m).dofs


def _displacements(m, v):
    """(q, q') of every FE DOF at the states in ``v`` (q = B eta for the modal model)."""
    dofs = _dof_names(m)
    if m.registry_name == "spindle":
        q = np.array([v[d] for d in dofs])
        qd = np.array([v[d.replace(".", ".v")] for d in dofs])
        return q, qd
    B = quantity(m, "B", v)
    r = B.shape[1]
    return B @ [v[f"eta{i}"] for i in range(r)], B @ [v[f"deta{i}"] for i in range(r)]


def test_film_layers_are_formulas_1_to_5(full):
    rng = np.random.default_rng(SEED_RNG + 5)
    v = _point(full, rng)
    n = full.options["n_turns"]
    c, r1, eta, x0, l, d0 = (v[k] for k in ("c_s", "r_s1", "eta", "x0", "l_s", "delta0"))
    r = r1 + c * np.arange(n)
    s = r[:-1].sum()
    eps = 1 - ((n - 1) * c - d0) / c * r / s
    W = v["Omega"]
    IK = [quad(lambda t, e=e: math.cos(t)**2 * math.sin(t) / (1 - e * math.cos(t))**2.28,
               0, math.pi / 2)[0] for e in eps]
    IC = [quad(lambda t, e=e: math.sin(t) * math.cos(t) / (1 - e * math.cos(t))**1.28,
               0, math.pi / 2)[0] for e in eps]
    Ki = 11.9808 * eta * x0 * W * r**5 * l / (c**4 * s**2) * np.array(IK)
    Ci = 9.36 * eta * r**4 * l / (c**3 * s) * np.array(IC)
    _close(quantity(full, "r_i", v).ravel(), r, rtol=1e-14)
    _close(quantity(full, "eps_i0", v).ravel(), eps, rtol=1e-12)
    _close(quantity(full, "J_K", v).ravel(), IK, rtol=1e-9)
    _close(quantity(full, "J_C", v).ravel(), IC, rtol=1e-9)
    _close(quantity(full, "k_i1", v).ravel() * W, Ki, rtol=1e-9)
    _close(quantity(full, "K_i", v).ravel(), Ki, rtol=1e-9)
    _close(quantity(full, "C_i", v).ravel(), Ci, rtol=1e-9)
    _close(quantity(full, "C_i_printed", v).ravel(), Ci / r, rtol=1e-9)  # r^3: defect S3
    k1 = v["E_s"] * v["a_s"]**3 * l / (12 * math.pi * np.sum(r**3))
    assert scalar(full, "k_spring", v) == pytest.approx(k1, rel=1e-13)
    kf = scalar(full, "K_film", v)
    assert kf == pytest.approx(1 / np.sum(1 / Ki), rel=1e-9)
    assert scalar(full, "C_film", v) == pytest.approx(1 / np.sum(1 / Ci), rel=1e-9)
    assert scalar(full, "K_2", v) == pytest.approx(k1 + kf, rel=1e-12)
    # the assembled K holds the housing's support: K_f + K_2 on h0.x
    K = quantity(full, "K", v)
    assert K[0, 0] == pytest.approx(quantity(full, "K_f", v)[0, 0] + k1 + kf,
                                    rel=1e-12)


def test_printed_damper_option_swaps_the_forms_of_5():
    m = load_model("spindle_modal", damper="printed", n_modes=1)
    names = [q.name for q in m.quantities]
    assert "C_i" in names and "C_i_corrected" in names and "C_i_printed" not in names
    v = _point(m, np.random.default_rng(SEED_RNG + 6))
    r = quantity(m, "r_i", v).ravel()
    _close(quantity(m, "C_i", v).ravel() * r, quantity(m, "C_i_corrected", v).ravel(),
           rtol=1e-12)


@pytest.mark.parametrize("name", ["spindle", "spindle_modal"])
def test_every_quantity_is_documented_in_derivation_order(name, full, modal):
    m = full if name == "spindle" else modal
    groups = []
    for q in m.quantities:
        assert q.unit in UNITS or q.unit == "", q.name
        assert q.description and q.symbol and q.source and q.group, q.name
        if not groups or groups[-1] != q.group:
            assert q.group not in groups, f"group {q.group!r} interleaved at {q.name}"
            groups.append(q.group)
    assert groups[0].startswith("beam element") and groups[-1] == "support forces"
    text = " ".join(q.description for q in m.quantities)
    for key, (printed, corrected, _) in DEFECTS.items():
        assert f"print defect {key}: printed {printed}; corrected {corrected}" in text


def test_timoshenko_element_is_przemieniecki_and_tends_to_euler():
    m = load_model("spindle_modal", beam="timoshenko", n_modes=1)
    v = _point(m, np.random.default_rng(SEED_RNG + 7))
    l, A, I = (scalar(m, n, v) for n in ("l_e", "A_e", "I_e"))
    EI = v["E"] * I
    ph = 12 * EI / (v["kappa"] * v["G_shear"] * A * l**2)
    assert 1e-4 < ph < 1  # a short element: shear matters
    Ke = EI / ((1 + ph) * l**3) * np.array(
        [[12, 6 * l, -12, 6 * l], [6 * l, (4 + ph) * l**2, -6 * l, (2 - ph) * l**2],
         [-12, -6 * l, 12, -6 * l], [6 * l, (2 - ph) * l**2, -6 * l, (4 + ph) * l**2]])
    _close(quantity(m, "K_e", v), Ke)
    assert "Timoshenko" in next(q.description for q in m.quantities if q.name == "K_e")
    # with a very stiff shear modulus the element is the Euler-Bernoulli one
    v["G_shear"] = 2e11
    v["kappa"] = 1.0
    ph = 12 * EI / (v["G_shear"] * A * l**2)
    euler = EI / l**3 * np.array([[12, 6 * l, -12, 6 * l], [6 * l, 4 * l**2, -6 * l, 2 * l**2],
                                  [-12, -6 * l, 12, -6 * l], [6 * l, 2 * l**2, -6 * l, 4 * l**2]])
    _close(quantity(m, "K_e", v), euler, rtol=2 * ph)
