"""Running a study: on dask.distributed, or as a plain serial loop.

    result = run_study(study, out="docs/results/sweep/x.csv", workers=2)   # LocalCluster
    result = run_study(study, out=..., scheduler="tcp://host:8786") # any cluster
    rows = run_serial(study)                                       # the baseline

The FMU is built once here (or given), its bytes scattered to every worker
(so workers need not share a file system with the client), and each case is
one dask task. Rows are appended to ``out`` as cases finish; a second call
with the same study and ``out`` skips every case already there (finished:
ok or failed), so an interrupted study resumes where it stopped.
"""
from __future__ import annotations

import dataclasses
import hashlib
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

from loomfmu.declare.checks import check_bool, check_int, check_number, check_writable
from loomfmu.sweep import store
from loomfmu.sweep.connect import MAX_CONNECT_TIMEOUT, check_scheduler, refused
from loomfmu.sweep.study import Study, case_key
from loomfmu.sweep.worker import STATUSES, FmuBlob, run_batch, run_case

#: most local worker processes
MAX_WORKERS = 64
#: dask settings of the embedded LocalCluster: the workers' statistical profiler
#: (a sample every 10 ms) and GIL monitor (every 1 ms) cost CPU in proportion to
#: the wall time and tell nothing about FMU cases
QUIET_WORKERS = {"distributed.worker.profile.enabled": False,
                 "distributed.admin.system-monitor.gil.enabled": False}


@dataclasses.dataclass
class StudyResult:
    """rows: every case's row, by index; executed: cases run by this call;
    skipped: cases found finished in ``out``; wall_s: this call's wall time;
    workers: local worker processes (-1: a given scheduler's); startup_s:
    of wall_s, starting the cluster and shipping the FMU; worker_cpu_s,
    client_cpu_s: CPU seconds the workers and this process (client and, for
    a LocalCluster, the scheduler) spent from the first task to the last;
    busiest_worker_cpu_s: the most any one worker spent (how evenly the work
    was split, whatever else the machine runs); notes: what the run had to
    mend, one line each (a corrupt row of ``out`` run again, a case run again
    after its worker was lost), also printed to standard error with
    ``progress``."""
    rows: list
    executed: int
    skipped: int
    wall_s: float
    workers: int
    out: Path | None
    startup_s: float = 0.0
    worker_cpu_s: float = 0.0
    client_cpu_s: float = 0.0
    busiest_worker_cpu_s: float = 0.0
    notes: list = dataclasses.field(default_factory=list)

    @property
    def failed(self) -> list[dict]:
        """The rows that are not "ok" (failed, refused, or completed with a
        warning of the FMU)."""
        return [r for r in self.rows if r["status"] != "ok"]



class _CancelRace(logging.Filter):
    """Drops one record: distributed's ``sync`` schedules ``cancel`` on its
    event loop when the waiting thread is interrupted (^C), and ``cancel``
    raises NameError there if the call's future was not made yet (a race in
    distributed.utils.sync); tornado logs that with a traceback after the
    interrupt has already been handled."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        return not (isinstance(exc, NameError) and "'future'" in str(exc))


def _quiet_cancel_race() -> None:
    log = logging.getLogger("tornado.application")
    if not any(isinstance(f, _CancelRace) for f in log.filters):
        log.addFilter(_CancelRace())


def open_client(workers: int, scheduler: str | None, connect_timeout: float):
    """(client, cluster): a LocalCluster of ``workers`` one-thread processes
    (cluster is then to be closed too), or a client of the (already checked)
    ``scheduler`` with cluster None."""
    import dask
    from dask.distributed import Client, LocalCluster
    _quiet_cancel_race()
    if scheduler is None:
        with dask.config.set(QUIET_WORKERS):  # passed on to the workers by their nannies
            # preload: the workers ignore SIGINT (a ^C reaches the whole process
            # group; this process stops them)
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=logging.ERROR,
                                   preload=["loomfmu.sweep.worker"])
        return Client(cluster), cluster
    try:
        return Client(scheduler, timeout=connect_timeout), None
    except Exception as exc:  # noqa: BLE001 (gone since check_scheduler)
        raise refused(scheduler, f"connecting failed ({type(exc).__name__}: "
                                 f"{str(exc)[:160]})") from None

def fmu_blob(study: Study, fmu: Path | str | None = None) -> FmuBlob:
    """The study's FMU as bytes: ``fmu`` (a built .fmu of the study's model)
    or built now from loomfmu.registry with the study's options."""
    if fmu is None:
        from loomfmu.fmu.builder import build_fmu
        from loomfmu.fmu.platforms import HOST
        from loomfmu.registry import load_model
        with tempfile.TemporaryDirectory() as tmp:
            model = (study.declaration if study.declaration is not None
                     else load_model(study.model, **study.options))
            path = build_fmu(model, out_dir=tmp,
                             validate=False, platforms=HOST,
                    reference_results=False).path
            data = Path(path).read_bytes()
            name = Path(path).name
    else:
        if not isinstance(fmu, (str, Path)) or not Path(fmu).is_file():
            raise ValueError(f"fmu = {fmu!r:.80}; allowed: None or the path of an "
                             "existing .fmu file")
        data, name = Path(fmu).read_bytes(), Path(fmu).name
    return FmuBlob(data, content_sha256(data), name)


