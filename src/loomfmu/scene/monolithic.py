"""A scene run as one model: its composed FMU (loomfmu.scene.compose), built
once into a folder and run through FMPy, returning the same
:class:`~loomfmu.scene.run.Result` as a co-simulation (``master`` is
"monolithic": there is no coupling step, every recorded variable is the one
DAE's)."""
from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

from loomfmu.declare.checks import check_choice, check_number, check_writable
from loomfmu.declare.solvers import SOLVERS
from loomfmu.scene.compose import compose
from loomfmu.scene.declare import Scene
from loomfmu.scene.fmus import declaration_key
from loomfmu.scene.run import Result, check_points

#: the ways a scene runs: its components co-simulated on our master, or
#: composed into one model and FMU
COUPLINGS = ("cosim", "monolithic")
#: the master's name a monolithic Result carries
MONOLITHIC = "monolithic"


def composed_fmu(scene: Scene, fmu_dir, *, fmi_version: int = 2, interface: str = "cs",
                 validate: bool = False):
    """The composed FMU of ``scene`` in ``fmu_dir``: ``<scene>-<hash>.fmu``,
    built unless a file of the same composed model and generator is there.
    Returns (path, model)."""
    from loomfmu.fmu.builder import build_fmu, fmu_file_name
    model = compose(scene)
    stem = fmu_file_name(scene.name, fmi_version, interface)[:-len(".fmu")]
    path = Path(fmu_dir) / f"{stem}-{declaration_key(model, model.options)}.fmu"
    if not path.is_file():
        # no FMI-LS-REF result: the scipy reference of a whole machine over its
        # default experiment (the spinning scene: 15 s of a rotor resolved in
        # microseconds) would cost far more than the build
        result = build_fmu(model, out_dir=fmu_dir, fmi_version=fmi_version,
                           interface=interface, validate=validate, reference_results=False)
        result.path.replace(path)
    return path, model


def run_monolithic(scene: Scene, *, step: float | None = None, stop: float | None = None,
                   solver: str = "dopri5", rtol: float = 1e-6, atol: float = 1e-9,
                   fmu_dir=None, fmu=None) -> Result:
    """Run ``scene`` composed into one FMU from 0 to ``stop`` (default the
    scene's stop time), recording the scene's recorded variables every
    ``step`` (default the scene's step); solver: one of the embedded solvers
    (loomfmu.declare.solvers.SOLVERS), rtol and atol its tolerances;
    fmu_dir: the folder the composed FMU is built into and reused from
    (default a temporary one); fmu: the path of a composed FMU built before
    (:func:`composed_fmu`), to skip the build (the scene's parameter and
    start values are set on it).  A run the FMU refuses
    raises RuntimeError with its last log lines."""
    if not isinstance(scene, Scene):
        raise ValueError(f"scene = {scene!r:.60}; allowed: a loomfmu.scene.Scene")
    stop = check_number("stop", scene.stop_time if stop is None else stop, lo=0.0,
                        lo_open=True, unit="s")
    step = check_number("step", min(scene.step, stop) if step is None else step, lo=0.0,
                        lo_open=True, hi=stop, unit="s")
    check_points(step, stop)
    solver = check_choice("solver", solver, SOLVERS)
    rtol = check_number("rtol", rtol, lo=1e-14, hi=0.1)
    atol = check_number("atol", atol, lo=1e-16, hi=1.0)
    if fmu_dir is not None:
        check_writable("fmu_dir", fmu_dir, folder=True)
    if fmu is not None and not (isinstance(fmu, (str, Path)) and Path(fmu).is_file()):
        raise ValueError(f"fmu = {fmu!r:.80}; allowed: None or the path of a composed FMU "
                         "file of the scene")
    refs = scene.recorded_variables()
    names = [f"{c}.{v}" for c, v in refs]
    md = _check_fmu(Path(fmu), scene, names) if fmu is not None else None
    # (an FMU built here is read by the instance)
    with tempfile.TemporaryDirectory() as tmp:
        if fmu is None:
            fmu, _ = composed_fmu(scene, fmu_dir if fmu_dir is not None else tmp)
        data, lines = _run_cs(Path(fmu), scene.name, names, md, stop=stop, step=step,
                              solver=solver, rtol=rtol, atol=atol,
                              values=_scene_values(scene))
    n = len(data) - 1
    return Result(data, MONOLITHIC, n, 0, np.diff(data["time"]), {scene.name: lines},
                  atol=atol)


