"""The seeds' studies, as sweeps (``loomfmu sweep design-map|drive-grid|hinge``).

design_map   heald frame (seed 000): slat width b1 and wall thickness d1
             against max |x2| (the top slat's mid-section out of the frame
             plane, towards the neighbouring frame) over loom widths (the
             seed-002 presets of one maker) and shed asymmetries k_z; the
             figure of ``loomfmu heald design`` (loomfmu.heald.claims.max_x2:
             max |x2_out| over two frame cycles, 1 ms samples), on the FMU.
drive_grid   spindle drive (seed 001): tracking error of the spindle speed
             against the optimal law over delays tau and time constants T,
             compensated and uncompensated cam (the figures and settings of
             ``loomfmu drive tracking``: loomfmu.drive.tracking).
hinge        heald frame, rigid (seed 002): the drive hinge's load N_rem
             over all presets and main-shaft speeds, one frame cycle.
loom_stick   the loom composed into one model (seeds 000, 002, 004): picks
             per minute against the backrest's preload (its static warp
             tension S0, from which seed 004 (8) sets the spring's preload
             F_0), the share of the time the backrest sticks (either pivot
             held, |omega| < STICK_SPEED) and the peak load of frame a's drive
             hinge, over one second (4 picks at 240 picks/min).
trends       spindle rotor (seed 003): the trend studies of ``loomfmu rotor
             trends`` on the full spindle FMU, started on the periodic
             unbalance orbit (loomfmu.spindle.start), orbit radii of the top
             and the bottom of the blade over two revolutions at 16 000 rpm.

Every ``prepare_*`` and figure function is module level: dask workers
import them by name.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

# imported here, not in the functions: a worker's warm-up imports this module
# and with it everything its cases need (see loomfmu.sweep.run)
from loomfmu.declare.checks import check_array, check_choice
from loomfmu.drive.tracking import M_HARMONICS, cam_values
from loomfmu.heald.hinge import KINETOSTATIC_PARAMETERS, hinge_load_kinetostatic
from loomfmu.mechanics.drive_law import law_constants
from loomfmu.mechanics.drive_params import RAD_S, DriveParams
from loomfmu.mechanics.heald_presets import MAKERS, preset_names, preset_values
from loomfmu.mechanics.layer_cam import tracking_error
from loomfmu.registry import load_model
from loomfmu.spindle.start import periodic_start
from loomfmu.spindle.study import WORK_RPM, Spindle, amplitude_table
from loomfmu.spindle.trends import STUDIES as ROTOR_STUDIES
from loomfmu.sweep.figures import Derived, Figure
from loomfmu.sweep.space import grid
from loomfmu.sweep.study import Study

# --- heald frame design map (seed 000) -------------------------------------

#: loom widths (cm) of the design map: presets of seed 002 table 1
MAP_WIDTHS_CM = (180, 280, 390)
MAP_MAKER = "Texo"
MAP_K_Z = (3.0, 5.0)
MAP_D1 = (0.001, 0.0014, 0.002)
MAP_B1 = tuple(float(b) for b in np.round(np.geomspace(0.005, 0.1, 14), 5))
#: frame cycles of the design figure (as loomfmu.heald.claims.run)
MAP_CYCLES = 2


@functools.lru_cache(maxsize=None)
def _model(name: str):
    return load_model(name)


def prepare_design(case: dict, fixed: dict) -> tuple[dict, float]:
    """Preset of width ``width_cm`` (maker ``fixed['maker']``), shed asymmetry
    k_z, section b1, d1; two frame cycles. ValueError (the case is invalid,
    not run) when the wall is not thinner than half the width or a
    constraint of the model fails."""
    values = preset_values(f"STB-{int(case['width_cm'])} {fixed['maker']}")
    values.update(k_z=case["k_z"], b1=case["b1"], d1=case["d1"])
    if not 2 * values["d1"] < values["b1"]:
        raise ValueError(f"d1 = {values['d1']!r} m; allowed: < b1/2 = {values['b1'] / 2!r} m "
                         "(the wall must be thinner than half the width)")
    _model("heald_frame").check_constraints(values)
    omega = fixed.get("omega", 60.0)
    values["omega"] = omega
    return values, MAP_CYCLES * 4 * math.pi / omega


def design_map(widths_cm=MAP_WIDTHS_CM, k_z=MAP_K_Z, d1=MAP_D1, b1=MAP_B1, *,
               maker: str = MAP_MAKER, rtol: float = 1e-8) -> Study:
    """The design map's study (see the module)."""
    check_choice("maker", maker, MAKERS)
    return Study("heald_frame", cases=grid(width_cm=list(widths_cm), k_z=list(k_z),
                                           d1=list(d1), b1=list(b1)),
                 figures=[Figure("max_abs", "x2_out")], stop_time=MAP_CYCLES * 4 * math.pi / 60,
                 output_interval=1e-3, rtol=rtol, atol=1e-11, fixed={"maker": maker},
                 prepare=prepare_design, name="design_map")


