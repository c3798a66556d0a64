"""Stability and error of each master on the two-mass benchmark against the
communication step, for input extrapolation of order 0, 1 and 2: theory (the
exact co-simulation maps of loomfmu.machines.two_mass) as lines, runs of our
master and of libcosim on the exported SSP as points.  Writes
docs/results/scenes/two_mass_stability.png, its json and the verdict table between
the markers in docs/guides/scenes.md.

    .venv/bin/python benchmarks/scene_stability.py [--out-dir docs] [--quick]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from loomfmu.machines import two_mass as tm
from loomfmu.progress import Progress
from loomfmu.scene import run
from loomfmu.scene.fmus import build_fmus

Z = ("force.x1_out", "force.v1_out", "disp.x2_out", "disp.v2_out")
HORIZON = 1.0   # s: the error is the largest over [0, HORIZON]
BEGIN, END = "<!-- scene_stability:begin -->", "<!-- scene_stability:end -->"
#: curve -> (algorithm of the theory, extrapolation order, label, master, master
#: options, colour, line style)
CURVES = {
    "jacobi": ("jacobi", 0, "Jacobi (ours)", "jacobi", {}, "C0", "-"),
    "gauss-seidel:force-first": ("gauss-seidel:force-first", 0, "Gauss-Seidel (ours)",
                                 "gauss-seidel", {}, "C1", "-"),
    "libcosim": ("libcosim", 0, "libcosim fixed step", "jacobi",
                 {"resolve_feedthrough": False}, "C2", "-"),
    "jacobi/1": ("jacobi", 1, "Jacobi, extrapolation 1", "jacobi", {}, "C0", "--"),
    "jacobi/2": ("jacobi", 2, "Jacobi, extrapolation 2", "jacobi", {}, "C0", ":"),
    "gauss-seidel:force-first/1": ("gauss-seidel:force-first", 1,
                                   "Gauss-Seidel, extrapolation 1", "gauss-seidel", {},
                                   "C1", "--"),
    "gauss-seidel:force-first/2": ("gauss-seidel:force-first", 2,
                                   "Gauss-Seidel, extrapolation 2", "gauss-seidel", {},
                                   "C1", ":"),
}


def states(data) -> np.ndarray:
    return np.column_stack([data[n] for n in Z])


def error(p, z: np.ndarray, t: np.ndarray) -> float:
    exact = tm.exact_solution(p, t, z[0])
    return float(np.abs(z - exact).max() / np.abs(exact).max())


def identified_radius(z: np.ndarray, algorithm: str, order: int = 0) -> float:
    """Spectral radius of the step map fitted by least squares to a run: on z
    (order 0), on z and x2, v2 of the step before (libcosim), on the last
    order + 1 states (extrapolation: z_{n+1} = sum_j K_j z_{n-j}; the first
    2 order + 2 points, with a shorter history, are left out)."""
    if algorithm == "libcosim":   # its state holds x2, v2 of the step before
        z = np.column_stack([z, np.vstack([z[:1, 2:4], z[:-1, 2:4]])])
    if order == 0:
        M = z[1:].T @ np.linalg.pinv(z[:-1].T)
        return float(max(abs(np.linalg.eigvals(M))))
    z, d = z[2 * order + 2:], order + 1
    X = np.hstack([z[d - 1 - j:len(z) - 1 - j] for j in range(d)])
    K, *_ = np.linalg.lstsq(X, z[d:], rcond=None)
    M = np.zeros((4 * d, 4 * d))
    M[:4] = K.T
    M[4:, :-4] = np.eye(4 * (d - 1))
    return float(max(abs(np.linalg.eigvals(M))))


def theory(p, hs) -> dict:
    """Spectral radius and error over HORIZON of each curve on the grid hs
    (extrapolated curves from 1e-4 s: their trajectories step in Python)."""
    out = {}
    z0 = [0.1, 0.0, 0.0, 0.0]
    for key, (a, order, *_rest) in CURVES.items():
        grid = [h for h in hs if order == 0 or h >= 1e-4]
        rho = [tm.spectral_radius(p, h, a, order) for h in grid]
        err = []
        for h in grid:
            n = int(round(HORIZON / h))
            z = (tm.trajectory(p, h, n, z0, a) if order == 0 else
                 tm.extrapolated_trajectory(p, h, n, z0, a, order))
            err.append(error(p, z, h * np.arange(n + 1)))
        out[key] = {"h": grid, "rho": rho, "error": err,
                    "limit": tm.stability_limit(p, a, order=order)}
    out["exact_rate"] = float(np.linalg.eigvals(tm.monolithic(p)).real.max())
    return out


def measured(p, hs, fmus, scene, tmp: Path, bar) -> dict:
    from loomfmu.scene.libcosim import run_ssp
    from loomfmu.scene.ssp import export_ssp
    ssp = export_ssp(scene, tmp / "two_mass.ssp", fmus=fmus)
    out = {a: {"h": [], "rho": [], "error": [], "seconds_per_step": []} for a in CURVES}
    out["libcosim (engine)"] = {"h": [], "rho": [], "error": [], "seconds_per_step": []}
    for h in hs:
        n = int(round(HORIZON / h))
        for key, (a, order, label, master, opts, *_rest) in CURVES.items():
            bar.stage(f"{label}, h = {h:.3g} s")
            t0 = time.perf_counter()
            res = run(scene, master=master, step=h, stop=n * h, fmus=fmus,
                      master_options=opts, extrapolation=order)
            dt = (time.perf_counter() - t0) / n
            z = states(res)
            rec = out[key]
            rec["h"].append(h)
            rec["rho"].append(identified_radius(z[: min(len(z), 60)], a, order)
                              if len(z) > 8 * order + 8 else float("nan"))
            rec["error"].append(error(p, z, res["time"]))
            rec["seconds_per_step"].append(dt)
        bar.stage(f"libcosim engine, h = {h:.3g} s")
        t0 = time.perf_counter()
        data = run_ssp(ssp, [tuple(n_.split(".")) for n_ in Z], step=h, stop=n * h)
        dt = (time.perf_counter() - t0) / n
        z = np.vstack([[0.1, 0, 0, 0], states(data)])
        t = np.concatenate([[0.0], data["time"]])
        rec = out["libcosim (engine)"]
        rec["h"].append(h)
        rec["rho"].append(identified_radius(z[: min(len(z), 60)], "libcosim"))
        rec["error"].append(error(p, z, t))
        rec["seconds_per_step"].append(dt)
        bar.advance(f"h = {h:.3g} s done")
    return out


def adaptive(p, scene, fmus, bar) -> list[dict]:
    rows = []
    for master in ("jacobi", "gauss-seidel"):
        for order, rtol in [(0, 1e-1), (0, 1e-2), (0, 1e-3), (1, 1e-2), (1, 1e-3), (2, 1e-2),
                            (2, 1e-3)]:
            bar.stage(f"adaptive {master}, extrapolation {order}, rtol {rtol:g}")
            t0 = time.perf_counter()
            res = run(scene, master=master, step=1e-3, adaptive=True, rtol=rtol, atol=1e-4,
                      stop=HORIZON, fmus=fmus, extrapolation=order)
            rows.append({"master": master, "order": order, "rtol": rtol,
                         "accepted": res.accepted,
                         "rejected": res.rejected, "h_max": float(res.h.max()),
                         "error": error(p, states(res), res["time"]),
                         "seconds": time.perf_counter() - t0})
        bar.advance(f"adaptive {master} done")
    return rows


def chart(path: Path, hs_theory, th: dict, me: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(14, 6))
    def rate(rho, h):   # growth rate per second: ln(rho) / H
        return np.log(np.asarray(rho)) / np.asarray(h)

    markers = {0: "o", 1: "s", 2: "^"}
    for a, (_, order, label, _, _, colour, ls) in CURVES.items():
        ax1.semilogx(th[a]["h"], rate(th[a]["rho"], th[a]["h"]), color=colour, ls=ls,
                     label=f"{label}: theory")
        ax1.semilogx(me[a]["h"], rate(me[a]["rho"], me[a]["h"]), markers[order],
                     color=colour, mfc="none", label=f"{label}: measured")
        ax2.loglog(th[a]["h"], th[a]["error"], color=colour, ls=ls, label=f"{label}: theory")
        ax2.loglog(me[a]["h"], me[a]["error"], markers[order], color=colour, mfc="none",
                   label=f"{label}: measured")
        ax1.axvline(th[a]["limit"], color=colour, ls=ls, lw=0.6)
    eng = me["libcosim (engine)"]
    ax1.semilogx(eng["h"], rate(eng["rho"], eng["h"]), "x", color="k",
                 label="libcosim engine (SSP)")
    ax2.loglog(eng["h"], eng["error"], "x", color="k", label="libcosim engine (SSP)")
    ax1.axhline(0.0, color="grey", lw=0.8)
    ax1.axhline(th["exact_rate"], color="k", lw=0.8, ls="--",
                label="the coupled system itself")
    ax1.set_ylim(-3, 12)
    ax1.set_xlabel("communication step H (s)")
    ax1.set_ylabel("growth rate ln(spectral radius) / H  (1/s)")
    ax1.set_title("stability: above 0 the co-simulation grows (thin lines: limits)")
    ax2.set_ylim(1e-8, 1e3)
    ax2.set_xlabel("communication step H (s)")
    ax2.set_ylabel(f"max |z - z_exact| / max |z_exact| over {HORIZON:g} s")
    ax2.set_title("error against the monolithic exact solution")
    ax1.legend(fontsize=6, loc="upper left", ncol=2)
    fig.suptitle("two masses, spring-damper coupling split into two FMUs "
                 "(force-displacement)\ninput extrapolation of order 0 (solid, circles), "
                 "1 (dashed, squares), 2 (dotted, triangles)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def h_for_error(hs, errs, target: float) -> str:
    """The largest step of the grid whose error is at most target, in ms."""
    ok = [h for h, e in zip(hs, errs) if e <= target]
    return f"{max(ok) * 1e3:.3g} ms" if ok else f"< {min(hs) * 1e3:g} ms"


def verdict(th: dict, me: dict, hs_theory, ad: list[dict]) -> str:
    lines = ["| master | stability limit H* (theory) | measured radius at 0.999 H* / "
             "1.001 H* | largest H for 1 % error | for 0.1 % error | steps per simulated "
             "second at 1 % | wall time per step (measured) |", "|" + "---|" * 7]
    for a, (_, _, label, *_rest) in CURVES.items():
        h1 = h_for_error(th[a]["h"], th[a]["error"], 1e-2)
        h01 = h_for_error(th[a]["h"], th[a]["error"], 1e-3)
        r = me[a]
        lines.append(f"| {label} | {th[a]['limit'] * 1e3:.4f} ms | "
                     f"{r['rho_below']:.7f} / {r['rho_above']:.7f} | {h1} | {h01} | "
                     f"{1e3 / float(h1.split()[0]):.0f} | "
                     f"{np.median(r['seconds_per_step']) * 1e6:.0f} µs |")
    eng = me["libcosim (engine)"]
    lines.append(f"| libcosim engine on the SSP | (its map: the row above) | "
                 f"{eng['rho_below']:.7f} / {eng['rho_above']:.7f} | "
                 f"| | | {np.median(eng['seconds_per_step']) * 1e6:.0f} µs |")
    lines += ["", "Adaptive step (our master, error estimate from the coupling signals, "
              f"atol 1e-4, first step 1 ms, over {HORIZON:g} s):", "",
              "| master | extrapolation | rtol | accepted | rejected | largest H | error | "
              "wall time |", "|---|---|---|---|---|---|---|---|"]
    for row in ad:
        lines.append(f"| {row['master']} | {row['order']} | {row['rtol']:g} | "
                     f"{row['accepted']} | "
                     f"{row['rejected']} | {row['h_max'] * 1e3:.3g} ms | {row['error']:.2g} | "
                     f"{row['seconds']:.2f} s |")
    return "\n".join(lines)


def radius_at_limit(p, scene, fmus, tmp, me, th) -> None:
    """The measured radius just below and just above each limit (our master's
    runs, and the libcosim engine at libcosim's limit rounded to ns)."""
    from loomfmu.scene.libcosim import run_ssp
    for a, (alg, order, _, master, opts, *_rest) in CURVES.items():
        lim = th[a]["limit"]
        for key, f in (("rho_below", 0.999), ("rho_above", 1.001)):
            n = 40 if order == 0 else 60
            res = run(scene, master=master, step=f * lim, stop=n * f * lim, fmus=fmus,
                      master_options=opts, extrapolation=order)
            me[a][key] = identified_radius(states(res), alg, order)
    lim = th["libcosim"]["limit"]
    ssp = tmp / "two_mass.ssp"
    for key, f in (("rho_below", 0.999), ("rho_above", 1.001)):
        h = round(f * lim * 1e9) / 1e9
        data = run_ssp(ssp, [tuple(n.split(".")) for n in Z], step=h, stop=40 * h)
        z = np.vstack([[0.1, 0, 0, 0], states(data)])
        me["libcosim (engine)"][key] = identified_radius(z, "libcosim")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out-dir", type=Path, default=Path("docs"),
                    help="docs folder: guides/scenes.md, results/scenes/ (default: ./docs)")
    ap.add_argument("--quick", action="store_true", help="fewer measured steps (a smoke run)")
    args = ap.parse_args(argv)
    p = tm.Params.declared()
    hs_theory = np.geomspace(1e-5, 3e-2, 120)
    hs = np.round(np.geomspace(2e-4, 2e-2, 4 if args.quick else 11) * 1e9) / 1e9  # whole ns
    scene = tm.scene(stop_time=HORIZON)
    with tempfile.TemporaryDirectory() as tmp, \
            Progress(total=len(hs) + 4, desc="scene stability") as bar:
        bar.stage("building the two FMUs")
        fmus = build_fmus(scene, tmp)
        bar.stage("theory: maps, spectral radii, errors")
        th = theory(p, hs_theory)
        bar.advance("theory done")
        me = measured(p, hs, fmus, scene, Path(tmp), bar)
        bar.stage("radius at the limits")
        radius_at_limit(p, scene, fmus, Path(tmp), me, th)
        bar.advance("limits done")
        ad = adaptive(p, scene, fmus, bar)
    png = args.out_dir / "results" / "scenes" / "two_mass_stability.png"
    chart(png, hs_theory, th, me)
    table = verdict(th, me, hs_theory, ad)
    (args.out_dir / "results" / "scenes" / "two_mass_stability.json").write_text(json.dumps(
        {"theory_limits": {a: th[a]["limit"] for a in CURVES}, "measured": me,
         "theory_error_1e-2": {a: h_for_error(th[a]["h"], th[a]["error"], 1e-2)
                               for a in CURVES},
         "theory_error_1e-3": {a: h_for_error(th[a]["h"], th[a]["error"], 1e-3)
                               for a in CURVES},
         "adaptive": ad}, indent=1, default=float) + "\n")
    md = args.out_dir / "guides" / "scenes.md"
    text = md.read_text() if md.is_file() else f"{BEGIN}\n{END}\n"
    if BEGIN not in text or END not in text:
        print(f"{md}: markers {BEGIN} ... {END} missing", file=sys.stderr)
        return 1
    head, rest = text.split(BEGIN, 1)
    md.write_text(head + BEGIN + "\n" + table + "\n" + END + rest.split(END, 1)[1])
    print(table)
    print(f"wrote {png} and the table in {md}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
