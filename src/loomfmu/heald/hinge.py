"""Kinetostatic load in the heald frame's drive hinge (seed 002).

Sign: N is the force of the frame on one drive hinge, positive upwards
(seed 002: "positive direction of N_REM: up").  Notation: G_RR = m_RR g
(frame), G_G = m_heald g (healds), G_rem = G_RR + G_G (1), F_in =
(m_RR + m_heald) a (3), n = n_hinge (n_OSh), N_warp = N_STR^max (warp
action at the open shed), dN = Delta N_OSN (warp action where the
acceleration peaks).

The seed's formulas by phase (``form="general"`` / ``form="simplified"``,
the latter with the seed's approximations dN ~ N_warp ~ G_G):

| # | phase | general | simplified |
|---|---|---|---|
| 1 | bottom dwell | (6) (N_warp - G_rem)/n | (7), (20) -G_RR/n |
| 2 | rise to crossing | (9) (-G_rem - F_in + dN)/n | (10) -(G_RR + F_in)/n |
| 3 | crossing | (11) -G_rem/n | (11) |
| 4 | rise to top dwell | (12) (-G_rem + F_in - dN)/n | (13) [-(G_RR + 2 G_G) + F_in]/n |
| 5 | top dwell | (14) -(G_rem + N_warp)/n | (15) -(G_RR + 2 G_G)/n |
| 6 | fall to crossing | (16) (-G_rem + F_in - dN)/n | (17) [m_RR (a - g) - 2 G_G]/n |
| 7 | crossing | (18) -G_rem/n | (18) |
| 8 | fall to bottom dwell | (-G_rem - F_in + dN)/n | (19) -(G_RR + F_in)/n |

Print defects of seed 002 (printed -> used, why):

* (3): printed N_STR m_G; used M_STR m_G (the thread count M_STR of (1);
  N_STR is the warp force).
* (9): printed without "/ n_OSh"; used with it, as (10) which it simplifies to.
* (19): labelled N^DVV like (12)-(13) (rise to the top dwell); it is the fall
  to the bottom dwell (the text before it), labelled phase 8 here.
* Phase 8 general form: the seed writes only the simplified (19); the
  general form is (9)'s mirror (same sign of acceleration and warp action).
* Summary after (20): printed N^DNZ = -[m_RR (a - g) - 2 G_G]/n, the
  negative of (17).  (17) follows from (16) with F_in = m_RR a and
  dN = G_G; the summary's extra minus would make a frame accelerating
  down faster than g push the hinge down.  Used: (17).
* Summary: N^VN < N^ZAST < N^DVV holds for magnitudes (all three are
  negative), not for the signed values.

The margins of the text after table 2: the computed loads are increased by
7-12 % (``margin``) and by 10-15 % for friction (``friction``); 0 means none.
"""
from __future__ import annotations

import math

import numpy as np

from loomfmu.declare.checks import (
    check_array,
    check_choice,
    check_mapping,
    check_number,
    check_order,
)
from loomfmu.models.heald_common import G_STD

#: The eight phases of one frame cycle (two main-shaft revolutions), seed 002.
PHASES = ("bottom dwell", "rise to crossing", "crossing", "rise to top dwell",
          "top dwell", "fall to crossing", "crossing (falling)", "fall to bottom dwell")
MARGIN_RANGE = (0.07, 0.12)
FRICTION_RANGE = (0.10, 0.15)


#: the keyword arguments of :func:`hinge_load_kinetostatic` (model parameter
#: names): pick them from a model's values with ``{k: v for k, v in values.items()
#: if k in KINETOSTATIC_PARAMETERS}``
KINETOSTATIC_PARAMETERS = ("m_RR", "m_heald", "n_hinge", "g", "h_m", "k_H", "omega", "l_1",
                           "k_z", "n_n", "T_min", "T_max")


def _check_margin(name: str, value: float, band: tuple[float, float]) -> float:
    value = check_number(name, value, lo=0.0, hi=band[1])
    if not (value == 0.0 or band[0] <= value <= band[1]):
        raise ValueError(f"{name} = {value!r}; allowed: 0 (none) or the seed's "
                         f"[{band[0]}, {band[1]}]")
    return value


def _check_positive(**kw) -> None:
    for name, value in kw.items():
        check_number(name, value, lo=0.0)


