"""Verification: the scipy reference solution of a declared model and the
check of an FMU against it through FMPy.

Owns :func:`~.reference.reference` (the same equations, events, modes and
delays, solved by scipy), :func:`~.verify.verify` and
:func:`~.verify.simulate`, and FMPy helpers (:mod:`.fmpy_logger`).

May import: :mod:`loomfmu.declare`, :mod:`loomfmu.export`.
"""
