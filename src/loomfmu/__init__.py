"""loomfmu: textile-machine mechanisms as CasADi DAEs, exported as
self-contained FMI co-simulation FMUs with embedded solvers.

The front door::

    from loomfmu import load_model, build_fmu, reference, verify
    model = load_model("heald_frame")
    result = build_fmu(model, out_dir="dist")
    info = loomfmu.inspect("heald_frame")    # the derivation: SymPy, numpy

``loomfmu.inspect`` (see :mod:`loomfmu.inspection.core`) is loaded on first use,
so that ``import loomfmu`` does not import SymPy.
"""
from loomfmu.declare.model import Model
from loomfmu.fmu.builder import BuildResult, build_fmu
from loomfmu.registry import MODELS, load_model

__all__ = ["Model", "BuildResult", "build_fmu", "load_model", "MODELS", "inspect"]


def __getattr__(name: str):
    if name == "inspect":  # the function, from loomfmu.inspection.core (SymPy on demand)
        from loomfmu.inspection.core import inspect
        return inspect
    raise AttributeError(f"module 'loomfmu' has no attribute {name!r}")
