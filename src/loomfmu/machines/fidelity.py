"""Fidelity chosen per scene, measured.

``loomfmu scene fidelity SCENE --outputs comp.var,... --tol 0.01``: the
scene is run with every combination of its components' levels (each a
model of loomfmu.registry.FIDELITY, with the build options of
loomfmu.fidelity.VARIANTS), the highest-fidelity combination is the
reference, and each output's error is its largest difference from the
reference run over the reference's range of that output (max - min).  The
answer is the cheapest combination (CPU seconds of the run, the least of
``repeats`` runs, ``time.process_time``: the FMUs run in this process) whose
every output is within the tolerance; the highest combination always is.
Costs within COST_NOISE of the cheapest passing one count as equal, and
among those the lowest levels win (a tie on a shared machine is noise).

A level that does not have an output (the rigid frame has no slat
deflection) predicts it as zero, and is measured so.

The coupling is one more choice (``couplings``, ``--couplings
cosim,monolithic``): each combination co-simulated on the master at the
step, or composed into one model and FMU (loomfmu.scene.compose) run at the
step as its output interval.  With "monolithic" among the couplings the
reference is the highest combination composed (no coupling error), so a
co-simulation's error includes its coupling error; among costs within
COST_NOISE the composed run ranks first (one FMU, no coupling step).

Honesty rules (warnings on a passing reduced combination):

* **not excited (frequency)**: the level leaves out modes from cut_hz up
  (loomfmu.fidelity.cut_frequency); the reference output's content above
  cut_hz / 2 (the detrended signal high-passed there by FFT, its largest
  magnitude over the output's range) is below the tolerance: the scene does
  not drive what the level leaves out, a scene that does may need more
  (the measure's floor is about 1e-3 of the range: :func:`high_content`).
* **not excited (stick)**: the level has no sticking and the reference
  backrest sticks (either pivot's speed below STICK_SPEED) for under a share
  tol of the run's samples.
* **small range**: the output's range in the reference run is below
  tol x its largest magnitude: the scene barely moves it, so an error
  relative to the range says little about the level.
"""
from __future__ import annotations

import functools
import itertools
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from loomfmu.declare.checks import check_number
from loomfmu.fidelity import cut_frequency, level
from loomfmu.progress import Progress

#: the pivots' relative speeds of the backrest, by scene: the reference run
#: (event-driven friction, a stuck pivot's speed is held at zero) is stuck where
#: either is below STICK_SPEED
_STICK_OUTPUT = {"loom": ("back.omega1_out", "back.omega2_out")}
STICK_SPEED = 1e-9   # rad/s
#: CPU costs within this share of the cheapest passing one count as equal
#: (timing noise on a shared machine); among them the lowest levels win
COST_NOISE = 0.10
#: share of the samples at each end left out of the high-frequency content
EDGE = 0.05
#: the key of the coupling in a row's levels; its values
COUPLING = "coupling"
COUPLINGS = ("cosim", "monolithic")


@dataclass(frozen=True)
class Choice:
    """A level of one component slot: model with build options."""

    model: str
    options: tuple = ()

    @property
    def label(self) -> str:
        opts = ",".join(f"{k}={v}" for k, v in self.options)
        return self.model + (f"({opts})" if opts else "")


def _loom(choices: dict, stop: float, step: float, **opts):
    from loomfmu.machines import loom
    return loom.scene(frame=choices["frames"].model, backrest=choices["backrest"].model,
                      stop_time=stop, step=step, **opts)


def _spinning(choices: dict, stop: float, step: float, **opts):
    from loomfmu.machines import spinning
    sp = choices["spindle"]
    return spinning.scene(fidelity=sp.model, spindle_options=dict(sp.options),
                          stop_time=stop, step=step, **opts)


#: the scene factory's options the selector passes on (the rest it sets itself)
SCENE_OPTIONS = {"loom": ("tension", "omega"), "spinning": ("cam", "n_const")}


def _spindles() -> list[Choice]:
    from loomfmu.fidelity import VARIANTS
    out = [Choice("spindle_modal", (("n_modes", n),))
           for n in VARIANTS["spindle_modal"]["n_modes"]]
    if True in VARIANTS["spindle_modal"]["static_correction"]:  # the cheapest basis, corrected
        n = min(VARIANTS["spindle_modal"]["n_modes"])
        out.insert(1, Choice("spindle_modal", (("n_modes", n), ("static_correction", True))))
    return out + [Choice("spindle")]


