"""What a study records of each case: figures reduced from output trajectories.

A :class:`Figure` reduces one output over time (from ``after`` seconds on)
with one of REDUCTIONS; a :class:`Derived` figure calls a module-level
function ``function(t, y, case) -> float`` on the recorded outputs (``y``: a
dict name -> array), so it can be shipped to dask workers by reference.
``parse_figure("max_abs:x2_out@0.1")`` reads the command-line form.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

from loomfmu.declare.checks import check_choice, check_number

#: reductions of one output over time
REDUCTIONS = {
    "max_abs": lambda y: np.max(np.abs(y)),
    "max": np.max,
    "min": np.min,
    "mean": np.mean,
    "final": lambda y: y[-1],
    "ptp": np.ptp,
    "rms": lambda y: np.sqrt(np.mean(np.square(y))),
}


@dataclasses.dataclass(frozen=True)
class Figure:
    """``kind`` (one of REDUCTIONS) of output ``output`` from ``after`` s on;
    ``label``: its column's name (default KIND_OUTPUT; a Study names two
    figures that differ only in ``after`` KIND_OUTPUT_from_<after>s)."""
    kind: str
    output: str
    after: float = 0.0
    label: str = ""

    def __post_init__(self):
        check_choice("kind", self.kind, REDUCTIONS)
        if not isinstance(self.output, str) or not self.output:
            raise ValueError(f"output = {self.output!r:.40}; allowed: an output's name")
        check_number("after", self.after, lo=0.0, unit="s")
        if not isinstance(self.label, str) or (self.label and not self.label.isidentifier()):
            raise ValueError(f"label = {self.label!r:.40}; allowed: empty or an identifier")

    @property
    def name(self) -> str:
        return self.label or f"{self.kind}_{self.output}"

    def from_label(self) -> str:
        """KIND_OUTPUT_from_<after>s (0.05 -> 0p05s): a name that tells
        figures of one kind and output apart by ``after``."""
        return f"{self.kind}_{self.output}_from_{format(self.after, 'g').replace('.', 'p')}s"

    @property
    def outputs(self) -> tuple[str, ...]:
        return (self.output,)

    def __call__(self, t: np.ndarray, y: dict, case: dict) -> float:
        sel = t >= self.after - 1e-12 * max(1.0, self.after)
        if not np.any(sel):
            raise ValueError(f"figure {self.name}: after = {self.after} s is past the "
                             f"last sample t = {t[-1]:g} s")
        return float(REDUCTIONS[self.kind](np.asarray(y[self.output])[sel]))


@dataclasses.dataclass(frozen=True)
class Derived:
    """A named figure computed by ``function(t, y, case) -> float`` from
    ``outputs`` (a module-level function, so that workers import it)."""
    name: str
    function: Callable
    outputs: tuple[str, ...]

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ValueError(f"name = {self.name!r:.40}; allowed: an identifier")
        if not callable(self.function) or "<locals>" in getattr(
                self.function, "__qualname__", "<locals>"):
            raise ValueError(f"function = {self.function!r:.60}; allowed: a module-level "
                             "function (workers import it by name)")
        if not self.outputs or not all(isinstance(o, str) for o in self.outputs):
            raise ValueError(f"outputs = {self.outputs!r:.60}; allowed: output names")

    def __call__(self, t, y, case) -> float:
        return float(self.function(t, y, case))


def parse_figure(text: str) -> Figure:
    """``KIND:OUTPUT`` or ``KIND:OUTPUT@AFTER`` (AFTER in s)."""
    kinds = ", ".join(REDUCTIONS)
    if not isinstance(text, str) or ":" not in text:
        raise ValueError(f"figure = {text!r:.60}; allowed: KIND:OUTPUT[@AFTER] with KIND "
                         f"one of {kinds}")
    kind, rest = text.split(":", 1)
    after = 0.0
    if "@" in rest:
        rest, a = rest.split("@", 1)
        try:
            after = float(a)
        except ValueError:
            raise ValueError(f"figure = {text!r:.60}: AFTER = {a!r:.20}; allowed: a time "
                             "in s >= 0") from None
        if not math.isfinite(after):
            raise ValueError(f"figure = {text!r:.60}: AFTER; allowed: a finite time >= 0")
    return Figure(kind, rest, after)
