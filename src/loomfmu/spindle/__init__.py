"""Analyses of the spindle rotor (seed 003): Campbell diagram, unbalance
response and compliance (:mod:`.analysis`), the calibration to the seed's
natural frequencies and critical speeds (:mod:`.study`), section V's
parameter trends and charts (:mod:`.trends`), the periodic start of a run-up
(:mod:`.start`); ``loomfmu rotor`` (:mod:`.__main__`).

May import: every layer below the mechanism packages (declare, mechanics,
models, registry, export, verification, inspection, fmu, scene, sweep); not
another mechanism's package.
"""