def smallest_b1(rows: list[dict], gap: float) -> list[dict]:
    """Reduction of the design map: for each (width, k_z, d1) the smallest
    b1 whose max |x2| <= gap, interpolated in log-log between the grid's
    neighbours (None where no b1 of the grid meets the gap, or the narrowest
    already does: then the grid's edge is reported)."""
    out = []
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r["status"] == "ok":
            groups.setdefault((r["width_cm"], r["k_z"], r["d1"]), []).append(r)
    for (w, kz, d1), rs in sorted(groups.items()):
        rs = sorted(rs, key=lambda r: r["b1"])
        b = np.array([r["b1"] for r in rs])
        x = np.array([r["max_abs_x2_out"] for r in rs])
        ok = np.nonzero(x <= gap)[0]
        row = {"width_cm": w, "k_z": kz, "d1": d1, "gap": gap, "b1_min": None, "note": ""}
        if not len(ok):
            row["note"] = f"no b1 <= {b[-1]} m meets the gap"
        elif ok[0] == 0:
            row["note"] = f"already b1 = {b[0]} m meets the gap"
        else:
            j = ok[0]
            lb, lx = np.log(b[j - 1:j + 1]), np.log(x[j - 1:j + 1])
            row["b1_min"] = float(np.exp(lb[0] + (math.log(gap) - lx[0]) * (lb[1] - lb[0])
                                         / (lx[1] - lx[0])))
        out.append(row)
    return out


# --- drive tracking grid (seed 001) ----------------------------------------

GRID_TAU = (0.1, 0.25, 0.5, 1.0)
GRID_T = (0.5, 1.0, 2.0, 4.0)


def _drive_params(case: dict):
    return dataclasses.replace(DriveParams(), tau=float(case["tau"]), T=float(case["T"]))


def prepare_drive(case: dict, fixed: dict) -> tuple[dict, float]:
    """Cam table of m = fixed['m'] harmonics designed for (tau, T),
    compensated or not, in the drive FMU's ``fixed['harmonics']`` slots; the
    run ends two law periods after the transient (30 T + tau)."""
    p = _drive_params(case)
    values = cam_values(p, fixed["m"], bool(case["compensate"]), fixed["harmonics"])
    return values, 30 * p.T + p.tau + 2 * law_constants(p).P


def drive_error_law(t, y, case) -> float:
    """max |n - n0| (rpm) after the transient, at equal cam angle."""
    return tracking_error(t, y["n_out"] / RAD_S, _drive_params(case), None, phi=y["phi_out"])


def drive_error_series(t, y, case) -> float:
    """max |n - n0's m-term series| (rpm): what a truncated cam can reach."""
    return tracking_error(t, y["n_out"] / RAD_S, _drive_params(case), M_HARMONICS,
                          phi=y["phi_out"])


def drive_grid(taus=GRID_TAU, time_constants=GRID_T, *, rtol: float = 1e-8) -> Study:
    """The drive tracking grid's study (see the module)."""
    taus = check_array("taus", taus, lo=1e-6, hi=5.0, unit="s")
    time_constants = check_array("time_constants", time_constants, lo=1e-6, hi=100.0,
                                 unit="s")
    harmonics = _model("drive").options["harmonics"]
    t_max = max(30 * T + tau for T in time_constants for tau in taus)
    return Study("drive", cases=grid(tau=list(taus), T=list(time_constants),
                                     compensate=[True, False]),
                 figures=[Derived("vs_law_rpm", drive_error_law, ("n_out", "phi_out")),
                          Derived("vs_series_rpm", drive_error_series, ("n_out", "phi_out"))],
                 stop_time=t_max + 10.0, output_interval=0.01, rtol=rtol, atol=1e-6,
                 fixed={"m": M_HARMONICS, "harmonics": harmonics}, prepare=prepare_drive,
                 name="drive_grid")


