"""The work-precision sweeps of ``loomfmu bench charts`` on dask.distributed.

One dask task per (model, method): a method's sweep is sequential (loose to
tight, stopping at its first run slower than the plan's cap), so it is the
natural unit. Each scene's preparation (FMU, grid, tight reference) is a
task too, and the scene's method tasks depend on it: the grid and the
reference are solved once, on one worker, and passed to the others; a worker
builds a scene's FMU and CasADi model once and keeps them for the scene's
other methods. Each run is timed inside its worker process exactly
as in the serial run (:func:`loomfmu.bench.runners.timed`); the workers have
one thread each. Each task also records its own process CPU time and wall
time: when the two part, the worker shared its core with another process
and its runs' seconds (wall times) are inflated.

Rows come back in the serial order (model, then :func:`methods` order), so
everything but the seconds equals the serial run's.
"""
from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from loomfmu.bench.scenes import BENCH, load_scene_model
from loomfmu.bench.sweep import (
    CASADI_PLUGINS,
    FMU_ADAPTIVE,
    SCIPY_METHODS,
    Case,
    Plan,
    method_sweep,
    methods,
    prepare,
)
from loomfmu.declare.checks import check_int
from loomfmu.sweep.connect import MAX_CONNECT_TIMEOUT, check_scheduler
from loomfmu.sweep.run import MAX_WORKERS, _need_distributed, open_client

#: a worker's prepared scenes: (name, quick, plan) -> Case
_CASES: dict = {}


def _worker_case(name: str, quick: bool, plan: Plan, known: tuple | None) -> Case:
    key = (name, quick, plan)
    if key not in _CASES:
        work = Path(tempfile.mkdtemp(prefix="loomfmu-bench-"))
        _CASES[key] = prepare(name, BENCH[name], load_scene_model(name), plan, quick, work,
                              known=known)
    return _CASES[key]


def _reference(name: str, quick: bool, plan: Plan) -> tuple:
    """A scene's (grid, reference, reference note, CasADi note), solved on a
    worker, which keeps the prepared scene."""
    case = _worker_case(name, quick, plan, None)
    return case.grid, case.ref, case.ref_note, case.casadi_note


def _task(name: str, quick: bool, plan: Plan, known: tuple, family: str,
          method: str) -> dict:
    """One method's sweep on one scene, in a worker: its rows, and the task's
    process CPU and wall seconds (the sweep only, not the scene's setup).
    A method the scene has not (a CasADi plugin the model cannot use) gives
    no rows."""
    case = _worker_case(name, quick, plan, known[:3])
    cpu0, wall0 = os.times(), time.perf_counter()
    rows = (method_sweep(case, plan, family, method)
            if (family, method) in methods(case) else [])
    cpu1 = os.times()
    return {"rows": rows, "cpu_s": (cpu1.user + cpu1.system) - (cpu0.user + cpu0.system),
            "wall_s": time.perf_counter() - wall0, "pid": os.getpid()}


#: every (family, method) a scene may have, in :func:`methods` order
ALL_METHODS = ([("fmu", s) for s in FMU_ADAPTIVE] + [("fmu", "rk4")]
               + [("scipy", m) for m in SCIPY_METHODS]
               + [("casadi", p) for p in CASADI_PLUGINS])


def check_dask(workers: int, scheduler: str | None, connect_timeout: float = 10.0) -> int:
    """The dask arguments of :func:`work_precision_dask` (returns ``workers``),
    dask.distributed installed and ``scheduler`` (if any) answering as a
    dask scheduler: else ValueError or ImportError in one line, before any
    work (``loomfmu bench charts --dask`` calls it first)."""
    workers = check_int("workers", workers, lo=1, hi=MAX_WORKERS)
    if scheduler is not None and (not isinstance(scheduler, str) or "://" not in scheduler):
        raise ValueError(f"scheduler = {scheduler!r:.60}; allowed: None or an address "
                         "such as tcp://host:8786")
    if not 0 < connect_timeout <= MAX_CONNECT_TIMEOUT:
        raise ValueError(f"connect_timeout = {connect_timeout!r}; allowed: "
                         f"0 < . <= {MAX_CONNECT_TIMEOUT:g} s")
    _need_distributed()
    if scheduler is not None:
        check_scheduler(scheduler, connect_timeout)
    return workers


def work_precision_dask(names: list[str], plan: Plan, quick: bool, *,
                        workers: int = 2, scheduler: str | None = None, only=None,
                        connect_timeout: float = 10.0, progress: bool = True) -> dict:
    """Every (model, method) sweep of the scenes ``names`` as one dask task
    each (after one preparation task per scene), on an embedded LocalCluster
    of ``workers`` processes (1 ... MAX_WORKERS, one thread each) or on the
    scheduler at ``scheduler`` (whose workers must have loomfmu installed).
    ``only``: the (family, method) pairs to sweep (None: all). Returns
    {"rows": {name: rows in the serial order}, "known": {name: (grid, ref,
    ref_note, casadi_note)}, "tasks": [per task: model, family, method,
    cpu_s, wall_s, pid]}."""
    workers = check_dask(workers, scheduler, connect_timeout)
    from dask.distributed import as_completed

    from loomfmu.progress import Progress
    unknown = sorted(set(names) - set(BENCH))
    if unknown:
        raise ValueError(f"names = {unknown}: not a scene; allowed: {', '.join(BENCH)}")
    units = [(name, fm) for name in names for fm in ALL_METHODS
             if only is None or fm in only]
    client, cluster = open_client(workers, scheduler, connect_timeout)
    results = {}
    try:
        known = {name: client.submit(_reference, name, quick, plan, key=f"wp-{name}-prepare",
                                     pure=False) for name in names}
        futures = {client.submit(_task, name, quick, plan, known[name], fam, meth,
                                 key=f"wp-{name}-{fam}-{meth}", pure=False): (name, fam, meth)
                   for name, (fam, meth) in units}
        bar = Progress(total=len(units), desc="bench charts (dask)") if progress else None
        try:
            for fut in as_completed(list(futures)):
                results[futures[fut]] = fut.result()
                if bar is not None:
                    name, fam, meth = futures[fut]
                    bar.advance(f"{name} {fam} {meth}: {len(results[futures[fut]]['rows'])}"
                                " points")
        finally:
            if bar is not None:
                bar.close()
        refs = {name: f.result() for name, f in known.items()}
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    rows = {name: [] for name in names}
    tasks = []
    for name, (fam, meth) in units:  # the serial order
        r = results[(name, fam, meth)]
        if not r["rows"]:  # a CasADi plugin the scene has not
            continue
        rows[name] += r["rows"]
        tasks.append({"model": name, "family": fam, "method": meth, "cpu_s": r["cpu_s"],
                      "wall_s": r["wall_s"], "pid": r["pid"]})
    return {"rows": rows, "known": refs, "tasks": tasks}
