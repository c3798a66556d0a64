"""The running FMUs of a scene, driven through FMI 2.0 by fmpy's FMU2Slave:
instantiate and initialize with the scene's values, move values along
connections (iterating the algebraic loops that direct feedthrough closes),
step, save and restore their states.

An algebraic loop (connections that direct feedthrough closes into a cycle)
is solved at each communication point, where FMI 2.0 lets a master set
inputs and read outputs without stepping: with u the loop's input values
and G(u) the outputs they produce (converted), u = G(u) is solved by Newton's
method with a finite-difference Jacobian (one extra output read per loop
variable; the loop's last solution is the first guess), or by relaxed
fixed-point iteration u <- u + w (G(u) - u).  Converged when every
|G(u) - u| <= loop_atol + loop_rtol s, with s fixed before iterating (the
larger of |u| and |G(u)| at the start, and |u| at the loop's earlier
solutions): a diverging iterate cannot widen its own tolerance.  After
loop_max_iter iterations, on a singular Jacobian or on a runaway iterate,
FMUError names the loop, the time and the residual.

Cost: the hot path calls FMPy's ctypes functions (``FMU2Slave._functions``)
directly with ctypes arrays made once (:class:`Values`), and moves values in
stages of one fmi2GetReal per source component and one fmi2SetReal per
receiving component (:meth:`System.exchange`); a failed call is repeated one
value at a time through :meth:`System._call`, so the error still names the
component, the call, the variable, the time and the FMU's last log line.
"""
from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2Integer,
    fmi2Real,
    fmi2True,
    fmi2ValueReference,
)

from loomfmu.scene.declare import Connection, Scene, _self_loop, feedthrough_blocks

#: FMU log lines kept per instance (the latest), shown when a call fails
LOG_LINES = 200
#: a loop's Jacobian I - dG/du with a larger condition number is singular: a
#: finite-difference Jacobian (relative error ~1e-9) cannot resolve it
LOOP_COND_MAX = 1e8
#: a loop iterate whose magnitude exceeds this many times its scale before
#: iterating (plus 1) runs away: the loop has no solution near its start
LOOP_RUNAWAY = 1e6


class FMUError(RuntimeError):
    """An FMU call failed; the message names the component, the call and the time."""


class ModelInvalid(FMUError):
    """fmi2DoStep returned Discard with fmi2Terminated true: the FMU says its
    model is not valid beyond where it stopped (a validity condition failed)
    under the inputs it was given.  The message says how far each of its
    coupled inputs moved within the last communication step: an input held
    or extrapolated over a long step can overshoot, where a shorter step or
    extrapolation may keep the model valid; a component without coupled
    inputs fails the same at any step."""


#: fmi2StatusKind fmi2Terminated (FMI 2.0, 4.2.3)
FMI2_TERMINATED = 3
#: the largest fmi2Status that is not a failure (fmi2Warning)
FMI2_WARNING = 1


class Values:
    """Real variables of one component exchanged in one FMI call: their value
    references and a value buffer, as ctypes arrays made once (the hot path
    calls FMPy's ctypes functions with them directly, without FMPy's
    per-call list-to-array conversion)."""

    __slots__ = ("inst", "n", "vr", "val")

    def __init__(self, inst: "Instance", vrs):
        self.inst, self.n = inst, len(vrs)
        self.vr = (fmi2ValueReference * self.n)(*vrs)
        self.val = (fmi2Real * self.n)()

    def get(self) -> bool:
        """fmi2GetReal of every variable into ``val``; False if it failed."""
        inst = self.inst
        return inst.f_get(inst.component, self.vr, self.n, self.val) <= FMI2_WARNING

    def set(self) -> bool:
        """fmi2SetReal of every variable from ``val``; False if it failed."""
        inst = self.inst
        return inst.f_set(inst.component, self.vr, self.n, self.val) <= FMI2_WARNING


def _needed_at_run_time(name: str) -> bool:
    return not name.startswith(("sources/", "documentation/", "extra/"))


