"""FMPy with a logger of our own, without FMPy's native logger proxy.

``fmpy.simulate_fmu(..., logger=f)`` and ``fmpy.instantiate_fmu(..., logger=f)``
for an FMI 2 FMU wrap ``f`` in a ctypes thunk and call ``addLoggerProxy``: FMPy's
logging.so stores that thunk in its ONE process-global pointer (``s_logger``)
and gives the FMU its formatting proxy, which calls ``s_logger``. The thunk lives
only as long as that call's instance; once it is freed ``s_logger`` dangles, and
every instance that logs through the proxy afterwards calls freed memory -- FMPy's
default callbacks (``simulate_fmu`` without ``logger``) go through the same proxy.
The process crashes (SIGSEGV, SIGILL, SIGFPE) or, if the memory was reused by
another thunk, the message goes to another instance's logger. Whether it crashes
depends on when the cyclic garbage collector runs, i.e. on which tests ran before
in the same process. Two instances with loggers alive at once (the sweep's
threads) share the one pointer as well.

Here an FMI 2 instance gets its own thunk (kept alive by the instance's
callbacks, as FMPy's ``instance.callbacks``) called directly by the FMU: no global
state. The message is the FMI 2 format string; a loomfmu FMU passes no arguments
and escapes '%' as '%%' and '#' as '##' (lf_fmi2.c); both are printed as one
character, as FMI 2.0 asks of an importer (FMPy's proxy leaves '##'). FMI 3 has no proxy (its message is
not a format): FMPy's own instantiation is used.
"""
from __future__ import annotations

import ctypes
import os
import re
import shutil
from typing import Callable

import fmpy
from fmpy import calloc, free
from fmpy.fmi2 import (
    FMU2Model,
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

#: FMI 2.0 (2.1.5): the message is a format string, '%%' prints '%', and '##'
#: prints '#' ('#' marks variable references); one pass, left to right
_UNESCAPE = re.compile(rb"([%#])\1")


def instantiate(unzipdir, model_description, fmi_type: str, logger: Callable,
                debug_logging: bool = False):
    """``fmpy.instantiate_fmu(unzipdir, model_description, fmi_type,
    logger=logger, debug_logging=...)`` without FMPy's global logger proxy for
    FMI 2 (see the module's doc). ``logger`` is called as FMPy calls it:
    (component environment, instance name, status, category, message) for
    FMI 2, FMPy's four arguments for FMI 3."""
    if model_description.fmiVersion != "2.0":
        return fmpy.instantiate_fmu(unzipdir, model_description, fmi_type,
                                    debug_logging=debug_logging, logger=logger)

    def direct(env, instance, status, category, message):
        logger(env, instance, status, category, _UNESCAPE.sub(rb"\1", message))

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(direct)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    me = fmi_type == "ModelExchange"
    interface = model_description.modelExchange if me else model_description.coSimulation
    fmu = (FMU2Model if me else FMU2Slave)(
        guid=model_description.guid, unzipDirectory=str(unzipdir),
        modelIdentifier=interface.modelIdentifier, instanceName=None)
    fmu.instantiate(callbacks=callbacks, loggingOn=debug_logging)  # fmu.callbacks keeps it
    return fmu


def simulate(filename, *, logger: Callable, fmi_type: str | None = None,
             model_description=None, debug_logging: bool = False, **kwargs):
    """``fmpy.simulate_fmu(filename, logger=logger, ...)`` on a fresh instance
    made by ``instantiate`` (freed before returning). ``filename``: an FMU or
    the directory it was extracted into (kept)."""
    extracted = os.path.isfile(os.path.join(filename, "modelDescription.xml"))
    unzipdir = str(filename) if extracted else fmpy.extract(str(filename))
    try:
        md = model_description or fmpy.read_model_description(unzipdir, validate=False)
        if fmi_type is None:
            fmi_type = "CoSimulation" if md.coSimulation is not None else "ModelExchange"
        fmu = instantiate(unzipdir, md, fmi_type, logger, debug_logging)
        try:
            return fmpy.simulate_fmu(unzipdir, fmi_type=fmi_type, model_description=md,
                                     fmu_instance=fmu, **kwargs)
        finally:
            try:
                fmu.freeInstance()
            except Exception:  # noqa: BLE001 (an instance in Error may refuse)
                pass
    finally:
        if not extracted:
            shutil.rmtree(unzipdir, ignore_errors=True)


_FMPY_PRINTER = None  # FMPy's default printer in a thunk that is never freed


def restore_fmpy_proxy() -> None:
    """Point FMPy's proxy (logging.so's ``s_logger``) back at FMPy's default
    printer, after code that called ``fmpy.simulate_fmu`` or
    ``fmpy.instantiate_fmu`` with ``logger=`` on an FMI 2 FMU (that thunk is
    freed with its instance). Instances made with FMPy's default callbacks log
    through the proxy safely again."""
    global _FMPY_PRINTER
    from fmpy.fmi2 import printLogMessage
    from fmpy.logging import addLoggerProxy
    if _FMPY_PRINTER is None:
        _FMPY_PRINTER = fmi2CallbackLoggerTYPE(printLogMessage)
    scratch = fmi2CallbackFunctions()
    scratch.logger = _FMPY_PRINTER
    addLoggerProxy(ctypes.byref(scratch))  # s_logger = _FMPY_PRINTER


def settable_names(md) -> set[str]:
    """Names of the variables of FMPy's model description ``md`` an importer may
    set before initialization: parameters, inputs, and continuous variables
    with an exact or approximate start (states)."""
    return {v.name for v in md.modelVariables
            if v.causality in ("parameter", "input")
            or (v.initial in ("exact", "approx") and v.variability == "continuous")}
