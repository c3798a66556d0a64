"""Fidelity levels declared as such.

For every model of :data:`loomfmu.registry.FIDELITY` a :class:`Level` says
what the model leaves out, what it still represents, a cost hint (with the
measurement it comes from), the documented case where it suffices, and what
the selector (:mod:`loomfmu.machines.fidelity`) needs to judge whether a scene
exercised what it leaves out:

* ``cut_hz``: the lowest natural frequency the level leaves out (Hz).  A
  scene whose reference outputs carry no content above half of it cannot
  tell the level from the full one by those dynamics.
* ``leaves_out_stick``: the level has no sticking (a regularized friction
  law); a scene whose reference run never sticks does not exercise it.

Adding a level is a declaration here plus the model in the registry; the
selector and ``loomfmu list`` read this table.  A model with build options
that change its fidelity (the modal spindle's ``n_modes``) declares them in
:data:`VARIANTS`, with the cut frequency for each.
"""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Level:
    """One fidelity level: a model of the registry (``model``) of a mechanism."""

    model: str
    mechanism: str
    leaves_out: tuple[str, ...]
    represents: tuple[str, ...]
    cost: str                       # a hint, with the measurement it comes from
    suffices: str                   # the documented case where it is enough
    cut_hz: float | None = None     # lowest natural frequency left out (Hz)
    leaves_out_stick: bool = False  # no sticking (regularized friction)
    sources: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self):
        for name in ("leaves_out", "represents", "sources"):
            items = getattr(self, name)
            if not isinstance(items, tuple) or not all(isinstance(x, str) for x in items):
                raise ValueError(f"Level {self.model!r}: {name} = {items!r:.60}; allowed: "
                                 "a tuple of strings")


#: the heald frame's undamped natural frequencies (Hz), model heald_frame,
#: from its M and C with mu = 0 (docs/guides/heald_claims.md, row "all natural
#: frequencies"): x (horizontal, out of the frame's plane) and y (vertical)
HEALD_MODES_HZ = {"x": (10.1, 47.2, 48.3), "y": (70.0, 162.9, 175.0)}

#: the modal spindle's planar mode frequencies (Hz), undamped, not spinning,
#: film stiffness at 16 000 rpm: the state descriptions of
#: load_model("spindle_modal", n_modes=12) (tests/test_fidelity.py checks them)
SPINDLE_MODES_HZ = (30.5, 411.0, 746.9, 1572.5, 2284.0, 3763.3, 5058.1, 6050.4, 7804.8,
                    10167.5, 18690.1, 20513.7)

_HEALD = ("docs/guides/heald_fidelity.md", "docs/guides/heald_claims.md")
_SPINDLE = ("docs/guides/scene_spinning.md (benchmarks/scene_seeds.py --part fidelity)",
            "docs/guides/spindle.md")

