"""Seed 002's tables 1 and 2 as named parameter sets of the heald-frame models.

A preset name is ``"STB-<width> <maker>"`` with an optional yarn,
``"STB-180 Elitex"`` or ``"STB-180 Elitex wool"`` (default yarn: cotton).
:func:`preset_values` gives the parameter values; use them as
``load_model("heald_frame", preset=name)`` (start values at build time) or as
FMPy ``start_values`` (run time, no rebuild).

What a preset sets, and from where:

| parameter | value | source |
|---|---|---|
| ``m_RR`` | frame mass by maker and loom width | seed 002, table 1 |
| ``m_heald`` | heald weight / g | seed 002, table 2, row "heald weight" |
| ``n_n`` | threads drawn into one frame | seed 002, table 2, row "threads per frame" |
| ``T_max`` | F_T / (sin a1 + sin a2) at the open shed | seed 002, table 2 note (F_T: vertical |
|  |  | warp force per thread by yarn) and seed 000's shed geometry |
| ``T_min`` | 0.3/0.8 of T_max | assumption: seed 000's ratio T_min/T_max |
| ``l`` | nominal loom width | assumption: seed 000 takes l = 1.8 m for the 180 cm loom |

Print defects of table 2 (checked against its own rows: N_T = n F_T,
heald weight = n x 0.018 N):

* F_T at 280 cm: printed 1.16 N/thread, corrected 0.16 (138.5 N / 860 threads
  = 0.161; the other columns are 0.15-0.18).
* N_T wool at 220 cm: printed 290 N, but 650 x 0.368 = 239 N; the row's
  other columns all equal n x 0.368 within 1 %.  Presets compute N_T = n F_T,
  so they use 239 N.
* N_T cotton at 250 cm: printed 120 N, 760 x 0.17 = 129 N (same reasoning).
* F_T linen: the note prints 0.134; the row is n x 0.135 exactly (67.5 =
  500 x 0.135).  Presets use 0.135.

Table 1's header names the columns MEZ-1 (steel and aluminium), Texo,
Remiz (two aluminium columns, not told apart: "Remiz A", "Remiz B"), Elitex
and Grob.  Table 1 has no 420 cm row, so 420 cm has no preset.
"""
from __future__ import annotations

import math

from loomfmu.declare.checks import check_choice, check_int, check_number

#: Standard gravity (seed 002 writes G = m g; its table 2 gives heald weights in N).
G_STD = 9.80665

#: Loom widths of table 1 (cm).
WIDTHS_CM = (180, 220, 250, 280, 330, 360, 390, 450)
#: Table 1 columns (makers), in the seed's order.
MAKERS = ("MEZ-1 steel", "MEZ-1", "Texo", "Remiz A", "Remiz B", "Elitex", "Grob")
#: Seed 002, table 1: frame mass without healds (kg), rows = WIDTHS_CM.
TABLE1_KG = {
    180: (3.9, 4.8, 4.6, 3.6, 4.6, 5.2, 4.5),
    220: (4.7, 5.8, 5.5, 4.2, 5.4, 6.3, 5.4),
    250: (5.4, 6.7, 6.4, 4.9, 6.3, 7.2, 6.3),
    280: (6.1, 7.6, 7.2, 5.6, 7.0, 7.9, 7.0),
    330: (7.0, 9.1, 8.6, 6.6, 8.4, 9.5, 8.4),
    360: (7.6, 10.1, 9.5, 8.3, 10.3, 10.4, 9.4),
    390: (8.2, 10.9, 10.4, 8.9, 11.1, 11.5, 10.4),
    450: (9.5, 12.5, 12.0, 10.1, 12.4, 13.2, 11.9),
}
#: Seed 002, table 2, by loom width (cm): threads per frame, heald weight (N),
#: frame weight G_rem (N), frame + healds (N), printed F_T (N/thread).
TABLE2 = {
    180: dict(threads=500, heald_N=9.0, G_rem=81.0, G_sum=90.0, F_T=0.18),
    220: dict(threads=650, heald_N=11.8, G_rem=88.2, G_sum=100.0, F_T=0.17),
    250: dict(threads=760, heald_N=13.5, G_rem=99.5, G_sum=113.0, F_T=0.17),
    280: dict(threads=860, heald_N=15.3, G_rem=123.2, G_sum=138.5, F_T=0.16),  # printed 1.16
    330: dict(threads=1000, heald_N=17.7, G_rem=138.3, G_sum=156.0, F_T=0.16),
    360: dict(threads=1100, heald_N=19.5, G_rem=154.0, G_sum=173.5, F_T=0.16),
    390: dict(threads=1200, heald_N=21.3, G_rem=169.7, G_sum=191.0, F_T=0.16),
    420: dict(threads=1300, heald_N=23.2, G_rem=177.8, G_sum=201.0, F_T=0.15),
    450: dict(threads=1400, heald_N=24.1, G_rem=186.4, G_sum=210.5, F_T=0.15),
}
#: Seed 002, table 2 note: vertical warp force per thread (N) by yarn, with
#: the front-shed angle of its row.
YARNS = {"wool": (0.368, 28.0), "cotton": (0.17, 24.0), "linen": (0.135, 18.0)}
DEFAULT_YARN = "cotton"
#: Seed 000's shed geometry, used to turn F_T into a thread tension.
SHED = dict(l_1=0.05, k_z=5.0, h_m=0.029)
#: Seed 000's ratio T_min / T_max.
T_RATIO = 0.3 / 0.8


