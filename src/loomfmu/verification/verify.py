"""Verification: run an FMU through FMPy and compare it with the scipy reference.

Error measures (per output, over the communication points):

* ``max_abs``: max |y_fmu - y_ref|;
* ``max_rel_range``: max_abs divided by the output's range (max - min of the
  reference; the magnitude if the range is zero).
"""
from __future__ import annotations

import contextlib
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import fmpy
import numpy as np

from loomfmu.declare.checks import (
    check_bool,
    check_choice,
    check_int,
    check_mapping,
    check_name_list,
    check_number,
    check_optional_number,
    check_text,
)
from loomfmu.declare.model import Model
from loomfmu.declare.solvers import SOLVERS
from loomfmu.verification import fmpy_logger
from loomfmu.verification.reference import (
    MAX_OUTPUTS,
    RTOL_MIN,
    Reference,
    check_model,
    on_times,
    reference,
)
from loomfmu.verification.times import experiment_times, grid_rows

#: The row label of a model-exchange run: FMPy's own solver integrates, once.
ME_LABEL = "CVode (FMPy, model exchange)"


@contextlib.contextmanager
def quiet_callbacks():
    """Drop the tracebacks FMPy's ctypes callbacks print when an FMU call
    returns Discard inside CVode's right-hand side (FMPy goes on; the FMU's
    own log line says what happened)."""
    old = sys.unraisablehook

    def hook(unraisable):
        if type(unraisable.exc_value).__name__ != "FMICallException":
            old(unraisable)
    sys.unraisablehook = hook
    try:
        yield
    finally:
        sys.unraisablehook = old


def fmu_interfaces(model_description) -> tuple[str, ...]:
    """("cs",), ("me",) or ("cs", "me"): what FMPy's ``model_description`` declares."""
    return tuple(k for k, attr in (("cs", "coSimulation"), ("me", "modelExchange"))
                 if getattr(model_description, attr, None) is not None)


@dataclass
class FmuRun:
    t: np.ndarray
    y: dict[str, np.ndarray]
    wall_seconds: float
    log: list[str] = field(default_factory=list)


