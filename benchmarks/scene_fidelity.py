"""Which levels each seed scene needs: the selector of
loomfmu.machines.fidelity on the loom and spinning scenes, per quantity, at
1 % and 0.1 % of each output's range.

    .venv/bin/python benchmarks/scene_fidelity.py [--out-dir docs/results/fidelity]
        [--part all|loom|spinning] [--loom-stop 5] [--spinning-stop 15]
        [--fmu-dir DIR] [--repeats 2]

Writes <out-dir>/<scene>.json (every combination's CPU seconds and error
per output, the facts of the runs, the answers), <out-dir>/<scene>.png
(cost-error chart over all the scene's outputs at 1 %) and
<out-dir>/answers.md (the table of docs/guides/fidelity.md).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import textwrap
from pathlib import Path

from loomfmu.machines.fidelity import evaluate

#: scene -> quantity -> outputs (the issue's list)
QUANTITIES = {
    "loom": {
        "hinge loads N_rem": ("frame_a.N_rem", "frame_b.N_rem"),
        "out-of-plane slat displacement x2": ("frame_a.x2_out", "frame_b.x2_out"),
        "warp tension": ("back.S2a", "back.S2b"),
        "backrest stick-slip (lever rate, friction torque)": ("back.omega1_out",
                                                              "back.M1f_out"),
    },
    "spinning": {
        "spindle top amplitude (orbit radius r_top)": ("spindle.r_top",),
        "support forces": ("spindle.F_upper", "spindle.F_lower"),
        "drive speed tracking": ("drive.n_out",),
    },
}
TOLS = (0.01, 0.001)


def study(scene: str, stop: float, fmu_dir: Path, repeats: int, out_dir: Path) -> list:
    outputs = [o for outs in QUANTITIES[scene].values() for o in outs]
    ev = evaluate(scene, outputs, stop_time=stop, fmu_dir=fmu_dir, repeats=repeats)
    answers = []
    for quantity, outs in QUANTITIES[scene].items():
        for tol in TOLS:
            sel = ev.select(tol, list(outs))
            answers.append({"scene": scene, "quantity": quantity, "outputs": list(outs),
                            "tol": tol, "chosen": sel.best.label(),
                            "error": sel.best.error, "cpu_s": sel.best.cpu_s,
                            "reference_cpu_s": sel.rows[-1].cpu_s,
                            "speedup": sel.speedup(), "warnings": sel.best.warnings,
                            "notes": sel.notes()})
            print(sel.table(), file=sys.stderr)
    whole = ev.select(0.01)
    chart(ev, out_dir / f"{scene}.png")
    doc = whole.to_dict()
    doc["answers"] = answers
    doc["command"] = " ".join(["benchmarks/scene_fidelity.py"] + sys.argv[1:])
    (out_dir / f"{scene}.json").write_text(json.dumps(doc, indent=1, default=str))
    return answers


def chart(ev, path: Path) -> Path:
    """One panel per quantity: each combination's CPU seconds against its
    largest error over the quantity's outputs; the tolerances as lines."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from loomfmu.machines.fidelity import _short
    quantities = QUANTITIES[ev.scene]
    fig, axes = plt.subplots(1, len(quantities), figsize=(4.2 * len(quantities), 4.9),
                             sharex=True)
    for ax, (quantity, outs) in zip(axes, quantities.items()):
        sel = ev.select(TOLS[0], list(outs))
        floor = min([r.error for r in sel.rows if r.error > 0] + [TOLS[-1]]) / 10
        for i, r in enumerate(sel.rows):
            y = r.error if r.error > 0 else floor
            colour = ("tab:green" if r.error <= TOLS[-1] else
                      "tab:orange" if r.error <= TOLS[0] else "tab:red")
            ax.scatter(r.cpu_s, y, color=colour, s=40, zorder=3)
            ax.annotate(_short(r), (r.cpu_s, y), fontsize=6.5, textcoords="offset points",
                        xytext=(4, 6 if i % 2 else -10))
        for tol, ls in zip(TOLS, ("--", ":")):
            ax.axhline(tol, color="grey", ls=ls, lw=1, label=f"{tol:.1%}")
        ax.set(yscale="log", title=textwrap.fill(quantity, 34),
               xlabel=f"CPU s of a {ev.stop:g} s run")
        ax.legend(loc="lower left", fontsize=7)
    axes[0].set_ylabel("largest error / output's range\n(error 0, the reference: at the "
                       "bottom)")
    fig.suptitle(f"{ev.scene}: cost and error of every level combination (green: within "
                 "0.1 %, orange: within 1 %, red: neither)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def table(answers: list, facts: dict) -> str:
    lines = []
    for scene, (stop, step) in facts.items():
        lines.append(f"* {scene}: {stop:g} s at communication step {step:g} s (Jacobi)")
    lines += ["", "| scene | quantity | tol | cheapest levels within tol | its error | CPU s "
              "| reference CPU s | speed-up | warnings |", "|---|---|---|---|---|---|---|---|---|"]
    for a in answers:
        warn = "; ".join(a["warnings"] + a["notes"]) or "-"
        lines.append(f"| {a['scene']} | {a['quantity']} | {a['tol']:g} | {a['chosen']} | "
                     f"{a['error']:.2e} | {a['cpu_s']:.3g} | {a['reference_cpu_s']:.3g} | "
                     f"{a['speedup']:.2f} | {warn} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", type=Path, default=Path("docs/results/fidelity"))
    ap.add_argument("--part", choices=("all", "loom", "spinning"), default="all")
    ap.add_argument("--loom-stop", type=float, default=5.0)
    ap.add_argument("--spinning-stop", type=float, default=15.0)
    ap.add_argument("--fmu-dir", type=Path, default=None)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args(argv)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    parts = ("loom", "spinning") if args.part == "all" else (args.part,)
    stops = {"loom": args.loom_stop, "spinning": args.spinning_stop}
    with tempfile.TemporaryDirectory() as tmp:
        fmu_dir = args.fmu_dir or Path(tmp)
        answers, facts = [], {}
        for scene in parts:
            answers += study(scene, stops[scene], fmu_dir,
                             args.repeats if scene == "loom" else 1, args.out_dir)
            facts[scene] = (stops[scene], 1e-3)
    # answers.md keeps the other scene's rows when only one part ran
    path = args.out_dir / "answers.json"
    old = json.loads(path.read_text()) if path.is_file() else {"answers": [], "facts": {}}
    keep = [a for a in old["answers"] if a["scene"] not in parts]
    facts = {**{k: tuple(v) for k, v in old["facts"].items() if k not in parts}, **facts}
    answers = sorted(keep + answers, key=lambda a: (a["scene"], a["quantity"], -a["tol"]))
    path.write_text(json.dumps({"answers": answers, "facts": facts}, indent=1))
    (args.out_dir / "answers.md").write_text(table(answers, facts))
    print(table(answers, facts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
