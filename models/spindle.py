"""Ring-spinning spindle D1201 as a finite-element rotor (seed 003).

Source: seed 003 (Yang, Liu, "Dynamic analysis of spindle"): FE rotor with
gyroscopic terms, 8-coefficient upper (bolster) and lower (footstep)
supports, the lower support as bearing + housing (fig. 4), the coil-spring
squeeze-film damper (1)-(5), equation of motion (12), unbalance forcing (13).

Mesh (z up from the footstep): ``n_low`` elements between the footstep
(node 0, lower support) and the bolster bearing (upper support), one
element up to the whorl, ``n_cone`` stepped elements for the blade's cone up
to its top.  Bobbin (tube + yarn, ``fill`` 0 empty .. 1 full) and whorl are
rigid disks.  The housing of the lower support (the centre tube on the coil
spring) has its own x, y DOF.  The D1201 geometry is not in the seed: every
dimension is an assumption (docs/guides/spindle.md), the unknown support
and bobbin values are calibrated (``loomfmu rotor calibrate``).

Print defects (docs/guides/spindle.md, S1-S5): the rotary-inertia matrix's
(4,2) entry is -l^2 (printed l^2); (2), (3) read K_xy = K_yx = 0; (5) has
r_i^4 (printed r_i^3, unit Pa s; ``damper="printed"`` keeps it); (20) gives
q, not q'.  Printed form, corrected form and reason of each are written
once, in models/spindle_derivation.py (DEFECTS), and shown next to the
derivation's quantities they affect (``loomfmu inspect spindle``).

The equations are written in first-order form, der(q) = v and der(v) = a,
where a solves M a = F - (C + Omega G) v - K q by a banded symbolic LDL^T
(loomfmu.mechanics.rotor.band_ldl_solve): M stays symbolic in every parameter, and the
right-hand side grows as n bw^2 instead of the n^3 of a dense symbolic solve.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from loomfmu.declare.checks import check_choice, check_int
from loomfmu.declare.model import Model
from loomfmu.mechanics.rotor import (
    Rotor,
    band_ldl_solve,
    circle_section,
    coil_spring_stiffness,
    film_eccentricities,
    film_layer_damping,
    film_layer_stiffness,
    isotropic,
    series_sum,
    spring_radii,
)
from loomfmu.models.spindle_derivation import (
    force_quantities,
    mesh_svg,
    modal_quantities,
    rotor_quantities,
    unbalance_quantity,
)

SEED = "seed 003"
RPM = 2 * math.pi / 60
ASSUME_GEOM = ("assumption: D1201 geometry is not in the seed; typical ring-spinning "
               "spindle of the D12 family (7.8 mm blade at the bolster)")
CALIB = "calibrated: loomfmu rotor calibrate (seed 003, natural frequencies)"

#: Calibrated values (written by ``loomfmu rotor calibrate``; see
#: docs/results/spindle_calibration.md).  Keys are parameter names.
CALIBRATED = {
    "E_t": 3.949e9,
    "k_u": 1.299e7,
    "k_f": 2.477e6,
    "a_s": 5.853e-4,
    "m_b": 0.0100,
    "Id_b": 3.437e-5,
    "m_y": 0.1370,
    "Id_y": 2.543e-4,
    "m_p": 0.02274,
    "L_s": 0.0500,
}


@dataclass
class SpindleRotor:
    """The symbolic spindle: matrices in the parameters and spin speed."""

    rotor: Rotor
    M: ca.SX
    C: ca.SX
    G: ca.SX
    K: ca.SX
    Omega: ca.SX
    nodes: dict          # role -> node index (footstep, bolster, whorl, bobbin, top)
    dofs: list[str]
    p: dict              # parameter name -> SX
    unbalance_mass: dict  # "bobbin"/"whorl" -> mass expression (kg)
    support: dict = field(default_factory=dict)  # the supports' pieces, by symbol

    def idx(self, name: str) -> int:
        return self.dofs.index(name)

    def plane_indices(self):
        """(x DOF, y DOF) index lists, paired (translations and slopes)."""
        xs = [i for i, d in enumerate(self.dofs) if d.endswith(".x") or d.endswith(".ax")]
        ys = [i for i, d in enumerate(self.dofs) if d.endswith(".y") or d.endswith(".ay")]
        return xs, ys


def declare_rotor(m: Model, Omega: ca.SX, *, beam: str = "euler", n_turns: int = 4,
                  damper: str = "corrected", n_low: int = 2, n_cone: int = 4,
                  bobbin_node: int | None = None, quantities: bool = True) -> SpindleRotor:
    """Declare the spindle's parameters on ``m`` and assemble its matrices.

    Omega: spin speed (rad/s), an SX expression (the FMU's input, or a free
    symbol for the analyses).  beam: "euler" or "timoshenko".  n_turns: coil
    spring turns (>= 2).  damper: "corrected" or "printed" form of (5).
    n_low, n_cone: elements below the bolster and along the cone (>= 1).
    bobbin_node: node of the bobbin's equivalent disk (default: the cone
    node nearest 0.5 L_up above the whorl).  quantities: keep the
    derivation's named quantities on ``m`` (element, supports, assembly;
    models/spindle_derivation.py); needs Omega to be an expression of m's
    variables.
    """
    check_choice("beam", beam, ("euler", "timoshenko"))
    check_choice("damper", damper, ("corrected", "printed"))
    # upper bounds: assumption, they keep the generated C compilable in about a
    # minute (the default mesh, 2 + 4 elements, gives 69 states and 1 MB of C)
    check_int("n_turns", n_turns, lo=2, hi=40)
    check_int("n_low", n_low, lo=1, hi=8)
    check_int("n_cone", n_cone, lo=1, hi=16)
    P = m.parameter
    cal = CALIBRATED
    p = {}

    def par(name, value, unit, description, source, lo, hi):
        p[name] = P(name, value, unit=unit, description=description, source=source,
                    min=lo, max=hi)
        return p[name]

    # -- blade ------------------------------------------------------------------
    E = par("E", 2.06e11, "Pa", "Young's modulus of the blade (steel)",
            "assumption: spindle blades are hardened carbon or bearing steel", 1e10, 5e11)
    rho = par("rho", 7850.0, "kg/m3", "density of the blade", "assumption: steel",
              1000.0, 20000.0)
    G_sh = par("G_shear", 7.9e10, "Pa", "shear modulus of the blade (Timoshenko option)",
               "assumption: steel, nu = 0.3", 1e9, 2e11)
    kappa = par("kappa", 0.886, "", "shear coefficient of the solid circular section",
                "assumption: Cowper 6(1+nu)/(7+6 nu) at nu = 0.3", 0.5, 1.0)
    L_s = par("L_s", cal["L_s"], "m", "distance between the supports (footstep to "
              "bolster bearing)", CALIB + "; searched in 50..120 mm", 0.02, 0.2)
    L_w = par("L_w", 0.016, "m", "bolster bearing to the whorl's centre", ASSUME_GEOM,
              0.002, 0.06)
    L_up = par("L_up", 0.190, "m", "whorl's centre to the top of the blade", ASSUME_GEOM,
               0.05, 0.4)
    d_low = par("d_low", 0.0060, "m", "blade diameter between the supports", ASSUME_GEOM,
                0.002, 0.02)
    d_bol = par("d_bol", 0.0078, "m", "blade diameter at the bolster and the whorl",
                ASSUME_GEOM, 0.003, 0.02)
    d_top = par("d_top", 0.0045, "m", "blade diameter at the top (end of the cone)",
                ASSUME_GEOM, 0.001, 0.02)
    k_d = par("k_d", 1.0, "", "factor on every blade diameter (seed 003, section V.3)",
              SEED + ", section V.3 (blade diameter study)", 0.3, 3.0)
    beta = par("beta", 2e-6, "s", "stiffness-proportional structural damping of the blade",
               "assumption: seed gives none; 0.3 % at 500 Hz keeps blade modes decaying",
               0.0, 1e-3)
    # -- whorl and bobbin (rigid disks) ---------------------------------------------
    m_w = par("m_w", 0.025, "kg", "whorl mass", ASSUME_GEOM + " (24 mm aluminium whorl)",
              0.001, 0.5)
    Id_w = par("Id_w", 3.0e-6, "kg.m2", "whorl diametral moment of inertia", ASSUME_GEOM,
               0.0, 1e-3)
    Ip_w = par("Ip_w", 2.0e-6, "kg.m2", "whorl polar moment of inertia", ASSUME_GEOM,
               0.0, 1e-3)
    m_b = par("m_b", cal["m_b"], "kg", "empty bobbin (tube) mass", CALIB, 0.001, 0.5)
    Id_b = par("Id_b", cal["Id_b"], "kg.m2", "empty bobbin diametral moment of inertia "
               "about its centre", CALIB, 0.0, 1e-2)
    Ip_b = par("Ip_b", 3.0e-6, "kg.m2", "empty bobbin polar moment of inertia",
               "assumption: the geometric estimate m (r_i^2 + r_o^2) / 2 of a 30 g tube, "
               "radii 9/11 mm, kept while the calibration fits m_b and Id_b as effective "
               "values (m_b came out at its 10 g bound; the seed gives neither); Ip_b "
               "enters only the gyroscopic terms", 0.0, 1e-3)
    m_y = par("m_y", cal["m_y"], "kg", "yarn mass on the full bobbin", CALIB, 0.0, 1.0)
    Id_y = par("Id_y", cal["Id_y"], "kg.m2", "yarn package diametral moment of inertia",
               CALIB, 0.0, 1e-2)
    Ip_y = par("Ip_y", 2.1e-5, "kg.m2", "yarn package polar moment of inertia",
               "assumption: the geometric estimate m (r_i^2 + r_o^2) / 2 of a 75 g "
               "package, radii 11/21 mm, kept while the calibration fits m_y and Id_y as "
               "effective values (m_y came out at 137 g; the seed gives neither); Ip_y "
               "enters only the gyroscopic terms", 0.0, 1e-3)
    E_t = par("E_t", cal["E_t"], "Pa", "effective Young's modulus of the bobbin tube "
              "pressed on the blade's cone: its bending stiffness E_t I_t adds to the "
              "cone's (the seed's 当量转子, equivalent rotor)", CALIB, 0.0, 2e11)
    d_t = par("d_t", 0.022, "m", "bobbin tube outer diameter", "assumption: ring-spinning "
              "tube near the whorl", 0.005, 0.06)
    d_ti = par("d_ti", 0.018, "m", "bobbin tube inner diameter", "assumption: 2 mm wall",
               0.0, 0.05)
    EI_t = E_t * circle_section(d_t, d_ti)[1]
    fill = par("fill", 0.0, "", "bobbin fill: 0 empty (空锭), 1 full (满管)",
               SEED + ", section V.1 (empty and full bobbin)", 0.0, 1.0)
    # -- upper support: bolster bearing (8 coefficients) ----------------------------
    k_u = par("k_u", cal["k_u"], "N/m", "bolster bearing stiffness k_xx = k_yy", CALIB,
              1e3, 1e10)
    k_u_xy = par("k_u_xy", 0.0, "N/m", "bolster bearing cross stiffness k_xy = -k_yx",
                 "assumption: rolling bearing, no cross-coupling", -1e9, 1e9)
    c_u = par("c_u", 30.0, "N.s/m", "bolster bearing damping c_xx = c_yy",
              "assumption: seed gives none; lightly damped rolling bearing", 0.0, 1e6)
    c_u_xy = par("c_u_xy", 0.0, "N.s/m", "bolster bearing cross damping c_xy = -c_yx",
                 "assumption: none", -1e6, 1e6)
    # -- lower support: footstep film (bearing) + housing on the coil spring ----------
    k_f = par("k_f", cal["k_f"], "N/m", "footstep film stiffness k_xx = k_yy (bearing of "
              "fig. 4)", CALIB, 1e3, 1e10)
    k_f_xy = par("k_f_xy", 0.0, "N/m", "footstep film cross stiffness k_xy = -k_yx",
                 "assumption: seed computes it by the matrix method of [6], not given",
                 -1e9, 1e9)
    c_f = par("c_f", 20.0, "N.s/m", "footstep film damping c_xx = c_yy",
              "assumption: seed's value (matrix method of [6]) is not given", 0.0, 1e6)
    c_f_xy = par("c_f_xy", 0.0, "N.s/m", "footstep film cross damping c_xy = -c_yx",
                 "assumption: none", -1e6, 1e6)
    m_p = par("m_p", cal["m_p"], "kg", "participating mass of the support housing "
              "(centre tube), fig. 4", CALIB, 1e-4, 1.0)
    E_s = par("E_s", 2.06e11, "Pa", "Young's modulus of the coil spring", "assumption: "
              "spring steel", 1e10, 5e11)
    a_s = par("a_s", cal["a_s"], "m", "coil spring strip thickness a of (1)", CALIB,
              5e-5, 2e-3)
    l_s = par("l_s", 0.025, "m", "coil spring (strip) width l of (1), (4), (5)",
              "assumption: 25 mm spring in the bolster", 0.002, 0.1)
    r_s1 = par("r_s1", 0.0075, "m", "radius of the coil spring's inner turn",
               "assumption: around a 15 mm centre tube", 0.002, 0.05)
    c_s = par("c_s", 0.0005, "m", "radial pitch c = r_{i+1} - r_i, the film clearance "
              "of (4), (5)", "assumption: " + SEED + " defines c = r_{i+1} - r_i", 1e-5, 0.005)
    eta = par("eta", 0.02, "", "dynamic viscosity of the spindle oil "
              "(Pa s)", "assumption: spindle oil near ISO VG 22 at 40 C", 1e-4, 1.0)
    x0 = par("x0", 2e-5, "m", "steady whirl amplitude x_0 in the film stiffness (4)",
             "assumption: of the order of the computed bottom amplitude", 1e-7, 1e-3)
    delta0 = par("delta0", 1e-4, "m", "radial initial displacement of the spring under "
                 "the tape tension", "assumption: tape pull 10 N on a few 1e5 N/m", 0.0, 1e-3)

    # -- the rotor ------------------------------------------------------------------------
    timo = beam == "timoshenko"
    r = Rotor(E, rho, G_sh, kappa, timoshenko=timo, structural_damping=beta)
    for _ in range(n_low):
        r.element(L_s / n_low, k_d * d_low)
    bolster = r.n_nodes - 1
    whorl = r.element(L_w, k_d * d_bol)
    for i in range(n_cone):
        zc = (i + 0.5) / n_cone
        r.element(L_up / n_cone, k_d * (d_bol + (d_top - d_bol) * zc), 0.0, EI_t)
    top = r.n_nodes - 1
    if bobbin_node is None:
        bobbin_node = whorl + max(1, round(n_cone / 2))
    if not whorl < bobbin_node <= top:
        raise ValueError(f"bobbin_node = {bobbin_node!r}; allowed: {whorl + 1}..{top}")
    r.disk(whorl, m_w, Id_w, Ip_w)
    r.disk(bobbin_node, m_b + fill * m_y, Id_b + fill * Id_y, Ip_b + fill * Ip_y)
    sup = {"K_u": isotropic(k_u, k_u_xy), "C_u": isotropic(c_u, c_u_xy),
           "K_f": isotropic(k_f, k_f_xy), "C_f": isotropic(c_f, c_f_xy),
           "radii": spring_radii(r_s1, c_s, n_turns), "damper": damper, "Omega": Omega}
    r.spring(bolster, sup["K_u"], sup["C_u"])
    sup["eps"] = film_eccentricities(sup["radii"], c_s, delta0)
    sup["k_spring"] = coil_spring_stiffness(E_s, a_s, l_s, sup["radii"])
    # (4) is proportional to the speed: the layers at omega = 1 (N/m per rad/s),
    # in series, times Omega (so Omega = 0 gives 0, not 1/inf)
    sup["K_i1"] = film_layer_stiffness(eta, x0, 1.0, sup["radii"], l_s, c_s, delta0)
    for form in ("corrected", "printed"):
        sup[f"C_i_{form}"] = film_layer_damping(eta, sup["radii"], l_s, c_s, delta0, form)
    sup["k_film"] = Omega * series_sum(sup["K_i1"])
    sup["c_film"] = series_sum(sup[f"C_i_{damper}"])
    r.housing(0, m_p, sup["K_f"], sup["C_f"], isotropic(sup["k_spring"] + sup["k_film"]),
              isotropic(sup["c_film"]))
    M, C, G, K = r.assemble()
    nodes = {"footstep": 0, "bolster": bolster, "whorl": whorl, "bobbin": bobbin_node,
             "top": top}
    sp = SpindleRotor(r, M, C, G, K, Omega, nodes, r.dof_names(), p,
                      {"bobbin": m_b + fill * m_y, "whorl": m_w}, sup)
    if quantities:
        rotor_quantities(m, sp)
        lay = mesh_layout(m, sp)
        m.figure("mesh", mesh_svg(lay), caption=(
            f"The finite-element mesh the model is built on, drawn from its own node heights "
            f"and element diameters at the default parameters (diameters {6:g} times the "
            f"length scale): {len(lay['z'])} nodes n0 ... n{len(lay['z']) - 1} (each with "
            f"x, y and the slopes ax, ay), {len(lay['d'])} "
            f"{'Timoshenko' if timo else 'Euler-Bernoulli'} beam elements "
            f"e1 ... e{len(lay['d'])} ({n_low} from the footstep to the bolster "
            f"bearing over L_s, one to the whorl over L_w, {n_cone} stepped ones along the "
            "blade's cone over L_up); rigid disks for the whorl and the bobbin (tube and "
            "yarn, by fill); the bolster bearing (upper support) with 8 coefficients to "
            "the frame; the footstep bearing film (k_f, c_f) to the housing, a mass with "
            f"its own x, y on the coil spring with {n_turns} turns and the squeeze-film "
            "layers between them (seed 003, fig. 4 and (1)-(5)). The seed gives no "
            "D1201 dimensions: lengths and diameters are the model's assumptions."))
    return sp


def mesh_layout(m: Model, sp: SpindleRotor) -> dict:
    """The mesh of ``sp`` at the default parameters of ``m``, for its drawing:
    node heights ``z`` (m), element diameters ``d`` (m), node roles, the disk,
    support and housing nodes, the element spans and the film layers."""
    rotor = sp.rotor
    f = ca.Function("mesh", [m.syms("parameter")],
                    [ca.vertcat(*[ca.SX(v) for v in rotor.node_z()]),
                     ca.vertcat(*[ca.SX(e[1]) for e in rotor.elements])])
    z, d = (np.asarray(v.full()).ravel().tolist() for v in f(m.starts("parameter")))
    nodes = sp.nodes
    roles = {nodes["footstep"]: "footstep", nodes["bolster"]: "bolster bearing",
             nodes["whorl"]: "whorl", nodes["top"]: "top of the blade"}
    roles[nodes["bobbin"]] = "bobbin seat" + (", top of the blade"
                                              if nodes["bobbin"] == nodes["top"] else "")
    return {"z": z, "d": d, "roles": roles, "whorl": nodes["whorl"],
            "bobbin": nodes["bobbin"], "bolster": rotor.springs[0][0],
            "housing": rotor.housings[0][0], "layers": len(sp.support["K_i1"]),
            "n_low": nodes["bolster"], "n_cone": nodes["top"] - nodes["whorl"],
            "span_low": (0, nodes["bolster"]), "span_w": (nodes["bolster"], nodes["whorl"]),
            "span_up": (nodes["whorl"], nodes["top"])}


def spindle_system(**options):
    """(Model with the parameters only, SpindleRotor with a free Omega) for the analyses."""
    m = Model("spindle", description="spindle rotor (analysis)")
    Omega = ca.SX.sym("Omega")
    return m, declare_rotor(m, Omega, quantities=False, **options)


def node_heights(m: Model, sp: SpindleRotor) -> list[float]:
    """Height of each node above the footstep (m) at the declared (default)
    parameter values of ``m``."""
    z = ca.vertcat(*[ca.SX(v) for v in sp.rotor.node_z()])
    f = ca.Function("node_z", [m.syms("parameter")], [z])
    return [float(v) for v in f(m.starts("parameter")).full().ravel()]


def node_labels(m: Model, sp: SpindleRotor) -> dict[str, tuple[str, str]]:
    """DOF prefix ("n3", "h0") -> (where the node is: role and height at the
    default lengths; a short tag), for the states' descriptions."""
    z = node_heights(m, sp)
    role = {k: r for r, k in sp.nodes.items()}
    text = {"footstep": ("footstep, lower support", "footstep"),
            "bolster": ("bolster bearing, upper support", "bolster bearing"),
            "whorl": ("whorl", "whorl"),
            "bobbin": ("bobbin seat, the bobbin's equivalent disk", "bobbin seat"),
            "top": ("top of the blade", "top of the blade")}
    out = {}
    for k, zk in enumerate(z):
        if k in role:
            what, tag = text[role[k]]
        else:
            what = tag = ("interior node below the bolster" if k < sp.nodes["bolster"]
                          else "interior node on the cone")
        out[f"n{k}"] = (f"node {k} ({what}; z = {zk * 1e3:.1f} mm up from the footstep at "
                        "the default lengths)", f"{tag}, node {k}")
    for h, (node, *_rest) in enumerate(sp.rotor.housings):
        out[f"h{h}"] = (f"the housing of the footstep bearing (centre tube on the coil "
                        f"spring) at node {node}", f"housing at node {node}")
    return out


