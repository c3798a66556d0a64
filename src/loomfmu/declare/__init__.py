"""The declaration layer: what a model is, before any code is generated.

Owns :class:`Model` and its variables, ports, delays, events, validity
conditions and named quantities (:mod:`.model`); the argument checks every
public function uses (:mod:`.checks`); units (:mod:`.units`); port kinds
(:mod:`.ports`); the embedded solvers' names and the runtime settings every
FMU exposes (:mod:`.solvers`).

May import: numpy, CasADi and the standard library only; nothing else of
loomfmu.  Every other layer may import it.
"""
from loomfmu.declare.model import Model, Quantity, Variable

__all__ = ["Model", "Quantity", "Variable"]