# --- hinge loads over all presets (seed 002) -------------------------------

HINGE_OMEGA = (40.0, 60.0, 80.0)


def prepare_hinge(case: dict, fixed: dict) -> tuple[dict, float]:
    """Preset number ``preset`` (index into preset_names()) on the rigid
    frame at main-shaft speed ``omega`` (rad/s); one frame cycle."""
    names = preset_names()
    i = case["preset"]
    if not isinstance(i, int) or not 0 <= i < len(names):
        raise ValueError(f"preset = {i!r}; allowed: an integer in [0, {len(names) - 1}]")
    values = preset_values(names[i], model="heald_frame_rigid")
    values["omega"] = case["omega"]
    return values, 4 * math.pi / case["omega"]


def hinge(omegas=HINGE_OMEGA) -> Study:
    """Hinge loads of every preset at each speed (see the module)."""
    return Study("heald_frame_rigid",
                 cases=grid(preset=list(range(len(preset_names()))), omega=list(omegas)),
                 figures=[Figure("max", "N_rem"), Figure("min", "N_rem")],
                 stop_time=4 * math.pi / min(omegas), output_interval=1e-4, rtol=1e-8,
                 atol=1e-10, prepare=prepare_hinge, name="hinge")


def hinge_closed_form(rows: list[dict], samples: int = 200_001) -> float:
    """Largest difference, relative to the load's range, between each case's
    max/min N_rem and seed 002's kinetostatic closed form
    (loomfmu.heald.hinge.hinge_load_kinetostatic) over one frame cycle."""
    starts = {v.name: v.start for v in _model("heald_frame_rigid").of_kind("parameter")}
    names = preset_names()
    phi = np.linspace(0.0, 4 * math.pi, samples)
    worst = 0.0
    for r in rows:
        if r["status"] != "ok":
            continue
        values = {**starts, **preset_values(names[r["preset"]], model="heald_frame_rigid"),
                  "omega": r["omega"]}
        N = hinge_load_kinetostatic(phi, **{k: values[k] for k in KINETOSTATIC_PARAMETERS})
        diff = max(abs(N.max() - r["max_N_rem"]), abs(N.min() - r["min_N_rem"]))
        worst = max(worst, diff / (N.max() - N.min()))
    return worst


# --- spindle trend studies (seed 003) --------------------------------------

#: the studies of loomfmu.spindle.trends that change run-time parameters (the
#: spring-turns study changes a build option: not here)
TRENDS = ("lower_support", "upper_support", "blade_diameter", "support_distance")
TREND_REVS = 3  # revolutions run; the first is skipped by the figures


def prepare_trend(case: dict, fixed: dict) -> tuple[dict, float]:
    """Trend study TRENDS[case['trend']] at x = case['x'] (its factor or
    value), applied to the base values in ``fixed`` as loomfmu.spindle.trends
    does; start on the periodic orbit of (15) at fixed['n_rpm'] (rpm; the
    FMU's input Omega is set in rad/s)."""
    i = case["trend"]
    if not isinstance(i, int) or not 0 <= i < len(TRENDS):
        raise ValueError(f"trend = {i!r}; allowed: an integer in [0, {len(TRENDS) - 1}]")
    opts, over = ROTOR_STUDIES[TRENDS[i]][2](case["x"], fixed["base"])
    if opts:
        raise ValueError(f"trend {TRENDS[i]}: changes build options {opts}; allowed: "
                         "run-time parameters only")
    n, ecc = fixed["n_rpm"], fixed["ecc"]
    values = periodic_start("spindle", n_rpm=n, e_b=ecc, e_w=ecc, parameters=over)
    values.update(over, Omega=n * RAD_S / 60.0, e_b=ecc, e_w=ecc)
    return values, TREND_REVS * 60.0 / n


