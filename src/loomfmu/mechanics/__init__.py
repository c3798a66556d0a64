"""Mechanics building blocks that model declarations are written with.

Owns the generic pieces (Lagrange's equations and generalized forces,
:mod:`.lagrange`; the Coulomb joint with its stick/slip modes,
:mod:`.friction`; the finite-element rotor library and the oil-film
integrals, :mod:`.rotor`) and the mechanism laws a declaration evaluates
(the spindle drive's machine values, optimal speed law and layer cam,
:mod:`.drive_params`, :mod:`.drive_law`, :mod:`.layer_cam`; the heald
frames' maker presets, :mod:`.heald_presets`).

May import: :mod:`loomfmu.declare`.  Imported by ``models/`` and by the
mechanism packages' analyses.
"""
