"""Co-simulation scenes: FMUs declared and connected in Python, run on our
master (Jacobi or Gauss-Seidel, fixed or adaptive communication steps) or
exported as an SSP file for other engines.  See docs/guides/scenes.md.

May import: declare, registry, export, verification, fmu.  A generic
layer: it never imports a mechanism's content; the seeds' scenes live in
:mod:`loomfmu.machines`.
"""
from loomfmu.scene.declare import Component, Connection, Scene, model_names
from loomfmu.scene.master import MASTERS, GaussSeidel, Jacobi, Master, StepResult
from loomfmu.scene.run import Result, run

__all__ = ["Scene", "Component", "Connection", "model_names", "Master", "Jacobi",
           "GaussSeidel", "MASTERS", "StepResult", "Result", "run"]