def _vel_name(dof: str) -> str:
    node, comp = dof.split(".")
    return f"{node}.v{comp}"


_DOF_TEXT = {"x": "x displacement", "y": "y displacement", "ax": "slope dx/dz",
             "ay": "slope dy/dz"}
_DOF_UNIT = {"x": "m", "y": "m", "ax": "rad", "ay": "rad"}


def build(*, beam: str = "euler", n_turns: int = 4, damper: str = "corrected",
          n_low: int = 2, n_cone: int = 4) -> Model:
    """The time-domain spindle: FE rotor under unbalance at a driven speed."""
    m = Model("spindle", description="D1201 ring-spinning spindle: FE rotor with "
              "gyroscopic terms, bolster and footstep supports, coil-spring squeeze-film "
              "damper, unbalance of bobbin and whorl (seed 003)",
              stop_time=0.02, step_size=2e-4, h_fixed=2e-6,
              options={"beam": beam, "n_turns": n_turns, "damper": damper,
                       "n_low": n_low, "n_cone": n_cone})
    Omega = m.input("Omega", 16000.0 * RPM, unit="rad/s", display_unit="rpm",
                    description="spin speed, from the drive (default 16 000 rpm)",
                    min=0.0, max=40000.0 * RPM)
    sp = declare_rotor(m, Omega, beam=beam, n_turns=n_turns, damper=damper,
                       n_low=n_low, n_cone=n_cone)
    declare_dynamics(m, sp, Omega, sp.M, sp.C, sp.G, sp.K)
    return m


