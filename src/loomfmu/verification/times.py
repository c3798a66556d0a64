"""Output times: the communication points FMPy makes, and where one grid's
times sit in another's (light: numpy only, so that ``import loomfmu`` and
the FMI-LS-REF check do not load scipy)."""
from __future__ import annotations

import math

import numpy as np

#: output times up to this much (relative to max(1, t_end)) past t_end are taken as t_end
T_ROUND = 1e-12


def experiment_times(start: float, stop: float, step: float) -> np.ndarray:
    """The communication points of the experiment as FMPy makes them with
    ``output_interval=step``: start + k step while before the stop time (and
    not within rounding of it), then the stop time."""
    t = [start]
    k = 1
    while True:
        tk = start + k * step
        if tk > stop or math.isclose(tk, stop):
            break
        t.append(tk)
        k += 1
    if not math.isclose(t[-1], stop):
        t.append(stop)
    return np.array(t)


def grid_rows(grid: np.ndarray, t: np.ndarray) -> np.ndarray | None:
    """The row of ``grid`` nearest each time of ``t`` if each is one of the
    grid's (within 1e-12 of max(1, |t|)), else None."""
    t, grid = np.asarray(t, dtype=float), np.asarray(grid, dtype=float)
    if not len(t) or not len(grid):
        return None
    k = np.clip(np.searchsorted(grid, t), 0, len(grid) - 1)
    k_lo = np.clip(k - 1, 0, len(grid) - 1)
    k = np.where(np.abs(grid[k_lo] - t) < np.abs(grid[k] - t), k_lo, k)
    if np.any(np.abs(grid[k] - t) > T_ROUND * np.maximum(1.0, np.abs(t))):
        return None
    return k
