"""The running FMUs of a scene, driven through FMI 2.0 by fmpy's FMU2Slave:
instantiate and initialize with the scene's values, move values along
connections, step, save and restore their states."""
from __future__ import annotations

import shutil
from pathlib import Path

from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

#: FMU log lines kept per instance (the latest), shown when a call fails
LOG_LINES = 200

from .declare import Connection, Scene, feedthrough_order


class FMUError(RuntimeError):
    """An FMU call failed; the message names the component, the call and the time."""


class Instance:
    """One FMU instance."""

    def __init__(self, name: str, path: Path):
        self.name = name
        self.md = read_model_description(str(path))
        self.dir = extract(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.type = {v.name: v.type for v in self.md.modelVariables}
        self.log: list[str] = []

        def logger(env, instance, status, category, message):
            self.log.append(message.decode(errors="replace"))
            del self.log[:-LOG_LINES]

        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName=name)
        self.fmu.instantiate(callbacks=self._callbacks, loggingOn=False)

    def set(self, values: dict[str, float]) -> None:
        for var, value in values.items():
            if self.type[var] in ("Integer", "Enumeration"):
                self.fmu.setInteger([self.vr[var]], [int(value)])
            else:
                self.fmu.setReal([self.vr[var]], [float(value)])

    def close(self) -> None:
        try:
            self.fmu.terminate()
        except Exception:
            pass
        try:
            self.fmu.freeInstance()
        finally:
            shutil.rmtree(self.dir, ignore_errors=True)


class System:
    """The scene's components as FMU instances, initialized at ``t0``."""

    def __init__(self, scene: Scene, fmus: dict[str, Path], *, t0: float = 0.0,
                 tolerance: float | None = None):
        self.scene = scene
        self.instances: dict[str, Instance] = {}
        try:
            for name in scene.components:
                self.instances[name] = Instance(name, Path(fmus[name]))
        except Exception:
            self.close()
            raise
        self.connections: list[Connection] = feedthrough_order(scene.connections,
                                                               scene.components)
        self._src = [(self.instances[c.src].fmu, self.instances[c.src].vr[c.src_var])
                     for c in self.connections]
        self._dst = [(self.instances[c.dst].fmu, self.instances[c.dst].vr[c.dst_var])
                     for c in self.connections]
        self.into = {name: [i for i, c in enumerate(self.connections) if c.dst == name]
                     for name in scene.components}
        self.held = [0.0] * len(self.connections)   # the value each input holds now
        self._initialize(t0, tolerance)

    def _initialize(self, t0: float, tolerance: float | None) -> None:
        for name, inst in self.instances.items():
            comp = self.scene.components[name]
            self._call(name, "fmi2SetupExperiment", t0, lambda: inst.fmu.setupExperiment(
                tolerance=tolerance, startTime=t0))
            self._call(name, "fmi2SetReal (parameters, starts)", t0,
                       lambda: inst.set({**comp.parameters, **comp.start}))
            self._call(name, "fmi2EnterInitializationMode", t0,
                       inst.fmu.enterInitializationMode)
        # consistent inputs at t0: every output read after the inputs it
        # depends on are set (connections in feedthrough order)
        self.exchange(range(len(self.connections)), t0)
        for name, inst in self.instances.items():
            self._call(name, "fmi2ExitInitializationMode", t0, inst.fmu.exitInitializationMode)
        self.exchange(range(len(self.connections)), t0)

    def _call(self, name: str, what: str, t: float, fn):
        try:
            return fn()
        except Exception as exc:
            inst = self.instances.get(name)
            log = f"; its log: {inst.log[-1]}" if inst is not None and inst.log else ""
            raise FMUError(f"{name}: {what} failed at t = {t:.9g} s ({exc}){log}") from None

    # -- values -----------------------------------------------------------
    def source_value(self, i: int) -> float:
        """The value connection ``i`` would carry now (converted to the input's unit)."""
        fmu, vr = self._src[i]
        c = self.connections[i]
        return c.gain * fmu.getReal([vr])[0] + c.bias

    def exchange(self, indices, t: float) -> None:
        """Move values along connections ``indices`` (in that order: each
        source is read after the inputs set before it)."""
        for i in indices:
            self.set_inputs([i], [self.source_value(i)], t)

    def set_inputs(self, indices, values, t: float) -> None:
        """Set the inputs of connections ``indices`` to ``values``."""
        for i, value in zip(indices, values):
            fmu, vr = self._dst[i]
            self._call(self.connections[i].dst, "fmi2SetReal (input)", t,
                       lambda: fmu.setReal([vr], [value]))
            self.held[i] = value

    def get(self, refs: list[tuple[str, str]]) -> list[float]:
        return [self.instances[c].fmu.getReal([self.instances[c].vr[v]])[0] for c, v in refs]

    # -- stepping and states --------------------------------------------------
    def do_step(self, name: str, t: float, h: float) -> None:
        inst = self.instances[name]
        self._call(name, f"fmi2DoStep (h = {h:.6g} s)", t, lambda: inst.fmu.doStep(t, h))

    def get_states(self) -> dict:
        return {n: self._call(n, "fmi2GetFMUstate", float("nan"), i.fmu.getFMUState)
                for n, i in self.instances.items()}

    def set_states(self, states: dict, held: list[float]) -> None:
        for n, s in states.items():
            self._call(n, "fmi2SetFMUstate", float("nan"),
                       lambda: self.instances[n].fmu.setFMUState(s))
        self.held = list(held)

    def free_states(self, states: dict) -> None:
        for n, s in states.items():
            self.instances[n].fmu.freeFMUState(s)

    def close(self) -> None:
        for inst in self.instances.values():
            inst.close()
        self.instances = {}
