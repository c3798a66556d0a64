"""loomfmu: textile-machine mechanisms as CasADi DAEs, exported as
self-contained FMI co-simulation FMUs with embedded solvers.

The front door::

    from loomfmu import load_model, build_fmu, reference, verify
    model = load_model("heald_frame")
    result = build_fmu(model, out_dir="dist")
"""
from .builder import BuildResult, build_fmu
from .declare import Model
from .registry import MODELS, load_model

__all__ = ["Model", "BuildResult", "build_fmu", "load_model", "MODELS"]
