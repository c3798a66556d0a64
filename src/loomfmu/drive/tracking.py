"""The point of seed 001, measured: the drive FMU fed by the compensated and
by the uncompensated cam, tracking error of the spindle speed against the
optimal law n0(t) after the transient, for several delays and time constants.

    loomfmu drive tracking [--out docs/guides/drive_tracking.md]

Each (tau, T) gets its own cam table (the compensated cam inverts the drive
it is made for), set as FMU parameters at run time: one FMU, no rebuild.
The FMU starts at the cam's periodic steady-state speed n_start; its
constant-history start still leaves a transient that decays as exp(-t/T),
which the error measure skips (30 T + tau, loomfmu.drive.tracking_error).
The error is compared at equal cam angle (the cam turns with the spindles).
"""
from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

from loomfmu.declare.checks import check_array, check_bool, check_int, check_number
from loomfmu.fmu.builder import build_fmu
from loomfmu.fmu.platforms import HOST
from loomfmu.mechanics.drive_law import MAX_HARMONICS, law_constants
from loomfmu.mechanics.drive_params import RAD_S, DriveParams, check_params
from loomfmu.mechanics.layer_cam import cam_profile_phi, fmu_cam_parameters, tracking_error
from loomfmu.registry import load_model
from loomfmu.verification.verify import simulate

M_HARMONICS = 40    # harmonics of n0 the cam reproduces
TAUS = (0.25, 0.5, 1.0)
TIME_CONSTANTS = (1.0, 2.0, 4.0)


def cam_values(p: DriveParams, m: int, compensate: bool, harmonics: int) -> dict:
    """FMU start values for a cam designed for p (delay, time constant, law);
    harmonics: the drive model's cam-table size (1 ... 512)."""
    check_params(p)
    m = check_int("m", m, lo=1, hi=MAX_HARMONICS)
    compensate = check_bool("compensate", compensate)
    harmonics = check_int("harmonics", harmonics, lo=1, hi=512)
    A0, A, B = cam_profile_phi(p, m, compensate=compensate, M=harmonics)
    n_start = fmu_cam_parameters(p, m, compensate=compensate)["n_start"]
    values = {"tau": p.tau, "T": p.T, "cam_A0": A0, "n": n_start * RAD_S}
    for j, (a, b) in enumerate(zip(A, B), 1):
        values[f"cam_A{j}"] = float(a)
        values[f"cam_B{j}"] = float(b)
    return values


def tracking_rows(taus=TAUS, time_constants=TIME_CONSTANTS, m: int = M_HARMONICS,
                  rtol: float = 1e-8) -> list[dict]:
    """Tracking errors (rpm) of the drive FMU under the compensated and the
    uncompensated cam for every tau in ``taus`` (s, > 0) and T in
    ``time_constants`` (s, > 0); m: harmonics of n0 (1 ... MAX_HARMONICS);
    rtol: FMU tolerance, in [1e-12, 1e-2]."""
    taus = check_array("taus", taus, lo=1e-6, hi=5.0, unit="s")
    time_constants = check_array("time_constants", time_constants, lo=1e-6, hi=100.0,
                                 unit="s")
    m = check_int("m", m, lo=1, hi=MAX_HARMONICS)
    rtol = check_number("rtol", rtol, lo=1e-12, hi=1e-2)
    model = load_model("drive")
    harmonics = model.options["harmonics"]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_fmu(model, out_dir=tmp, validate=False, platforms=HOST,
                    reference_results=False).path
        for tau in taus:
            for T in time_constants:
                p = dataclasses.replace(DriveParams(), tau=float(tau), T=float(T))
                t_end = 30 * T + tau + 2 * law_constants(p).P
                row = {"tau_s": float(tau), "T_s": float(T)}
                for label, comp in (("compensated", True), ("uncompensated", False)):
                    run = simulate(fmu, solver="dopri5", rtol=rtol, atol=1e-6,
                                   stop_time=t_end, output_interval=0.01,
                                   output=["n_out", "phi_out"],
                                   values=cam_values(p, m, comp, harmonics))
                    n = run.y["n_out"] / RAD_S
                    row[f"{label}_vs_law_rpm"] = tracking_error(run.t, n, p, None,
                                                                phi=run.y["phi_out"])
                    row[f"{label}_vs_series_rpm"] = tracking_error(run.t, n, p, m,
                                                                   phi=run.y["phi_out"])
                    row[f"{label}_fmu_s"] = run.wall_seconds
                rows.append(row)
    return rows


