"""Run an exported SSP file with libcosim (the Open Simulation Platform's
engine, through ``libcosimpy``): an independent master to compare ours with.

libcosim's fixed-step algorithm steps every FMU over the base step (integer
nanoseconds) and then passes each output to the inputs it drives: the values
an FMU holds over a step are the outputs read right after the previous step,
before any input changed.  An output with direct feedthrough (the two-mass
coupling force depends on the position it receives) is therefore read with
the input of the previous step: libcosim's step is our Jacobi step with the
feedthrough resolved one step late (:func:`loomfmu.scene.two_mass.cosim_map`
gives both maps).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..checks import check_number

#: nanoseconds per second: libcosim's time unit
NS = 1_000_000_000


def step_ns(step: float) -> int:
    """The communication step in integer nanoseconds (ValueError unless the
    step is a whole number of nanoseconds)."""
    step = check_number("step", step, lo=1e-9, unit="s")
    ns = round(step * NS)
    if abs(ns - step * NS) > 1e-6 * max(1.0, step * NS):
        raise ValueError(f"step = {step!r} s is not a whole number of nanoseconds; allowed: "
                         "a multiple of 1e-9 s (libcosim counts time in integer nanoseconds)")
    return ns


def run_ssp(ssp, refs: list[tuple[str, str]], *, step: float, stop: float,
            quiet: bool = True) -> np.ndarray:
    """Run the SSP file ``ssp`` with libcosim's fixed-step algorithm; record
    ``refs`` (component, variable) at every step.  Returns a structured array
    like :class:`loomfmu.scene.Result`'s data (``time`` and
    ``component.variable`` fields)."""
    try:
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
        from libcosimpy.CosimObserver import CosimObserver
    except ImportError as exc:
        raise RuntimeError("libcosimpy is not installed (pip install libcosimpy)") from exc
    ssp = Path(ssp)
    if not ssp.is_file():
        raise ValueError(f"ssp = {str(ssp)!r}: no such file; allowed: an .ssp file")
    h_ns = step_ns(step)
    n = int(round(check_number("stop", stop, lo=step, unit="s") * NS / h_ns))
    if quiet:
        log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(str(ssp), step_size=h_ns)
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    index, vrs = {}, []
    for comp, var in refs:
        if comp not in index:
            index[comp] = ex.slave_index_from_instance_name(comp)
        found = {v.name.decode(): v.reference for v in ex.slave_variables(index[comp])}
        if var not in found:
            raise ValueError(f"{comp}.{var}: not a variable of the FMU libcosim loaded")
        vrs.append((index[comp], found[var]))

    def sample() -> list[float]:
        return [obs.last_real_values(i, [vr])[0] for i, vr in vrs]

    ex.step(1)     # libcosim initializes on its first step: t = h afterwards
    rows = [sample()]
    for _ in range(n - 1):
        if not ex.step(1):
            raise RuntimeError(f"libcosim failed to step at t = {len(rows) * step:.9g} s")
        rows.append(sample())
    names = ["time"] + [f"{c}.{v}" for c, v in refs]
    data = np.zeros(n, dtype=[(nm, "f8") for nm in names])
    data["time"] = (np.arange(n) + 1) * h_ns / NS
    values = np.array(rows)
    for j, nm in enumerate(names[1:]):
        data[nm] = values[:, j]
    return data
