"""Charts of the seeds' studies (PNG, matplotlib's Agg backend)."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def design_map_chart(rows: list[dict], path: Path, gap: float) -> Path:
    """max |x2| against b1, one panel per (k_z, loom width), a line per d1,
    the gap as a dashed line; cases that did not run are left out."""
    plt = _plt()
    ok = [r for r in rows if r["status"] == "ok"]
    widths = sorted({r["width_cm"] for r in ok})
    kzs = sorted({r["k_z"] for r in ok})
    d1s = sorted({r["d1"] for r in ok})
    fig, axes = plt.subplots(len(kzs), len(widths), figsize=(3.6 * len(widths), 3.2 * len(kzs)),
                             sharex=True, sharey=True, squeeze=False)
    for i, kz in enumerate(kzs):
        for j, w in enumerate(widths):
            ax = axes[i][j]
            for d1 in d1s:
                rs = sorted((r for r in ok if (r["width_cm"], r["k_z"], r["d1"]) == (w, kz, d1)),
                            key=lambda r: r["b1"])
                if rs:
                    ax.loglog([r["b1"] * 1e3 for r in rs],
                              [r["max_abs_x2_out"] * 1e3 for r in rs], "o-", ms=3,
                              label=f"d1 = {d1 * 1e3:g} mm")
            ax.axhline(gap * 1e3, color="k", ls="--", lw=1, label=f"gap {gap * 1e3:g} mm")
            ax.set_title(f"loom {w / 100:g} m, k_z = {kz:g}", fontsize=9)
            ax.grid(True, which="both", alpha=0.3)
            _plain_log_ticks(ax.xaxis, (5, 10, 20, 50, 100))
            if i == len(kzs) - 1:
                ax.set_xlabel("slat width b1 (mm)")
            if j == 0:
                ax.set_ylabel("max |x2| (mm)")
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Heald frame: largest out-of-plane displacement of the top slat "
                 "(2 cycles, 60 rad/s)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _plain_log_ticks(axis, ticks) -> None:
    from matplotlib.ticker import FixedLocator, NullFormatter, ScalarFormatter
    axis.set_major_locator(FixedLocator(ticks))
    axis.set_major_formatter(ScalarFormatter())
    axis.set_minor_formatter(NullFormatter())


def _plain_log_labels(axis) -> None:
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def drive_grid_chart(rows: list[dict], path: Path) -> Path:
    """Tracking error against T, a line per tau: compensated and
    uncompensated cam side by side (log scale)."""
    plt = _plt()
    ok = [r for r in rows if r["status"] == "ok"]
    taus = sorted({r["tau"] for r in ok})
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    for ax, comp, title in ((axes[0], True, "compensated cam"),
                            (axes[1], False, "uncompensated cam")):
        for tau in taus:
            rs = sorted((r for r in ok if r["tau"] == tau and r["compensate"] is comp),
                        key=lambda r: r["T"])
            ax.semilogy([r["T"] for r in rs], [r["vs_law_rpm"] for r in rs], "o-",
                        label=f"tau = {tau:g} s")
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("time constant T (s)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("max |n - n0| after the transient (rpm)")
    series = max((r["vs_series_rpm"] for r in ok if r["compensate"] is True), default=None)
    if series is not None:
        from loomfmu.drive.tracking import M_HARMONICS
        axes[0].text(0.03, 0.9, f"what is left: n0's harmonics above the cam's "
                     f"m = {M_HARMONICS}\n"
                     f"(against the m-term series: <= {series:.1g} rpm)",
                     transform=axes[0].transAxes, fontsize=8, va="top")
    axes[1].legend(fontsize=8)
    fig.suptitle("Spindle drive: speed error against the optimal law n0", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def hinge_chart(rows: list[dict], names: list[str], path: Path) -> Path:
    """Largest and least hinge load per preset, a marker per speed."""
    plt = _plt()
    ok = [r for r in rows if r["status"] == "ok"]
    omegas = sorted({r["omega"] for r in ok})
    fig, ax = plt.subplots(figsize=(12, 4.5))
    for k, om in enumerate(omegas):
        rs = sorted((r for r in ok if r["omega"] == om), key=lambda r: r["preset"])
        x = np.array([r["preset"] for r in rs]) + (k - (len(omegas) - 1) / 2) * 0.2
        line = ax.plot(x, [r["max_N_rem"] for r in rs], "^", ms=4,
                       label=f"max, omega = {om:g} rad/s")[0]
        ax.plot(x, [r["min_N_rem"] for r in rs], "v", ms=4, color=line.get_color(),
                label=f"min, omega = {om:g} rad/s")
    ticks = [i for i, n in enumerate(names) if i == 0 or n.split()[0] != names[i - 1].split()[0]]
    ax.set_xticks(ticks, [names[i].split()[0] for i in ticks], fontsize=8)
    ax.set_xlabel("preset (loom width; makers within each width in seed 002's order)")
    ax.set_ylabel("hinge load N_rem (N, + up)")
    ax.axhline(0, color="k", lw=0.5)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=3)
    ax.set_title("Rigid heald frame: drive hinge load over one cycle, every preset", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def loom_stick_chart(rows: list[dict], path: Path) -> Path:
    """The composed loom: the backrest's stick share and frame a's peak hinge
    load against picks per minute, a line per preload factor."""
    plt = _plt()
    ok = [r for r in rows if r["status"] == "ok"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    for f in sorted({r["preload"] for r in ok}):
        rs = sorted((r for r in ok if r["preload"] == f), key=lambda r: r["ppm"])
        x = [r["ppm"] for r in rs]
        line = a1.plot(x, [100 * r["stick_share"] for r in rs], "o-",
                       label=f"preload x {f:g}")[0]
        a2.plot(x, [r["max_abs_frame_a.N_rem"] for r in rs], "o-", color=line.get_color(),
                label=f"preload x {f:g}")
    a1.set(xlabel="picks per minute", ylabel="backrest stuck (% of the run)")
    a2.set(xlabel="picks per minute", ylabel="peak |N_rem| of frame a's drive hinge (N)")
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Loom composed into one FMU: speed against the backrest's preload "
                 "(S0 x factor)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def trends_chart(rows: list[dict], path: Path) -> Path:
    """A1 (top) and A2 (bottom of the blade) against each study's x: the
    FMU's orbit radius (markers) on (15)'s line."""
    plt = _plt()
    names = list(dict.fromkeys(r["study"] for r in rows))
    fig, axes = plt.subplots(1, len(names), figsize=(3.6 * len(names), 3.6), squeeze=False)
    for ax, name in zip(axes[0], names):
        rs = sorted((r for r in rows if r["study"] == name and "A1_fmu" in r),
                    key=lambda r: r["x"])
        x = [r["x"] for r in rs]
        for key, label in (("A1", "A1 top"), ("A2", "A2 bottom")):
            line = ax.plot(x, [r[f"{key}_15"] * 1e6 for r in rs], "-", lw=1,
                           label=f"{label}, (15)")[0]
            ax.plot(x, [r[f"{key}_fmu"] * 1e6 for r in rs], "o", ms=4, mfc="none",
                    color=line.get_color(), label=f"{label}, FMU")
        ax.set_title(name.replace("_", " "), fontsize=9)
        ax.set_xlabel("factor" if "support" in name and name != "support_distance"
                      else ("L_s (m)" if name == "support_distance" else "k_d"))
        ax.set_yscale("log")
        _plain_log_labels(ax.yaxis)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("orbit radius (um)")
    axes[0][0].legend(fontsize=7)
    fig.suptitle("Spindle trends at 16 000 rpm: the full FMU on its periodic orbit against "
                 "(15)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path