def unbalance_force(m: Model, sp: SpindleRotor, Omega, phi) -> ca.SX:
    """Force vector (13) of the bobbin's and the whorl's unbalance; declares the
    eccentricity inputs and phase parameters on ``m``."""
    e_b = m.input("e_b", 5e-6, unit="m", description="mass-centre eccentricity of the "
                  "bobbin (unbalance m e Omega^2)", min=0.0, max=1e-3)
    e_w = m.input("e_w", 5e-6, unit="m", description="mass-centre eccentricity of the "
                  "whorl", min=0.0, max=1e-3)
    ph_b = m.parameter("phase_b", 0.0, unit="rad", description="angular position of the "
                       "bobbin's unbalance", source="assumption: in phase with the whorl's",
                       min=-10.0, max=10.0)
    ph_w = m.parameter("phase_w", 0.0, unit="rad", description="angular position of the "
                       "whorl's unbalance", source="assumption: reference angle",
                       min=-10.0, max=10.0)
    F = ca.SX.zeros(len(sp.dofs))
    for role, e, ph in (("bobbin", e_b, ph_b), ("whorl", e_w, ph_w)):
        node = sp.nodes[role]
        amp = sp.unbalance_mass[role] * e * Omega**2
        F[sp.idx(f"n{node}.x")] += amp * ca.cos(phi + ph)
        F[sp.idx(f"n{node}.y")] += amp * ca.sin(phi + ph)
    unbalance_quantity(m, F)
    return F


