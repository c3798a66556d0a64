"""One case of a study, run where dask puts it.

Each worker process extracts a study's FMU once (keyed by the FMU's SHA-256)
and instantiates it once per thread; every further case on that worker
starts with ``fmi2Reset`` on the same instance, as FMPy's parameter-variation
example does. A case that fails (the FMU returned Discard/Error, or the
case's values were refused before running) comes back as a row with its
status and the FMU's last log line: it is never lost and never stops the
study. A case that completed while the FMU logged a warning (an input
outside its range, say) is "warning" with that log line, not "ok".
``reuse=False`` runs the plain loop instead: ``fmpy.simulate_fmu`` with a
fresh instance per case (the serial baseline the sweep is compared
with).
"""
from __future__ import annotations

import atexit
import dataclasses
import math
import os
import shutil
import socket
import tempfile
import threading
import time
from typing import Callable

import fmpy
import numpy as np

from loomfmu.declare.solvers import SOLVERS
from loomfmu.verification import fmpy_logger

#: FMI status codes -> the status a row records
FMI_STATUS = {2: "discard", 3: "error", 4: "fatal"}
#: statuses a row can have ("warning": the run completed but the FMU logged a
#: warning, e.g. an input outside its range; the message is its log line)
STATUSES = ("ok", "warning", "discard", "error", "fatal", "invalid", "failed")


@dataclasses.dataclass(frozen=True)
class FmuBlob:
    """An FMU's bytes and their SHA-256: shipped once to every worker."""
    data: bytes
    sha256: str
    name: str


@dataclasses.dataclass(frozen=True)
class Setup:
    """The experiment every case of a study shares (see Study)."""
    solver: str
    rtol: float
    atol: float
    stop_time: float
    output_interval: float
    outputs: tuple
    figures: tuple
    fixed: dict
    prepare: Callable | None


class _Slot:
    """An extracted FMU and (per thread) its instance and log."""

    def __init__(self, blob: FmuBlob):
        self.dir = tempfile.mkdtemp(prefix=f"loomfmu-sweep-{blob.sha256[:8]}-")
        path = os.path.join(self.dir, blob.name)
        with open(path, "wb") as f:
            f.write(blob.data)
        self.unzipdir = fmpy.extract(path, unzipdir=os.path.join(self.dir, "x"))
        self.md = fmpy.read_model_description(self.unzipdir, validate=False)
        self.log: list[tuple[int, str]] = []
        self.instance = None
        self.used = False
        self.owner = threading.current_thread()

    def logger(self, *args):
        # FMI 2: (environment, instance, status, category, message); FMI 3:
        # FMPy passes (instance, status, category, message)
        status, category, message = args[-3:]
        self.log.append((int(status), f"[{_text(category)}] {_text(message)}"))

    def get_instance(self):
        if self.instance is None:
            self.instance = fmpy_logger.instantiate(self.unzipdir, self.md, "CoSimulation",
                                                    self.logger)
            self.used = False
        return self.instance

    def drop_instance(self) -> None:
        if self.instance is not None:
            try:
                self.instance.freeInstance()
            except Exception:  # noqa: BLE001 (an instance in Error may refuse; drop it)
                pass
            self.instance = None

    def close(self) -> None:
        self.drop_instance()
        shutil.rmtree(self.dir, ignore_errors=True)


_SLOTS: dict[tuple[str, int], _Slot] = {}
_LOCK = threading.Lock()


def _slot(blob: FmuBlob) -> _Slot:
    key = (blob.sha256, threading.get_ident())
    # current_thread() also registers a thread not started by threading (a
    # dummy that counts as alive for good), so every owner is a Thread
    me = threading.current_thread()
    with _LOCK:
        if len(_SLOTS) >= threading.active_count():
            _close_dead_threads()
        slot = _SLOTS.get(key)
        if slot is None:
            slot = _SLOTS[key] = _Slot(blob)
        slot.owner = me  # (an ended thread's identifier given to a new one: its slot)
        return slot


def _close_dead_threads() -> None:
    """Close the slots whose thread has ended (a process that runs batches
    on one thread pool after another would otherwise keep every pool's
    instances and extracted FMUs until it exits).  Called with _LOCK held
    when there are at least as many slots as threads (one FMU per thread is
    the usual case).  A slot is used by its owner thread only, so one whose
    owner has ended is in nobody's hands; a thread that threading does not
    know (started by _thread or natively) is its dummy Thread, alive for
    good: its slot is kept."""
    for key in [k for k, slot in _SLOTS.items() if not slot.owner.is_alive()]:
        _SLOTS.pop(key).close()