#: scene -> (factory(choices, stop, step), {slot: levels cheapest first},
#: default stop (s), default step (s), which components each slot sets)
SCENES = {
    "loom": (_loom, {"frames": [Choice("heald_frame_rigid"), Choice("heald_frame_planar"),
                                Choice("heald_frame")],
                     "backrest": [Choice("backrest_regularized"), Choice("backrest")]},
             1.0, 1e-3, {"frames": ("frame_a", "frame_b"), "backrest": ("back",)}),
    "spinning": (_spinning, {"spindle": _spindles()}, 1.0, 1e-3,
                 {"spindle": ("spindle",)}),
}


@dataclass
class Row:
    """One combination run: its levels, CPU seconds, error per output."""

    levels: dict
    cpu_s: float
    errors: dict
    absent: list
    warnings: list = field(default_factory=list)

    @property
    def error(self) -> float:
        return max(self.errors.values())

    def label(self) -> str:
        return " + ".join(f"{k}={v}" for k, v in self.levels.items())


@dataclass
class Evaluation:
    """Every combination's errors on ``outputs`` against the reference (the
    last row), and what the runs were."""

    scene: str
    outputs: list
    stop: float
    step: float
    rows: list
    facts: dict
    reference: dict             # the reference run's data per output (for the rules)

    def select(self, tol: float, outputs=None) -> "Selection":
        """The cheapest combination with every output of ``outputs``
        (default all) within ``tol`` (0 < tol < 1) of its range."""
        tol = check_number("tol", tol, lo=0.0, lo_open=True, hi=1.0, hi_open=True)
        outputs = self.outputs if outputs is None else _check_outputs(outputs, self.outputs)
        rows = []
        for r in self.rows:
            err = {o: r.errors[o] for o in outputs}
            rows.append(Row(r.levels, r.cpu_s, err, [a for a in r.absent if a in outputs]))
        passing = [r for r in rows if r.error <= tol]     # the reference (last) always
        cheapest = min(r.cpu_s for r in passing)
        near = [r for r in passing if r.cpu_s <= cheapest * (1 + COST_NOISE)]
        chosen = min(near, key=lambda r: (self._rank(r), r.cpu_s))
        for r in rows[:-1]:
            if r.error <= tol:
                r.warnings = self._warnings(r, tol, outputs)
        return Selection(self, tol, list(outputs), rows, rows.index(chosen))

    def _rank(self, row: Row) -> int:
        """Sum of the row's level indices (0: the lowest level of each slot;
        the coupling: 0 composed, 1 co-simulated)."""
        slots = SCENES[self.scene][1]
        return sum(([c.label for c in slots[k]].index(v) if k != COUPLING
                    else int(v != "monolithic")) for k, v in row.levels.items())

    def _warnings(self, row: Row, tol: float, outputs) -> list:
        out = []
        for slot, label in row.levels.items():
            if slot == COUPLING:
                continue
            choice = _choice(self.scene, slot, label)
            if choice == SCENES[self.scene][1][slot][-1]:
                continue
            cut = cut_frequency(choice.model, dict(choice.options))
            if cut is not None:
                for o in outputs:
                    hf = high_content(self.reference["time"], self.reference[o], cut / 2)
                    if hf < tol:
                        out.append(f"{o}: {choice.label} passes, but the reference's content"
                                   f" above {cut / 2:g} Hz (half its lowest left-out mode, "
                                   f"{cut:g} Hz) is {hf:.2g} of the range (< tol): the scene "
                                   "does not excite what it leaves out")
            if level(choice.model).leaves_out_stick and self.scene in _STICK_OUTPUT:
                share = float(np.mean(self.reference["_stick"]))
                if share < tol:
                    out.append(f"{choice.label} passes, but the reference backrest sticks "
                               f"{share:.2%} of the run (< tol): the scene does not "
                               "exercise the sticking it leaves out")
        for o in outputs:
            y = self.reference[o]
            rng, mag = float(np.ptp(y)), float(np.abs(y).max())
            if rng < tol * mag:
                out.append(f"{o}: its range in the reference ({rng:.3g}) is below tol x its "
                           f"magnitude ({mag:.3g}): the scene barely moves it")
        return out