def content_sha256(data: bytes) -> str:
    """SHA-256 over an FMU's members (names and contents, not the zip's
    timestamps): a rebuild of the same model and runtime gives the same
    value, so a study resumes across builds; any changed byte inside (the
    equations, the runtime, the binary) gives another."""
    import io
    import zipfile
    h = hashlib.sha256()
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            for name in sorted(z.namelist()):
                h.update(name.encode() + b"\0" + hashlib.sha256(z.read(name)).digest())
    except zipfile.BadZipFile:
        raise ValueError("fmu: not a zip file; allowed: an .fmu file") from None
    return h.hexdigest()


def _check_fmu(study: Study, blob: FmuBlob) -> None:
    """The study's names against the FMU's variables."""
    import fmpy
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / blob.name
        path.write_bytes(blob.data)
        try:
            md = fmpy.read_model_description(str(path), validate=False)
        except Exception as exc:  # noqa: BLE001 (FMPy raises bare Exceptions)
            raise ValueError(f"fmu = {blob.name!r}: not a readable FMU ({exc})") from None
    if md.modelName != study.model:
        raise ValueError(f"fmu = {blob.name!r}: a build of model {md.modelName!r}, not of "
                         f"the study's model {study.model!r}; allowed: an FMU of "
                         f"{study.model} (or none: built now)")
    settable = [v.name for v in md.modelVariables if v.start is not None]
    study.check_names(settable, [v.name for v in md.modelVariables])


def _keys(study: Study, blob: FmuBlob) -> list[str]:
    fp = study.fingerprint(blob.sha256)
    keys = [case_key(fp, c) for c in study.cases]
    if len(set(keys)) != len(keys):
        raise ValueError("cases: some cases repeat; allowed: distinct cases")
    return keys


def run_serial(study: Study, *, fmu=None, blob: FmuBlob | None = None,
               reuse: bool = False) -> list[dict]:
    """Every case in this process, one after the other: with ``reuse`` False
    (the plain loop) ``fmpy.simulate_fmu`` instantiates the FMU afresh for
    each case; with True it reuses one instance with fmi2Reset."""
    blob = blob or fmu_blob(study, fmu)
    _check_fmu(study, blob)
    reuse = check_bool("reuse", reuse)
    setup = study.setup()
    return [run_case(blob, setup, i, k, c, reuse=reuse)
            for i, (k, c) in enumerate(zip(_keys(study, blob), study.cases))]


