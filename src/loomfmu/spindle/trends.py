"""Seed 003, section V(二): the parameter studies, and the analysis charts.

Each study varies one quantity of the calibrated spindle (empty bobbin) and
computes the top (A1) and bottom (A2) orbit radii at 16 000 rpm from (15)
and the three lowest forward-whirl frequencies.  The verdict compares the
direction of each change over the sweep with the seed's sentence:
"up" / "down" when the end-to-end change exceeds 2 %, "flat" otherwise.
"""
from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from loomfmu.declare.checks import check_array, check_choice, check_number  # noqa: E402
from loomfmu.spindle.analysis import RPM, campbell, dynamic_compliance  # noqa: E402
from loomfmu.spindle.study import CHARTS, DOCS, WORK_RPM, Spindle, amplitude_table  # noqa: E402

FLAT = 0.02

#: name -> (label, x values, how to apply x: (options, overrides), seed's claims)
#: claims: quantity -> expected direction ("up", "down", "flat", or a note)
STUDIES = {
    "lower_support": (
        "lower support stiffness factor (k_f and coil spring x s)",
        [0.25, 0.5, 1.0, 2.0, 4.0],
        lambda s, v: ({}, {"k_f": v["k_f"] * s, "a_s": v["a_s"] * s ** (1 / 3)}),
        {"A1": "up", "A2": "down", "f1": "up", "f2": "up", "f3": "up"}),
    "upper_support": (
        "upper support stiffness factor (k_u x s)",
        [0.1, 0.3, 1.0, 3.0, 9.0],
        lambda s, v: ({}, {"k_u": v["k_u"] * s}),
        {"A1": "flat", "A2": "flat", "f1": "up", "f2": "up", "f3": "flat"}),
    "blade_diameter": (
        "blade diameter factor k_d",
        [0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5],
        lambda s, v: ({}, {"k_d": s}),
        {"A1": "small at 0.7 and 1.5, large at 0.9 and 1.4"}),
    "support_distance": (
        "distance between the supports L_s (m)",
        [0.04, 0.05, 0.06, 0.08, 0.10],
        lambda s, v: ({}, {"L_s": s}),
        {"f1": "up", "f2": "down", "f3": "down"}),
    "spring_turns": (
        "coil spring turns n",
        [2, 3, 4, 5, 6, 8],
        lambda s, v: ({"n_turns": int(s)}, {}),
        {"A1": "up", "A2": "down", "f1": "up", "f2": "up", "f3": "up"}),
}


def direction(y) -> str:
    """"up", "down" or "flat" (within FLAT) from y[0] to y[-1]; y[0] != 0."""
    y = check_array("y", y, min_size=2)
    if y[0] == 0:
        raise ValueError("y[0] = 0; allowed: nonzero (the change is relative to it)")
    change = (y[-1] - y[0]) / abs(y[0])
    return "flat" if abs(change) <= FLAT else ("up" if change > 0 else "down")


def run_study(name: str, ecc: float) -> dict:
    """Study ``name`` (a key of STUDIES) at eccentricity ``ecc`` (m, > 0)."""
    check_choice("name", name, tuple(STUDIES))
    ecc = check_number("ecc", ecc, lo=0.0, lo_open=True, unit="m")
    label, xs, apply, claims = STUDIES[name]
    base = Spindle({})
    rows = []
    cache: dict = {}
    for x in xs:
        opts, over = apply(x, base.values())
        key = tuple(sorted(opts.items()))
        sp = cache.setdefault(key, Spindle(opts) if opts else base)
        v = sp.values(**over)
        a1, a2 = sp.unbalance(WORK_RPM, v, e_b=ecc, e_w=ecc)
        f = sp.forward_freqs_rpm(v)
        rows.append({"x": float(x), "A1": a1, "A2": a2, "f1": f[0], "f2": f[1], "f3": f[2]})
    verdicts = {}
    for q, claim in claims.items():
        ys = [r[q] for r in rows]
        if claim in ("up", "down", "flat"):
            got = direction(ys)
            verdicts[q] = {"seed": claim, "model": got, "agrees": got == claim}
        else:  # the diameter study: local extremes at given factors
            xarr = np.array(xs)
            big = [ys[int(np.argmin(abs(xarr - v)))] for v in (0.9, 1.4)]
            small = [ys[int(np.argmin(abs(xarr - v)))] for v in (0.7, 1.5)]
            ok = min(big) > max(small)
            verdicts[q] = {"seed": claim, "model": "A1 at 0.9/1.4: "
                           f"{big[0] * 1e6:.1f}/{big[1] * 1e6:.1f} um, at 0.7/1.5: "
                           f"{small[0] * 1e6:.1f}/{small[1] * 1e6:.1f} um", "agrees": ok}
    return {"label": label, "rows": rows, "verdicts": verdicts}


