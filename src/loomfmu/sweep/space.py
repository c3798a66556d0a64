"""Parameter spaces of a study: a list of cases, each a {name: value} dict.

    grid(b1=[0.006, 0.01], k_z=[3, 5])      full factorial, last name fastest
    lists(tau=[0.25, 0.5], T=[1, 2])        the i-th value of every name together
    latin_hypercube({"b1": (0.005, 0.04)}, n=20, seed=1)

Values are real numbers (bool and int are kept as they are, for build-free
switches such as ``compensate``); names are checked against the study's
model when the study is made.
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from loomfmu.declare.checks import check_int

#: most cases one space may hold
MAX_CASES = 1_000_000


def _axis(name: str, values) -> list:
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__"):
        raise ValueError(f"{name} = {values!r:.60}; allowed: a non-empty list of numbers")
    out = []
    for v in values:
        if isinstance(v, (bool, np.bool_)):
            out.append(bool(v))
        elif isinstance(v, (int, np.integer)):
            out.append(int(v))
        elif isinstance(v, (float, np.floating)):
            out.append(float(v))  # NaN and inf are kept: the FMU refuses them, per case
        else:
            raise ValueError(f"{name}: value {v!r:.40}; allowed: numbers or booleans")
    if not out:
        raise ValueError(f"{name} = []; allowed: a non-empty list of numbers")
    return out


def _names(axes: dict) -> None:
    if not axes:
        raise ValueError("axes: none given; allowed: one or more name=[values]")
    for name in axes:
        if not isinstance(name, str) or not name.isidentifier():
            raise ValueError(f"axis name {name!r:.40}; allowed: a variable name")


def grid(**axes) -> list[dict]:
    """Every combination of the axes' values (the last axis varies fastest)."""
    _names(axes)
    cols = {n: _axis(n, v) for n, v in axes.items()}
    size = math.prod(len(v) for v in cols.values())
    if size > MAX_CASES:
        raise ValueError(f"axes: {size} combinations; allowed: at most {MAX_CASES}")
    return [dict(zip(cols, combo)) for combo in itertools.product(*cols.values())]


def lists(**axes) -> list[dict]:
    """Case i takes the i-th value of every axis (all axes of equal length)."""
    _names(axes)
    cols = {n: _axis(n, v) for n, v in axes.items()}
    lengths = {len(v) for v in cols.values()}
    if len(lengths) != 1:
        raise ValueError(f"axes: lengths {sorted(lengths)}; allowed: all of equal length")
    return [dict(zip(cols, combo)) for combo in zip(*cols.values())]


def latin_hypercube(bounds: dict, *, n: int, seed: int) -> list[dict]:
    """n cases in the box ``bounds`` ({name: (lo, hi)}, lo < hi, finite), one
    per row and column of each axis' n strata (scipy.stats.qmc.LatinHypercube
    with ``seed``, an integer >= 0: the same seed gives the same cases)."""
    from scipy.stats import qmc
    if not isinstance(bounds, dict):
        raise ValueError(f"bounds = {bounds!r:.60}; allowed: a dict name -> (lo, hi)")
    _names(bounds)
    n = check_int("n", n, lo=1, hi=MAX_CASES)
    seed = check_int("seed", seed, lo=0)
    lo, hi = [], []
    for name, b in bounds.items():
        try:
            a, c = (float(x) for x in b)
        except (TypeError, ValueError):
            raise ValueError(f"bounds[{name!r}] = {b!r:.60}; allowed: (lo, hi), "
                             "finite numbers with lo < hi") from None
        if not (math.isfinite(a) and math.isfinite(c) and a < c):
            raise ValueError(f"bounds[{name!r}] = {b!r:.60}; allowed: (lo, hi), "
                             "finite numbers with lo < hi")
        lo.append(a)
        hi.append(c)
    unit = qmc.LatinHypercube(d=len(bounds), seed=np.random.default_rng(seed)).random(n)
    points = qmc.scale(unit, lo, hi)
    return [{name: float(p[j]) for j, name in enumerate(bounds)} for p in points]
