"""The seeds' machines: scenes and studies made of several mechanisms.

Owns the seed scenes (the loom, :mod:`.loom`; the spinning position,
:mod:`.spinning`; the two-mass benchmark with its exact answer,
:mod:`.two_mass`), their library by name (:mod:`.library`), the choice of
fidelity per scene (:mod:`.fidelity`) and the parameter studies of the seeds
(:mod:`.studies`, :mod:`.charts`).

May import: the generic layers (scene, sweep and all below them) and the
mechanism packages.  The generic scene and sweep layers never import it.
"""