def _raise(exc: Exception):
    raise exc


class Instance:
    """One FMU instance."""

    def __init__(self, name: str, path: Path, md=None):
        self.name = name
        self.md = md if md is not None else read_model_description(str(path))
        # what an instance needs: not the sources, the documentation or the
        # reference results (a composed FMU's sources are most of its files)
        self.dir = extract(str(path), include=_needed_at_run_time)
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
        # FMPy's ctypes functions, called directly on the hot path (Values, System.do_step)
        f = self.fmu._functions
        self.component = self.fmu.component
        self.f_get, self.f_set = f["fmi2GetReal"], f["fmi2SetReal"]
        self.f_do_step = f["fmi2DoStep"]
        self.f_set_der = f["fmi2SetRealInputDerivatives"]

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

    #: loop solvers
    LOOP_METHODS = ("newton", "fixed-point")

    def __init__(self, scene: Scene, fmus: dict[str, Path], *, t0: float = 0.0,
                 tolerance: float | None = None, loop_method: str = "newton",
                 loop_rtol: float = 1e-10, loop_atol: float = 1e-12, loop_max_iter: int = 50,
                 relaxation: float = 0.5):
        if loop_method not in self.LOOP_METHODS:
            raise ValueError(f"loop_method = {loop_method!r:.40}; allowed: "
                             f"{', '.join(self.LOOP_METHODS)}")
        for arg, value, lo, hi in (("loop_rtol", loop_rtol, 0.0, 1.0),
                                   ("loop_atol", loop_atol, 0.0, math.inf),
                                   ("relaxation", relaxation, 0.0, 1.0)):
            if not (isinstance(value, (int, float)) and not isinstance(value, bool)
                    and lo < value <= hi and math.isfinite(value)):
                raise ValueError(f"{arg} = {value!r:.40}; allowed: a number in ({lo:g}, "
                                 f"{hi:g}]")
        if not (isinstance(loop_max_iter, int) and not isinstance(loop_max_iter, bool)
                and 1 <= loop_max_iter <= 10000):
            raise ValueError(f"loop_max_iter = {loop_max_iter!r:.40}; allowed: an integer "
                             "in [1, 10000]")
        self.loop_method, self.loop_rtol, self.loop_atol = loop_method, loop_rtol, loop_atol
        self.loop_max_iter, self.relaxation = loop_max_iter, float(relaxation)
        self.scene = scene
        self.instances: dict[str, Instance] = {}
        try:
            for name in scene.components:
                self.instances[name] = Instance(name, Path(fmus[name]))
        except Exception:
            self.close()
            raise
        blocks = feedthrough_blocks(scene.connections, scene.components)
        self.connections: list[Connection] = [c for b in blocks for c in b]
        #: the connections in feedthrough order, in blocks of indices; a block
        #: of a loop has several connections (or one that loops on itself)
        self.blocks: list[list[int]] = []
        k = 0
        for b in blocks:
            self.blocks.append(list(range(k, k + len(b))))
            k += len(b)
        self.is_loop = [len(b) > 1 or _self_loop(b[0], scene.components) for b in blocks]
        self.loop_iterations = 0     # loop iterations (output reads) so far
        #: each component's coupled inputs over its last successful step
        self._stepped_inputs: dict[str, list[float]] = {}
        #: each loop's largest input magnitude at its earlier solutions
        self._loop_size: dict[tuple[int, ...], np.ndarray] = {}
        #: each component's time (its last communication point)
        self.time = {name: t0 for name in scene.components}
        self._src = [(self.instances[c.src].fmu, self.instances[c.src].vr[c.src_var])
                     for c in self.connections]
        self._dst = [(self.instances[c.dst].fmu, self.instances[c.dst].vr[c.dst_var])
                     for c in self.connections]
        self.into = {name: [i for i, c in enumerate(self.connections) if c.dst == name]
                     for name in scene.components}
        self.held = [0.0] * len(self.connections)   # the value each input holds now
        self._gain = [c.gain for c in self.connections]
        self._bias = [c.bias for c in self.connections]
        #: value buffers of one connection's source and input (single-value calls)
        self._src1 = [Values(self.instances[c.src], [self.instances[c.src].vr[c.src_var]])
                      for c in self.connections]
        self._dst1 = [Values(self.instances[c.dst], [self.instances[c.dst].vr[c.dst_var]])
                      for c in self.connections]
        self._plans: dict[tuple, list] = {}   # exchange(indices) -> its stages
        self._der1: dict[tuple[int, int], tuple] = {}   # set_input_derivatives' arrays
        self._der_calls: dict[tuple, list] = {}   # set_input_derivatives_together's
        self._set_calls: dict[tuple, list] = {}   # set_inputs_together's
        self._watched: list[tuple[str, str]] = []
        self._end: list[Values] = []          # read_end's calls, one per component
        self._end_src: list[tuple[Values, int]] = []
        self._end_rec: list[tuple[Values, int]] = []
        self.watch([])
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

    def call(self, name: str, what: str, t: float, fn):
        """fn(), an FMI call of component ``name``; FMUError naming it, the call
        and the time when it fails."""
        return self._call(name, what, t, fn)

    def _call(self, name: str, what: str, t: float, fn):
        try:
            return fn()
        except Exception as exc:
            inst = self.instances.get(name)
            log = f"; its log: {inst.log[-1]}" if inst is not None and inst.log else ""
            raise FMUError(f"{name}: {what} failed at t = {t:.9g} s ({exc}){log}") from None

    def _terminated(self, name: str) -> bool:
        """fmi2GetBooleanStatus(fmi2Terminated) of component ``name`` (False
        when the FMU cannot say)."""
        try:
            return self.instances[name].fmu.getBooleanStatus(FMI2_TERMINATED)
        except Exception:
            return False

    # -- values -----------------------------------------------------------
    def source_value(self, i: int) -> float:
        """The value connection ``i`` would carry now (converted to the input's unit)."""
        src = self._src1[i]
        if not src.get():
            c = self.connections[i]
            fmu, vr = self._src[i]
            self._call(c.src, f"fmi2GetReal ({c.src_var}, for {c})", self.time[c.src],
                       lambda: fmu.getReal([vr])[0])    # fails again: FMUError naming it
        return self._gain[i] * src.val[0] + self._bias[i]

    def exchange(self, indices, t: float, *, iterate=None) -> None:
        """Move values along connections ``indices`` in feedthrough order (each
        source is read after the inputs it depends on are set).  A loop among
        them is solved (all its connections) when ``iterate(block)`` is true
        (default: always); otherwise its values are passed on once.

        The moves are made in stages (:meth:`_plan`): one fmi2GetReal per
        source component, then one fmi2SetReal per receiving component.  A
        stage ends before a read of a component that received an input in it,
        so every FMU computes its outputs from the same inputs, in the same
        order, as when each value is moved on its own (bit-identical results,
        also for FMUs whose outputs depend on their history, e.g. a Newton
        iteration started from its last solution)."""
        key = tuple(indices)
        plan = self._plans.get(key)
        if plan is None:
            plan = self._plans[key] = self._plan(key)
        held, gain, bias = self.held, self._gain, self._bias
        for stage in plan:
            if stage[0] == "loop":
                block, mine = stage[1], stage[2]
                if iterate is None or iterate(block):
                    self.solve_loop(block, t)
                else:
                    self._move_one_by_one(mine, t)
                continue
            _, reads, writes, conns = stage
            ok = True
            for vals, pairs in reads:
                if not vals.get():
                    ok = False
                    break
                v = vals.val
                for p, i in pairs:
                    held[i] = gain[i] * v[p] + bias[i]
            if ok:
                for vals, pairs in writes:
                    v = vals.val
                    for p, i in pairs:
                        v[p] = held[i]
                    if not vals.set():
                        ok = False
                        break
            if not ok:   # repeat one by one: the failing call raises FMUError naming it
                self._move_one_by_one(conns, t)

    def _move_one_by_one(self, conns, t: float) -> None:
        for i in conns:
            self.set_inputs([i], [self.source_value(i)], t)

    def _plan(self, indices: tuple) -> list:
        """The stages of exchange(indices): ("loop", block, its connections
        among indices) or ("batch", reads, writes, connections) where reads
        and writes are [(Values, [(position, connection)])], one per
        component."""
        wanted = set(indices)
        stages: list = []
        run: list[int] = []

        def close():
            if run:
                stages.append(("batch", self._group(run, "src"), self._group(run, "dst"),
                               list(run)))
                run.clear()

        for block, loop in zip(self.blocks, self.is_loop):
            mine = [i for i in block if i in wanted]
            if not mine:
                continue
            if loop:
                close()
                stages.append(("loop", block, mine))
                continue
            for i in mine:
                if self.connections[i].src in {self.connections[j].dst for j in run}:
                    close()
                run.append(i)
        close()
        return stages

    def _group(self, conns: list[int], side: str) -> list:
        """[(Values, [(position, connection)])]: connections ``conns`` by their
        ``side`` ("src" or "dst") component, in order."""
        by: dict[str, list[int]] = {}
        for i in conns:
            by.setdefault(getattr(self.connections[i], side), []).append(i)
        out = []
        for name, group in by.items():
            inst = self.instances[name]
            var = "src_var" if side == "src" else "dst_var"
            vals = Values(inst, [inst.vr[getattr(self.connections[i], var)] for i in group])
            out.append((vals, list(enumerate(group))))
        return out

    # -- the values at the end of a step ------------------------------------------
    def watch(self, refs: list[tuple[str, str]]) -> None:
        """Read the variables ``refs`` (component, variable) with the sources
        in :meth:`read_end`: one fmi2GetReal per component after each step."""
        self._watched = list(refs)
        names: dict[str, list[int]] = {}
        src_pos, rec_pos = [], []
        for c in self.connections:
            vrs = names.setdefault(c.src, [])
            src_pos.append((c.src, len(vrs)))
            vrs.append(self.instances[c.src].vr[c.src_var])
        for c, v in self._watched:
            if self.instances[c].type[v] != "Real":   # a mode, a flag: read on its own
                rec_pos.append((c, None))
                continue
            vrs = names.setdefault(c, [])
            rec_pos.append((c, len(vrs)))
            vrs.append(self.instances[c].vr[v])
        vals = {n: Values(self.instances[n], vrs) for n, vrs in names.items()}
        self._end = list(vals.values())
        self._end_src = [(vals[n], p) for n, p in src_pos]
        self._end_rec = [(vals[n], p) if p is not None else (None, r)
                         for r, (n, p) in enumerate(rec_pos)]
        self.end_fresh = False

    def read_end(self) -> bool:
        """Read every source and watched variable now (after a step), one
        fmi2GetReal per component; False if a read failed (then read them one
        by one, :meth:`source_value` and :meth:`get`, to name the failure)."""
        for vals in self._end:
            if not vals.get():
                self.end_fresh = False
                return False
        self.end_fresh = True
        return True

    def end_source(self, i: int) -> float:
        """Connection ``i``'s source value at the last :meth:`read_end`."""
        vals, p = self._end_src[i]
        return self._gain[i] * vals.val[p] + self._bias[i]

    def recorded(self, refs: list[tuple[str, str]]) -> list[float]:
        """The values of ``refs`` now: from the last read_end when it is of
        this state and ``refs`` are the watched ones, else :meth:`get`."""
        if self.end_fresh and refs == self._watched:
            return [vals.val[p] if vals is not None else self.get([refs[p]])[0]
                    for vals, p in self._end_rec]
        return self.get(refs)

    def loop_name(self, block) -> str:
        return "; ".join(str(self.connections[i]) for i in block)

    def solve_loop(self, block: list[int], t: float) -> None:
        """Solve the algebraic loop of connections ``block`` at time ``t``
        (see the module's doc); the inputs end at the solution.

        Convergence is measured against a scale fixed before iterating, s =
        the larger of |u| and |G(u)| at the start and |u| at this loop's
        earlier solutions: an iterate that runs away does not widen its own
        tolerance.  A Jacobian I - dG/du that is singular (condition number
        above LOOP_COND_MAX: the loop has no unique solution, e.g. a loop
        gain of exactly 1) and an iterate that runs away (|u| beyond
        LOOP_RUNAWAY times s) stop the run with FMUError naming the loop,
        the time and the residual."""
        def G(u):
            self.set_inputs(block, list(u), t)
            self.loop_iterations += 1
            return np.array([self.source_value(i) for i in block])

        key = tuple(block)
        u = np.array([self.held[i] for i in block], dtype=float)
        g = G(u)
        scale = np.maximum(np.abs(u), np.abs(g)) if np.all(np.isfinite(g)) else np.abs(u)
        if key in self._loop_size:
            scale = np.maximum(scale, self._loop_size[key])
        tol = self.loop_atol + self.loop_rtol * scale
        for it in range(self.loop_max_iter + 1):
            r = g - u
            if not np.all(np.isfinite(g)):
                break
            if np.all(np.abs(r) <= tol):
                self._loop_size[key] = np.maximum(self._loop_size.get(key, 0.0), np.abs(u))
                return      # the inputs hold u (the last G call)
            if it == self.loop_max_iter:
                break
            if np.any(np.abs(u) > LOOP_RUNAWAY * (1.0 + scale)):
                raise FMUError(f"algebraic loop ({self.loop_name(block)}) diverges at t = "
                               f"{t:.9g} s: after {it} {self.loop_method} iterations |u| = "
                               f"{float(np.max(np.abs(u))):.3g} (more than {LOOP_RUNAWAY:g} "
                               f"times its scale {float(np.max(scale)):.3g} at the start), "
                               f"largest |G(u) - u| = {float(np.max(np.abs(r))):.3g}; the "
                               "loop has no solution near its start")
            if self.loop_method == "fixed-point":
                u = u + self.relaxation * r
            else:
                J = np.zeros((len(block), len(block)))
                for j in range(len(block)):
                    du = 1e-7 * max(1.0, abs(u[j]))
                    e = u.copy()
                    e[j] += du
                    J[:, j] = (G(e) - g) / du
                A = np.eye(len(block)) - J
                cond = np.linalg.cond(A) if np.all(np.isfinite(A)) else math.inf
                if not cond <= LOOP_COND_MAX:
                    raise FMUError(f"algebraic loop ({self.loop_name(block)}): singular "
                                   f"Jacobian I - dG/du at t = {t:.9g} s (condition number "
                                   f"{cond:.3g}, above {LOOP_COND_MAX:g}; largest |G(u) - u| "
                                   f"= {float(np.max(np.abs(r))):.3g}): the loop equations "
                                   "have no unique solution (e.g. a loop gain of exactly 1)")
                u = u + np.linalg.solve(A, r)
            g = G(u)
        res = float(np.max(np.abs(g - u))) if np.all(np.isfinite(g)) else math.nan
        raise FMUError(f"algebraic loop ({self.loop_name(block)}) did not converge at t = "
                       f"{t:.9g} s after {self.loop_max_iter} {self.loop_method} iterations: "
                       f"largest |G(u) - u| = {res:.3g} (tolerance loop_atol = "
                       f"{self.loop_atol:g} + loop_rtol = {self.loop_rtol:g} * s, s = "
                       f"{float(np.max(scale)):.3g}: |u| and |G(u)| before iterating)")

    def set_inputs(self, indices, values, t: float) -> None:
        """Set the inputs of connections ``indices`` to ``values``."""
        for i, value in zip(indices, values):
            dst = self._dst1[i]
            dst.val[0] = value
            if not dst.set():
                fmu, vr = self._dst[i]
                self._call(self.connections[i].dst, "fmi2SetReal (input)", t,
                           lambda: fmu.setReal([vr], [value]))   # fails again: FMUError
            self.held[i] = value

    def set_inputs_together(self, indices: list[int], values: list[float], t: float) -> None:
        """set_inputs(indices, values, t) with one fmi2SetReal per receiving
        component (each input's value set before its derivatives, as one
        by one; a failed call is repeated one by one to name it)."""
        key = tuple(indices)
        calls = self._set_calls.get(key)
        if calls is None:
            calls = self._set_calls[key] = self._value_calls(list(indices))
        held = self.held
        for inst, rows, vrs, vals, n in calls:
            for p, r in enumerate(rows):
                vals[p] = values[r]
            if inst.f_set(inst.component, vrs, n, vals) > FMI2_WARNING:
                self.set_inputs([indices[r] for r in rows], [values[r] for r in rows], t)
                continue
            for r in rows:
                held[indices[r]] = values[r]

    def _value_calls(self, indices: list[int]) -> list:
        """[(Instance, rows of indices, vr array, value array, n)]: one
        fmi2SetReal per receiving component of connections ``indices``."""
        by: dict[str, list[int]] = {}
        for r, i in enumerate(indices):
            by.setdefault(self.connections[i].dst, []).append(r)
        return [(self.instances[name], rows,
                 (fmi2ValueReference * len(rows))(*[self._dst[indices[r]][1] for r in rows]),
                 (fmi2Real * len(rows))(), len(rows)) for name, rows in by.items()]

    def set_input_derivatives_together(self, indices: list[int], D: list[list[float]],
                                       t: float) -> None:
        """set_input_derivatives(i, D[r], t) for connection indices[r], with
        one fmi2SetRealInputDerivatives per receiving component."""
        k = len(D[0]) if D else 0
        if not k:
            return
        key = (tuple(indices), k)
        calls = self._der_calls.get(key)
        if calls is None:
            calls = self._der_calls[key] = self._derivative_calls(list(indices), k)
        for inst, rows, vrs, orders, values, n in calls:
            p = 0
            for r in rows:
                for x in D[r]:
                    values[p] = x
                    p += 1
            if inst.f_set_der(inst.component, vrs, n, orders, values) > FMI2_WARNING:
                for r in rows:
                    self.set_input_derivatives(indices[r], list(D[r]), t)

    def _derivative_calls(self, indices: list[int], k: int) -> list:
        by: dict[str, list[int]] = {}
        for r, i in enumerate(indices):
            by.setdefault(self.connections[i].dst, []).append(r)
        calls = []
        for name, rows in by.items():
            n = len(rows) * k
            vrs = [self._dst[indices[r]][1] for r in rows for _ in range(k)]
            calls.append((self.instances[name], rows, (fmi2ValueReference * n)(*vrs),
                          (fmi2Integer * n)(*(list(range(1, k + 1)) * len(rows))),
                          (fmi2Real * n)(), n))
        return calls

    def set_input_derivatives(self, i: int, derivatives: list[float], t: float) -> None:
        """Set the derivatives (orders 1, 2, ...) of connection ``i``'s input."""
        if not derivatives:
            return
        n = len(derivatives)
        arrays = self._der1.get((i, n))
        if arrays is None:
            vr = self._dst[i][1]
            arrays = self._der1[i, n] = ((fmi2ValueReference * n)(*([vr] * n)),
                                         (fmi2Integer * n)(*range(1, n + 1)),
                                         (fmi2Real * n)())
        vrs, orders, values = arrays
        for m, d in enumerate(derivatives):
            values[m] = d
        inst = self._dst1[i].inst
        if inst.f_set_der(inst.component, vrs, n, orders, values) > FMI2_WARNING:
            fmu, vr = self._dst[i]
            self._call(self.connections[i].dst, "fmi2SetRealInputDerivatives", t,
                       lambda: fmu.setRealInputDerivatives([vr] * n, list(range(1, n + 1)),
                                                           derivatives))   # fails again

    def get(self, refs: list[tuple[str, str]]) -> list[float]:
        """The values of variables ``refs`` (component, variable) now, as
        numbers (an Integer, enumeration or Boolean variable too: a Boolean
        is 0.0 or 1.0)."""
        out = []
        for c, v in refs:
            inst = self.instances[c]
            kind = inst.type[v]
            getter = {"Real": "getReal", "Integer": "getInteger",
                      "Enumeration": "getInteger", "Boolean": "getBoolean"}[kind]
            fn = getattr(inst.fmu, getter)
            call = "fmi2GetReal" if kind == "Real" else f"fmi2{getter[0].upper()}{getter[1:]}"
            out.append(float(self._call(c, f"{call} ({v})", self.time[c],
                                        lambda: fn([inst.vr[v]])[0])))
        return out

    # -- stepping and states --------------------------------------------------
    def do_step(self, name: str, t: float, h: float) -> None:
        inst = self.instances[name]
        self.end_fresh = False
        status = inst.f_do_step(inst.component, t, h, fmi2True)
        try:
            if status > FMI2_WARNING:
                self._call(name, f"fmi2DoStep (h = {h:.6g} s)", t, lambda: _raise(
                    FMICallException(function="fmi2DoStep", status=status)))
        except FMUError as exc:
            if self._terminated(name):
                raise ModelInvalid(f"{exc} [fmi2Terminated: the model is not valid beyond "
                                   f"this point; {self._moved(name, h)}]") from None
            raise
        self.time[name] = t + h
        self._stepped_inputs[name] = [self.held[i] for i in self.into[name]]

    def _moved(self, name: str, h: float) -> str:
        """How far component ``name``'s coupled inputs moved from its previous
        step to the step that failed (of length h), and what may help."""
        idx = self.into[name]
        if not idx:
            return ("the component has no coupled input: a shorter communication step "
                    "cannot help")
        before = self._stepped_inputs.get(name)
        parts = []
        for k, i in enumerate(idx):
            c, now = self.connections[i], self.held[i]
            unit = self.scene.components[name].interface.variables[c.dst_var].unit
            unit = f" {unit}" if unit else ""
            if before is None:
                parts.append(f"{c.dst_var} = {now:.4g}{unit} (its first step)")
                continue
            was = before[k]
            size = max(abs(now), abs(was))
            rel = f", {100 * abs(now - was) / size:.3g} % of its size" if size > 0 else ""
            parts.append(f"{c.dst_var} moved by {now - was:+.4g}{unit} from {was:.4g} to "
                         f"{now:.4g} since the previous communication point{rel}")
        return (f"its coupled inputs at the start of this step of {h:.4g} s: "
                + "; ".join(parts) + ". An input held or extrapolated over a long step can "
                "overshoot: a shorter communication step or input extrapolation may help")

    def get_states(self) -> dict:
        states = {n: self._call(n, "fmi2GetFMUstate", self.time[n], i.fmu.getFMUState)
                  for n, i in self.instances.items()}
        self._saved_time = dict(self.time)
        self._saved_inputs = dict(self._stepped_inputs)
        return states

    def set_states(self, states: dict, held: list[float]) -> None:
        for n, s in states.items():
            self._call(n, "fmi2SetFMUstate", self._saved_time[n],
                       lambda: self.instances[n].fmu.setFMUState(s))
        self.held = list(held)
        self.time = dict(self._saved_time)
        self._stepped_inputs = dict(self._saved_inputs)
        self.end_fresh = False

    def free_states(self, states: dict) -> None:
        for n, s in states.items():
            self._call(n, "fmi2FreeFMUstate", self.time[n],
                       lambda: self.instances[n].fmu.freeFMUState(s))

    def close(self) -> None:
        for inst in self.instances.values():
            inst.close()
        self.instances = {}