@dataclass
class Selection:
    evaluation: Evaluation
    tol: float
    outputs: list
    rows: list
    chosen: int

    @property
    def best(self) -> Row:
        return self.rows[self.chosen]

    def speedup(self) -> float:
        return self.rows[-1].cpu_s / max(self.best.cpu_s, 1e-9)

    def table(self) -> str:
        ev = self.evaluation
        head = ["levels", "CPU s"] + self.outputs + ["max", "within"]
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for i, r in enumerate(self.rows):
            cells = [("**" + r.label() + "**") if i == self.chosen else r.label(),
                     f"{r.cpu_s:.3g}"]
            cells += [f"{r.errors[o]:.2e}" + (" (absent)" if o in r.absent else "")
                      for o in self.outputs]
            cells += [f"{r.error:.2e}", "yes" if r.error <= self.tol else "no"]
            lines.append("| " + " | ".join(cells) + " |")
        text = [f"scene {ev.scene}: {ev.stop:g} s at step {ev.step:g} s; tol {self.tol:g} of "
                "each output's range in the reference (the last row)", *lines,
                f"chosen: {self.best.label()} (CPU {self.best.cpu_s:.3g} s, "
                f"speed-up {self.speedup():.3g} over the reference)"]
        text += [f"warning: {w}" for w in self.best.warnings]
        facts = ev.facts
        text.append(f"ran ({facts['master']} master; the reference's components, the other "
                    "combinations differ in the levels only):")
        for name, c in facts["components"].items():
            set_ = {**c["parameters"], **c["start"]}
            text.append(f"  {name}: {c['model']} {c['options'] or ''} "
                        + (", ".join(f"{k} = {v:.6g}" for k, v in set_.items())
                           or "defaults"))
        text.append("  inputs: " + "; ".join(facts["inputs"]))
        text += [f"note: {n}" for n in self.notes()]
        return "\n".join(text)

    def notes(self) -> list:
        """Outputs the reference run barely moves (range < tol x magnitude):
        their errors relative to the range are large for any level."""
        out = []
        for o in self.outputs:
            if all(r.errors[o] == 0.0 for r in self.rows):
                out.append(f"{o}: every combination gives the reference's values exactly: "
                           "the output does not depend on the levels tried (e.g. a one-way "
                           "coupling)")
            y = self.evaluation.reference[o]
            rng, mag = float(np.ptp(y)), float(np.abs(y).max())
            if rng < self.tol * mag:
                out.append(f"{o}: its range in the reference ({rng:.3g}) is below tol x its "
                           f"magnitude ({mag:.3g}): the scene barely moves it, and the error "
                           "relative to that range is large for any level but the reference")
        return out

    def to_dict(self) -> dict:
        ev = self.evaluation
        return {"scene": ev.scene, "stop_time": ev.stop, "step": ev.step, "tol": self.tol,
                "outputs": self.outputs, "facts": ev.facts,
                "chosen": self.best.label(), "speedup": self.speedup(),
                "warnings": self.best.warnings, "notes": self.notes(),
                "rows": [{**asdict(r), "label": r.label(), "error": r.error,
                          "within": r.error <= self.tol} for r in self.rows]}

    def chart(self, path) -> Path:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(8.5, 5.5))
        nonzero = [r.error for r in self.rows if r.error > 0]
        floor = min(nonzero + [self.tol]) / 10     # the reference (error 0) drawn here
        for i, r in enumerate(self.rows):
            ok = r.error <= self.tol
            y = r.error if r.error > 0 else floor
            ax.scatter(r.cpu_s, y, s=140 if i == self.chosen else 36,
                       marker="*" if i == self.chosen else "o",
                       color="tab:green" if ok else "tab:red", zorder=3)
            text = ("reference: " if i == len(self.rows) - 1 else "") + _short(r)
            ax.annotate(text, (r.cpu_s, y), fontsize=7, textcoords="offset points",
                        xytext=(5, 8 if i % 2 else -12))
        ax.axhline(self.tol, color="grey", ls="--", label=f"tol {self.tol:g}; star: chosen "
                   f"(costs within {COST_NOISE:.0%} count as equal, lowest levels win)")
        ax.set(yscale="log", xlabel=f"CPU s of a {self.evaluation.stop:g} s run",
               ylabel="largest error / output's range (reference: drawn at the bottom)",
               title=f"{self.evaluation.scene}: {', '.join(self.outputs)}"[:90])
        ax.legend(loc="lower left")
        fig.tight_layout()
        path = Path(path)
        fig.savefig(path, dpi=110)
        plt.close(fig)
        return path


