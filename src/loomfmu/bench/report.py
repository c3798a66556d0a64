"""Charts, the CSV of every point, the speed table and docs/results/bench/summary.md.

The speed table compares methods at one achieved error (:data:`TARGET`, the
max-over-grid norm), never at equal tolerance: each method's time at that
error is interpolated log-log on its work-precision curve
(:func:`loomfmu.bench.classic.time_at_error`); a method whose sweep does not
bracket the target shows "–".
"""
from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import matplotlib

from loomfmu.bench.classic import time_at_error

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

#: achieved error (max over the grid, worst key output, relative to its range)
#: at which the speed table compares methods
TARGETS = (1e-4, 1e-6)
TARGET = TARGETS[-1]
COLUMNS = ("model", "study", "family", "method", "rtol", "h", "param", "value", "seconds",
           "err_final", "err_max", "n_rhs", "status", "note")
#: our FMU's solvers: one colour each, shared by the FMPy (solid) and C-level
#: (dotted) lines of the same solver
FMU_COLORS = {"dopri5": "#1a9850", "rodas4": "#762a83", "rk4": "#d73027",
              "ros34pw2": "#2166ac"}
PEERS = ("scipy RK45", "scipy DOP853", "scipy Radau", "scipy BDF", "scipy LSODA",
         "casadi cvodes", "casadi idas")


def write_csv(rows: list[dict], path: Path) -> None:
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if isinstance(r.get(k), float) and math.isnan(r[k]) else r.get(k))
                        for k in COLUMNS})


def _curves(rows, model, norm="err_max") -> dict[str, list[tuple[float, float]]]:
    out: dict[str, list[tuple[float, float]]] = {}
    for r in rows:
        if r["model"] == model and r["study"] == "wp" and r["status"] == "ok":
            e, s = r[norm], r["seconds"]
            if e > 0 and math.isfinite(e) and s > 0:
                out.setdefault(f"{r['family']} {r['method']}", []).append((e, s))
    return out


