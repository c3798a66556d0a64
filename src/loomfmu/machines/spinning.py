"""The spinning position: the spindle drive with its layer cam feeding the
spindle rotor (seeds 001 and 003).

    drive (models/drive.py)  --spindles -> drive-->  spindle (spindle_modal or spindle)
           n_out [rad/s, shown in rpm]                 Omega [rad/s, shown in rpm]

The drive's speed follows the layer cam's speed law (12 000 -> 15 000 rpm
over a layer of T_c + T_n = 15 s with the assumed machine values); the
spindle's unbalance response (vibration of the blade's top, forces of the
bolster and footstep bearings) follows the speed.  The coupling is one way
(the spindle's load torque is not fed back: the drive model has no torque
input), so no master can make it unstable; the communication step sets the
error only (docs/guides/scene_spinning.md).

The spindle starts on its periodic unbalance solution at the drive's start
speed (loomfmu.spindle.start.periodic_start), so it does not ring.
"""
from __future__ import annotations

import math

from loomfmu.declare.checks import check_choice, check_number
from loomfmu.scene.declare import Scene, declare_model
from loomfmu.spindle.start import periodic_start

#: one layer cycle (s): T_c + T_n of loomfmu.drive.DriveParams
LAYER_CYCLE = 15.0
#: the spindle models a scene can use, cheapest first
FIDELITIES = ("spindle_modal", "spindle")
#: the drive's cam tables (build option ``cam`` of models/drive.py)
CAMS = ("compensated", "uncompensated", "none")
#: what the scene records
RECORDED = ("drive.n_out", "drive.r", "spindle.x_top", "spindle.r_top", "spindle.r_footstep",
            "spindle.F_upper", "spindle.F_lower")


def start_speed(cam: str = "compensated") -> float:
    """The drive's speed at t = 0 (rpm): its state n (rad/s) starts at the
    steady state of the cam signal at the cam's start angle (models/drive.py)."""
    return float(declare_model("drive", {"cam": cam}).var("n").start) * 60.0 / (2 * math.pi)


#: the master the scene recommends (docs/guides/scene_spinning.md, verdict): the
#: drive's speed is smooth and the spindle, stepping after the drive,
#: interpolates its newest value; 1e-3 of the vibration's phase at H = 0.1 s
RECOMMENDED = {"master": "gauss-seidel", "extrapolation": 2}


def scene(*, cam: str = "compensated", fidelity: str = "spindle",
          stop_time: float = LAYER_CYCLE, step: float = 1e-2,
          drive_parameters: dict | None = None, n_const: float | None = None,
          spindle_options: dict | None = None) -> Scene:
    """The spinning-position scene.

    cam: the drive's cam table, one of CAMS ("compensated": the cam inverts
    the drive's lag and delay; "uncompensated": proportional to the speed
    law; "none": constant speed n_min); fidelity: the spindle model, one of
    FIDELITIES; stop_time, step (s): the defaults of a run (10 ms: the
    amplitudes and forces are within 0.4 % with any master; the vibration's
    phase needs extrapolation order 2, docs/guides/scene_spinning.md), run
    by default on the RECOMMENDED master;
    drive_parameters: parameter values of the drive FMU; n_const: a constant
    drive speed (rpm, 1000 ... 40000) instead of the cam's law (the cam
    switched off, cam_on = 0, and n_min = n_const converted to rad/s);
    spindle_options: build
    options of the spindle model (e.g. ``{"n_modes": 8}`` for spindle_modal).
    """
    cam = check_choice("cam", cam, CAMS)
    fidelity = check_choice("fidelity", fidelity, FIDELITIES)
    params = dict(drive_parameters or {})
    if n_const is not None:
        n_const = check_number("n_const", n_const, lo=1000.0, hi=40000.0, unit="rpm")
        params.update({"cam_on": 0.0, "n_min": n_const * 2 * math.pi / 60.0})
        n0 = n_const
    else:
        n0 = start_speed(cam)
    s = Scene("spinning", description="spinning position: the drive with its layer cam "
              f"({cam}) feeding the spindle rotor ({fidelity})", stop_time=stop_time,
              step=step, **RECOMMENDED)
    s.add("drive", model="drive", options={"cam": cam}, parameters=params)
    options = dict(spindle_options or {})
    s.add("spindle", model=fidelity, options=options,
          start=periodic_start(fidelity, n_rpm=n0, options=options))
    s.connect("drive.spindles", "spindle.drive")
    s.record(*RECORDED)
    return s
