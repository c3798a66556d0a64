"""Run a scene on our master: fixed or adaptive communication steps; results
as a numpy structured array (field ``time`` and one per recorded variable,
named ``component.variable``) and CSV."""
from __future__ import annotations

import math
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from loomfmu.declare.checks import MAX_POINTS, check_number
from loomfmu.progress import Progress
from loomfmu.scene.declare import Scene
from loomfmu.scene.fmus import build_fmus, check_fmus
from loomfmu.scene.master import MASTERS, check_options, make_master
from loomfmu.scene.system import System

#: step-size controller of the adaptive run (error ~ h^(order + 1) for an
#: extrapolation of that order)
SAFETY, FAC_MIN, FAC_MAX = 0.9, 0.2, 2.0
#: a recorded variable that changes by more than this fraction of its
#: largest magnitude within one communication step is not resolved by the
#: steps (Result.largest_step_change): the run is flagged (scene run warns)
UNRESOLVED = 0.1
#: fewest steps a run needs for that judgement: over fewer steps a signal
#: that starts from rest changes by about 2 / steps of its size per step
#: however well resolved (a quadratic ramp), which 20 steps keep at 0.1
MIN_JUDGED_STEPS = 20


class UnresolvedCoupling(UserWarning):
    """A run whose steps do not resolve a coupled signal (more than
    UNRESOLVED of its size within one step): its result may be unstable or
    wrong.  run() warns; ``loomfmu scene run`` prints it on stderr."""


#: options of the algebraic-loop solver (loomfmu.scene.system.System)
LOOP_OPTIONS = ("loop_method", "loop_rtol", "loop_atol", "loop_max_iter", "relaxation")


@dataclass
class Result:
    """data: structured array; master: its name; accepted, rejected:
    communication steps; h: the accepted step sizes; log: each component's
    FMU log lines (warnings such as an input outside its range)."""

    data: np.ndarray
    master: str
    accepted: int
    rejected: int
    h: np.ndarray = field(default_factory=lambda: np.zeros(0))
    log: dict[str, list[str]] = field(default_factory=dict)   # each FMU's log lines
    loop_iterations: int = 0     # output reads spent iterating algebraic loops
    notes: list[str] = field(default_factory=list)   # the master's fallbacks, if any
    #: the recorded variables that feed a connection ("component.variable")
    coupled: list[str] = field(default_factory=list)
    #: absolute floor of a signal's size in largest_step_change (run's atol)
    atol: float = 1e-6
    #: the order of the input extrapolation the run used
    extrapolation: int = 0

    def __getitem__(self, name: str) -> np.ndarray:
        return self.data[name]

    def largest_step_change(self) -> tuple[float, str]:
        """The largest change of a coupled signal (a recorded variable that
        feeds a connection: ``coupled``) within one communication step,
        relative to that variable's largest magnitude over the run plus
        ``atol`` (as the adaptive master scales its error estimate; a signal
        that stays near zero changes by nothing), inf where a value is not
        finite, and the variable's name; (0.0, "") with none recorded or a
        run of fewer than MIN_JUDGED_STEPS steps.  How well the steps resolve
        what the master holds or extrapolates: a co-simulation whose result
        holds changes each by a few per cent of its size per step or less;
        one that the step makes unstable by about its whole size (the growth
        factor per step minus one).  Other outputs are not judged: a friction moment jumps at a
        switch, a rotor's orbit oscillates far faster than the coupling.
        Computed from the recorded values after the run: it costs the master
        nothing per step."""
        worst, name = 0.0, ""
        if len(self.data) - 1 < MIN_JUDGED_STEPS:
            return worst, name
        for n in self.coupled:
            y = self.data[n]
            if not np.all(np.isfinite(y)):
                return math.inf, n
            change = float(np.max(np.abs(np.diff(y)))) / (self.atol + float(np.max(np.abs(y))))
            if change > worst:
                worst, name = change, n
        return worst, name

    def to_csv(self, path) -> Path:
        path = Path(path)
        names = self.data.dtype.names
        table = np.column_stack([self.data[n] for n in names])
        np.savetxt(path, table, delimiter=",", header=",".join(names), comments="",
                   fmt="%.17g")
        return path