def run_study(study: Study, *, out: Path | str | None = None, workers: int = 2,
              scheduler: str | None = None, fmu=None, blob: FmuBlob | None = None,
              resume: bool = True, progress: bool = True, batch: int = 1,
              connect_timeout: float = 10.0) -> StudyResult:
    """Run ``study`` on dask.distributed and return every case's row.

    out: the results CSV (None: none kept, no resume). workers: local worker
    processes of the embedded LocalCluster (1 ... MAX_WORKERS; one thread
    each); scheduler: the address of a running dask scheduler instead
    ("tcp://host:8786"), whose workers must have loomfmu installed. fmu: a
    built .fmu of the model (default: built now). resume: skip the cases
    already in ``out``; False starts ``out`` afresh. progress: a
    loomfmu.progress bar over the cases as they complete. batch: cases per
    dask task (1 ... 10000): more than 1 spreads dask's per-task overhead
    (a few ms) over short cases; rows are still kept case by case.
    connect_timeout: s (0 < . <= 600) to wait for ``scheduler`` to answer;
    a scheduler that does not (closed port, another service, no answer) is
    a ValueError naming the address, before the FMU is built.
    """
    workers = check_int("workers", workers, lo=1, hi=MAX_WORKERS)
    batch = check_int("batch", batch, lo=1, hi=10_000)
    resume, progress = check_bool("resume", resume), check_bool("progress", progress)
    if scheduler is not None and (not isinstance(scheduler, str) or "://" not in scheduler):
        raise ValueError(f"scheduler = {scheduler!r:.60}; allowed: None or an address "
                         "such as tcp://host:8786")
    connect_timeout = check_number("connect_timeout", connect_timeout, lo=0.0,
                                   hi=MAX_CONNECT_TIMEOUT, lo_open=True, unit="s")
    if out is not None and not isinstance(out, (str, Path)):
        raise ValueError(f"out = {out!r:.60}; allowed: None or a .csv path")
    if out is not None:
        out = check_writable("out", out)
    _need_distributed()
    if scheduler is not None:
        check_scheduler(scheduler, connect_timeout)
    blob = blob or fmu_blob(study, fmu)
    _check_fmu(study, blob)
    keys = _keys(study, blob)
    cols = store.columns(study.case_names, [f.name for f in study.figures])
    notes: list[str] = []
    done = _finished(out, keys, cols, resume, [f.name for f in study.figures], notes)
    for note in notes:
        _say(study, note, progress)
    pending = [(i, k, c) for i, (k, c) in enumerate(zip(keys, study.cases)) if k not in done]
    t0 = time.perf_counter()
    rows = dict(done)
    appender = store.Appender(Path(out), cols) if out is not None else None
    stats = {"startup_s": 0.0, "worker_cpu_s": 0.0, "client_cpu_s": 0.0,
             "busiest_worker_cpu_s": 0.0}
    try:
        if pending:
            rows.update(_dask_run(study, blob, pending, (workers, scheduler, connect_timeout),
                                  progress, appender, stats, batch, notes))
    finally:
        if appender is not None:
            appender.close()
    ordered = sorted(rows.values(), key=lambda r: r["index"])
    if out is not None:
        store.write_rows(Path(out), cols, ordered)
    return StudyResult(ordered, len(pending), len(done), time.perf_counter() - t0,
                       workers if scheduler is None else -1, None if out is None else Path(out),
                       notes=notes, **stats)


def _say(study: Study, note: str, progress: bool) -> None:
    """A note of the run as one line on standard error (with ``progress``)."""
    if progress:
        print(f"sweep {study.name}: note: {note}", file=sys.stderr, flush=True)


def _need_distributed() -> None:
    import importlib.util
    if importlib.util.find_spec("distributed") is None:
        raise ImportError("loomfmu.sweep runs on dask.distributed, which is not installed: "
                          "pip install 'loomfmu[distributed]'")


def _finished(out, keys: list[str], cols: list[str], resume: bool, figures: list[str],
              notes: list[str]) -> dict[str, dict]:
    """Rows of ``out`` that belong to this study (by case key) and are whole.
    A corrupt row (cut short when a study was killed, more fields than the
    header, an unknown status, an ok row whose figure is not a number) is run
    again, with a note naming the file, the line and what is wrong. Rows of
    other settings (another FMU, experiment or figures) are dropped from the
    file."""
    if out is None:
        return {}
    path = Path(out)
    if not path.exists():
        return {}
    if not resume:
        path.unlink()  # a fresh start
        return {}
    header = store.header_of(path)
    if header is not None and header != cols:
        raise ValueError(f"out = {str(path)!r}: its columns {header[:6]}... are not this "
                         f"study's {cols[:6]}...; allowed: this study's table, a new path, "
                         "or resume=False (--fresh) to replace it")
    index = {k: i for i, k in enumerate(keys)}
    found = store.read_lines(path)
    rows = {}
    for line, r, problem in found:
        if r.get("key") not in index:
            continue   # another setting's row
        problem = problem or _row_problem(r, figures)
        if problem is not None:
            notes.append(f"{path}:{line}: case {index[r['key']]} is run again: {problem}")
            continue
        r["index"] = index[r["key"]]
        rows[r["key"]] = r
    if len(rows) < len(found):  # rows of other settings or corrupt: keep only ours
        store.write_rows(path, cols, list(rows.values()))
    return rows


def _row_problem(row: dict, figures: list[str]) -> str | None:
    """What is wrong with a row of this study read back (None: nothing)."""
    if row.get("status") not in STATUSES:
        return f"status {row.get('status')!r:.40} is not one of {', '.join(STATUSES)}"
    if row["status"] in ("ok", "warning"):   # completed: every figure is a number
        for f in figures:
            v = row.get(f)
            if not isinstance(v, (int, float)) or isinstance(v, bool):
                return f"figure {f} = {v!r:.40} is not a number"
    return None