def simulate(fmu: Path | str, *, solver: str = "dopri5", rtol: float = 1e-6,
             atol: float = 1e-9, stop_time: float | None = None,
             output_interval: float | None = None, values: dict | None = None,
             output: list[str] | None = None, model_description=None,
             interface: str | None = None) -> FmuRun:
    """Simulate ``fmu`` with ``fmpy.simulate_fmu``.

    interface: "cs" (co-simulation with the embedded ``solver``) or "me"
    (model exchange: FMPy's CVode integrates at ``rtol``; ``solver`` and
    ``atol`` are not used); default: "cs" if the FMU has it, else "me".
    solver: one of SOLVERS.  rtol: in (0, 0.1]; atol: > 0 (adaptive solvers).
    stop_time: > 0 (default: the FMU's DefaultExperiment).
    output_interval: communication step, in (0, stop_time] (default: the
    FMU's DefaultExperiment); at most MAX_OUTPUTS communication points.
    values: start values by name (variables with a start value: parameters,
    inputs, states, solver settings); output: names of variables to record.
    model_description: FMPy's parsed description, to skip parsing on repeated runs.
    Bad arguments raise ValueError naming the argument; an FMU that fails
    raises RuntimeError with the end of its log.
    """
    check_choice("solver", solver, SOLVERS)
    rtol = check_number("rtol", rtol, lo=0.0, hi=0.1, lo_open=True)
    atol = check_number("atol", atol, lo=0.0, lo_open=True)
    if not isinstance(fmu, (str, Path)) or not Path(fmu).exists():
        raise ValueError(f"fmu = {fmu!r:.80}; allowed: the path of an existing .fmu file "
                         "or of its unzipped folder")
    if model_description is None:
        try:
            model_description = fmpy.read_model_description(str(fmu), validate=False)
        except Exception as e:  # noqa: BLE001 (FMPy raises bare Exceptions)
            raise ValueError(f"fmu = {str(fmu)!r}: not a readable FMU ({e})") from None
    elif not hasattr(model_description, "modelVariables"):
        raise ValueError(f"model_description = {model_description!r:.60}; allowed: FMPy's "
                         "ModelDescription of this FMU, or None")
    have = fmu_interfaces(model_description)
    interface = check_choice("interface", interface or have[0], have)
    variables = model_description.modelVariables
    settable = [v.name for v in variables if v.start is not None]
    values = check_mapping("values", values, settable, what="variables with a start value",
                           numbers_only=False)
    for v in variables:
        if v.name in values:
            values[v.name] = _check_value(v, values[v.name])
    by_name = {v.name: v for v in variables}
    for arg, value, setting in (("rtol", rtol, "solver_rtol"), ("atol", atol, "solver_atol")):
        if setting in by_name:  # the FMU's range of the setting
            check_number(arg, value, lo=_bound(by_name[setting].min, -np.inf),
                         hi=_bound(by_name[setting].max, np.inf))
    output = check_name_list("output", output, [v.name for v in variables],
                             what="variables of the FMU")
    experiment = model_description.defaultExperiment
    stop_time = check_optional_number("stop_time", stop_time, lo=0.0, lo_open=True, unit="s")
    output_interval = check_optional_number("output_interval", output_interval, lo=0.0,
                                            lo_open=True, unit="s")
    t_stop = stop_time if stop_time is not None else float(
        getattr(experiment, "stopTime", None) or 1.0)
    dt = output_interval if output_interval is not None else float(
        getattr(experiment, "stepSize", None) or t_stop / 500)
    if output_interval is not None and output_interval > t_stop:
        raise ValueError(f"output_interval = {output_interval!r} s; allowed: in (0, "
                         f"stop_time = {t_stop!r}]")
    if t_stop / dt > MAX_OUTPUTS:
        raise ValueError(f"stop_time = {t_stop!r} s, output_interval = {dt!r} s: "
                         f"{t_stop / dt:.3g} communication points; allowed: at most "
                         f"{MAX_OUTPUTS}")
    log: list[str] = []

    def logger(*args):  # FMI 2: (component, instance, status, category, message); FMI 3
        status, category, message = args[-3:]  # (environment, status, category, message)
        log.append(f"[{status}] {category.decode()}: {message.decode()}")

    start = ({"solver": SOLVERS.index(solver) + 1, "solver_atol": atol} if interface == "cs"
             else {})
    start.update(values or {})
    wall = time.perf_counter()
    try:
        with quiet_callbacks():
            res = fmpy_logger.simulate(str(fmu), validate=False, stop_time=stop_time,
                                       fmi_type="CoSimulation" if interface == "cs"
                                       else "ModelExchange",
                                       relative_tolerance=rtol, output_interval=output_interval,
                                       start_values=start, output=output, logger=logger,
                                       model_description=model_description)
    except Exception as e:  # noqa: BLE001 (FMPy raises bare Exceptions)
        tail = "; ".join(log[-3:]) or "no log"
        raise RuntimeError(f"simulate {Path(fmu).name}: {e} (log: {tail})") from e
    wall = time.perf_counter() - wall
    names = [n for n in res.dtype.names if n != "time"]
    return FmuRun(np.asarray(res["time"]), {n: np.asarray(res[n]) for n in names}, wall, log)


def _default_grid_reference(model, t: np.ndarray, rtol: float, atol: float):
    """The reference at ``t`` taken from the one on the default experiment's
    grid (the FMI-LS-REF result's, and in the reference cache once a build
    computed it), where the run covers the default experiment on a subset of
    that grid (FMPy widens the output interval past 1000 points); else None."""
    if not len(t) or t[-1] != model.stop_time or t[0] != 0.0:
        return None
    grid = experiment_times(0.0, model.stop_time, model.step_size)
    if grid_rows(grid, t) is None:
        return None
    return on_times(reference(model, t_eval=grid, rtol=rtol, atol=atol,
                              method=model.reference_method), t)


