"""A study: a model, a parameter space, what to record of each case.

    study = Study("heald_frame_rigid", cases=grid(omega=[40, 60]),
                  figures=[Figure("max_abs", "N_rem")], stop_time=0.3)

The model is one of loomfmu.registry's (built once into an FMU with
``options``), its variables' names are checked here; the values themselves
are checked by the FMU, per case (an out-of-range value is that case's
Error, with the FMU's log line).
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from typing import Callable

from loomfmu.declare.checks import MAX_POINTS, check_choice, check_names, check_number
from loomfmu.declare.solvers import SOLVERS
from loomfmu.registry import MODELS
from loomfmu.sweep.figures import Derived, Figure
from loomfmu.sweep.worker import Setup


@dataclasses.dataclass
class Study:
    """model: a name in loomfmu.registry.MODELS; options: its build options.
    cases: list of {name: value} (see loomfmu.sweep.space), at least one.
    figures: Figure / Derived (at least one). stop_time: s (> 0);
    output_interval: communication step, s (0 < . <= stop_time).
    solver: one of loomfmu.declare.solvers.SOLVERS (the FMU's ``solver`` enumeration);
    rtol in (0, 0.1]; atol > 0.
    fixed: start values set in every case. prepare: a module-level function
    ``prepare(case, fixed) -> (values, stop_time or None)`` that turns a case
    into the FMU's start values (a ValueError there marks the case invalid).
    name: the study's name (file names, progress).
    declaration: a declared loomfmu Model (e.g. a scene composed into one,
    loomfmu.scene.compose) to build instead of a registry model; ``model``
    is then its name and ``options`` stay empty."""
    model: str
    cases: list
    figures: list
    stop_time: float
    output_interval: float
    solver: str = "dopri5"
    rtol: float = 1e-6
    atol: float = 1e-9
    fixed: dict = dataclasses.field(default_factory=dict)
    prepare: Callable | None = None
    options: dict = dataclasses.field(default_factory=dict)
    name: str = ""
    declaration: object = None

    def __post_init__(self):
        if self.declaration is not None:
            from loomfmu.declare.model import Model
            if not isinstance(self.declaration, Model):
                raise ValueError(f"declaration = {self.declaration!r:.60}; allowed: None or a "
                                 "declared loomfmu Model")
            if self.model != self.declaration.name or self.options:
                raise ValueError(f"model = {self.model!r:.60}, options = {self.options!r:.60}:"
                                 f" allowed with a declaration: model = its name "
                                 f"{self.declaration.name!r} and no options")
        elif not isinstance(self.model, str) or self.model not in MODELS:
            raise ValueError(f"model = {self.model!r:.60}; allowed: one of "
                             f"{', '.join(sorted(MODELS))}")
        if not isinstance(self.cases, list) or not self.cases or not all(
                isinstance(c, dict) for c in self.cases):
            raise ValueError("cases: allowed: a non-empty list of {name: value} dicts "
                             "(loomfmu.sweep.grid, lists, latin_hypercube)")
        if not isinstance(self.figures, (list, tuple)) or not self.figures or not all(
                isinstance(f, (Figure, Derived)) for f in self.figures):
            raise ValueError("figures: allowed: a non-empty list of Figure or Derived")
        self.stop_time = check_number("stop_time", self.stop_time, lo=0.0, lo_open=True,
                                      unit="s")
        self.figures = _named(list(self.figures), self.stop_time)
        self.output_interval = check_number("output_interval", self.output_interval,
                                            lo=0.0, hi=self.stop_time, lo_open=True,
                                            unit="s")
        check_choice("solver", self.solver, SOLVERS)
        self.rtol = check_number("rtol", self.rtol, lo=0.0, hi=0.1, lo_open=True)
        self.atol = check_number("atol", self.atol, lo=0.0, lo_open=True)
        if not isinstance(self.fixed, dict):
            raise ValueError(f"fixed = {self.fixed!r:.60}; allowed: a dict name -> value")
        if self.prepare is not None and (not callable(self.prepare) or "<locals>" in getattr(
                self.prepare, "__qualname__", "<locals>")):
            raise ValueError(f"prepare = {self.prepare!r:.60}; allowed: None or a "
                             "module-level function (workers import it by name)")
        if not isinstance(self.options, dict):
            raise ValueError(f"options = {self.options!r:.60}; allowed: a dict of build "
                             "options")
        self.name = self.name or self.model
        if not isinstance(self.name, str) or not self.name.replace("-", "_").isidentifier():
            raise ValueError(f"name = {self.name!r:.60}; allowed: letters, digits, _ and -")

    def check_names(self, variables: list[str], outputs: list[str]) -> None:
        """Case and fixed names are FMU variables with a start value (unless a
        ``prepare`` translates them); figure outputs are FMU variables."""
        if self.prepare is None:
            given = set(self.fixed) | {n for c in self.cases for n in c}
            check_names("cases", sorted(given), variables,
                        what=f"variables of {self.model} with a start value")
        check_names("figures", sorted(self.outputs), outputs,
                    what=f"variables of {self.model}")
        points = self.stop_time / self.output_interval
        if points > MAX_POINTS:
            raise ValueError(f"stop_time / output_interval = {points:.3g}; allowed: at most "
                             f"{MAX_POINTS} communication points")

    @property
    def outputs(self) -> tuple[str, ...]:
        seen: dict[str, None] = {}
        for f in self.figures:
            for o in f.outputs:
                seen[o] = None
        return tuple(seen)

    @property
    def case_names(self) -> list[str]:
        seen: dict[str, None] = {}
        for c in self.cases:
            for n in c:
                seen[n] = None
        return list(seen)

    def setup(self) -> Setup:
        return Setup(self.solver, self.rtol, self.atol, self.stop_time, self.output_interval,
                     self.outputs, tuple(self.figures), dict(self.fixed), self.prepare)

    def fingerprint(self, fmu_sha256: str) -> str:
        """What every case of this study shares (the FMU's bytes included):
        a changed setting gives new case keys, so nothing stale is resumed."""
        def fig(f):
            if isinstance(f, Figure):
                return [f.kind, f.output, f.after] + ([f.label] if f.label else [])
            return [f.name, f"{f.function.__module__}.{f.function.__qualname__}",
                    list(f.outputs)]
        prep = (None if self.prepare is None
                else f"{self.prepare.__module__}.{self.prepare.__qualname__}")
        doc = dict(fmu=fmu_sha256, model=self.model, options=self.options,
                   solver=self.solver, rtol=self.rtol, atol=self.atol,
                   stop_time=self.stop_time, output_interval=self.output_interval,
                   figures=[fig(f) for f in self.figures], fixed=self.fixed, prepare=prep)
        return hashlib.sha256(_json(doc).encode()).hexdigest()


def _named(figures: list, stop_time: float) -> list:
    """``figures`` with ``after`` in [0, stop_time], and distinct names: figures
    that share KIND_OUTPUT but differ in ``after`` (and have no label) are
    named KIND_OUTPUT_from_<after>s; truly repeated figures are refused."""
    for f in figures:
        if isinstance(f, Figure) and f.after > stop_time:
            raise ValueError(f"after = {f.after:g} s (figure {f.name}); allowed: 0 ... "
                             f"stop_time = {stop_time:g} s")
    clash = {n for n in (f.name for f in figures) if [g.name for g in figures].count(n) > 1}
    figures = [dataclasses.replace(f, label=f.from_label())
               if isinstance(f, Figure) and not f.label and f.name in clash else f
               for f in figures]
    names = [f.name for f in figures]
    if len(set(names)) != len(names):
        raise ValueError(f"figures: names {names} repeat; allowed: distinct figures (a "
                         "Figure's label names its column)")
    return figures


def case_key(fingerprint: str, case: dict) -> str:
    """16 hex digits naming ``case`` under a study fingerprint."""
    return hashlib.sha256((fingerprint + _json(case)).encode()).hexdigest()[:16]


def _json(doc) -> str:
    def default(o):
        if isinstance(o, float) and not math.isfinite(o):
            return repr(o)
        return repr(o)
    return json.dumps(doc, sort_keys=True, default=default, allow_nan=True)
