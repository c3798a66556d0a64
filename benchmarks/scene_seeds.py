"""The seed scenes: what they show, and where the
masters fail on them.

    .venv/bin/python benchmarks/scene_seeds.py [--out-dir docs] [--quick]
        [--part all|spinning|loom|fidelity] [--charts-only]

Spinning position (loomfmu.machines.spinning): the drive with its layer cam
feeding the full FE spindle over the second layer cycle (the first carries
the drive's start transient), cam compensated and uncompensated:
docs/results/scenes/spinning_layer.png.  Loom (loomfmu.machines.loom): the backrest's
stick-slip under shedding and the frames' out-of-plane motion with the
returned tension against the prescribed (geometry) tension:
docs/results/scenes/loom_shedding.png.

Stability and error (docs/results/scenes/<scene>_stability.png): each scene run by
Jacobi and Gauss-Seidel (input extrapolation order 0-2) and by libcosim's
fixed-step engine on the exported SSP, over a sweep of communication steps;
the error is the largest difference from a fine-step run of the same scene
(Gauss-Seidel, extrapolation order 2; its own error, against the same run
at twice its step, is in the json), each output scaled by its largest magnitude in that
run; the growth is the largest magnitude of the run over the reference's.
A run fails when an FMU refuses a step (Error/Discard), a value is not
finite, or it grows past GROWTH_FAIL.  CPU seconds (time.process_time: the
FMUs run in this process) per simulated second are kept for the verdict.
Figures and verdict: docs/results/scenes/<scene>_study.json.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from loomfmu.machines import loom as loom_scene
from loomfmu.machines import spinning
from loomfmu.scene import run
from loomfmu.scene.fmus import build_fmus

#: the reference run: Gauss-Seidel with quadratic input extrapolation at a fine step
REFERENCE_ORDER = 2
#: a run whose largest magnitude exceeds the reference's by this factor has failed
GROWTH_FAIL = 2.0
#: the error a user would accept (the verdict's step is the largest below it)
ERROR_OK = 0.01
#: the algorithms of the sweep: label -> (master, extrapolation order, colour, marker)
ALGORITHMS = {
    "Jacobi, order 0": ("jacobi", 0, "C0", "o"),
    "Jacobi, order 1": ("jacobi", 1, "C0", "s"),
    "Jacobi, order 2": ("jacobi", 2, "C0", "^"),
    "Gauss-Seidel, order 0": ("gauss-seidel", 0, "C1", "o"),
    "Gauss-Seidel, order 1": ("gauss-seidel", 1, "C1", "s"),
    "Gauss-Seidel, order 2": ("gauss-seidel", 2, "C1", "^"),
}
LIBCOSIM = "libcosim (fixed step, SSP)"

#: per scene: the outputs the error is measured on, the sweep's horizon (s),
#: communication steps (s) and the reference step (s)
STUDIES = {
    "spinning": {
        "outputs": ("drive.n_out", "spindle.r_top", "spindle.F_upper", "spindle.F_lower",
                    "spindle.x_top"),
        # the vibration's amplitude and the forces (not its phase: x_top)
        "amplitudes": ("drive.n_out", "spindle.r_top", "spindle.F_upper", "spindle.F_lower"),
        "horizon": 3.0, "steps": (2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2, 1e-1),
        "reference": 5e-5, "quick_steps": (1e-3, 1e-2, 1e-1),
    },
    "loom": {
        "outputs": ("back.phi1_out", "back.omega1_out", "back.omega2_out", "frame_a.x2_out",
                    "frame_b.x2_out", "back.S2a"),
        "horizon": 1.0, "steps": (1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2, 5e-2, 1e-1),
        "reference": 2e-5, "quick_steps": (1e-3, 1e-2),
    },
}

#: the drive's speed n_out is rad/s; the figures and tables show rpm
RPM_PER_RAD_S = 60.0 / (2 * math.pi)


def spinning_study_scene():
    """The sweep's spinning scene: the 4-mode spindle (the master's error is
    measured against the same scene, so the cheap fidelity is enough)."""
    return spinning.scene(fidelity="spindle_modal")


def loom_study_scene():
    return loom_scene.scene()


# -- runs ------------------------------------------------------------------------
def timed(scene, fmus, **kw):
    t0 = time.process_time()
    res = run(scene, fmus=fmus, **kw)
    return res, time.process_time() - t0


def error_of(data, ref, outputs) -> tuple[float, float, dict]:
    """(error, growth, per-output error): each output's largest difference
    from the reference (interpolated to the run's times), over the output's
    largest magnitude in the reference."""
    per, growth = {}, 0.0
    for name in outputs:
        y = np.asarray(data[name])
        r = np.interp(data["time"], ref["time"], ref[name])
        scale = float(np.abs(ref[name]).max()) or 1.0
        if not np.all(np.isfinite(y)):
            return math.inf, math.inf, {name: math.inf}
        per[name] = float(np.abs(y - r).max() / scale)
        growth = max(growth, float(np.abs(y).max() / scale))
    return max(per.values()), growth, per


def sweep(name: str, scene, fmus, tmp: Path, quick: bool) -> dict:
    st = STUDIES[name]
    horizon, outputs = st["horizon"], st["outputs"]
    steps = st["quick_steps"] if quick else st["steps"]
    print(f"{name}: reference run, h = {st['reference']:g} s", file=sys.stderr)
    ref, ref_cpu = timed(scene, fmus, master="gauss-seidel", step=st["reference"],
                         stop=horizon, extrapolation=REFERENCE_ORDER)
    # the reference's own error: against the same run at twice its step
    coarse, _ = timed(scene, fmus, master="gauss-seidel", step=2 * st["reference"],
                      stop=horizon, extrapolation=REFERENCE_ORDER)
    ref_err = error_of(coarse.data, ref.data, outputs)[0]
    out = {"horizon": horizon, "outputs": list(outputs), "reference_step": st["reference"],
           "reference": f"gauss-seidel, extrapolation order {REFERENCE_ORDER}",
           "reference_vs_twice_its_step": ref_err, "reference_cpu_s": ref_cpu, "runs": []}
    for label, (master, order, _, _) in ALGORITHMS.items():
        for h in steps:
            row = {"algorithm": label, "h": h}
            try:
                res, cpu = timed(scene, fmus, master=master, step=h, stop=horizon,
                                 extrapolation=order)
                err, growth, per = error_of(res.data, ref.data, outputs)
                row.update(error=err, growth=growth, per_output=per, cpu_s=cpu,
                           cpu_per_sim_s=cpu / horizon,
                           status="ok" if growth <= GROWTH_FAIL and math.isfinite(err)
                           else "unstable")
            except Exception as exc:   # an FMU refused a step, or the master did
                row.update(status="failed", message=str(exc)[:300])
            print(f"  {label}, h = {h:g}: {row.get('status')} "
                  f"error {row.get('error', float('nan')):.3g}", file=sys.stderr)
            out["runs"].append(row)
    out["runs"] += libcosim_sweep(scene, fmus, tmp, steps, horizon, outputs, ref)
    return out


def libcosim_sweep(scene, fmus, tmp, steps, horizon, outputs, ref) -> list[dict]:
    """libcosim on the exported SSP (run_ssp sets the SSP's start values of
    states as libcosim initial values: libcosim 0.0.6 skips them in the
    parameter set)."""
    from loomfmu.scene.libcosim import run_ssp
    from loomfmu.scene.ssp import export_ssp
    ssp = export_ssp(scene, tmp / f"{scene.name}.ssp", fmus=fmus)
    rows = []
    refs = [tuple(o.split(".", 1)) for o in outputs]
    for h in steps:
        row = {"algorithm": LIBCOSIM, "h": h}
        try:
            t0 = time.process_time()
            data = run_ssp(ssp, refs, step=h, stop=horizon)
            cpu = time.process_time() - t0
            err, growth, per = error_of(data, ref.data, outputs)
            row.update(error=err, growth=growth, per_output=per, cpu_s=cpu,
                       cpu_per_sim_s=cpu / horizon,
                       status="ok" if growth <= GROWTH_FAIL and math.isfinite(err)
                       else "unstable")
        except Exception as exc:
            row.update(status="failed", message=str(exc)[:300])
        print(f"  libcosim, h = {h:g}: {row['status']} {row.get('error', float('nan')):.3g}",
              file=sys.stderr)
        rows.append(row)
    return rows


def verdict(study: dict, outputs=None) -> list[dict]:
    """Per algorithm: the largest step with error <= ERROR_OK (over
    ``outputs``, default all), its CPU cost per simulated second, and the
    smallest step where it fails (or is off by more than 10 %)."""
    rows = []
    labels = list(ALGORITHMS) + [LIBCOSIM]
    for label in labels:
        runs = sorted((dict(r, error=max(r["per_output"][o] for o in outputs))
                       if outputs and r["status"] == "ok" else r
                       for r in study["runs"] if r["algorithm"] == label),
                      key=lambda r: r["h"])
        good = [r for r in runs if r["status"] == "ok" and r["error"] <= ERROR_OK]
        bad = [r for r in runs if r["status"] != "ok"]
        off = [r for r in runs if r["status"] == "ok" and r["error"] > 0.1]
        best = max(good, key=lambda r: r["h"]) if good else None
        rows.append({
            "algorithm": label,
            "largest_h_for_1pct": best["h"] if best else None,
            "error_there": best["error"] if best else None,
            "cpu_per_sim_s_there": best["cpu_per_sim_s"] if best else None,
            "first_failure_h": bad[0]["h"] if bad else None,
            "first_failure": (bad[0]["status"] + ": " + bad[0].get("message", "")[:160])
            if bad else None,
            "first_h_over_10pct": off[0]["h"] if off else None,
        })
    return rows


# -- charts ------------------------------------------------------------------------
def chart_stability(name: str, study: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(15, 4.6))
    styles = {k: (c, mk) for k, (_, _, c, mk) in ALGORITHMS.items()}
    styles[LIBCOSIM] = ("C2", "x")
    top = max([r["error"] for r in study["runs"] if r["status"] == "ok"] + [1e-6])
    for label, (colour, marker) in styles.items():
        runs = sorted((r for r in study["runs"] if r["algorithm"] == label),
                      key=lambda r: r["h"])
        ok = [r for r in runs if r["status"] == "ok"]
        if ok:
            h = [r["h"] for r in ok]
            ls = "--" if "order 1" in label else ":" if "order 2" in label else "-"
            ax1.loglog(h, [max(r["error"], 1e-12) for r in ok], ls, marker=marker,
                       color=colour, label=label, mfc="none" if ls != "-" else colour)
            ax2.semilogx(h, [r["growth"] for r in ok], ls, marker=marker, color=colour)
            ax3.loglog(h, [r["cpu_per_sim_s"] for r in ok], ls, marker=marker,
                       color=colour)
        failed = [r for r in runs if r["status"] != "ok"]
        if failed:
            ax1.loglog([r["h"] for r in failed], [top * 3] * len(failed), marker="X",
                       ls="none", color=colour, ms=10,
                       label=f"{label}: failed" if not ok else None)
    ax1.axhline(ERROR_OK, color="k", lw=0.6, ls="--")
    ax1.text(min(r["h"] for r in study["runs"]), ERROR_OK * 1.15, "1 %", fontsize=8)
    ax1.set(xlabel="communication step H (s)", ylabel="error vs fine-step run (relative)",
            title=f"{name}: error (X at the top: run failed)")
    ax2.axhline(GROWTH_FAIL, color="r", lw=0.8, ls="--")
    ax2.set(xlabel="communication step H (s)", ylabel="largest |y| / reference's",
            title="stability: growth (fails above the red line)")
    ax3.set(xlabel="communication step H (s)", ylabel="CPU s per simulated s",
            title="cost")
    handles, labels = ax1.get_legend_handles_labels()
    ax3.legend(handles, labels, fontsize=7, loc="upper right")   # the emptiest corner
    for ax in (ax1, ax2, ax3):
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def envelope(t, y, window: float) -> tuple[np.ndarray, np.ndarray]:
    """Largest |y| over consecutive windows of ``window`` s: (window centres, maxima)."""
    t, y = np.asarray(t), np.abs(np.asarray(y))
    edges = np.arange(t[0], t[-1] + window, window)
    idx = np.searchsorted(t, edges)
    c, v = [], []
    for a, b in zip(idx[:-1], idx[1:]):
        if b > a:
            c.append(t[a:b].mean())
            v.append(y[a:b].max())
    return np.array(c), np.array(v)


def spinning_layer(tmp: Path, quick: bool, fmu_dir: Path) -> dict:
    """The full spindle over the second layer cycle, cam compensated and not."""
    cycle = spinning.LAYER_CYCLE
    stop, h = (2 * cycle, 2e-3) if not quick else (0.3, 2e-3)
    out = {"stop": stop, "step": h, "cams": {}}
    for cam in ("compensated", "uncompensated"):
        s = spinning.scene(cam=cam, fidelity="spindle", stop_time=stop, step=h)
        fmus = build_fmus(s, fmu_dir)
        print(f"spinning layer cycle, cam {cam}", file=sys.stderr)
        res, cpu = timed(s, fmus, master="gauss-seidel", step=h, stop=stop)
        d = res.data
        keep = d["time"] >= (cycle if not quick else 0.0)
        out["cams"][cam] = {"cpu_s": cpu, "data": {n: d[n][keep].tolist()
                                                   for n in d.dtype.names}}
    return out


def chart_spinning(layer: dict, path: Path) -> dict:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(4, 1, figsize=(10, 10), sharex=True)
    figures = {}
    for cam, colour in (("compensated", "C0"), ("uncompensated", "C3")):
        d = {k: np.array(v) for k, v in layer["cams"][cam]["data"].items()}
        t = d["time"] - d["time"][0]
        axes[0].plot(t, d["drive.n_out"] * RPM_PER_RAD_S, color=colour, label=f"cam {cam}")
        tc, r = envelope(t, d["spindle.r_top"], 0.05)
        axes[1].plot(tc, r * 1e6, color=colour)
        tc, fu = envelope(t, d["spindle.F_upper"], 0.05)
        tc2, fl = envelope(t, d["spindle.F_lower"], 0.05)
        axes[2].plot(tc, fu, color=colour)
        axes[3].plot(tc2, fl, color=colour)
        figures[cam] = {
            "n_rpm_range": [float(d["drive.n_out"].min() * RPM_PER_RAD_S),
                            float(d["drive.n_out"].max() * RPM_PER_RAD_S)],
            "r_top_um_range": [float(r.min() * 1e6), float(r.max() * 1e6)],
            "F_upper_N_range": [float(fu.min()), float(fu.max())],
            "F_lower_N_range": [float(fl.min()), float(fl.max())],
            "cpu_s": layer["cams"][cam]["cpu_s"],
        }
    axes[0].set(ylabel="drive speed (rpm)",
                title="spinning position over one layer cycle (the second: the first "
                      "holds the drive's start transient); full FE spindle")
    axes[1].set(ylabel="vibration of the blade top,\nlargest |r| per 50 ms (µm)")
    axes[2].set(ylabel="bolster bearing force,\nlargest per 50 ms (N)")
    axes[3].set(ylabel="footstep bearing force,\nlargest per 50 ms (N)",
                xlabel="time in the layer cycle (s)")
    axes[0].legend()
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return figures


#: loom speeds of the shedding chart (picks/min): the scene's default, and a
#: slow loom where the backrest sticks
SHED_SPEEDS = (240.0, 60.0)
#: loom speeds of the regime sweep (picks/min)
REGIME_SPEEDS = (30.0, 45.0, 60.0, 90.0, 120.0, 150.0, 180.0, 210.0, 240.0, 270.0, 300.0)
#: the shedding runs: Gauss-Seidel, order 2, 1 ms (the verdict's choice, error 1.4e-5)
SHED_RUN = {"master": "gauss-seidel", "extrapolation": 2, "step": 1e-3}
#: a joint is stuck when its rate is below this (rad/s; the FMU sets it to 0)
STUCK = 1e-9


def omega_of(ppm: float) -> float:
    return ppm / 60.0 * 2 * math.pi


def stuck_phases(t, w, after: float) -> tuple[float, int]:
    """(share of the time after ``after`` the rate is zero, number of stick phases)."""
    st = np.abs(np.asarray(w))[np.asarray(t) > after] < STUCK
    if st.size == 0:      # a run shorter than ``after`` (--quick)
        return math.nan, 0
    return float(st.mean()), int(np.count_nonzero(np.diff(st.astype(int)) == 1) + st[0])


def loom_shedding(quick: bool, fmu_dir: Path) -> dict:
    """Both tension variants at each of SHED_SPEEDS over 8 picks (2 when quick)."""
    picks = 8 if not quick else 2
    out = {"picks": picks, "run": SHED_RUN, "speeds": {}}
    for ppm in SHED_SPEEDS:
        stop = picks * 60.0 / ppm
        out["speeds"][str(ppm)] = {}
        for tension in loom_scene.TENSIONS:
            s = loom_scene.scene(tension=tension, omega=omega_of(ppm), stop_time=stop)
            fmus = build_fmus(s, fmu_dir)
            print(f"loom, {ppm:g} picks/min, tension {tension}", file=sys.stderr)
            res, cpu = timed(s, fmus, stop=stop, **SHED_RUN)
            out["speeds"][str(ppm)][tension] = {
                "cpu_s": cpu, "data": {n: res.data[n].tolist() for n in res.data.dtype.names}}
    return out


def loom_regimes(quick: bool, fmu_dir: Path) -> list[dict]:
    """The returned-tension scene at each of REGIME_SPEEDS over 6 picks: how
    much of the time each backrest joint sticks (after the first 2 picks),
    and where the warp goes slack (the FMU ends the step: fmi2Discard)."""
    rows = []
    for ppm in (REGIME_SPEEDS if not quick else (60.0, 240.0)):
        stop = 6 * 60.0 / ppm
        s = loom_scene.scene(omega=omega_of(ppm), stop_time=stop)
        fmus = build_fmus(s, fmu_dir)
        row = {"picks_per_min": ppm}
        try:
            res, cpu = timed(s, fmus, stop=stop, **SHED_RUN)
            d = res.data
            for joint, var in (("O1", "back.omega1_out"), ("O2", "back.omega2_out")):
                row[f"stuck_share_{joint}"], row[f"stick_phases_{joint}"] = stuck_phases(
                    d["time"], d[var], 2 * 60.0 / ppm)
            row.update(status="ok", S2a_min=float(d["back.S2a"].min()),
                       S2a_max=float(d["back.S2a"].max()),
                       x2_max_mm=float(np.abs(d["frame_a.x2_out"]).max() * 1e3), cpu_s=cpu)
        except Exception as exc:
            row.update(status="failed", message=str(exc)[:400])
        print(f"loom regime {ppm:g} picks/min: {row['status']}", file=sys.stderr)
        rows.append(row)
    return rows


def chart_loom(shed: dict, regimes: list[dict], path: Path) -> dict:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(5, 2, figsize=(14, 13))
    figures = {}
    for col, ppm in enumerate(SHED_SPEEDS):
        ax = axes[:, col]
        figures[str(ppm)] = {}
        for tension, colour in (("returned", "C0"), ("prescribed", "C3")):
            d = {k: np.array(v) for k, v in shed["speeds"][str(ppm)][tension]["data"].items()}
            t = d["time"]
            ax[0].plot(t, d["frame_a.T"] + d["frame_b.T"], color=colour,
                       label=f"tension {tension}: on the frames")
            if tension == "prescribed":
                ax[0].plot(t, d["back.S2a"] + d["back.S2b"], color="k", lw=0.6, ls="--",
                           label="the backrest's, frames on the prescribed tension")
            ax[1].plot(t, d["back.omega1_out"], color=colour, lw=0.8)
            ax[2].plot(t, d["back.omega2_out"], color=colour, lw=0.8)
            ax[3].plot(t, d["frame_a.x2_out"] * 1e3, color=colour, lw=0.8)
            after = 2 * 60.0 / ppm
            figures[str(ppm)][tension] = {
                "frame_tension_total_N_range": [float((d["frame_a.T"] + d["frame_b.T"]).min()),
                                                float((d["frame_a.T"] + d["frame_b.T"]).max())],
                "x2_mm_range": [float(d["frame_a.x2_out"].min() * 1e3),
                                float(d["frame_a.x2_out"].max() * 1e3)],
                "stuck_O1": stuck_phases(t, d["back.omega1_out"], after),
                "stuck_O2": stuck_phases(t, d["back.omega2_out"], after),
                "cpu_s": shed["speeds"][str(ppm)][tension]["cpu_s"],
            }
        ax[0].set(ylabel="warp tension through\nboth frames (N)",
                  title=f"{ppm:g} picks/min" + (" (the scene's default)" if ppm == 240 else ""))
        top = ax[0].get_ylim()[1]
        ax[0].set_ylim(top=top + 0.45 * (top - ax[0].get_ylim()[0]))
        ax[0].legend(fontsize=7, loc="upper left", ncol=2)
        ax[1].set(ylabel="backrest lever rate\n(rad/s; 0: stuck)")
        ax[2].set(ylabel="roller rate rel. lever\n(rad/s; 0: stuck)")
        ax[3].set(ylabel="frame A top slat,\nout of plane x2 (mm)", xlabel="time (s)")
        for a in ax[:4]:
            a.grid(True, alpha=0.3)
    # the regime sweep across the bottom
    gs = axes[4, 0].get_gridspec()
    for a in axes[4, :]:
        a.remove()
    ax = fig.add_subplot(gs[4, :])
    ok = [r for r in regimes if r["status"] == "ok"]
    ax.plot([r["picks_per_min"] for r in ok], [r["stuck_share_O1"] for r in ok], "o-",
            label="lever pivot O1")
    ax.plot([r["picks_per_min"] for r in ok], [r["stuck_share_O2"] for r in ok], "s-",
            label="roller pivot O2")
    bad = [r for r in regimes if r["status"] != "ok"]
    if bad:
        ax.plot([r["picks_per_min"] for r in bad], [0.0] * len(bad), "rX", ms=12,
                label="warp slack: the FMU ends the run (fmi2Discard)")
    ax.set(xlabel="loom speed (picks/min)", ylabel="share of the time stuck",
           title="backrest regime against loom speed (tension returned; after 2 picks, "
                 "over 4)")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    figures["regimes"] = regimes
    return figures


#: the spindle fidelities compared in the spinning scene: (label, model, options)
FIDELITY_LEVELS = (("spindle_modal, 4 modes (default)", "spindle_modal", {}),
                   ("spindle_modal, 8 modes", "spindle_modal", {"n_modes": 8}),
                   ("spindle_modal, 12 modes", "spindle_modal", {"n_modes": 12}),
                   ("spindle (full FE)", "spindle", {}))


def spinning_fidelity(fmu_dir: Path, quick: bool) -> dict:
    """Each spindle fidelity in the spinning scene at a constant 16 000 rpm
    (started on its periodic solution): CPU seconds per simulated second and
    the orbit of the blade's top and the bearing forces, against the full
    model's."""
    stop = 0.5 if not quick else 0.05
    rows = []
    for label, model, opts in FIDELITY_LEVELS:
        s = spinning.scene(fidelity=model, spindle_options=opts, n_const=16000.0,
                           stop_time=stop, step=1e-3)
        fmus = build_fmus(s, fmu_dir)
        print(f"fidelity: {label}", file=sys.stderr)
        res, cpu = timed(s, fmus, master="gauss-seidel", step=1e-3, stop=stop)
        rows.append({"label": label, "model": model, "options": opts,
                     "cpu_per_sim_s": cpu / stop,
                     **{k: float(res[f"spindle.{k}"][-1]) for k in
                        ("r_top", "F_upper", "F_lower")}})
    full = rows[-1]
    for r in rows:
        r["vs_full"] = {k: r[k] / full[k] - 1 for k in ("r_top", "F_upper", "F_lower")}
    return {"n_rpm": 16000.0, "stop": stop, "rows": rows}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out-dir", type=Path, default=Path("docs"))
    ap.add_argument("--quick", action="store_true", help="coarse sweep, short runs")
    ap.add_argument("--part", choices=("all", "spinning", "loom", "fidelity"), default="all")
    ap.add_argument("--charts-only", action="store_true", help="keep the stability sweep "
                    "of the json already written; redo the verdict and the charts")
    ap.add_argument("--fmu-dir", type=Path, default=None, help="FMU cache (default: a "
                    "temporary folder)")
    args = ap.parse_args(argv)
    out = args.out_dir / "results" / "scenes"
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp_:
        tmp = Path(tmp_)
        fmu_dir = args.fmu_dir or tmp / "fmus"
        fmu_dir.mkdir(parents=True, exist_ok=True)
        if args.part in ("all", "fidelity"):
            fid = spinning_fidelity(fmu_dir, args.quick)
            (out / "spinning_fidelity.json").write_text(json.dumps(fid, indent=1) + "\n")
        for name in ("spinning", "loom"):
            if args.part not in ("all", name):
                continue
            t0 = time.perf_counter()
            saved = out / f"{name}_study.json"
            if args.charts_only and saved.is_file():   # the sweep as last written
                study = json.loads(saved.read_text())
                sweep_s = study.get("sweep_wall_s", study.get("wall_s"))
            else:
                scene = spinning_study_scene() if name == "spinning" else loom_study_scene()
                fmus = build_fmus(scene, fmu_dir)
                study = sweep(name, scene, fmus, tmp, args.quick)
                sweep_s = time.perf_counter() - t0
            study["verdict"] = verdict(study)
            if "amplitudes" in STUDIES[name]:
                study["verdict_amplitudes"] = verdict(study, STUDIES[name]["amplitudes"])
            chart_stability(name, study, out / f"{name}_stability.png")
            t1 = time.perf_counter()
            if name == "spinning":
                shown = chart_spinning(spinning_layer(tmp, args.quick, fmu_dir),
                                       out / "spinning_layer.png")
            else:
                shown = chart_loom(loom_shedding(args.quick, fmu_dir),
                                   loom_regimes(args.quick, fmu_dir), out / "loom_shedding.png")
            study["chart"] = shown
            study["sweep_wall_s"] = sweep_s
            study["chart_wall_s"] = time.perf_counter() - t1
            study["wall_s"] = study["sweep_wall_s"] + study["chart_wall_s"]
            study["quick"] = args.quick
            (out / f"{name}_study.json").write_text(json.dumps(study, indent=1) + "\n")
            print(f"{name}: {study['wall_s']:.0f} s wall; wrote {out}/{name}_*",
                  file=sys.stderr)
    print(f"total {time.perf_counter() - t_start:.0f} s wall", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