def _dask_run(study, blob, pending, where, progress, appender,
              stats: dict, batch: int, notes: list[str]) -> dict:
    """The pending cases on dask; a ^C (SIGINT, in the main thread) stops it
    without dask's shutdown chatter and raises KeyboardInterrupt."""
    import signal
    import threading
    args = (study, blob, pending, where, progress, appender, stats, batch, notes)
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        return _dask_run_on(*args)
    levels = {n: logging.getLogger(n).level for n in _DASK_LOGGERS}
    previous = signal.signal(signal.SIGINT, _on_sigint)
    try:
        return _dask_run_on(*args)
    finally:
        signal.signal(signal.SIGINT, previous)
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)


def _dask_run_on(study, blob, pending, where, progress, appender, stats: dict, batch: int,
                 notes: list[str]) -> dict:
    from dask.distributed import as_completed

    from loomfmu.progress import Progress
    t0 = time.perf_counter()
    workers, scheduler, connect_timeout = where
    client, cluster = open_client(workers, scheduler, connect_timeout)
    rows, futures = {}, []
    try:
        setup = study.setup()
        remote_blob = client.scatter(blob, broadcast=True)
        client.run(_warm_up, sorted(_modules(study)))  # imports counted as startup
        stats["startup_s"] = time.perf_counter() - t0
        cpu0, own0 = client.run(_cpu_seconds), time.process_time()
        chunks = [pending[j:j + batch] for j in range(0, len(pending), batch)]
        futures = [client.submit(run_batch, remote_blob, setup, chunk,
                                 key=f"{study.name}-{chunk[0][0]}-{chunk[0][1]}", pure=False)
                   for chunk in chunks]

        bar = Progress(total=len(pending), desc=f"sweep {study.name}") if progress else None
        try:
            for fut in as_completed(futures):
                for row in fut.result():
                    rows[row["key"]] = row
                    if appender is not None:
                        appender.add(row)
                    if bar is not None:
                        bar.advance(f"case {row['index']}: {row['status']}")
        finally:
            if bar is not None:
                bar.close()
        for note in _lost_worker_notes(client, futures, chunks):
            _say(study, note, progress)
            notes.append(note)
        cpu1 = client.run(_cpu_seconds)
        stats["client_cpu_s"] = time.process_time() - own0
        spent = [cpu1[w] - cpu0.get(w, 0.0) for w in cpu1]
        stats["worker_cpu_s"], stats["busiest_worker_cpu_s"] = sum(spent), max(spent)
    except KeyboardInterrupt:   # ^C: stop quietly, the rows appended so far stay
        _silence_dask()
        try:
            client.cancel(futures)
        except Exception:  # noqa: BLE001 (closing anyway)
            pass
        raise
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return rows


_DASK_LOGGERS = ("distributed", "tornado", "asyncio")


def _silence_dask() -> None:
    """No more log records of dask, tornado and asyncio in this process: after
    an interruption their shutdown chatter (cancelled keys, closed comms, a
    callback's traceback) says nothing the caller's one line does not."""
    for name in _DASK_LOGGERS:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def _on_sigint(signum, frame):
    _silence_dask()   # before dask's own callbacks see the interruption
    raise KeyboardInterrupt


def _lost_worker_notes(client, futures, chunks) -> list[str]:
    """One note per task that ran again because the worker running it was
    lost (the scheduler counts such a task as suspicious; a worker that dies
    on it more often than distributed.scheduler.allowed-failures fails it
    with KilledWorker instead)."""
    keys = [f.key for f in futures]

    def suspicious(dask_scheduler, keys=keys):   # pickled by value: any scheduler runs it
        tasks = dask_scheduler.tasks
        return {k: tasks[k].suspicious for k in keys if k in tasks}

    try:
        counts = client.run_on_scheduler(suspicious)
    except Exception:  # noqa: BLE001 (an older scheduler: the rows are right regardless)
        return []
    notes = []
    for key, chunk in zip(keys, chunks):
        if counts.get(key):
            cases = ", ".join(str(i) for i, _, _ in chunk)
            notes.append(f"case(s) {cases} ran again after the worker running them was "
                         f"lost ({counts[key]} time(s))")
    return notes


def _modules(study: Study) -> set[str]:
    """Modules a worker imports to run the study's cases."""
    mods = {"loomfmu.sweep.worker"}
    for f in [study.prepare, *(getattr(f, "function", None) for f in study.figures)]:
        if f is not None:
            mods.add(f.__module__)
    return mods


def _warm_up(modules: list[str]) -> None:
    import importlib
    for m in modules:
        importlib.import_module(m)


def _cpu_seconds() -> float:
    """CPU seconds (user + system) of this worker process so far."""
    t = os.times()
    return t.user + t.system
