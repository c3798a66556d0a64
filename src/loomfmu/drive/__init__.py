"""Spindle drive with pure delay and the layer cam that compensates it (seed 001).

The laws the drive model is declared with live in :mod:`loomfmu.mechanics`
and are re-exported here:

* :mod:`loomfmu.mechanics.drive_params`: :class:`DriveParams` (machine
  values, all assumptions);
* :mod:`loomfmu.mechanics.drive_law`: the optimal speed law n0(t) of (5)-(7),
  its slope, cumulative revolutions and Fourier series (8);
* :mod:`loomfmu.mechanics.layer_cam`: the compensated cam (3), cam angle (4),
  profile r(phi) as a Fourier table for the drive FMU, periodic steady state
  of the drive, and the tracking error.

The analyses: :mod:`.report` (``loomfmu drive {table, charts}``) and
:mod:`.tracking` (``loomfmu drive tracking``).

Speeds are rev/s inside, rpm only at the edges (:data:`RPM`); the drive FMU's
speeds are rad/s (shown in rpm), converted where values go in and out.

May import: every layer below the mechanism packages; not another
mechanism's package.
"""
from loomfmu.mechanics.drive_law import (
                  LawConstants,
                  amplitude_phase,
                  fourier,
                  invert_increasing,
                  law_constants,
                  revolutions,
                  series,
                  speed_law,
                  speed_slope,
                  trig_eval,
)
from loomfmu.mechanics.drive_params import RPM, DriveParams
from loomfmu.mechanics.layer_cam import (
                  U_z,
                  cam_angle,
                  cam_coefficients,
                  cam_from_fourier,
                  cam_profile_phi,
                  cam_radius,
                  cam_radius_ideal,
                  drive_response_coefficients,
                  f_rad,
                  fmu_cam_parameters,
                  forward_gain,
                  ideal_radius_at_reversals,
                  inverse_gain,
                  pressure_angle,
                  profile_error,
                  profile_radius,
                  simulate_drive_steady,
                  time_of_angle,
                  tracking_error,
)

__all__ = [
    "DriveParams", "LawConstants", "RPM", "U_z", "amplitude_phase", "cam_angle",
    "cam_coefficients", "cam_from_fourier", "cam_profile_phi", "cam_radius",
    "cam_radius_ideal", "drive_response_coefficients", "f_rad", "fmu_cam_parameters",
    "forward_gain", "fourier", "ideal_radius_at_reversals", "inverse_gain",
    "invert_increasing", "law_constants", "pressure_angle", "profile_error", "profile_radius",
    "revolutions", "series", "simulate_drive_steady", "speed_law", "speed_slope",
    "time_of_angle", "tracking_error", "trig_eval",
]