def _scene_values(scene: Scene) -> dict[str, float]:
    """The scene's parameter and start values under the composed names: the
    composed model's defaults, set on the instance too, so that a composed
    FMU built before (``fmu=``) runs the scene as it is declared now."""
    return {f"{c}.{k}": v for c, comp in scene.components.items()
            for k, v in {**comp.parameters, **comp.start}.items()}


def _run_cs(path: Path, name: str, names: list[str], md, *, stop: float, step: float,
            solver: str, rtol: float, atol: float,
            values: dict[str, float] | None = None) -> tuple[np.ndarray, list[str]]:
    """The composed FMU's co-simulation interface stepped from 0 to ``stop`` at
    ``step`` (the last step shortened to end at ``stop``), ``names`` read after
    each step: the loop calls FMPy's ctypes functions directly with arrays made
    once, as the co-simulation master does (loomfmu.scene.system), not FMPy's
    simulate_fmu, whose own work per step (its recorder, a new ctypes array per
    read) costs more than the loom's doStep.  md: the FMU's model description
    if read before (else read here).  Returns (the record, the FMU's
    log lines); a step or read the FMU refuses raises RuntimeError with its
    last log lines."""
    from fmpy.fmi2 import fmi2True

    from loomfmu.scene.system import FMI2_WARNING, Instance, Values
    from loomfmu.verification.fmpy_logger import settable_names
    n = max(1, math.ceil(stop / step * (1 - 1e-12)))
    times = np.minimum(np.arange(n + 1) * step, stop)
    times[-1] = stop
    data = np.zeros(n + 1, dtype=[("time", "f8")] + [(v, "f8") for v in names])
    data["time"] = times
    inst = None
    try:
        inst = Instance(name, path, md)
        settable = settable_names(inst.md)
        # a value the composition did not use (an input the scene drives) is not set
        inst.set({k: v for k, v in (values or {}).items() if k in settable})
        inst.set({"solver": SOLVERS.index(solver) + 1, "solver_rtol": rtol,
                  "solver_atol": atol})
        inst.fmu.setupExperiment(tolerance=rtol, startTime=0.0, stopTime=stop)
        inst.fmu.enterInitializationMode()
        inst.fmu.exitInitializationMode()
        values = Values(inst, [inst.vr[v] for v in names])
        row = np.frombuffer(values.val, dtype=np.float64)
        rows = np.empty((n + 1, len(names)))
        do_step, comp = inst.f_do_step, inst.component
        for i in range(n + 1):
            if i and do_step(comp, times[i - 1], times[i] - times[i - 1], fmi2True) \
                    > FMI2_WARNING:
                raise RuntimeError(f"fmi2DoStep from t = {times[i - 1]:.17g} s failed")
            if not values.get():
                raise RuntimeError(f"fmi2GetReal at t = {times[i]:.17g} s failed")
            rows[i] = row
    except Exception as exc:  # noqa: BLE001 (FMPy's FMICallException and others)
        lines = inst.log if inst is not None else []
        said = "; ".join(lines[-3:]) or "no log line"
        raise RuntimeError(f"scene {name} composed: {exc} (log: {said})") from None
    finally:
        if inst is not None:
            inst.close()
    for k, v in enumerate(names):
        data[v] = rows[:, k]
    return data, list(inst.log)


def _check_fmu(path: Path, scene: Scene, names: list[str]):
    """ValueError naming ``fmu`` unless it is an FMU with every variable the
    scene records (the composed FMU of this scene); its model description."""
    from fmpy import read_model_description
    try:  # names only: the schema check (validate) costs more than the loom's run
        md = read_model_description(str(path), validate=False)
        have = {v.name for v in md.modelVariables}
    except Exception:  # noqa: BLE001 (FMPy raises bare Exceptions for a damaged file)
        have = None
    missing = None if have is None else [n for n in names if n not in have]
    if have is None or missing:
        why = ("not a readable FMU" if have is None else
               f"it has no {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''}")
        raise ValueError(f"fmu = {str(path)!r:.80}: {why}; allowed: the composed FMU of scene "
                         f"{scene.name!r} (loomfmu.scene.monolithic.composed_fmu)")
    if md.coSimulation is None:
        raise ValueError(f"fmu = {str(path)!r:.80}: it has no co-simulation interface; allowed: "
                         f"the composed FMU of scene {scene.name!r} built with interface 'cs' "
                         "or 'both'")
    return md
