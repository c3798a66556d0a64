"""The embedded solvers and the runtime settings every FMU exposes: names,
order, descriptions and ranges.  The declaration layer reserves these names
(``reserved_names``); code generation, the model descriptions and the
command line read them from here."""
from __future__ import annotations

from dataclasses import dataclass

#: Solvers in the order of the runtime registry (lf_methods[] in lf_solvers.c);
#: the FMU's ``solver`` enumeration value is the 1-based position.
SOLVERS = ("dopri5", "rodas4", "rk4", "ros34pw2")
SOLVER_DESCRIPTIONS = {
    "dopri5": "explicit adaptive Dormand-Prince 5(4) with 4th-order dense output",
    "rodas4": "implicit adaptive Rosenbrock RODAS4 with the exact CasADi Jacobian",
    "rk4": "classical fixed-step Runge-Kutta 4 (step solver_h_fixed), for real time",
    "ros34pw2": "implicit adaptive Rosenbrock-W ROS34PW2 (order 3) reusing the Jacobian and "
                "its factorization across steps, for stiff models",
}
#: the solvers that control their step by the tolerance (the others: a fixed
#: step, solver_h_fixed)
ADAPTIVE_SOLVERS = tuple(s for s in SOLVERS if s != "rk4")


@dataclass(frozen=True)
class Setting:
    """A runtime setting exposed as a fixed FMU parameter."""

    name: str
    macro: str
    unit: str
    description: str
    min: float
    max: float


#: Descriptions use FMI 2.0 names; FMI 3.0 model descriptions and pages
#: translate them (loomfmu.export.fmi_xml.fmi3_text: fmi3DoStep, lastSuccessfulTime).
SETTINGS = (
    Setting("solver_rtol", "LF_SET_RTOL", "", "relative tolerance of the adaptive solvers",
            1e-14, 0.1),
    Setting("solver_atol", "LF_SET_ATOL", "", "absolute tolerance of the adaptive solvers "
            "(in the states' units)", 1e-16, 1.0),
    Setting("solver_h_max", "LF_SET_H_MAX", "s", "largest internal step of the adaptive "
            "solvers", 1e-9, 1e6),
    Setting("solver_h_fixed", "LF_SET_H_FIXED", "s", "step of the fixed-step solver rk4",
            1e-9, 1e3),
    Setting("solver_max_steps", "LF_SET_MAX_STEPS", "", "most solver steps (accepted and "
            "rejected, event location included) in one fmi2DoStep: past it the call returns "
            "fmi2Discard with a log line, the outputs readable at the last accepted time "
            "(fmi2GetRealStatus(fmi2LastSuccessfulTime)); bounds the wall time of one call",
            1.0, 1e9),
)

#: Default of solver_max_steps: about a second of work per fmi2DoStep for the
#: models here (measured: benchmarks/runtime_checks.py, "runaway").
MAX_STEPS_DEFAULT = 100000



#: The solver as a plain Integer parameter (beside the ``solver`` enumeration),
#: for importers that do not show enumerations.
SOLVER_INDEX = "solver_index"