def _output_points(run: FmuRun) -> FmuRun:
    """``run`` at its communication points only: FMPy's model exchange also
    records each event time twice (before and after), where a comparison
    with the reference would measure the jump."""
    t = run.t
    if len(t) < 3:
        return run
    dt = float(np.max(np.diff(t)))  # events only split the intervals
    k = (t - t[0]) / dt
    keep = np.abs(k - np.round(k)) < 1e-6
    keep[:-1] &= ~(np.isclose(t[:-1], t[1:], rtol=0, atol=1e-12) & keep[1:])  # after an event
    return FmuRun(t[keep], {n: y[keep] for n, y in run.y.items()}, run.wall_seconds, run.log)


def _bound(text, default: float) -> float:
    return default if text is None else float(text)


def _check_value(var, value):
    """``value`` for the FMU variable ``var`` (FMPy's ScalarVariable): a number
    in its [min, max], an Enumeration's item value, a bool, a string."""
    key = f"values[{var.name!r}]"
    if var.type == "Real":
        return check_number(key, value, lo=_bound(var.min, -np.inf), hi=_bound(var.max, np.inf),
                            unit=var.unit or "")
    if var.type == "Enumeration" and var.declaredType is not None:
        items = {int(i.value): i.name for i in var.declaredType.items}
        allowed = ", ".join(f"{k} ({n})" for k, n in items.items())
        if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)) \
                and int(value) in items:
            return int(value)
        raise ValueError(f"{key} = {value!r:.60}; allowed: {allowed}"
                         + (" (or the solver argument)" if var.name == "solver" else ""))
    if var.type in ("Integer", "Enumeration"):
        return check_int(key, value, lo=None if var.min is None else int(var.min),
                         hi=None if var.max is None else int(var.max))
    if var.type == "Boolean":
        return check_bool(key, value)
    return check_text(key, value)


def compare(run: FmuRun | Reference, ref: Reference,
            names: list[str]) -> dict[str, dict[str, float]]:
    """Error of each output in ``names`` of ``run`` (an FMU run or another
    reference) at the reference's times; names: outputs in both."""
    for arg, value in (("run", run), ("ref", ref)):
        if not isinstance(value, (FmuRun, Reference)):
            raise ValueError(f"{arg} = {value!r:.60}; allowed: an FmuRun or a Reference")
    names = check_name_list("names", names, [n for n in ref.y if n in run.y],
                            what="outputs of both runs")
    if len(run.t) != len(ref.t) or not np.allclose(run.t, ref.t, rtol=0, atol=1e-9):
        raise ValueError("FMU and reference output times differ")
    errs = {}
    for name in names:
        r, y = ref.y[name], run.y[name]
        span = float(np.ptp(r)) or float(np.max(np.abs(r))) or 1.0
        err = float(np.max(np.abs(y - r)))
        errs[name] = {"max_abs": err, "max_rel_range": err / span}
    return errs