def _check_shed(*, h_m, k_H, omega, l_1, k_z, n_n, T_min, T_max) -> None:
    """The motion-law and shed arguments, in the ranges of the models' parameters."""
    check_number("h_m", h_m, lo=0.0, lo_open=True, unit="m")
    check_number("k_H", k_H, lo=0.0, lo_open=True)
    check_number("omega", omega, lo=0.0, unit="rad/s")
    check_number("l_1", l_1, lo=0.0, lo_open=True, unit="m")
    check_number("k_z", k_z, lo=0.0, lo_open=True)
    check_number("n_n", n_n, lo=0.0)
    check_number("T_min", T_min, lo=0.0, unit="N")
    check_number("T_max", T_max, lo=0.0, unit="N")
    check_order("T_min", T_min, "T_max", T_max, strict=False)


def hinge_load_phases(*, m_RR: float, m_heald: float, a_max: float, n_hinge: float = 2.0,
                      N_warp: float | None = None, dN: float | None = None,
                      g: float = G_STD, form: str = "simplified", margin: float = 0.0,
                      friction: float = 0.0) -> dict[str, float]:
    """The seed's kinetostatic hinge load (N, positive up) of each phase.

    m_RR, m_heald: frame and heald mass (kg); a_max: peak frame acceleration
    (m/s2); n_hinge: number of drive hinges (>= 1); N_warp, dN: warp action
    at the open shed and at peak acceleration (N; form="general" only, default
    G_G as the seed); form: "general" or "simplified" (table in the module
    doc); margin: 0 or 0.07-0.12; friction: 0 or 0.10-0.15.
    """
    _check_positive(m_RR=m_RR, m_heald=m_heald, a_max=a_max, g=g)
    check_number("n_hinge", n_hinge, lo=1.0)
    margin = _check_margin("margin", margin, MARGIN_RANGE)
    friction = _check_margin("friction", friction, FRICTION_RANGE)
    check_choice("form", form, ("general", "simplified"))
    G_RR, G_G = m_RR * g, m_heald * g
    G_rem, F_in = G_RR + G_G, (m_RR + m_heald) * a_max
    if form == "general":
        N_warp = G_G if N_warp is None else N_warp
        dN = G_G if dN is None else dN
        _check_positive(N_warp=N_warp, dN=dN)
        values = (N_warp - G_rem, -G_rem - F_in + dN, -G_rem, -G_rem + F_in - dN,
                  -(G_rem + N_warp), -G_rem + F_in - dN, -G_rem, -G_rem - F_in + dN)
    elif form == "simplified":
        if N_warp is not None or dN is not None:
            raise ValueError("N_warp, dN: only with form='general' (the simplified form "
                             "takes both as G_G)")
        values = (-G_RR, -(G_RR + F_in), -G_rem, -(G_RR + 2 * G_G) + F_in,
                  -(G_RR + 2 * G_G), m_RR * (a_max - g) - 2 * G_G, -G_rem, -(G_RR + F_in))
    else:
        raise ValueError(f"form = {form!r}; allowed: 'general', 'simplified'")
    k = (1 + margin) * (1 + friction) / n_hinge
    return {p: k * v for p, v in zip(PHASES, values)}


def max_phases(loads: dict[str, float], rel_tol: float = 1e-9) -> list[str]:
    """The phases whose |N| is the largest (ties within rel_tol, in [0, 1))."""
    loads = check_mapping("loads", loads, PHASES, what="phases")
    if not loads:
        raise ValueError("loads = {}; allowed: a non-empty dict {phase: N}")
    check_number("rel_tol", rel_tol, lo=0.0, hi=1.0, hi_open=True)
    top = max(abs(v) for v in loads.values())
    return [p for p, v in loads.items() if abs(v) >= top * (1 - rel_tol)]