@atexit.register
def _close_all() -> None:
    for slot in _SLOTS.values():
        slot.close()
    _SLOTS.clear()


def instances_made() -> int:
    """Extracted FMUs held by this process (one per FMU and thread)."""
    return len(_SLOTS)


def case_values(setup: Setup, case: dict) -> tuple[dict, float]:
    """The start values and stop time of ``case``: the study's fixed values
    and the case, or what the study's ``prepare(case, fixed)`` makes of them."""
    if setup.prepare is None:
        return {**setup.fixed, **case}, setup.stop_time
    values, stop = setup.prepare(case, dict(setup.fixed))
    return values, (setup.stop_time if stop is None else float(stop))


def _text(b) -> str:
    return b.decode(errors="replace") if isinstance(b, bytes) else str(b)


def _message(log: list[tuple[int, str]], exc: Exception) -> str:
    """The exception and the log's first line of status Discard or worse (the
    cause: FMPy may call the FMU again after a Discard, and the last line is
    then the refusal of that call), with the last one if it differs."""
    bad = [text for status, text in log if status >= 2]
    if not bad:
        return f"{exc}; log: {log[-1][1] if log else 'no log'}"
    tail = f" ... {bad[-1]}" if len(bad) > 1 else ""
    return f"{exc}; log: {bad[0]}{tail}"


def run_case(blob: FmuBlob, setup: Setup, index: int, key: str, case: dict,
             reuse: bool = True) -> dict:
    """Run one case; return its row (index, key, case, status, message,
    figures, wall_s, worker; and instance: 'new', 'reset' (an instance reused
    after fmi2Reset) or 'plain' (reuse False), not written to the table)."""
    row = {"index": index, "key": key, **case, "status": "ok", "message": ""}
    row.update({f.name: float("nan") for f in setup.figures})
    t0 = time.perf_counter()
    slot = _slot(blob)
    try:
        values, stop = case_values(setup, case)
    except (ValueError, TypeError) as exc:
        row.update(status="invalid", message=str(exc), wall_s=0.0, worker=_worker())
        return row
    # the FMU's ``solver`` enumeration value: the 1-based position in SOLVERS
    start = {"solver": SOLVERS.index(setup.solver) + 1, "solver_atol": setup.atol, **values}
    slot.log.clear()
    kwargs = dict(validate=False, model_description=slot.md, stop_time=stop,
                  relative_tolerance=setup.rtol, output_interval=setup.output_interval,
                  start_values=start, output=list(setup.outputs))
    try:
        if reuse:
            inst = slot.get_instance()
            if slot.used:
                inst.reset()
            row["instance"] = "reset" if slot.used else "new"
            slot.used = True
            res = fmpy.simulate_fmu(slot.unzipdir, fmu_instance=inst, **kwargs)
        else:
            row["instance"] = "plain"
            res = fmpy_logger.simulate(slot.unzipdir, logger=slot.logger, **kwargs)
    except Exception as exc:  # noqa: BLE001 (FMPy raises FMICallException or bare Exception)
        status = FMI_STATUS.get(getattr(exc, "status", None), "error")
        row.update(status=status, message=_message(slot.log, exc))
        slot.drop_instance()  # a fresh instance for the next case
    else:
        warned = [text for status, text in slot.log if status == 1]
        if warned:  # completed, but not "ok": the FMU said its answer may not hold
            tail = f" ... ({len(warned)} warnings)" if len(warned) > 1 else ""
            row.update(status="warning", message=f"log: {warned[0]}{tail}")
        t = np.asarray(res["time"])
        y = {n: np.asarray(res[n]) for n in setup.outputs}
        try:
            for fig in setup.figures:
                row[fig.name] = value = fig(t, y, case)
                if not math.isfinite(value):  # never "ok" with NaN
                    raise ValueError(f"{fig.name} = {value} at stop time {t[-1]:g} s")
        except (ValueError, ArithmeticError) as exc:
            row.update(status="failed", message=f"figure: {exc}")
    row.update(wall_s=time.perf_counter() - t0, worker=_worker())
    return row


def run_batch(blob: FmuBlob, setup: Setup, items: list, reuse: bool = True) -> list[dict]:
    """run_case for each (index, key, case) of ``items``, in order."""
    return [run_case(blob, setup, i, k, c, reuse=reuse) for i, k, c in items]


def dask_setup(worker) -> None:
    """Run by a local cluster's worker processes at start (dask's preload):
    SIGINT is ignored there. A ^C in a terminal reaches every process of the
    group; the process that started the cluster stops the workers, and
    without this each worker would print its own KeyboardInterrupt traceback."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _worker() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"