#: the cam of the mismatch study is designed for DriveParams()' (tau, T) and
#: runs on drives whose delay and time constant differ by these factors
MISMATCH = (0.8, 1.0, 1.2)


def mismatch_rows(factors=MISMATCH, m: int = M_HARMONICS, rtol: float = 1e-8) -> list[dict]:
    """Tracking errors (rpm, against n0) of cams designed for the assumed
    drive (DriveParams: tau, T) on drives whose tau and T are those times
    ``factors`` (each in [0.1, 10]): how much of the compensation is left
    when the drive is not the one the cam was made for.  The uncompensated
    cam beside it, designed for the same law."""
    factors = check_array("factors", factors, lo=0.1, hi=10.0)
    m = check_int("m", m, lo=1, hi=MAX_HARMONICS)
    rtol = check_number("rtol", rtol, lo=1e-12, hi=1e-2)
    model = load_model("drive")
    harmonics = model.options["harmonics"]
    design = DriveParams()
    cams = {comp: cam_values(design, m, comp, harmonics) for comp in (True, False)}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_fmu(model, out_dir=tmp, validate=False, platforms=HOST,
                    reference_results=False).path
        for f_tau in factors:
            for f_T in factors:
                plant = dataclasses.replace(design, tau=design.tau * float(f_tau),
                                            T=design.T * float(f_T))
                t_end = 30 * plant.T + plant.tau + 2 * law_constants(plant).P
                row = {"tau_s": plant.tau, "T_s": plant.T}
                for label, comp in (("compensated", True), ("uncompensated", False)):
                    run = simulate(fmu, solver="dopri5", rtol=rtol, atol=1e-6,
                                   stop_time=t_end, output_interval=0.01,
                                   output=["n_out", "phi_out"],
                                   values={**cams[comp], "tau": plant.tau, "T": plant.T})
                    row[f"{label}_vs_law_rpm"] = tracking_error(
                        run.t, run.y["n_out"] / RAD_S, plant, None, phi=run.y["phi_out"])
                rows.append(row)
    return rows


def mismatch_markdown(rows: list[dict], m: int = M_HARMONICS) -> str:
    d = DriveParams()
    lines = [
        "",
        "## The cam of one drive on another",
        "",
        f"Cams of m = {m} harmonics designed for tau = {d.tau:g} s, T = {d.T:g} s (the "
        "assumed drive), run on drives whose delay and time constant differ from those; "
        "max |n - n0| in rpm, measured as above (after 30 T + tau of the drive run):",
        "",
        "| drive tau (s) | drive T (s) | compensated vs law | uncompensated vs law |",
        "|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['tau_s']:g} | {r['T_s']:g} | {r['compensated_vs_law_rpm']:.3g} | "
                     f"{r['uncompensated_vs_law_rpm']:.4g} |")
    return "\n".join(lines) + "\n"


def tracking_markdown(rows: list[dict], m: int = M_HARMONICS) -> str:
    lines = [
        "# Drive tracking error: compensated vs uncompensated cam",
        "",
        "Generated by `loomfmu drive tracking`: the drive FMU (dopri5, rtol 1e-8, "
        f"history on the dense output), cams of m = {m} harmonics designed for each (tau, T); "
        "max |n - n0| in rpm over whole periods after 30 T + tau, at equal cam angle; "
        f"'series' = against the {m}-term Fourier series of n0 (what a truncated cam can "
        "reproduce at best), 'law' = against n0 itself.",
        "",
        "| tau (s) | T (s) | compensated vs series | compensated vs law | uncompensated vs law |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['tau_s']:g} | {r['T_s']:g} | {r['compensated_vs_series_rpm']:.3g} "
                     f"| {r['compensated_vs_law_rpm']:.3g} | "
                     f"{r['uncompensated_vs_law_rpm']:.4g} |")
    return "\n".join(lines) + "\n"


def write_tracking(out: Path) -> str:
    text = tracking_markdown(tracking_rows()) + mismatch_markdown(mismatch_rows())
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    return text