def wp_chart(rows, model: str, info: dict, path: Path) -> None:
    fig, ax = plt.subplots(1, 2, figsize=(13.5, 4.8), sharey=True)
    for a, norm, title in ((ax[0], "err_max", "max over the communication grid"),
                           (ax[1], "err_final", "at the final time")):
        for i, (label, pts) in enumerate(sorted(_curves(rows, model, norm).items())):
            pts = sorted(pts, key=lambda p: p[1])
            fmu = label.startswith("fmu")
            style = "o-" if label.startswith("fmu ") else "o:" if fmu else (
                "s--" if label.startswith("scipy") else "^-.")
            a.loglog([p[0] for p in pts], [p[1] for p in pts], style,
                     lw=2.2 if fmu else 1, ms=5, label=label,
                     color=FMU_COLORS.get(label.split()[1], "k") if fmu else f"C{i % 10}")
        a.axvline(TARGET, color="k", lw=0.6, ls=":")
        a.set(xlabel=f"achieved error / range ({title})", title=f"{model}: {title}")
        a.grid(True, which="both", alpha=0.3)
    ax[0].set_ylabel("CPU time (s), median of repeats")
    ax[1].legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.suptitle(f"{model}, {info['t_end']:g} s; reference: {info['ref']}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def time_to_reach(points: list[tuple[float, float]], target: float) -> float | None:
    """The least time at which a method's error is <= target: interpolated
    log-log where its curve crosses the target, or a point already below it."""
    cands = [s for e, s in points if e <= target]
    pts = sorted(points)
    for (e0, s0), (e1, s1) in zip(pts, pts[1:]):
        if e0 <= target <= e1:
            cands.append(time_at_error([(e0, s0), (e1, s1)], target))
    return min(cands) if cands else None


def speed_table(rows, models) -> list[dict]:
    """Per model and target: our FMU's best time and each peer's ratio to it."""
    table = []
    for model, target in ((m, t) for m in models for t in TARGETS):
        at = {label: time_to_reach(pts, target)
              for label, pts in _curves(rows, model).items()}
        fmu = {k: v for k, v in at.items() if k.startswith("fmu ") and v}
        best = min(fmu, key=fmu.get) if fmu else None
        # the same FMU runs timed at C level (loomfmu.bench.limit.speed_points)
        c_level = {k: v for k, v in at.items() if k.startswith("fmu-c ") and v}
        c_best = min(c_level, key=c_level.get) if c_level else None
        cvodes = at.get("casadi cvodes")
        table.append({"model": model, "target": target, "fmu_method": best,
                      "fmu_seconds": fmu.get(best) if best else None,
                      "ratio": {p: (at[p] / fmu[best] if at.get(p) and best else None)
                                for p in PEERS}, "seconds": at,
                      "fmu_c_method": c_best,
                      "fmu_c_seconds": c_level.get(c_best) if c_best else None,
                      "cvodes_ratio_c": (cvodes / c_level[c_best] if cvodes and c_best
                                         else None)})
    return table


def speed_table_md(table) -> str:
    head = ("| model | error | our FMU ms (solver) | " + " | ".join(PEERS)
            + " | our FMU at C level ms (solver) | casadi cvodes ÷ C level |\n|---|---|---|"
            + "---|" * (len(PEERS) + 2) + "\n")
    lines = []
    for t in table:
        fmu = (f"{t['fmu_seconds'] * 1e3:.1f} ({t['fmu_method'].split()[1]})"
               if t["fmu_seconds"] else "–")
        cells = [f"{t['ratio'][p]:.3g}×" if t["ratio"][p] else "–" for p in PEERS]
        c_sec = t.get("fmu_c_seconds")
        c_level = (f"{c_sec * 1e3:.2f} ({t['fmu_c_method'].split()[1]})" if c_sec else "–")
        cv = t.get("cvodes_ratio_c")
        lines.append(f"| {t['model']} | {t['target']:g} | {fmu} | " + " | ".join(cells)
                     + f" | {c_level} | {f'{cv:.3g}×' if cv else '–'} |")
    return head + "\n".join(lines) + "\n"


READING = """\
How to read the charts (`docs/results/bench/<model>_wp.png`): each line is one method swept
over its tolerances (rk4: over its fixed step); x is the achieved error, the
worst key output's |y − y_ref| divided by that output's range in the
reference — left panel the max over the communication grid, right panel at
the final time; y is CPU time, the median of repeated runs (runs over 1 s
once). Lower and further left is better; compare methods along a vertical
line (equal achieved error), never at equal tolerance. Our FMU is timed
through FMPy on one instance kept and reset before each run, as a script
that runs a model many times does (`fmi2Reset`, then `fmpy.simulate_fmu`
with `fmu_instance`: start values, initialization, every step and output
read); loading its library and FMPy's binding of its functions (about
1.3 ms per new instance) are outside the time, as building CasADi's
integrator is outside CasADi's. scipy's time is its integration only, with
a Python right-hand side from the same declaration (`loomfmu.verification.reference`);
CasADi's is the integrator call only. The dotted "fmu-c" lines are the
same FMU runs (same settings, same communication grid, the same
trajectory: final outputs equal bit for bit) driven by the C program of
`loomfmu bench limit` without Python: our FMU's own time, without FMPy's
(its Python side costs about 6 µs per communication step, `python
benchmarks/master_overhead.py`), the fair match for CasADi's integrator
call.
Models with friction modes or delays have no CasADi points (its integrators
support neither); the regularized backrest is CasADi's stand-in."""


def summary_md(table, verdicts: dict, infos: dict, cmd: str, wall: float) -> str:
    lines = [READING, "",
             f"**Speed table** (from `{cmd}`, {wall / 60:.1f} min on this machine): "
             "time of each peer ÷ time of our FMU's fastest solver, both at the same "
             "achieved error (max over the grid, worst key output, relative to its range: "
             f"{' and '.join(f'{t:g}' for t in TARGETS)}), the least time at which each "
             "curve is at or below that error (interpolated log-log where it crosses); "
             "– : the sweep did not reach it (scipy sweeps stop after the first run "
             "slower than 5 s). Last two columns: our FMU's fastest solver timed at C "
             "level (the dotted fmu-c lines) and CasADi cvodes' time ÷ that.",
             "", speed_table_md(table), "| model | key outputs | length | reference |",
             "|---|---|---|---|"]
    lines += [f"| {m} | {', '.join(i['outputs'])} | {i['t_end']:g} s | {i['ref']} |"
              for m, i in infos.items()]
    lines += ["", "**Where methods fail** (charts `docs/results/bench/<model>_<study>.png`):", ""]
    lines += [f"* {v}" for v in verdicts.values()]
    lines += ["", f"Every point is in `docs/results/bench/points.csv`. Regenerate: `{cmd}` "
              "(`--quick` for a coarse sweep)."]
    return "\n".join(lines) + "\n"


def update_readme(readme: Path, section: str) -> bool:
    """Replace the text between the bench markers in a page (docs/guides/speed.md), if present."""
    text = readme.read_text()
    pat = re.compile(r"(<!-- bench:start -->\n).*?(<!-- bench:end -->)", re.S)
    if not pat.search(text):
        return False
    readme.write_text(pat.sub(lambda m: m.group(1) + section + m.group(2), text))
    return True
