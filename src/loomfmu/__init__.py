"""loomfmu: textile-machine mechanisms as CasADi DAEs, exported as
self-contained FMI co-simulation FMUs with embedded solvers.

The front door::

    from loomfmu import load_model, build_fmu, reference, verify
    model = load_model("heald_frame")
    result = build_fmu(model, out_dir="dist")
    info = loomfmu.inspect("heald_frame")    # the derivation: SymPy, numpy

``loomfmu.inspect`` (see :mod:`loomfmu.inspection`) is loaded on first use,
so that ``import loomfmu`` does not import SymPy.
"""
from .builder import BuildResult, build_fmu
from .declare import Model
from .registry import MODELS, load_model

__all__ = ["Model", "BuildResult", "build_fmu", "load_model", "MODELS", "inspect"]


def __getattr__(name: str):
    if name == "inspect":  # the function, from loomfmu.inspection (SymPy on demand)
        from .inspection import inspect
        return inspect
    raise AttributeError(f"module 'loomfmu' has no attribute {name!r}")