def _short(row: Row) -> str:
    """A row's levels without the mechanism prefixes (chart labels)."""
    return " + ".join(v.replace("heald_frame_", "").replace("heald_frame", "spatial")
                      .replace("backrest_", "").replace("spindle_modal", "modal")
                      for v in row.levels.values())


def _choice(scene: str, slot: str, label: str) -> Choice:
    return next(c for c in SCENES[scene][1][slot] if c.label == label)


def high_content(t, y, f_hz: float) -> float:
    """The largest magnitude of ``y``'s part above ``f_hz`` over y's range (0
    if flat): the signal less the line through its ends, extended odd (so it
    and its slope are continuous where the FFT wraps), high-passed at f_hz;
    the first and last EDGE of the samples are left out (edge ringing).  Its
    floor is about 1e-3 of the range (leakage of a few cycles of a sine,
    tests/test_fidelity.py), so the rule cannot see content below that."""
    y = np.asarray(y, float)
    rng, n = float(np.ptp(y)), len(y)
    if rng == 0.0 or n < 8:
        return 0.0
    dt = float(t[1] - t[0])
    yd = y - np.linspace(y[0], y[-1], n)
    yd = np.concatenate([yd, -yd[::-1]])
    spec = np.fft.rfft(yd)
    spec[np.fft.rfftfreq(len(yd), dt) < f_hz] = 0.0
    e = int(n * EDGE)
    return float(np.abs(np.fft.irfft(spec, len(yd))[e:n - e]).max() / rng)


def _check_outputs(outputs, allowed) -> list:
    if isinstance(outputs, str):
        outputs = [o.strip() for o in outputs.split(",") if o.strip()]
    outputs = list(outputs)
    bad = [o for o in outputs if not isinstance(o, str) or o not in allowed]
    if not outputs or bad:
        raise ValueError(f"outputs = {outputs!r:.80}: {'empty' if not outputs else 'unknown '}"
                         f"{', '.join(map(repr, bad))}; allowed: a non-empty list of "
                         f"{', '.join(sorted(allowed))}")
    return outputs


def _check_couplings(couplings) -> tuple:
    if isinstance(couplings, str):
        couplings = [c.strip() for c in couplings.split(",") if c.strip()]
    try:
        couplings = list(couplings)
    except TypeError:
        couplings = [couplings]
    bad = [c for c in couplings if not isinstance(c, str) or c not in COUPLINGS]
    if not couplings or bad or len(set(couplings)) != len(couplings):
        raise ValueError(f"couplings = {couplings!r:.80}; allowed: some of "
                         f"{', '.join(COUPLINGS)}, each once")
    return tuple(c for c in COUPLINGS if c in couplings)   # the reference's last


def scene_outputs(scene_name: str, scene_options: dict | None = None) -> list[str]:
    """The outputs the selector can compare in scene ``scene_name``: every
    output variable of the reference scene's components."""
    ref = _reference_scene(scene_name, 1.0, 1e-3, scene_options or {})
    return sorted(f"{c.name}.{v.name}" for c in ref.components.values()
                  for v in c.interface.variables.values()
                  if v.causality == "output" and v.type == "Real")


def _reference_scene(scene_name, stop, step, opts):
    factory, slots, *_ = SCENES[scene_name]
    return factory({k: v[-1] for k, v in slots.items()}, stop, step, **opts)