def preset_names() -> list[str]:
    """Every preset name without yarn (append " wool"/" cotton"/" linen" for a yarn)."""
    return [f"STB-{w} {mk}" for w in WIDTHS_CM for mk in MAKERS]


def parse(name: str) -> tuple[int, str, str]:
    """(width_cm, maker, yarn) of a preset name; ValueError naming the allowed values."""
    if not isinstance(name, str) or not name.startswith("STB-"):
        raise ValueError(f"preset = {name!r}; allowed: 'STB-<width> <maker> [yarn]', e.g. "
                         f"'STB-180 Elitex'; widths {WIDTHS_CM}, makers {MAKERS}, "
                         f"yarns {tuple(YARNS)}")
    head, _, rest = name[4:].partition(" ")
    yarn = DEFAULT_YARN
    for y in YARNS:
        if rest.endswith(" " + y):
            rest, yarn = rest[: -len(y) - 1], y
    if not head.isdigit() or int(head) not in WIDTHS_CM:
        raise ValueError(f"preset = {name!r}: width {head!r} cm is not in table 1; "
                         f"allowed: {WIDTHS_CM}")
    if rest not in MAKERS:
        raise ValueError(f"preset = {name!r}: maker {rest!r} is not in table 1; "
                         f"allowed: {MAKERS}")
    return int(head), rest, yarn


def _shed_sum(l_1: float, k_z: float, h: float) -> float:
    """sin a1 + sin a2 at frame position h (seed 000, fig. 2)."""
    return h / math.hypot(l_1, h) + h / math.hypot(k_z * l_1, h)


def reduced_vertical_mass(l: float) -> float:
    """sum M_y of seed 000's reduced masses for the default section at slat length l (m)."""
    l = check_number("l", l, lo=0.0, lo_open=True, unit="m")
    rho, h1, b1, d1, l_n = 2700.0, 0.1, 0.01, 0.0014, 0.45
    m_l = rho * (h1 * b1 - (h1 - 2 * d1) * (b1 - 2 * d1)) * l
    m_h = rho * 0.03 * 0.006 * 0.35
    return m_l + 2 * m_h + 2 * m_l * (l_n / l) * 33 / 140


#: the heald-frame models a preset applies to, and the preset parameters each
#: lacks (the rigid frame has no slats, so no slat length l)
MODEL_LACKS = {"heald_frame": (), "heald_frame_planar": (), "heald_frame_rigid": ("l",)}


def preset_values(name: str, model: str | None = None) -> dict[str, float]:
    """Parameter values of preset ``name`` (for load_model(preset=...) or FMPy
    start_values).  model: a key of MODEL_LACKS, to get only the parameters
    that model has (e.g. start values for the rigid frame's FMU, which
    refuses names it does not have); None: every preset parameter."""
    if model is not None:
        check_choice("model", model, tuple(MODEL_LACKS))
    width, maker, yarn = parse(name)
    t2 = TABLE2[width]
    m_RR = TABLE1_KG[width][MAKERS.index(maker)]
    l = width / 100.0
    if reduced_vertical_mass(l) > m_RR:
        raise ValueError(f"preset {name!r}: m_RR = {m_RR} kg is less than the slats' "
                         f"reduced masses {reduced_vertical_mass(l):.2f} kg")
    F_T = YARNS[yarn][0]
    T_max = F_T / _shed_sum(SHED["l_1"], SHED["k_z"], SHED["h_m"])
    values = {"l": l, "m_RR": m_RR, "m_heald": t2["heald_N"] / G_STD,
              "n_n": float(t2["threads"]), "T_max": T_max, "T_min": T_RATIO * T_max}
    lacks = MODEL_LACKS[model] if model is not None else ()
    return {k: v for k, v in values.items() if k not in lacks}


def warp_force(width_cm: int, yarn: str) -> float:
    """N_T = n F_T (N): the vertical warp force on the frame at the open shed."""
    width_cm = check_int("width_cm", width_cm, lo=min(TABLE2), hi=max(TABLE2))
    if width_cm not in TABLE2:
        raise ValueError(f"width_cm = {width_cm!r}; allowed: {tuple(TABLE2)}")
    check_choice("yarn", yarn, tuple(YARNS))
    return TABLE2[width_cm]["threads"] * YARNS[yarn][0]