# -- the continuous kinetostatic load along seed 000's motion law ------------------
def motion(phi: np.ndarray, *, h_m: float = 0.029, k_H: float = 9 / 7,
           omega: float = 60.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """H, H', H'' (time derivatives, constant omega) of seed 000's corrected
    motion law, written out in numpy (independent of the CasADi model)."""
    phi = check_array("phi", phi, ndim=None, min_size=0, unit="rad")
    check_number("h_m", h_m, lo=0.0, lo_open=True, unit="m")
    check_number("k_H", k_H, lo=0.0, lo_open=True)
    check_number("omega", omega, lo=0.0, unit="rad/s")
    rev = np.floor(phi / (2 * math.pi))
    phi_r = phi - 2 * math.pi * rev
    phi_a = np.clip(phi_r - math.radians(40), 0, math.radians(280))
    moving = (phi_r > math.radians(40)) & (phi_r < math.radians(320))
    sign = np.where(rev % 2 == 0, 1.0, -1.0)
    th = k_H * phi_a
    H = h_m * ((th - np.sin(th)) / math.pi - 1) * sign
    v = np.where(moving, h_m * k_H * (1 - np.cos(th)) / math.pi * omega * sign, 0.0)
    a = np.where(moving, h_m * k_H**2 * np.sin(th) / math.pi * omega**2 * sign, 0.0)
    return H, v, a


def warp_vertical(H: np.ndarray, *, h_m: float = 0.029, l_1: float = 0.05, k_z: float = 5.0,
                  n_n: float = 1000.0, T_min: float = 0.3, T_max: float = 0.8) -> np.ndarray:
    """f_y (N) of seed 000, fig. 2: positive when the warp pulls the frame down."""
    H = check_array("H", H, ndim=None, min_size=0, unit="m")
    _check_shed(h_m=h_m, k_H=1.0, omega=0.0, l_1=l_1, k_z=k_z, n_n=n_n, T_min=T_min,
                T_max=T_max)
    l_2 = k_z * l_1
    L1, L2 = np.hypot(l_1, H), np.hypot(l_2, H)
    dl_max = math.hypot(l_1, h_m) + math.hypot(l_2, h_m) - l_1 - l_2
    T = n_n * (T_min + (T_max - T_min) * (L1 + L2 - l_1 - l_2) / dl_max)
    return T * (H / L1 + H / L2)


def hinge_load_kinetostatic(phi, *, m_RR: float = 4.6, m_heald: float = 9.0 / G_STD,
                            n_hinge: float = 2.0, g: float = G_STD, h_m: float = 0.029,
                            k_H: float = 9 / 7, omega: float = 60.0, l_1: float = 0.05,
                            k_z: float = 5.0, n_n: float = 1000.0, T_min: float = 0.3,
                            T_max: float = 0.8) -> np.ndarray:
    """N(phi) = -[(m_RR + m_heald)(g + H'') + f_y] / n_hinge for a rigid frame:
    seed 002's (4)-(5) with the actual acceleration and warp action of seed
    000's motion law and shed.  Keyword names are the models' parameter names
    (KINETOSTATIC_PARAMETERS; pick them from a model's start values, any
    other name is an error)."""
    _check_positive(m_RR=m_RR, m_heald=m_heald, g=g)
    check_number("n_hinge", n_hinge, lo=1.0)
    _check_shed(h_m=h_m, k_H=k_H, omega=omega, l_1=l_1, k_z=k_z, n_n=n_n, T_min=T_min,
                T_max=T_max)
    H, _, a = motion(phi, h_m=h_m, k_H=k_H, omega=omega)
    f_y = warp_vertical(H, h_m=h_m, l_1=l_1, k_z=k_z, n_n=n_n, T_min=T_min, T_max=T_max)
    return -((m_RR + m_heald) * (g + a) + f_y) / n_hinge


def phase_of(H, h_dot, h_m: float, band: float = 0.1) -> np.ndarray:
    """Phase index 0..7 (PHASES) of each sample; ``band``: the crossing zone
    |H| <= band h_m (the seed's "region of the crossing")."""
    H = check_array("H", H, ndim=None, min_size=0, unit="m")
    h_dot = check_array("h_dot", h_dot, ndim=None, min_size=0, unit="m/s")
    if H.shape != h_dot.shape:
        raise ValueError(f"H, h_dot: shapes {H.shape} and {h_dot.shape}; allowed: equal")
    check_number("h_m", h_m, lo=0.0, lo_open=True, unit="m")
    check_number("band", band, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    vmax = np.max(np.abs(h_dot)) or 1.0
    dwell = np.abs(h_dot) <= 1e-9 * vmax
    up = h_dot > 0
    cross = np.abs(H) <= band * h_m
    out = np.where(up, np.where(H < 0, 1, 3), np.where(H > 0, 5, 7))
    out = np.where(cross, np.where(up, 2, 6), out)
    return np.where(dwell, np.where(H < 0, 0, 4), out)


def phase_extremes(N, phase) -> dict[str, float]:
    """The largest |N| (with sign) in each phase (phase: indices 0..7 of PHASES)."""
    N = check_array("N", N, ndim=None, min_size=0, unit="N")
    phase = check_array("phase", phase, lo=0, hi=len(PHASES) - 1, ndim=None, min_size=0)
    if N.shape != phase.shape:
        raise ValueError(f"N, phase: shapes {N.shape} and {phase.shape}; allowed: equal")
    out = {}
    for k, name in enumerate(PHASES):
        sel = N[phase == k]
        if sel.size:
            out[name] = float(sel[np.argmax(np.abs(sel))])
    return out
