"""Finite-element rotor assembly in CasADi: beam elements, rigid disks,
8-coefficient supports, a support with its housing's mass, the coil-spring
squeeze-film damper of seed 003, and a banded symbolic LDL^T solve.

Coordinates.  The spin axis is z.  Every node carries four DOF, in the
order ``(x, y, ax, ay)``: the translations and the slopes ax = dx/dz,
ay = dy/dz.  With slopes (not rotation angles) both bending planes use the
same element matrices, and the gyroscopic coupling of a disk spinning at
+Omega about z reads (derivation in docs/guides/spindle.md)::

    x-plane, slope row:  Id ax'' + Ip Omega ay' = Q_ax
    y-plane, slope row:  Id ay'' - Ip Omega ax' = Q_ay

so the global equations are ``M q'' + (C + Omega G) q' + K q = F`` with G
skew-symmetric.  Forward whirl (x + i y ~ e^{+i w t}) stiffens with Omega.

Every matrix is built from CasADi SX (or plain floats), so the parameters of
a model stay symbolic; :func:`numeric` evaluates them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from loomfmu.declare.checks import check_bool, check_int, check_number

#: Gauss-Legendre points for the squeeze-film integrals of (4), (5).
FILM_QUADRATURE_POINTS = 16
#: most Gauss-Legendre points of :func:`gauss_integral`, most coil-spring turns
MAX_POINTS, MAX_TURNS = 1000, 100


def _is_symbolic(value) -> bool:
    return isinstance(value, (ca.SX, ca.MX, ca.DM))


def _num(name: str, value, *, lo: float = 0.0, lo_open: bool = True, hi: float = math.inf):
    """A numeric argument checked like :func:`~loomfmu.declare.checks.check_number`
    (default > 0); a CasADi expression passes unchanged (it is a model's
    parameter, checked by the parameter's range)."""
    if _is_symbolic(value):
        return value
    return check_number(name, value, lo=lo, lo_open=lo_open, hi=hi)


def _coeffs(name: str, value):
    """A 2x2 coefficient table [[xx, xy], [yx, yy]] of numbers or expressions."""
    try:
        rows = [list(r) for r in value]
        ok = len(rows) == 2 and all(len(r) == 2 for r in rows)
    except TypeError:
        ok = False
    if not ok:
        raise ValueError(f"{name} = {value!r:.60}; allowed: 2x2 coefficients "
                         "[[xx, xy], [yx, yy]]")
    return [[_num(f"{name}[{i}][{j}]", v, lo=-math.inf) for j, v in enumerate(r)]
            for i, r in enumerate(rows)]


# ---------------------------------------------------------------- beam element
def beam_planar(l, EI, rhoA, rhoI, phi=0.0):
    """Planar 4x4 matrices (v1, v1', v2, v2') of a uniform beam element.

    phi = 12 EI / (kappa G A l^2) is the shear parameter (0: Euler-Bernoulli).
    Returns (K, M_t, M_r): stiffness, translational and rotary inertia
    (Przemieniecki's Timoshenko element; at phi = 0 the classical Hermite
    matrices, e.g. M_r = rhoI/(30 l) [36 3l -36 3l; 3l 4l2 -3l -l2; ...]).
    The gyroscopic matrix of the element is 2 M_r (I_p = 2 I_d for a
    circular section), see :func:`element_global`.
    """
    l, EI, rhoA = _num("l", l), _num("EI", EI), _num("rhoA", rhoA)
    rhoI, phi = _num("rhoI", rhoI, lo_open=False), _num("phi", phi, lo_open=False)
    p = phi
    k = EI / ((1 + p) * l**3)
    K = [[12 * k, 6 * l * k, -12 * k, 6 * l * k],
         [6 * l * k, (4 + p) * l**2 * k, -6 * l * k, (2 - p) * l**2 * k],
         [-12 * k, -6 * l * k, 12 * k, -6 * l * k],
         [6 * l * k, (2 - p) * l**2 * k, -6 * l * k, (4 + p) * l**2 * k]]
    mt = rhoA * l / (1 + p) ** 2
    m11 = 13 / 35 + 7 * p / 10 + p**2 / 3
    m12 = (11 / 210 + 11 * p / 120 + p**2 / 24) * l
    m13 = 9 / 70 + 3 * p / 10 + p**2 / 6
    m14 = -(13 / 420 + 3 * p / 40 + p**2 / 24) * l
    m22 = (1 / 105 + p / 60 + p**2 / 120) * l**2
    m24 = -(1 / 140 + p / 60 + p**2 / 120) * l**2
    Mt = [[m11, m12, m13, m14], [m12, m22, -m14, m24],
          [m13, -m14, m11, -m12], [m14, m24, -m12, m22]]
    Mt = [[mt * e for e in row] for row in Mt]
    mr = rhoI / ((1 + p) ** 2 * l)
    r12 = (1 / 10 - p / 2) * l
    r22 = (2 / 15 + p / 6 + p**2 / 3) * l**2
    r24 = (-1 / 30 - p / 6 + p**2 / 6) * l**2
    Mr = [[6 / 5, r12, -6 / 5, r12], [r12, r22, -r12, r24],
          [-6 / 5, -r12, 6 / 5, -r12], [r12, r24, -r12, r22]]
    Mr = [[mr * e for e in row] for row in Mr]
    return K, Mt, Mr


def circle_section(d_out, d_in=0.0):
    """Area and second moment of area of a (hollow) circular section
    (d_out > d_in >= 0)."""
    d_out, d_in = _num("d_out", d_out), _num("d_in", d_in, lo_open=False)
    if not (_is_symbolic(d_out) or _is_symbolic(d_in)) and d_in >= d_out:
        raise ValueError(f"d_in = {d_in!r}, d_out = {d_out!r}; allowed: d_in < d_out")
    return math.pi / 4 * (d_out**2 - d_in**2), math.pi / 64 * (d_out**4 - d_in**4)


# ------------------------------------------------------------ the assembly
@dataclass
class Rotor:
    """A rotor on nodes 0..N (z upwards); build it, then :meth:`assemble`.

    ``E``, ``rho``, ``G_shear``, ``kappa``: blade material and shear factor;
    ``timoshenko``: include shear deformation in the beam elements.
    """

    E: object
    rho: object
    G_shear: object = 8.0e10
    kappa: object = 0.9
    timoshenko: bool = False
    elements: list = field(default_factory=list)  # (l, d_out, d_in, EI_extra)
    disks: list = field(default_factory=list)     # (node, m, Id, Ip)
    springs: list = field(default_factory=list)   # (node, K2x2, C2x2)
    housings: list = field(default_factory=list)  # (node, m_p, K1, C1, K2, C2)
    structural_damping: object = 0.0              # beta: C += beta K_beam

    def __post_init__(self):
        self.E, self.rho = _num("E", self.E), _num("rho", self.rho)
        self.G_shear, self.kappa = _num("G_shear", self.G_shear), _num("kappa", self.kappa)
        self.timoshenko = check_bool("timoshenko", self.timoshenko)
        self.structural_damping = _num("structural_damping", self.structural_damping,
                                       lo_open=False)

    def _node(self, node) -> int:
        return check_int("node", node, lo=0, hi=self.n_nodes - 1)

    @property
    def n_nodes(self) -> int:
        return len(self.elements) + 1

    def element(self, l, d_out, d_in=0.0, EI_extra=0.0) -> int:
        """Append a beam element above the last node; return its top node.
        EI_extra: bending stiffness of a part that stiffens the element
        without adding mass here (e.g. a bobbin tube pressed on the blade)."""
        circle_section(d_out, d_in)
        self.elements.append((_num("l", l), d_out, d_in, _num("EI_extra", EI_extra,
                                                                lo_open=False)))
        return len(self.elements)

    def disk(self, node, m, Id, Ip) -> None:
        """A rigid disk (mass, diametral and polar moment of inertia) at ``node``."""
        self.disks.append((self._node(node), _num("m", m, lo_open=False),
                           _num("Id", Id, lo_open=False), _num("Ip", Ip, lo_open=False)))

    def spring(self, node, K, C) -> None:
        """An 8-coefficient support to ground: K, C are 2x2 [[xx, xy], [yx, yy]]."""
        self.springs.append((self._node(node), _coeffs("K", K), _coeffs("C", C)))

    def housing(self, node, m_p, K1, C1, K2, C2) -> None:
        """Bearing (K1, C1) from ``node`` to a housing of participating mass
        m_p, and the housing's support (K2, C2) to ground (seed 003, fig. 4).
        The housing adds two DOF (its x, y), placed before the node's DOF."""
        self.housings.append((self._node(node), _num("m_p", m_p), _coeffs("K1", K1),
                              _coeffs("C1", C1), _coeffs("K2", K2), _coeffs("C2", C2)))

    # -- DOF layout ------------------------------------------------------------
    def dof_names(self) -> list[str]:
        names = []
        for k in range(self.n_nodes):
            for h, (node, *_rest) in enumerate(self.housings):
                if node == k:
                    names += [f"h{h}.x", f"h{h}.y"]
            names += [f"n{k}.x", f"n{k}.y", f"n{k}.ax", f"n{k}.ay"]
        return names

    def dof(self, name: str) -> int:
        names = self.dof_names()
        if name not in names:
            raise ValueError(f"name = {name!r}; allowed: a DOF name such as 'n0.x' "
                             f"({len(names)} DOF: {', '.join(names[:8])}, ...)")
        return names.index(name)

    def node_z(self) -> list:
        z = [0.0]
        for l, *_ in self.elements:
            z.append(z[-1] + l)
        return z

    def element_section(self, e: int):
        """(l, A, I, EI) of element ``e``: length, area, second moment of area
        and bending stiffness E I + EI_extra."""
        e = check_int("e", e, lo=0, hi=len(self.elements) - 1)
        l, d_o, d_i, EI_x = self.elements[e]
        A, I = circle_section(d_o, d_i)
        return l, A, I, self.E * I + EI_x

    def element_matrices(self, e: int):
        """Planar (K, M_t, M_r) of element ``e`` (see :func:`beam_planar`), as
        :meth:`assemble` places them in both bending planes.  The same
        expressions each call (kept per element and its data), so that a
        derivation naming element 1's matrices names what the assembly uses."""
        l, A, I, EI = self.element_section(e)
        key = (e, id(self.elements[e]), id(self.E), id(self.rho), self.timoshenko)
        cache = self.__dict__.setdefault("_element_cache", {})
        if key not in cache:
            phi = (12 * EI / (self.kappa * self.G_shear * A * l**2)
                   if self.timoshenko else 0.0)
            cache[key] = (self.elements[e], beam_planar(l, EI, self.rho * A, self.rho * I,
                                                        phi))
        return cache[key][1]

    def assemble(self):
        """(M, C, G, K) as SX matrices: M q'' + (C + Omega G) q' + K q = F.

        C holds the supports' damping and the blade's structural damping
        beta K_beam; G the gyroscopic matrix per unit spin speed (rad/s).
        """
        names = self.dof_names()
        n = len(names)
        idx = {s: i for i, s in enumerate(names)}
        M, C, G, K = (ca.SX.zeros(n, n) for _ in range(4))
        Kb = ca.SX.zeros(n, n)
        for e in range(len(self.elements)):
            Ke, Mt, Mr = self.element_matrices(e)
            for plane, other in (("x", "y"), ("y", "x")):
                dofs = [idx[f"n{e}.{plane}"], idx[f"n{e}.a{plane}"],
                        idx[f"n{e + 1}.{plane}"], idx[f"n{e + 1}.a{plane}"]]
                odofs = [idx[f"n{e}.{other}"], idx[f"n{e}.a{other}"],
                         idx[f"n{e + 1}.{other}"], idx[f"n{e + 1}.a{other}"]]
                sign = 1.0 if plane == "x" else -1.0
                for a in range(4):
                    for b in range(4):
                        Kb[dofs[a], dofs[b]] += Ke[a][b]
                        M[dofs[a], dofs[b]] += Mt[a][b] + Mr[a][b]
                        G[dofs[a], odofs[b]] += sign * 2 * Mr[a][b]
        K += Kb
        C += self.structural_damping * Kb
        for node, m, Id, Ip in self.disks:
            x, y, ax, ay = (idx[f"n{node}.{s}"] for s in ("x", "y", "ax", "ay"))
            M[x, x] += m
            M[y, y] += m
            M[ax, ax] += Id
            M[ay, ay] += Id
            G[ax, ay] += Ip
            G[ay, ax] -= Ip
        for node, Ks, Cs in self.springs:
            d = [idx[f"n{node}.x"], idx[f"n{node}.y"]]
            for a in range(2):
                for b in range(2):
                    K[d[a], d[b]] += Ks[a][b]
                    C[d[a], d[b]] += Cs[a][b]
        for h, (node, m_p, K1, C1, K2, C2) in enumerate(self.housings):
            s = [idx[f"n{node}.x"], idx[f"n{node}.y"]]
            hh = [idx[f"h{h}.x"], idx[f"h{h}.y"]]
            M[hh[0], hh[0]] += m_p
            M[hh[1], hh[1]] += m_p
            for a in range(2):
                for b in range(2):
                    for (i, j, sg) in ((s[a], s[b], 1), (hh[a], hh[b], 1),
                                       (s[a], hh[b], -1), (hh[a], s[b], -1)):
                        K[i, j] += sg * K1[a][b]
                        C[i, j] += sg * C1[a][b]
                    K[hh[a], hh[b]] += K2[a][b]
                    C[hh[a], hh[b]] += C2[a][b]
        return M, C, G, K


def isotropic(k, k_cross=0.0):
    """The 2x2 coefficients [[k, k_cross], [-k_cross, k]] of an isotropic
    support with cross-coupling (k_xy = -k_yx, as in a fluid film)."""
    k, k_cross = _num("k", k, lo_open=False), _num("k_cross", k_cross, lo=-math.inf)
    return [[k, k_cross], [-k_cross, k]]


# --------------------------------------------------- banded symbolic solve
def bandwidth(A: ca.SX) -> int:
    """Largest |i - j| over the structural nonzeros of ``A``."""
    rows, cols = A.sparsity().get_triplet()
    return max((abs(i - j) for i, j in zip(rows, cols)), default=0)


def band_ldl_solve(A: ca.SX, b: ca.SX, bw: int | None = None) -> ca.SX:
    """Solve A x = b for symmetric positive definite banded A by LDL^T.

    The expression grows as n bw^2 (a dense symbolic factorization grows
    as n^3), which keeps the generated right-hand side of an FE rotor small.
    """
    if not isinstance(A, (ca.SX, ca.DM)) or A.size1() != A.size2():
        raise ValueError(f"A: {A!r:.60}; allowed: a square CasADi matrix")
    n = A.size1()
    if ca.SX(b).numel() != n:
        raise ValueError(f"b: {ca.SX(b).numel()} elements; allowed: {n} (the size of A)")
    bw = bandwidth(A) if bw is None else check_int("bw", bw, lo=0, hi=max(n - 1, 0))
    L: dict[tuple[int, int], ca.SX] = {}
    D: list[ca.SX] = []
    for j in range(n):
        lo = max(0, j - bw)
        d = A[j, j] - sum((L[j, k] ** 2 * D[k] for k in range(lo, j)), ca.SX(0))
        D.append(d)
        for i in range(j + 1, min(n, j + bw + 1)):
            lo_i = max(0, i - bw)
            s = A[i, j] - sum((L[i, k] * L[j, k] * D[k] for k in range(max(lo, lo_i), j)),
                              ca.SX(0))
            L[i, j] = s / d
    y = []
    for i in range(n):
        y.append(b[i] - sum((L[i, k] * y[k] for k in range(max(0, i - bw), i)), ca.SX(0)))
    x = [None] * n
    for i in reversed(range(n)):
        x[i] = y[i] / D[i] - sum((L[k, i] * x[k] for k in range(i + 1, min(n, i + bw + 1))),
                                 ca.SX(0))
    return ca.vertcat(*x)


# ------------------------------------------ coil-spring squeeze-film damper
def gauss_integral(fun, a: float, b: float, n: int = FILM_QUADRATURE_POINTS):
    """int_a^b fun(t) dt by n-point Gauss-Legendre (fun may return SX)."""
    if not callable(fun):
        raise ValueError(f"fun = {fun!r:.60}; allowed: a function of one argument")
    a, b = check_number("a", a), check_number("b", b)
    n = check_int("n", n, lo=1, hi=MAX_POINTS)
    t, w = np.polynomial.legendre.leggauss(n)
    half, mid = (b - a) / 2, (a + b) / 2
    return sum(float(wi) * half * fun(mid + half * float(ti)) for ti, wi in zip(t, w))


def spring_radii(r1, c, n: int) -> list:
    """Radii of the n turns of the coil spring, r_{i+1} - r_i = c (seed 003, (5))."""
    n = check_int("n", n, lo=2, hi=MAX_TURNS)
    r1, c = _num("r1", r1), _num("c", c)
    return [r1 + i * c for i in range(n)]


def coil_spring_stiffness(E, a, l, radii):
    """Structural stiffness (1): K = E a^3 l / (12 pi sum r_i^3)."""
    E, a, l, radii = _num("E", E), _num("a", a), _num("l", l), _radii(radii)
    return E * a**3 * l / (12 * math.pi * sum(r**3 for r in radii))


def film_eccentricities(radii, c, delta0) -> list:
    """eps_i0 = 1 - ((n-1) c - delta0)/c * r_i / sum_{j<n} r_j (seed 003, after (5))."""
    radii, c, delta0 = _radii(radii), _num("c", c), _num("delta0", delta0, lo_open=False)
    n = len(radii)
    s = sum(radii[: n - 1])
    return [1 - ((n - 1) * c - delta0) / c * r / s for r in radii]


def _radii(radii) -> list:
    """The turns' radii: a list of at least two (> 0)."""
    if isinstance(radii, (str, bytes)) or not hasattr(radii, "__len__") or len(radii) < 2:
        raise ValueError(f"radii = {radii!r:.60}; allowed: a list of >= 2 radii (m, > 0)")
    return [_num(f"radii[{i}]", r) for i, r in enumerate(radii)]


def _pow(base, e):
    return ca.exp(e * ca.log(base)) if isinstance(base, (ca.SX, ca.MX)) else base**e


def film_integral_K(eps):
    """int_0^{pi/2} cos^2 t sin t / (1 - eps cos t)^2.28 dt of (4)."""
    return gauss_integral(lambda t: math.cos(t) ** 2 * math.sin(t)
                          / _pow(1 - eps * math.cos(t), 2.28), 0.0, math.pi / 2)


def film_integral_C(eps):
    """int_0^{pi/2} sin t cos t / (1 - eps cos t)^1.28 dt of (5)."""
    return gauss_integral(lambda t: math.sin(t) * math.cos(t)
                          / _pow(1 - eps * math.cos(t), 1.28), 0.0, math.pi / 2)


def film_layer_stiffness(eta, x0, omega, radii, l, c, delta0) -> list:
    """The layers' film stiffness K^(i) of (4), one per turn of the coil spring:
    11.9808 eta x0 omega r_i^5 l / (c^4 (sum_{j<n} r_j)^2) int_0^{pi/2} cos^2 t sin t
    (1 - eps_i0 cos t)^-2.28 dt."""
    eta, x0, l = _num("eta", eta), _num("x0", x0), _num("l", l)
    omega = _num("omega", omega, lo_open=False)
    radii = _radii(radii)
    s = sum(radii[: len(radii) - 1])
    eps = film_eccentricities(radii, c, delta0)
    return [11.9808 * eta * x0 * omega * r**5 * l / (c**4 * s**2) * film_integral_K(e)
            for r, e in zip(radii, eps)]


def film_layer_damping(eta, radii, l, c, delta0, form: str = "corrected") -> list:
    """The layers' film damping C^(i) of (5), one per turn:
    9.36 eta r_i^p l / (c^3 sum_{j<n} r_j) int_0^{pi/2} sin t cos t
    (1 - eps_i0 cos t)^-1.28 dt with p = 4 (form="corrected") or p = 3
    (form="printed", unit Pa s; docs/guides/spindle.md, defect S3)."""
    if form not in ("corrected", "printed"):
        raise ValueError(f"form = {form!r}; allowed: 'corrected', 'printed'")
    eta, l = _num("eta", eta), _num("l", l)
    radii = _radii(radii)
    s = sum(radii[: len(radii) - 1])
    eps = film_eccentricities(radii, c, delta0)
    return [9.36 * eta * (r**4 if form == "corrected" else r**3) * l / (c**3 * s)
            * film_integral_C(e) for r, e in zip(radii, eps)]


def series_sum(layers) -> object:
    """1 / sum_i 1/k_i: the layers in series, (2) and (3)."""
    return 1 / sum(1 / k for k in layers)


def film_stiffness(eta, x0, omega, radii, l, c, delta0):
    """Film stiffness K_xx = K_yy of (2) with the layers' K^(i) of (4)."""
    return series_sum(film_layer_stiffness(eta, x0, omega, radii, l, c, delta0))


def film_damping(eta, radii, l, c, delta0, form: str = "corrected"):
    """Film damping C_xx = C_yy of (3) with the layers' C^(i) of (5).

    form="printed": C^(i) = 9.36 eta r_i^3 l / (c^3 sum r) -- unit Pa s, not
    N s/m.  form="corrected" (default): r_i^4 in place of r_i^3, i.e. the
    long-damper term eta r^3 l / c^3 times the layer's share r_i / sum r,
    as the share enters (4) (docs/guides/spindle.md, defect S3).
    """
    return series_sum(film_layer_damping(eta, radii, l, c, delta0, form))


def equivalent_support(K1, C1, K2, C2, m_p, w):
    """The bearing in series with its housing as one 8-coefficient support at
    whirl frequency w (seed 003, fig. 4): Z = Z1 (Z1 + Z2)^-1 Z2 with the
    displacement impedances Z1 = K1 + i w C1, Z2 = K2 + i w C2 - w^2 m_p I.
    Returns (K_eq, C_eq) as 2x2 numpy arrays (K_eq = Re Z, C_eq = Im Z / w)."""
    K1, C1, K2, C2 = (np.array(_coeffs(n, v), dtype=float)
                      for n, v in (("K1", K1), ("C1", C1), ("K2", K2), ("C2", C2)))
    m_p = check_number("m_p", m_p, lo=0.0)
    w = check_number("w", w, lo=0.0, lo_open=True, unit="rad/s")
    Z1 = K1 + 1j * w * C1
    Z2 = K2 + 1j * w * C2 - w**2 * m_p * np.eye(2)
    Z = Z1 @ np.linalg.solve(Z1 + Z2, Z2)
    return Z.real, Z.imag / w


def numeric(exprs, syms: ca.SX, values) -> list[np.ndarray]:
    """Evaluate SX expressions at numeric values of ``syms`` (one finite value each)."""
    from loomfmu.declare.checks import check_array
    values = check_array("values", values, ndim=None, min_size=0)
    if values.size != syms.numel():
        raise ValueError(f"values: {values.size} numbers; allowed: {syms.numel()} (one per "
                         "symbol)")
    f = ca.Function("f", [syms], list(exprs))
    return [np.asarray(v) for v in f(ca.DM(values))]
