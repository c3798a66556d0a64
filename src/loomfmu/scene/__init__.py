"""Co-simulation scenes: FMUs declared and connected in Python, run on our
master (Jacobi or Gauss-Seidel, fixed or adaptive communication steps) or
exported as an SSP file for other engines.  See docs/guides/scenes.md."""
from .declare import Component, Connection, Scene, model_names
from .master import MASTERS, GaussSeidel, Jacobi, Master, StepResult
from .run import Result, run

__all__ = ["Scene", "Component", "Connection", "model_names", "Master", "Jacobi",
           "GaussSeidel", "MASTERS", "StepResult", "Result", "run"]