def evaluate(scene: str, outputs, *, stop_time: float | None = None,
             step: float | None = None, fmu_dir=None, progress: bool = True,
             master: str = "jacobi", repeats: int = 2,
             scene_options: dict | None = None, couplings=("cosim",)) -> Evaluation:
    """Run scene ``scene`` (a name of SCENES) with every level combination
    and measure ``outputs`` ("comp.var", a list or comma-separated) against
    the highest-fidelity run; stop_time, step (s): the run (defaults: the
    selector's for the scene); fmu_dir: FMU cache (default a temporary folder);
    repeats: runs per combination (1 ... 10), the cost is the least CPU time;
    scene_options: options of the scene factory (SCENE_OPTIONS, e.g. the
    loom's tension or omega), checked by the factory; couplings: how each
    combination runs, some of COUPLINGS (a list or comma-separated): "cosim"
    on the master at the step, "monolithic" composed into one FMU."""
    import tempfile

    from loomfmu.scene.fmus import build_fmus
    from loomfmu.scene.monolithic import composed_fmu, run_monolithic
    from loomfmu.scene.run import run
    if not isinstance(scene, str) or scene not in SCENES:
        raise ValueError(f"scene = {scene!r:.60}; allowed: {', '.join(sorted(SCENES))}")
    factory, slots, stop0, step0, sets = SCENES[scene]
    stop = check_number("stop_time", stop0 if stop_time is None else stop_time, lo=0.0,
                        lo_open=True, hi=3600.0, unit="s")
    step = check_number("step", step0 if step is None else step, lo=0.0, lo_open=True,
                        hi=stop, unit="s")
    if not isinstance(master, str) or master not in ("jacobi", "gauss-seidel"):
        raise ValueError(f"master = {master!r:.40}; allowed: jacobi, gauss-seidel")
    if not isinstance(repeats, int) or isinstance(repeats, bool) or not 1 <= repeats <= 10:
        raise ValueError(f"repeats = {repeats!r:.40}; allowed: an integer 1 ... 10")
    scene_options = dict(scene_options or {})
    bad = sorted(set(scene_options) - set(SCENE_OPTIONS[scene]))
    if bad:
        raise ValueError(f"scene_options: unknown {bad}; allowed for {scene}: "
                         f"{', '.join(SCENE_OPTIONS[scene])}")
    outputs = _check_outputs(outputs, scene_outputs(scene, scene_options))
    couplings = _check_couplings(couplings)
    combos = [(dict(zip(slots, c)), k) for c in itertools.product(*slots.values())
              for k in couplings]
    combos = combos[-1:] + combos[:-1]          # the reference first
    tmp = tempfile.TemporaryDirectory() if fmu_dir is None else None
    fmu_dir = Path(tmp.name if tmp else fmu_dir)
    bar = Progress(len(combos), f"fidelity {scene}") if progress else None
    rows, ref_data, facts = [], None, {}
    try:
        for choices, coupling in combos:
            label = ", ".join(c.label for c in choices.values())
            if len(couplings) > 1:
                label += f", {coupling}"
            s = factory(choices, stop, step, **scene_options)
            have = {f"{c}.{v}" for c, v in s.recorded}
            absent = []
            for o in outputs + list(_STICK_OUTPUT.get(scene, ())):
                comp, var = o.split(".", 1)
                if o in have:
                    continue
                if var in s.components[comp].interface.variables:
                    s.record(o)
                else:
                    absent.append(o)
            if bar is not None:
                bar.stage(f"{label}: build")
            if coupling == "monolithic":
                fmu, _ = composed_fmu(s, fmu_dir)
                go = functools.partial(run_monolithic, s, fmu=fmu, stop=stop, step=step)
            else:
                fmus = build_fmus(s, fmu_dir)
                go = functools.partial(run, s, fmus=fmus, stop=stop, step=step, master=master,
                                       extrapolation=0)
            if bar is not None:
                bar.stage(f"{label}: run {stop:g} s")
            cpu = math.inf
            for _ in range(repeats):
                t0 = time.process_time()
                res = go()
                cpu = min(cpu, time.process_time() - t0)
            data = {o: (np.zeros(len(res.data)) if o in absent else np.asarray(res[o]))
                    for o in outputs}
            if ref_data is None:
                ref_data = {"time": np.asarray(res["time"]), **data}
                if scene in _STICK_OUTPUT:
                    ref_data["_stick"] = np.any([np.abs(res[o]) < STICK_SPEED
                                                 for o in _STICK_OUTPUT[scene]], axis=0)
                facts = _facts(s, stop, step, master, scene_options)
                facts["reference_coupling"] = coupling
            errors = {}
            for o in outputs:
                rng = float(np.ptp(ref_data[o]))
                diff = np.abs(data[o] - ref_data[o])
                if not np.all(np.isfinite(data[o])):
                    errors[o] = math.inf
                elif rng == 0.0:
                    errors[o] = 0.0 if diff.max() == 0.0 else math.inf
                else:
                    errors[o] = float(diff.max() / rng)
            levels = {k: c.label for k, c in choices.items()}
            if len(couplings) > 1:
                levels[COUPLING] = coupling
            rows.append(Row(levels, cpu, errors, absent))
            if bar is not None:
                bar.advance(f"{label}: CPU {cpu:.3g} s, error {max(errors.values()):.2e}")
    finally:
        if bar is not None:
            bar.close()
        if tmp is not None:
            tmp.cleanup()
    rows = rows[1:] + rows[:1]                  # the reference last
    return Evaluation(scene, outputs, stop, step, rows, facts, ref_data)