def _chart(name: str, study: dict, charts: Path) -> Path:
    rows = study["rows"]
    x = [r["x"] for r in rows]
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    a.plot(x, [r["A1"] * 1e6 for r in rows], "o-", label="A1 top")
    a.plot(x, [r["A2"] * 1e6 for r in rows], "s-", label="A2 bottom")
    a.set_xlabel(study["label"])
    a.set_ylabel("orbit radius at 16 000 rpm (um)")
    a.legend()
    for k in ("f1", "f2", "f3"):
        b.plot(x, [r[k] for r in rows], "o-", label=k)
    b.set_xlabel(study["label"])
    b.set_ylabel("forward whirl frequency (rpm)")
    b.set_yscale("log")
    b.legend()
    fig.suptitle(f"spindle D1201, {name.replace('_', ' ')} (empty bobbin)")
    fig.tight_layout()
    charts.mkdir(parents=True, exist_ok=True)
    out = charts / f"trend_{name}.png"
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def write_trends(out: Path = DOCS / "spindle_trends.md") -> dict:
    ecc = amplitude_table(Spindle({}), 0.0)["eccentricity_m"]
    studies = {name: run_study(name, ecc) for name in STUDIES}
    lines = ["# Spindle parameter studies (seed 003, section V)", "",
             "Generated by `loomfmu rotor trends`.  Empty bobbin, 16 000 rpm, "
             f"eccentricity {ecc * 1e6:.2f} um of bobbin and whorl (fitted to the seed's "
             f"A1).  Direction: end-to-end change beyond {FLAT:.0%}.", "",
             "| study | quantity | seed | model | agrees |", "|---|---|---|---|---|"]
    for name, st in studies.items():
        for q, v in st["verdicts"].items():
            lines.append(f"| {name.replace('_', ' ')} | {q} | {v['seed']} | {v['model']} | "
                         f"{'yes' if v['agrees'] else 'no'} |")
        _chart(name, st, out.parent / "spindle")
    for name, st in studies.items():
        lines += ["", f"## {name.replace('_', ' ')}: {st['label']}", "",
                  f"![{name}](spindle/trend_{name}.png)", "",
                  "| x | A1 (um) | A2 (um) | f1 (rpm) | f2 (rpm) | f3 (rpm) |",
                  "|---|---|---|---|---|---|"]
        for r in st["rows"]:
            lines.append(f"| {r['x']:g} | {r['A1'] * 1e6:.2f} | {r['A2'] * 1e6:.2f} | "
                         f"{r['f1']:.0f} | {r['f2']:.0f} | {r['f3']:.0f} |")
    out.write_text("\n".join(lines) + "\n")
    out.with_suffix(".json").write_text(json.dumps(studies, indent=1, default=float))
    print("\n".join(lines[:6 + sum(len(s["verdicts"]) for s in studies.values()) + 1]))
    return studies


def write_charts(out_dir: Path = CHARTS) -> list[Path]:
    """Campbell diagram, unbalance response over speed, dynamic compliance,
    written into ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    sp = Spindle({})
    paths = []
    speeds = np.linspace(0, 30000, 31)
    speeds[0] = 200.0
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for fill, ls in ((0.0, "-"), (1.0, "--")):
        v = sp.values(fill=fill)
        c = campbell(lambda w: sp.matrices(w, v), speeds, sp.xi, sp.yi, n_modes=3)
        tag = "full" if fill else "empty"
        for k in range(3):
            ax.plot(speeds, c["forward"][:, k], "C0" + ls, lw=1,
                    label=f"forward, {tag}" if k == 0 else None)
            ax.plot(speeds, c["backward"][:, k], "C1" + ls, lw=1,
                    label=f"backward, {tag}" if k == 0 else None)
    ax.plot(speeds, speeds, "k:", label="1x spin")
    ax.set_ylim(0, 60000)
    ax.set_xlabel("spin speed (rpm)")
    ax.set_ylabel("whirl frequency (rpm)")
    ax.set_title("Campbell diagram (damped, gyroscopic)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(out_dir / "campbell.png")
    fig.savefig(paths[-1], dpi=90)
    plt.close(fig)

    ecc = amplitude_table(sp, 0.0)["eccentricity_m"]
    sweep = np.linspace(300, 25000, 150)
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for fill, ls in ((0.0, "-"), (1.0, "--")):
        v = sp.values(fill=fill)
        amps = np.array([sp.unbalance(n, v, e_b=ecc, e_w=ecc) for n in sweep])
        tag = "full" if fill else "empty"
        ax.semilogy(sweep, amps[:, 0] * 1e3, "C0" + ls, label=f"A1 top, {tag}")
        ax.semilogy(sweep, amps[:, 1] * 1e3, "C1" + ls, label=f"A2 bottom, {tag}")
    from loomfmu.spindle.study import SEED_TABLE
    ax.semilogy(SEED_TABLE["speed_rpm"], np.array(SEED_TABLE["A1_m"]) * 1e3, "C0o",
                label="A1 seed")
    ax.semilogy(SEED_TABLE["speed_rpm"], np.array(SEED_TABLE["A2_m"]) * 1e3, "C1s",
                label="A2 seed")
    ax.set_xlabel("spin speed (rpm)")
    ax.set_ylabel("orbit radius (mm)")
    ax.set_title(f"unbalance response (15), eccentricity {ecc * 1e6:.1f} um")
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(out_dir / "unbalance_response.png")
    fig.savefig(paths[-1], dpi=90)
    plt.close(fig)

    w = WORK_RPM * RPM
    M, C, G, K = sp.matrices(w)
    a = np.zeros(M.shape[0])
    a[sp.sp.idx(f"n{sp.sp.nodes['top']}.x")] = 1.0
    freqs = np.linspace(100, 60000, 400)
    h = [abs(dynamic_compliance(M, C + w * G, K, f * RPM, a)) for f in freqs]
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    ax.semilogy(freqs, h)
    ax.set_xlabel("excitation frequency (rpm)")
    ax.set_ylabel("|u0/P0| at the top of the blade (m/N)")
    ax.set_title("dynamic compliance (21) at 16 000 rpm, empty bobbin")
    fig.tight_layout()
    paths.append(out_dir / "dynamic_compliance.png")
    fig.savefig(paths[-1], dpi=90)
    plt.close(fig)
    return paths