def verify(fmu: Path | str, model: Model, *, solvers=None, model_exchange: bool | None = None,
           rtol: float = 1e-6, atol: float = 1e-9, ref_rtol: float = 1e-11,
           ref_atol: float = 1e-13, on_stage=None) -> dict:
    """Run ``fmu`` with every solver and compare with a tight scipy reference.

    solvers: the embedded solvers to run in co-simulation, a list from
    SOLVERS (default: all of them if the FMU has co-simulation, none if it
    is model exchange only; then passing any is a ValueError: the importer
    integrates).  model_exchange: also run the FMU once as model exchange,
    integrated by FMPy's CVode at ``rtol``, reported under :data:`ME_LABEL`
    (default: only if the FMU has no co-simulation).  A model-exchange run
    that the FMU refuses (e.g. FMPy's steps longer than a delay: Discard,
    which FMPy's CVode steps over) is reported with its "error" (and its
    "errors" if FMPy finished the run anyway).
    on_stage: called with a short text before each run (progress display).

    Returns {"reference_wall_seconds", "reference_rhs_calls", "reference_cached"
    (the reference came from the on-disk cache; its wall seconds are then
    those of the run that computed it), "solvers":
    {label: {"interface": "cs"|"me", "wall_seconds", "log", "errors":
    {output: {"max_abs", "max_rel_range"}}}}}; label: the solver's name in
    co-simulation, ME_LABEL for model exchange.  rtol, atol as for
    :func:`simulate`; ref_rtol, ref_atol as rtol, atol of
    :func:`~loomfmu.verification.reference.reference`.
    """
    check_model(model)
    try:
        md = fmpy.read_model_description(str(fmu), validate=False)
    except Exception as e:  # noqa: BLE001 (FMPy raises bare Exceptions)
        raise ValueError(f"fmu = {str(fmu)!r}: not a readable FMU ({e})") from None
    have = fmu_interfaces(md)
    if solvers is None:
        solvers = SOLVERS if "cs" in have else ()
    solvers = check_name_list("solvers", solvers, SOLVERS, what="solvers")
    if solvers and "cs" not in have:
        raise ValueError(f"solvers = {solvers!r}: {Path(fmu).name} is model exchange only "
                         "(the importer's solver integrates, the FMU's solver parameter is "
                         "unused); allowed: none")
    if model_exchange is None:
        model_exchange = "cs" not in have
    check_bool("model_exchange", model_exchange)
    if model_exchange and "me" not in have:
        raise ValueError(f"model_exchange = True: {Path(fmu).name} has no model exchange")
    if not solvers and not model_exchange:
        raise ValueError(f"solvers = []; allowed: a non-empty list from {SOLVERS}")
    check_number("ref_rtol", ref_rtol, lo=RTOL_MIN, hi=0.1)
    check_number("ref_atol", ref_atol, lo=0.0, lo_open=True)
    names = [v.name for v in model.of_kind("output")]
    stage = on_stage or (lambda text: None)
    runs, failed = {}, {}
    for s in solvers:
        stage(f"FMU run, {s}")
        runs[s] = simulate(fmu, solver=s, rtol=rtol, atol=atol, output=names,
                           model_description=md, interface="cs")
    if model_exchange:
        stage(f"FMU run, {ME_LABEL}")
        try:
            runs[ME_LABEL] = simulate(fmu, rtol=rtol, output=names, model_description=md,
                                      interface="me")
        except RuntimeError as e:
            failed[ME_LABEL] = {"interface": "me", "error": str(e), "errors": {}}
        else:  # FMPy's CVode goes on after a Discard of a derivative: the run failed
            refused = [ln for ln in runs[ME_LABEL].log if ln[1:2] in "234" and ln[2] == "]"]
            if refused:
                failed[ME_LABEL] = {"error": f"the FMU refused {len(refused)} call(s) of "
                                             f"FMPy's CVode; first: {refused[0]}"}
    if ME_LABEL in runs:
        runs[ME_LABEL] = _output_points(runs[ME_LABEL])
    out = {s: {"interface": "me" if s == ME_LABEL else "cs", "wall_seconds": run.wall_seconds,
               "log": run.log[-5:]} for s, run in runs.items()}
    ref_wall = ref_calls = ref_cached = None
    if runs:
        refs: list[Reference] = []  # one per grid (FMPy's model exchange adds event times)
        for s, run in runs.items():
            ref = next((r for r in refs if len(r.t) == len(run.t)
                        and np.allclose(r.t, run.t, rtol=0, atol=1e-9)), None)
            if ref is None:
                stage(f"scipy reference ({model.reference_method}, rtol {ref_rtol:g})")
                ref = _default_grid_reference(model, run.t, ref_rtol, ref_atol) or reference(
                    model, t_end=run.t[-1], t_eval=run.t, rtol=ref_rtol, atol=ref_atol,
                    method=model.reference_method)
                refs.append(ref)
            out[s]["errors"] = compare(run, ref, names)
        ref_wall, ref_calls, ref_cached = refs[0].wall_seconds, refs[0].n_rhs, refs[0].cached
    for s, res in failed.items():
        out[s] = {**out.get(s, {}), **res}
    return {"reference_wall_seconds": ref_wall, "reference_rhs_calls": ref_calls,
            "reference_cached": ref_cached, "solvers": out}
