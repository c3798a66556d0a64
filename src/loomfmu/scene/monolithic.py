"""A scene run as one model: its composed FMU (loomfmu.scene.compose), built
once into a folder and run through FMPy, returning the same
:class:`~loomfmu.scene.run.Result` as a co-simulation (``master`` is
"monolithic": there is no coupling step, every recorded variable is the one
DAE's)."""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from loomfmu.declare.checks import check_choice, check_number
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
    (:func:`composed_fmu`), to skip the build.  A run the FMU refuses
    raises RuntimeError with its last log lines."""
    from loomfmu.verification.fmpy_logger import simulate
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
    if fmu is not None and not (isinstance(fmu, (str, Path)) and Path(fmu).is_file()):
        raise ValueError(f"fmu = {fmu!r:.80}; allowed: None or the path of a composed FMU "
                         "file of the scene")
    refs = scene.recorded_variables()
    names = [f"{c}.{v}" for c, v in refs]
    if fmu is not None:
        _check_fmu(Path(fmu), scene, names)
    lines: list[str] = []

    def logger(component, instance, status, category, message):
        lines.append(f"[{category.decode(errors='replace')}] "
                     f"{message.decode(errors='replace')}")

    with tempfile.TemporaryDirectory() as tmp:
        if fmu is None:
            fmu, _ = composed_fmu(scene, fmu_dir if fmu_dir is not None else tmp)
        try:
            res = simulate(str(fmu), logger=logger, stop_time=stop, output_interval=step,
                           relative_tolerance=rtol, output=names,
                           start_values={"solver": SOLVERS.index(solver) + 1,
                                         "solver_rtol": rtol, "solver_atol": atol})
        except Exception as exc:  # noqa: BLE001 (FMPy's FMICallException and others)
            said = "; ".join(lines[-3:]) or "no log line"
            raise RuntimeError(f"scene {scene.name} composed: {exc} (log: {said})") from None
    data = np.zeros(len(res), dtype=[("time", "f8")] + [(n, "f8") for n in names])
    data["time"] = res["time"]
    for n in names:
        data[n] = res[n]
    n = len(res) - 1
    return Result(data, MONOLITHIC, n, 0, np.diff(data["time"]), {scene.name: lines},
                  atol=atol)


def _check_fmu(path: Path, scene: Scene, names: list[str]) -> None:
    """ValueError naming ``fmu`` unless it is an FMU with every variable the
    scene records (the composed FMU of this scene)."""
    from fmpy import read_model_description
    try:
        have = {v.name for v in read_model_description(str(path)).modelVariables}
    except Exception:  # noqa: BLE001 (FMPy raises bare Exceptions for a damaged file)
        have = None
    missing = None if have is None else [n for n in names if n not in have]
    if have is None or missing:
        why = ("not a readable FMU" if have is None else
               f"it has no {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''}")
        raise ValueError(f"fmu = {str(path)!r:.80}: {why}; allowed: the composed FMU of scene "
                         f"{scene.name!r} (loomfmu.scene.monolithic.composed_fmu)")