LEVELS: dict[str, Level] = {lv.model: lv for lv in (
    Level("heald_frame_rigid", "heald frame",
          leaves_out=("slat bending in both planes (no x2, y2: the slats move with the frame)",
                      "the frame's natural modes (lowest 10.1 Hz, x)"),
          represents=("the frame's lift h(phi) and its derivatives",
                      "the kinetostatic hinge load N_rem (seed 002)",
                      "the warp elongation dl and tension T at the frame"),
          cost="0.75 x the spatial model's wall time per FMPy run (docs/guides/heald_fidelity.md)",
          suffices="hinge loads N_rem at 1 % with the seed's tension model: 0.9 % of the "
                   "spatial model's range alone (k_z 1 ... 1.1, docs/guides/heald_fidelity.md), "
                   "0.65 % in the loom scene with tension='prescribed'; not with the "
                   "tension returned by the backrest (1.06 %, docs/guides/fidelity.md)",
          cut_hz=HEALD_MODES_HZ["x"][0], sources=_HEALD),
    Level("heald_frame_planar", "heald frame",
          leaves_out=("horizontal (out-of-plane) slat bending x2: no clearance to the "
                      "neighbouring frame",
                      "the x modes (10.1, 47.2, 48.3 Hz)"),
          represents=("vertical slat bending y2 and the y modes (70.0 ... 175.0 Hz)",
                      "hinge load N_rem with the slats' elastic part",
                      "warp elongation and tension"),
          cost="0.91 x the spatial model's wall time (docs/guides/heald_fidelity.md)",
          suffices="N_rem and y2 within 2e-9 of range for k_z 1 ... 5; x2 exactly zero "
                   "for the symmetric frame k_z = 1 (docs/guides/heald_fidelity.md)",
          cut_hz=HEALD_MODES_HZ["x"][0], sources=_HEALD),
    Level("heald_frame", "heald frame",
          leaves_out=("the side stays' own bending (their section is assumed)",),
          represents=("the spatial 6-DOF model of seed 000: slat bending x and y, every "
                      "quantity of the lower levels",),
          cost="the reference (1.00)",
          suffices="the highest level: the reference of the others"),
    Level("backrest_regularized", "backrest",
          leaves_out=("sticking: friction torque -r_f N tanh(w/eps), the pivots creep at "
                      "|w| < eps instead of stopping",),
          represents=("the lever's and roller's motion while slipping", "warp tensions "
                      "S1, S2", "the friction torque's magnitude in sliding"),
          cost="no events; cheaper when the pivots reverse often "
               "(docs/guides/backrest.md, 'Regularized vs event-driven')",
          suffices="warp tension in a scene where the pivots slide throughout (fast loom, "
                   "docs/guides/scene_loom.md: the stick share falls with loom speed)",
          leaves_out_stick=True, sources=("docs/guides/backrest.md",)),
    Level("backrest", "backrest",
          leaves_out=("pivot friction other than Coulomb (no Stribeck, no viscous)",),
          represents=("stick/slip in both pivots as events (modes inside the FMU)",),
          cost="the reference", suffices="the highest level: the reference"),
    Level("spindle_modal", "spindle rotor",
          leaves_out=("modes above the n_modes-th (4 modes: above 1572.5 Hz, i.e. the 5th "
                      "at 2284 Hz and up), and their static (residual) flexibility; with "
                      "static_correction=True only their dynamics (the residual "
                      "flexibility is added to the recovered displacements)",),
          represents=("the first n_modes planar modes per plane, Ritz projection of the FE "
                      "rotor at 16 000 rpm; the blade's unbalance orbit",
                      "static_correction=True: plus the quasi-static response of the "
                      "dropped modes to the unbalance (mode-acceleration method, "
                      "R = K^-1 - B (B^T K B)^-1 B^T)"),
          cost="4 modes 0.20, 8 modes 0.49, 12 modes 1.14 CPU s per simulated s against "
               "3.36 for the full FE (docs/guides/scene_spinning.md); static_correction adds "
               "no state: 4 modes 3.08 vs 3.11 CPU s/s without, full FE 34.9, in "
               "3-revolution fmpy runs incl. start-up "
               "(tests/test_spindle_static_correction.py)",
          suffices="the orbit of the blade's top at constant speed: 0.0 % with 4 modes; "
                   "bearing forces need 12 (within 3 %) (docs/guides/scene_spinning.md), or 4 "
                   "with static_correction=True: bolster -0.75 %, footstep -1.03 %, top "
                   "+0.01 % of the full FE amplitude at 16 000 rpm "
                   "(tests/test_spindle_static_correction.py)",
          sources=_SPINDLE),
    Level("spindle", "spindle rotor",
          leaves_out=("the cone and blade above the FE mesh's resolution (n_low, n_cone "
                      "converged: docs/guides/spindle.md)",),
          represents=("the full FE rotor of seed 003 with its film bearings",),
          cost="3.36 CPU s per simulated s in the spinning scene (docs/guides/scene_spinning.md)",
          suffices="the highest level: the reference", sources=_SPINDLE),
    Level("drive", "spindle drive",
          leaves_out=("load torque of the spindles (no torque input: the coupling is one "
                      "way)",),
          represents=("T n' + n = K u(t - tau) with the layer cam",),
          cost="one level", suffices="the only level"),
    Level("loom_shaft", "loom main shaft",
          leaves_out=("shaft compliance and speed variation under load",),
          represents=("the prescribed shaft speed omega_0",),
          cost="one level", suffices="the only level"),
    Level("two_mass_force", "two-mass benchmark, force side", leaves_out=(),
          represents=("the benchmark's exact equations",), cost="one level",
          suffices="the only level"),
    Level("two_mass_displacement", "two-mass benchmark, displacement side", leaves_out=(),
          represents=("the benchmark's exact equations",), cost="one level",
          suffices="the only level"),
)}

#: build options that change a model's fidelity: model -> option -> values,
#: cheapest first
VARIANTS: dict[str, dict[str, tuple]] = {"spindle_modal": {"n_modes": (4, 8, 12),
                                                           "static_correction": (False, True)}}


def level(model: str) -> Level:
    """The declared level of ``model`` (a model of loomfmu.registry.FIDELITY)."""
    if not isinstance(model, str) or model not in LEVELS:
        raise ValueError(f"model = {model!r:.60}; allowed: one of {', '.join(sorted(LEVELS))}")
    return LEVELS[model]


def cut_frequency(model: str, options: dict | None = None) -> float | None:
    """The lowest natural frequency (Hz) the level ``model`` with build
    ``options`` leaves out; None where it leaves out no mode."""
    lv = level(model)
    if model == "spindle_modal":
        n = int((options or {}).get("n_modes", 4))
        return SPINDLE_MODES_HZ[n] if n < len(SPINDLE_MODES_HZ) else None
    return lv.cut_hz


def undeclared() -> list[str]:
    """Models of loomfmu.registry.FIDELITY without a Level (should be none)."""
    from loomfmu.registry import FIDELITY
    return sorted(m for levels in FIDELITY.values() for m in levels if m not in LEVELS)