def run(scene: Scene, *, master: str | None = None, step: float | None = None,
        stop: float | None = None, adaptive: bool = False, rtol: float = 1e-3,
        atol: float = 1e-6, h_min: float = 1e-9, h_max: float | None = None,
        fmu_dir=None, fmus: dict | None = None, progress: bool = False,
        master_options: dict | None = None, extrapolation: int | None = None,
        loop_options: dict | None = None) -> Result:
    """Run ``scene`` from 0 to ``stop`` (default the scene's stop_time).

    master: "jacobi" or "gauss-seidel" (default the scene's recommendation,
    Scene.master); step: the communication step (s; default the scene's),
    the first step when ``adaptive``; adaptive: control
    the step by the coupling error estimate (rtol, atol; h_min <= h <= h_max,
    default the larger of stop / 10 and step); fmu_dir: folder
    the models are built into (default a temporary folder); fmus: component ->
    FMU path, to skip the build; progress: show progress on stderr;
    extrapolation: order of the input extrapolation (0, 1, 2; default the
    scene's recommendation, Scene.extrapolation; above 0 every FMU that
    receives an input must declare canInterpolateInputs);
    master_options: more options of the master (e.g. Gauss-Seidel's order);
    loop_options: options of the algebraic-loop solver (loop_method "newton"
    or "fixed-point", loop_rtol, loop_atol, loop_max_iter, relaxation).
    """
    if not isinstance(scene, Scene):
        hint = (f"loomfmu.machines.library.load_scene({scene!r}) gives a shipped scene "
                "by name" if isinstance(scene, str) else "declare one with Scene(...)")
        raise ValueError(f"scene = {scene!r:.60}; allowed: a loomfmu.scene.Scene ({hint})")
    master = scene.master if master is None else master
    extrapolation = scene.extrapolation if extrapolation is None else extrapolation
    stop = check_number("stop", scene.stop_time if stop is None else stop, lo=0.0,
                        lo_open=True, unit="s")
    if step is None and scene.step > stop:
        raise ValueError(f"stop = {stop!r} s is shorter than the scene's step {scene.step!r} "
                         f"s; allowed: stop >= {scene.step!r} s, or a step <= stop")
    step = check_number("step", scene.step if step is None else step, lo=0.0, lo_open=True,
                        hi=stop, unit="s")
    if not adaptive:
        check_points(step, stop)
    if adaptive:
        h_min = check_number("h_min", h_min, lo=0.0, lo_open=True, hi=step, unit="s")
        h_max = check_number("h_max", max(stop / 10, step) if h_max is None else h_max,
                             lo=step, unit="s")
    # every option checked before any FMU is built
    if master not in MASTERS:
        raise ValueError(f"master = {master!r:.40}; allowed: {', '.join(MASTERS)}")
    opts = dict(master_options or {})
    twice = sorted(set(opts) & {"rtol", "atol", "adaptive", "extrapolation"})
    if twice:
        raise ValueError(f"master_options: {twice} are arguments of run(); "
                         "allowed: options of the master itself (e.g. order)")
    check_options(rtol=rtol, atol=atol, extrapolation=extrapolation,
                  output_derivatives=opts.get("output_derivatives", False))
    loop_options = dict(loop_options or {})
    bad = sorted(set(loop_options) - set(LOOP_OPTIONS))
    if bad:
        raise ValueError(f"loop_options: unknown {bad}; allowed: {list(LOOP_OPTIONS)}")
    if fmus is not None:
        check_fmus(scene, fmus)
    bar = Progress(100, f"scene {scene.name} ({master})") if progress else None
    with tempfile.TemporaryDirectory() as tmp:
        if fmus is None:
            fmus = build_fmus(scene, fmu_dir if fmu_dir is not None else tmp, progress=bar)
        system = System(scene, fmus, **loop_options)
        try:
            m = make_master(master, system, rtol=rtol, atol=atol, adaptive=adaptive,
                            extrapolation=extrapolation, **opts)
            refs = scene.recorded_variables()
            system.watch(refs)     # read with the sources after each step
            times, rows, hs = [0.0], [system.get(refs)], []
            t, h, k, shown = 0.0, step, 0, 0
            while t < stop * (1 - 1e-12):
                if m.n_accepted + m.n_rejected >= MAX_POINTS:
                    raise RuntimeError(f"scene {scene.name}: {MAX_POINTS} communication "
                                       f"steps taken by t = {t:.9g} s of stop = {stop:g} s "
                                       f"(h = {h:.3g} s); allowed: at most {MAX_POINTS}: "
                                       "a larger h_min or rtol")
                h_try = min(h, stop - t)
                if not adaptive:   # t_k = k h: no drift from summing steps
                    h_try = min(step * (k + 1), stop) - t
                res = m.step(t, h_try)
                if res.accepted:
                    k += 1
                    t = t + h_try if adaptive else min(step * k, stop)
                    times.append(t)
                    rows.append(system.recorded(refs))
                    hs.append(h_try)
                    done = int(100 * t / stop)
                    if bar is not None and done > shown:   # plain logs: a line per 10 %
                        text = (f"t = {t:.4g} s, h = {h_try:.3g} s, {m.n_rejected} rejected"
                                if done // 10 > shown // 10 else "")
                        bar.advance(text, n=done - shown)
                        shown = done
                if adaptive:
                    fac = (SAFETY * max(res.error, 1e-10) ** (-1.0 / (extrapolation + 1))
                           if math.isfinite(res.error) else FAC_MIN)
                    h = min(h_max, max(h_try * min(FAC_MAX, max(FAC_MIN, fac)), h_min))
                    if not res.accepted and h_try <= h_min:
                        raise RuntimeError(f"scene {scene.name}: step rejected at t = {t:.9g}"
                                           f" s with h = h_min = {h_min:g} s (error "
                                           f"{res.error:.3g}) {res.message}")
        finally:
            logs = {n: list(i.log) for n, i in system.instances.items()}
            loop_iterations = system.loop_iterations
            system.close()
            if bar is not None:
                bar.close()
    names = ["time"] + [f"{c}.{v}" for c, v in refs]
    data = np.zeros(len(times), dtype=[(n, "f8") for n in names])
    data["time"] = times
    values = np.array(rows, dtype=float)
    for j, n in enumerate(names[1:]):
        data[n] = values[:, j]
    sources = {f"{c.src}.{c.src_var}" for c in scene.connections}
    result = Result(data, m.name, m.n_accepted, m.n_rejected, np.array(hs), logs,
                    loop_iterations, list(m.notes), [n for n in names[1:] if n in sources],
                    atol, extrapolation)
    change, name = result.largest_step_change()
    if change > UNRESOLVED:
        warnings.warn(unresolved_message(change, name), UnresolvedCoupling, stacklevel=2)
    return result


def check_points(step: float, stop: float) -> None:
    """ValueError naming ``step`` unless a fixed-step run from 0 to ``stop``
    has at most MAX_POINTS communication points (checked before anything is
    built or run: more would fill the memory before the run ends)."""
    if stop / step > MAX_POINTS:
        raise ValueError(f"step = {step!r} s gives {stop / step:.3g} communication points "
                         f"up to stop = {stop:g} s; allowed: a step in "
                         f"[{stop / MAX_POINTS:.3g}, {stop:g}] s (at most {MAX_POINTS} "
                         "points)")


def unresolved_message(change: float, name: str) -> str:
    return (f"{name} changes by {change:.3g} times its largest magnitude within one "
            f"communication step (more than {UNRESOLVED:g}): the steps do not resolve the "
            "coupled signals and the result may be unstable or wrong; try a smaller step, "
            "or the adaptive step")