def declare_dynamics(m: Model, sp: SpindleRotor, Omega, M, C, G, K, basis=None,
                     basis_labels: list[str] | None = None, basis_omega=None,
                     residual=None) -> None:
    """States, equations (12) and outputs.  ``basis`` (numeric n x r) makes a
    Ritz reduction q = basis eta (spindle_modal); None keeps every FE DOF.
    basis_labels: what each basis column is (e.g. its mode and frequency),
    for the states' descriptions; basis_omega: the natural frequencies
    (rad/s) of the basis' planar modes, for the derivation's quantities.
    residual (numeric n x n, with a basis): the residual flexibility R of the
    dropped modes; the outputs then use q = B eta + R F, v = B eta' + R F'
    (mode-acceleration recovery; the reduced dynamics are unchanged)."""
    phi = m.state("phi", 0.0, unit="rad", description="rotation angle of the spindle "
                  "(phase of the unbalance forces)")
    m.eq(m.der(phi), Omega)
    F = unbalance_force(m, sp, Omega, phi)
    if basis is None:
        where = node_labels(m, sp)
        q = ca.vertcat(*[m.state(d, 0.0, unit=_DOF_UNIT[d.split('.')[1]], nominal=1e-4,
                                 description=f"{_DOF_TEXT[d.split('.')[1]]} of "
                                 f"{where[d.split('.')[0]][0]}") for d in sp.dofs])
        v = ca.vertcat(*[m.state(_vel_name(d), 0.0, unit=_DOF_UNIT[d.split('.')[1]] + "/s",
                                 nominal=0.1, description=f"rate of {d} "
                                 f"({where[d.split('.')[0]][1]})") for d in sp.dofs])
        a = band_ldl_solve(M, F - (C + Omega * G) @ v - K @ q)
        qv, vv = q, v
    else:
        r = basis.shape[1]
        B = ca.DM(basis)
        labels = basis_labels or [f"basis vector {i}" for i in range(r)]
        if len(labels) != r:
            raise ValueError(f"basis_labels: {len(labels)} labels; allowed: one per basis "
                             f"column ({r})")
        # nominals (the scale an importer's absolute tolerance takes, rtol x
        # nominal): assumption, the modal coordinates' typical size; over the
        # default experiment they stay between 3e-9 and 2e-5 m, their rates
        # between 2e-5 and 7e-3 m/s (the scipy reference at rtol 1e-11)
        eta_ = ca.vertcat(*[m.state(f"eta{i}", 0.0, unit="m", nominal=1e-6,
                                    description=f"modal coordinate of {labels[i]}")
                            for i in range(r)])
        deta = ca.vertcat(*[m.state(f"deta{i}", 0.0, unit="m/s", nominal=1e-3,
                                    description=f"rate of eta{i} "
                                    f"({labels[i].split(', largest')[0]})")
                            for i in range(r)])
        Mr = B.T @ M @ B
        if basis_omega is not None:
            modal_quantities(m, basis, ca.DM(basis_omega), Mr, B.T @ C @ B, B.T @ G @ B,
                             B.T @ K @ B, B.T @ F)
        a = band_ldl_solve(Mr, B.T @ (F - (C + Omega * G) @ (B @ deta) - K @ (B @ eta_)))
        q, v, qv, vv = B @ eta_, B @ deta, eta_, deta
        if residual is not None:
            from loomfmu.models.spindle_derivation import static_correction_quantities
            dF = ca.jacobian(F, phi) * Omega  # exact at constant speed
            q, v = q + ca.DM(residual) @ F, v + ca.DM(residual) @ dF
            static_correction_quantities(m, residual, F, dF, q, v)
    for i in range(qv.numel()):
        m.eq(m.der(qv[i]), vv[i])
        m.eq(m.der(vv[i]), a[i])
    _outputs(m, sp, q, v)
    m.port("drive", "flange", speed="Omega", description="spindle speed from the drive "
           "(tape on the whorl)")


