"""The work-precision sweeps of ``loomfmu bench charts`` on dask.distributed.

One dask task per (model, method): a method's sweep is sequential (loose to
tight, stopping at its first run slower than the plan's cap), so it is the
natural unit. The client prepares each scene once (FMU, grid, tight
reference) as the serial run does and ships the grid and the reference; a
worker builds the scene's FMU and CasADi model once and keeps them for the
scene's other methods. Each run is timed inside its worker process exactly
as in the serial run (:func:`loomfmu.bench.runners.timed`); the workers have
one thread each. Each task also records its own process CPU time and wall
time: when the two part, the worker shared its core with another process
and its runs' seconds (wall times) are inflated.

Rows come back in the serial order (model, then :func:`methods` order), so
everything but the seconds equals the serial run's.
"""
from __future__ import annotations

import logging
import os
import tempfile
import time
from pathlib import Path

from ..bench.scenes import BENCH, load_scene_model
from ..bench.sweep import Case, Plan, method_sweep, methods, prepare
from ..checks import check_int
from .connect import MAX_CONNECT_TIMEOUT, check_scheduler, refused
from .run import MAX_WORKERS, QUIET_WORKERS, _need_distributed

#: a worker's prepared scenes: (name, quick, plan) -> Case
_CASES: dict = {}


def _worker_case(name: str, quick: bool, plan: Plan, known: tuple) -> Case:
    key = (name, quick, plan)
    if key not in _CASES:
        work = Path(tempfile.mkdtemp(prefix="loomfmu-bench-"))
        _CASES[key] = prepare(name, BENCH[name], load_scene_model(name), plan, quick, work,
                              known=known)
    return _CASES[key]


def _task(name: str, quick: bool, plan: Plan, known: tuple, family: str,
          method: str) -> dict:
    """One method's sweep on one scene, in a worker: its rows, and the task's
    process CPU and wall seconds (the sweep only, not the scene's setup)."""
    case = _worker_case(name, quick, plan, known)
    cpu0, wall0 = os.times(), time.perf_counter()
    rows = method_sweep(case, plan, family, method)
    cpu1 = os.times()
    return {"rows": rows, "cpu_s": (cpu1.user + cpu1.system) - (cpu0.user + cpu0.system),
            "wall_s": time.perf_counter() - wall0, "pid": os.getpid()}


def work_precision_dask(cases: dict[str, Case], plan: Plan, quick: bool, *,
                        workers: int = 2, scheduler: str | None = None, only=None,
                        connect_timeout: float = 10.0, progress: bool = True) -> dict:
    """Every (model, method) sweep of ``cases`` (name -> prepared Case) as one
    dask task each, on an embedded LocalCluster of ``workers`` processes
    (1 ... MAX_WORKERS, one thread each) or on the scheduler at ``scheduler``
    (whose workers must have loomfmu installed). ``only``: the (family,
    method) pairs to sweep (None: all). Returns {"rows": {name: rows in the
    serial order}, "tasks": [per-task model, method, cpu_s, wall_s, pid]}."""
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
    import dask
    from dask.distributed import Client, LocalCluster, as_completed

    from ..progress import Progress
    units = [(name, fm) for name, case in cases.items() for fm in methods(case)
             if only is None or fm in only]
    cluster = None
    if scheduler is None:
        with dask.config.set(QUIET_WORKERS):
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.ERROR)
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=connect_timeout)
        except Exception as exc:  # noqa: BLE001 (gone since check_scheduler)
            raise refused(scheduler, f"connecting failed ({type(exc).__name__}: "
                                     f"{str(exc)[:160]})") from None
    results = {}
    try:
        known = {name: client.scatter((c.grid, c.ref, c.ref_note), broadcast=True)
                 for name, c in cases.items()}
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
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    rows = {name: [] for name in cases}
    tasks = []
    for name, (fam, meth) in units:  # the serial order
        r = results[(name, fam, meth)]
        rows[name] += r["rows"]
        tasks.append({"model": name, "family": fam, "method": meth, "cpu_s": r["cpu_s"],
                      "wall_s": r["wall_s"], "pid": r["pid"]})
    return {"rows": rows, "tasks": tasks}
