"""The declarations (installed as ``loomfmu.models``): one module per
mechanism and fidelity level, each a ``model(**options)`` that returns a
:class:`loomfmu.declare.Model` with its variables (units, ranges, the seed
and equation or the assumption behind each parameter), its equations and
the derivation's named quantities; beside a mechanism's declarations, its
derivation (``*_derivation.py``) and what its levels share (``*_common.py``).
:mod:`loomfmu.registry` names them.

May import: declare, mechanics.
"""