def _facts(s, stop, step, master, scene_options) -> dict:
    """What the runs were: length, step, master, each component's model,
    options, parameters and starts set by the scene (the rest at defaults)."""
    return {"description": s.description, "stop_time_s": stop,
            "scene_options": scene_options, "step_s": step,
            "master": master,
            "components": {c.name: {"model": c.model, "options": c.options,
                                    "parameters": c.parameters, "start": c.start}
                           for c in s.components.values()},
            "inputs": [str(c) for c in s.connections]}


def select(scene: str, outputs, tol: float, **kw) -> Selection:
    """evaluate(scene, outputs, **kw).select(tol): the tolerance is checked first."""
    check_number("tol", tol, lo=0.0, lo_open=True, hi=1.0, hi_open=True)
    return evaluate(scene, outputs, **kw).select(tol)


# -- command line (loomfmu scene fidelity) ----------------------------------------
def add_parser(sub) -> None:
    f = sub.add_parser("fidelity", help="the cheapest level combination whose outputs stay "
                       "within a tolerance of the highest-fidelity run")
    f.add_argument("scene", help=f"one of {', '.join(sorted(SCENES))}")
    f.add_argument("--outputs", required=True, help="comma-separated comp.var")
    f.add_argument("--tol", type=float, default=0.01,
                   help="tolerance relative to each output's range (0 < tol < 1; default 0.01)")
    f.add_argument("--stop", "--stop-time", dest="stop_time", type=float, default=None,
                   help="run length in s (as in loomfmu scene run)")
    f.add_argument("--step", type=float, default=None, help="communication step in s")
    f.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                   help="an option of the scene (loom: tension, omega; spinning: cam, "
                        "n_const); numbers are read as numbers")
    f.add_argument("--repeats", type=int, default=2,
                   help="runs per combination; the cost is the least CPU time (default 2)")
    f.add_argument("--couplings", default="cosim",
                   help="how each combination runs, comma-separated: cosim (the master at "
                        "the step, the default), monolithic (composed into one FMU); with "
                        "both, the reference is the highest combination composed")
    f.add_argument("--fmu-dir", type=Path, default=None, help="FMU cache folder")
    f.add_argument("--json", type=Path, default=None, help="write the selection as JSON")
    f.add_argument("--chart", type=Path, default=None, help="write the cost-error chart")


def main(args) -> int:
    import json

    from loomfmu.declare.checks import check_output_options
    check_output_options(args, files=["json", "chart"], folders=["fmu_dir"])
    opts = {}
    for item in args.option:
        name, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"--option {item!r:.40}; allowed: NAME=VALUE")
        try:
            opts[name] = float(value)
        except ValueError:
            opts[name] = value
    sel = select(args.scene, args.outputs, args.tol, stop_time=args.stop_time,
                 step=args.step, fmu_dir=args.fmu_dir, repeats=args.repeats,
                 scene_options=opts, couplings=args.couplings)
    print(sel.table())
    if args.json is not None:
        args.json.write_text(json.dumps(sel.to_dict(), indent=1, default=str))
        print(f"written: {args.json}")
    if args.chart is not None:
        print(f"written: {sel.chart(args.chart)}")
    return 0
