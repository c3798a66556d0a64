"""Co-simulation scenes: FMUs declared and connected in Python, run on our
master (Jacobi or Gauss-Seidel, fixed or adaptive communication steps) or
exported as an SSP file for other engines; or composed at the equation level
into one model and one FMU (compose, run_monolithic).  See
docs/guides/scenes.md and docs/guides/composed.md.

May import: declare, progress, registry, export, verification, fmu.  A generic
layer: it never imports a mechanism's content; the seeds' scenes live in
:mod:`loomfmu.machines`.
"""
from loomfmu.scene.compose import compose
from loomfmu.scene.declare import Component, Connection, Scene, model_names
from loomfmu.scene.master import MASTERS, GaussSeidel, Jacobi, Master, StepResult
from loomfmu.scene.monolithic import COUPLINGS, composed_fmu, run_monolithic
from loomfmu.scene.run import Result, run

__all__ = ["Scene", "Component", "Connection", "model_names", "Master", "Jacobi",
           "GaussSeidel", "MASTERS", "StepResult", "Result", "run", "compose", "composed_fmu", "run_monolithic",
           "COUPLINGS"]
