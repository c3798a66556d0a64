"""loomfmu: textile-machine mechanisms as CasADi DAEs, exported as
self-contained FMI 2.0/3.0 FMUs with their solvers inside, checked through
FMPy against scipy references.

The front door: declare (or load) a model, build its FMU, run it, and check
it against the scipy solution of the same equations::

    >>> import tempfile
    >>> import loomfmu
    >>> model = loomfmu.load_model("two_mass_force")    # a model of loomfmu.MODELS
    >>> [v.name for v in model.of_kind("state")]
    ['x1', 'v1']
    >>> fmu = loomfmu.build_fmu(model, out_dir=tempfile.mkdtemp())
    >>> fmu.path.name, fmu.problems                     # validated by FMPy
    ('two_mass_force.fmu', [])
    >>> run = loomfmu.simulate(fmu.path, stop_time=1.0, output_interval=0.1, rtol=1e-9)
    >>> ref = loomfmu.reference(model, t_end=1.0, t_eval=run.t)
    >>> bool(abs(run.y["x1_out"] - ref.y["x1_out"]).max() < 1e-6)
    True

``loomfmu.inspect(model)`` shows the derivation (named quantities, printed
equations); ``loomfmu.verify(path, model)`` runs every embedded solver
against the reference.  ``inspect``, ``reference``, ``simulate`` and
``verify`` are loaded on first use, so that ``import loomfmu`` imports
neither SymPy nor scipy.

The packages by role, and who may import whom: CONTRIBUTING.md.
"""
from loomfmu.declare.model import Model
from loomfmu.fmu.builder import BuildResult, build_fmu
from loomfmu.registry import MODELS, load_model

__all__ = ["Model", "MODELS", "load_model", "build_fmu", "BuildResult", "simulate",
           "reference", "verify", "inspect"]

#: the names loaded on first use: name -> module that defines it
_LAZY = {"inspect": "loomfmu.inspection.core", "reference": "loomfmu.verification.reference",
         "simulate": "loomfmu.verification.verify", "verify": "loomfmu.verification.verify"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'loomfmu' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
