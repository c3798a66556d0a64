"""Run an exported SSP file with libcosim (the Open Simulation Platform's
engine, through ``libcosimpy``): an independent master to compare ours with.

libcosim's fixed-step algorithm steps every FMU over the base step (integer
nanoseconds) and then passes each output to the inputs it drives: the values
an FMU holds over a step are the outputs read right after the previous step,
before any input changed.  An output with direct feedthrough (the two-mass
coupling force depends on the position it receives) is therefore read with
the input of the previous step: libcosim's step is our Jacobi step with the
feedthrough resolved one step late (:func:`loomfmu.machines.two_mass.cosim_map`
gives both maps).

libcosim 0.0.6 reads the SSP's parameter sets but skips a value for a
variable that is not an input or parameter (it logs "Non-input causality for
variable frame_a:phi" and the FMU keeps its default start): a state's start
value would be lost.  :func:`run_ssp` therefore also gives every value of the
SSP's parameter sets to libcosim as an initial value (``real_initial_value``,
``integer_initial_value``), which libcosim sets before initialization
whatever the causality.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np

from loomfmu.declare.checks import check_number

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


_SSD = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
_SSV = "{http://ssp-standard.org/SSP1/SystemStructureParameterValues}"


def ssp_values(ssp) -> dict[str, dict[str, tuple[str, float]]]:
    """Each component's values in the SSP's inline parameter sets:
    component -> variable -> (``"Real"`` or ``"Integer"``, value)."""
    with zipfile.ZipFile(ssp) as z:
        root = ET.fromstring(z.read("SystemStructure.ssd"))
    values: dict[str, dict[str, tuple[str, float]]] = {}
    for comp in root.iter(f"{_SSD}Component"):
        mine = values.setdefault(comp.get("name"), {})
        for par in comp.iter(f"{_SSV}Parameter"):
            for typ in ("Real", "Integer"):
                el = par.find(f"{_SSV}{typ}")
                if el is not None:
                    mine[par.get("name")] = (typ, float(el.get("value")))
    return values


def run_ssp(ssp, refs: list[tuple[str, str]], *, step: float, stop: float,
            quiet: bool = True) -> np.ndarray:
    """Run the SSP file ``ssp`` with libcosim's fixed-step algorithm; record
    ``refs`` (component, variable) at every step.  Returns a structured array
    like :class:`loomfmu.scene.Result`'s data (``time`` and
    ``component.variable`` fields).  A damaged ``ssp`` (see
    :func:`loomfmu.scene.ssp.validate_ssd`) is a ValueError naming each
    problem, before libcosim sees it."""
    try:
        from libcosimpy.CosimExecution import CosimExecution
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
        from libcosimpy.CosimObserver import CosimObserver
    except ImportError as exc:
        raise RuntimeError("libcosimpy is not installed (pip install libcosimpy)") from exc
    from loomfmu.scene.ssp import validate_ssd
    ssp = Path(ssp)
    if not ssp.is_file():
        raise ValueError(f"ssp = {str(ssp)!r}: no such file; allowed: an .ssp file")
    problems = validate_ssd(ssp)   # libcosim would only say "check if path is correct"
    if problems:
        raise ValueError(f"ssp = {str(ssp)!r}: " + "; ".join(problems) +
                         "; allowed: an .ssp file that loomfmu.scene.ssp.validate_ssd passes")
    h_ns = step_ns(step)
    n = int(round(check_number("stop", stop, lo=step, unit="s") * NS / h_ns))
    if quiet:
        log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(str(ssp), step_size=h_ns)
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    # the parameter sets' values again as initial values: libcosim drops the
    # values of states (see the module's doc)
    for comp, values in ssp_values(ssp).items():
        i = ex.slave_index_from_instance_name(comp)
        found = {v.name.decode(): v.reference for v in ex.slave_variables(i)}
        for var, (typ, value) in values.items():
            if var not in found:
                raise ValueError(f"ssp = {str(ssp)!r}: {comp}.{var} is set in the SSP but is "
                                 "not a variable of the FMU libcosim loaded")
            if typ == "Integer":
                ok = ex.integer_initial_value(i, found[var], int(value))
            else:
                ok = ex.real_initial_value(i, found[var], value)
            if not ok:
                raise RuntimeError(f"libcosim refused the initial value {comp}.{var} = "
                                   f"{value!r}")
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