def _outputs(m: Model, sp: SpindleRotor, q, v) -> None:
    nd = sp.nodes
    X = lambda node, c: q[sp.idx(f"n{node}.{c}")]  # noqa: E731

    def pair(vec, dof):  # the (x, y) of a node or housing
        return ca.vertcat(vec[sp.idx(f"{dof}.x")], vec[sp.idx(f"{dof}.y")])

    for role, label in (("top", "top of the blade (锭端)"), ("footstep", "bottom of the "
                        "blade (锭底)")):
        x, y = X(nd[role], "x"), X(nd[role], "y")
        m.output(f"x_{role}", x, unit="m", description=f"x displacement of the {label}")
        m.output(f"y_{role}", y, unit="m", description=f"y displacement of the {label}")
        m.output(f"r_{role}", ca.sqrt(x**2 + y**2 + 1e-30), unit="m",
                 description=f"radial displacement of the {label}")
    b = nd["bolster"]
    h = pair(q, "h0")
    vh = pair(v, "h0")
    Fu, Fl = force_quantities(m, sp.support, pair(q, f"n{b}"), pair(v, f"n{b}"),
                              pair(q, "n0") - h, pair(v, "n0") - vh, h, vh)
    for tag, F, label in (("upper", Fu, "bolster bearing (upper support)"),
                          ("lower", Fl, "footstep bearing (lower support)")):
        m.output(f"F_{tag}_x", F[0], unit="N", description=f"x force of the {label} on "
                 "the blade")
        m.output(f"F_{tag}_y", F[1], unit="N", description=f"y force of the {label} on "
                 "the blade")
        m.output(f"F_{tag}", ca.sqrt(F[0]**2 + F[1]**2 + 1e-30), unit="N",
                 description=f"magnitude of the {label} force")
