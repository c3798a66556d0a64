"""The loom: a main shaft driving two heald frames in opposition (plain
weave) whose shed stretches the warp, and the backrest (whip roll) taking
up the warp and returning its tension to the frames (seeds 000,
002, 004).

    shaft (loom_shaft) --frames -> shaft--> frame_a, frame_b (heald_frame*)
    frame_a.warp <-> back.warp_front_a      elongation dl ->, <- tension
    frame_b.warp <-> back.warp_front_b

The frames' motion law alternates each revolution, H(phi + 2 pi) = -H(phi)
(models/heald_common.py): the frame in opposition runs one revolution
ahead, phi_b = phi_a + 2 pi (phi_b = phi_a + pi would put it a quarter of
its cycle behind, at the middle when the other is at the bottom).  The
scene starts at the closed shed, phi_a = pi and phi_b = 3 pi (both frames
at the middle, h = 0, dl = 0), where the backrest's start, its static
equilibrium with every elongation zero, is consistent with the frames; at
phi_a = 0 the frames would impose the full shed's elongation on a backrest
at rest, a step that makes it ring and slackens the warp.

tension="returned": the frames take their ends' tension from the backrest
(heald frame build option warp_tension="input"); tension="prescribed": the
seed's model, each frame computes its tension from its own shed
(warp_tension="geometry") and the backrest is only driven by the shed's
elongation (the tension is not returned).  Both frames stretch their ends
by the same dl (dl is even in H), so the sheet's upper branch sees that
elongation.

The models' defaults agree: each frame carries
n_n = 1000 ends and the backrest's sheet is both frames' ends, its S0 and
c2 from the heald frame's tension law (models/backrest.py); the shaft turns
at the backrest's loom speed, 240 picks/min (8 pi rad/s); the backrest's
built-in shedding is off (build option shedding=False) and it has a front
port per frame (fronts=2).
"""
from __future__ import annotations

import math

from loomfmu.declare.checks import check_choice, check_number
from loomfmu.scene.declare import Scene

#: the ways the frames get their warp tension
TENSIONS = ("returned", "prescribed")
#: heald-frame models a scene can use, cheapest first
FRAMES = ("heald_frame_rigid", "heald_frame_planar", "heald_frame")
#: backrest models (events: stick/slip state machine; regularized: tanh)
BACKRESTS = ("backrest", "backrest_regularized")
_COMMON = ("shaft.omega_out", "frame_a.h", "frame_b.h", "frame_a.dl", "frame_a.T",
           "frame_b.T", "frame_a.f_x", "back.S2a", "back.S2b", "back.phi1_out",
           "back.phi2_out", "back.omega1_out", "back.omega2_out", "back.M1f_out",
           "back.M2f_out")
#: what the scene records, by frame model (the rigid frame has no slat motion)
RECORDED = {"heald_frame_rigid": _COMMON,
            "heald_frame_planar": _COMMON + ("frame_a.y2_out", "frame_b.y2_out"),
            "heald_frame": _COMMON + ("frame_a.x2_out", "frame_b.x2_out", "frame_a.y2_out",
                                      "frame_b.y2_out")}
#: shaft angle of frame A at the start (rad): the closed shed (h = 0, dl = 0)
PHI_CLOSED = math.pi
#: frame B runs one revolution ahead of A (rad): in opposition
PHI_OPPOSITION = 2 * math.pi


def pick_time(omega: float = 8 * math.pi) -> float:
    """One pick (one shaft revolution) at ``omega`` rad/s (s)."""
    return 2 * math.pi / omega


#: the master and step the scene recommends (docs/guides/scene_loom.md,
#: verdict): error 1.1e-4 at H = 2 ms, 1.8e-3 at 5 ms, against 1 % at 0.5 ms
#: holding the inputs; from 20 ms the extrapolated tension can go negative
RECOMMENDED = {"master": "gauss-seidel", "extrapolation": 2}
#: the recommended communication step (s)
STEP = 2e-3


def scene(*, tension: str = "returned", frame: str = "heald_frame",
          backrest: str = "backrest", omega: float = 8 * math.pi,
          stop_time: float = 1.0, step: float = STEP) -> Scene:
    """The loom scene.

    tension: one of TENSIONS; frame: the heald-frame model (FRAMES); backrest:
    the backrest model (BACKRESTS); omega: main-shaft speed (rad/s, 1 ... 100);
    stop_time, step (s): the defaults of a run, on the RECOMMENDED master
    (Gauss-Seidel, extrapolation order 2) unless the run gives another.
    """
    tension = check_choice("tension", tension, TENSIONS)
    frame = check_choice("frame", frame, FRAMES)
    backrest = check_choice("backrest", backrest, BACKRESTS)
    omega = check_number("omega", omega, lo=1.0, hi=100.0, unit="rad/s")
    returned = tension == "returned"
    s = Scene("loom", description=f"loom: main shaft, two heald frames ({frame}) in "
              f"opposition, backrest ({backrest}); warp tension {tension}",
              stop_time=stop_time, step=step, **RECOMMENDED)
    s.add("shaft", model="loom_shaft", parameters={"omega_0": omega})
    f_opts = {"warp_tension": "input" if returned else "geometry"}
    for name, phi0 in (("frame_a", PHI_CLOSED), ("frame_b", PHI_CLOSED + PHI_OPPOSITION)):
        s.add(name, model=frame, options=f_opts, start={"phi": phi0})
        s.connect("shaft.frames", f"{name}.shaft")
    b_opts = {"shedding": False, "fronts": 2}
    s.add("back", model=backrest, options=b_opts)
    # port to port: the roles both ends have (prescribed: the elongation only)
    s.connect("frame_a.warp", "back.warp_front_a")
    s.connect("frame_b.warp", "back.warp_front_b")
    s.record(*RECORDED[frame])
    return s