def trends() -> Study:
    """The spindle trend studies on the FMU (see the module)."""
    base = Spindle({})
    ecc = amplitude_table(base, 0.0)["eccentricity_m"]  # as loomfmu rotor trends
    cases = [{"trend": i, "x": float(x)} for i, name in enumerate(TRENDS)
             for x in ROTOR_STUDIES[name][1]]
    rev = 60.0 / WORK_RPM
    v = base.values()
    return Study("spindle", cases=cases,
                 figures=[Figure("max", "r_top", after=rev), Figure("min", "r_top", after=rev),
                          Figure("max", "r_footstep", after=rev)],
                 stop_time=TREND_REVS * rev, output_interval=rev / 200, rtol=1e-8, atol=1e-12,
                 fixed={"n_rpm": WORK_RPM, "ecc": ecc,
                        "base": {k: float(v[k]) for k in ("k_f", "a_s", "k_u")}},
                 prepare=prepare_trend, name="trends")


def trends_against_15(rows: list[dict], ecc: float) -> list[dict]:
    """Each case's FMU radii next to (15)'s A1, A2 (loomfmu.spindle.trends,
    the same study at the same eccentricity), with the relative differences
    and the top radius' drift over the recorded revolutions."""
    from loomfmu.spindle.trends import run_study as rotor_study
    ref = {name: {r["x"]: r for r in rotor_study(name, ecc)["rows"]} for name in TRENDS}
    out = []
    for r in rows:
        name = TRENDS[r["trend"]]
        a = ref[name].get(r["x"])
        row = {"study": name, "x": r["x"], "status": r["status"]}
        if r["status"] == "ok" and a is not None:
            row.update(A1_fmu=r["max_r_top"], A2_fmu=r["max_r_footstep"], A1_15=a["A1"],
                       A2_15=a["A2"], dA1=abs(r["max_r_top"] / a["A1"] - 1),
                       dA2=abs(r["max_r_footstep"] / a["A2"] - 1),
                       drift=(r["max_r_top"] - r["min_r_top"]) / r["max_r_top"])
        out.append(row)
    return out


# --- the loom as one model: speed against the backrest's preload ---------

#: picks per minute (the main shaft's turns per minute) and the backrest's
#: preload as a factor of its declared static warp tension S0
LOOM_PPM = (180.0, 240.0, 300.0)
LOOM_PRELOAD = (0.7, 1.0, 1.3)
LOOM_STOP = 1.0


def prepare_loom(case: dict, fixed: dict) -> tuple[dict, None]:
    """The shaft's speed from picks per minute, the backrest's S0 scaled."""
    return {"shaft.omega_0": case["ppm"] * 2 * math.pi / 60.0,
            "back.S0": fixed["S0"] * case["preload"]}, None


def stick_share(t, y, case) -> float:
    """The share of the samples where either pivot of the backrest is held
    (the event-driven backrest holds a stuck pivot's speed at exactly 0)."""
    from loomfmu.machines.fidelity import STICK_SPEED
    stuck = (np.abs(y["back.omega1_out"]) < STICK_SPEED) | (
        np.abs(y["back.omega2_out"]) < STICK_SPEED)
    return float(np.mean(stuck))


def loom_stick(ppm=LOOM_PPM, preload=LOOM_PRELOAD, *, stop_time: float = LOOM_STOP) -> Study:
    """The loom study on the loom scene composed into one FMU (see the module)."""
    from loomfmu.machines.loom import scene
    from loomfmu.scene.compose import compose
    ppm = check_array("ppm", ppm, lo=60.0, hi=900.0, unit="picks/min")
    preload = check_array("preload", preload, lo=0.1, hi=10.0)
    m = compose(scene(stop_time=stop_time))
    return Study(m.name, declaration=m, cases=grid(ppm=list(ppm), preload=list(preload)),
                 figures=[Derived("stick_share", stick_share,
                                  ("back.omega1_out", "back.omega2_out")),
                          Figure("max_abs", "frame_a.N_rem")],
                 stop_time=stop_time, output_interval=1e-3,
                 fixed={"S0": m.var("back.S0").start}, prepare=prepare_loom,
                 name="loom_stick")


STUDIES = {"design-map": design_map, "drive-grid": drive_grid, "hinge": hinge,
           "trends": trends, "loom-stick": loom_stick}
