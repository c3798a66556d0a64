"""The shared C runtime's files and the facts Python needs about it."""
from __future__ import annotations

from pathlib import Path

RUNTIME_DIR = Path(__file__).parent / "runtime"

#: Sources of the shared runtime (compiled with -Wall -Wextra -Werror).
RUNTIME_SOURCES = ("lf_fmi2.c", "lf_runtime.c", "lf_solvers.c", "lf_linalg.c", "lf_state.c")
RUNTIME_HEADERS = ("lf_model.h", "lf_runtime.h", "lf_solver.h", "lf_linalg.h", "lf_state.h")

#: Log categories, in the order of LfLogCategory in lf_runtime.h; written into
#: the generated declaration (LF_LOG_CATEGORY_NAMES) and the model description.
LOG_CATEGORIES = (
    ("logEvents", "event located inside a step, solver restarted"),
    ("logStatusWarning", "warnings: values outside their range, adjusted settings "
     "(always logged)"),
    ("logStatusDiscard", "step not completed: solver failure or non-finite values "
     "(always logged)"),
    ("logStatusError", "invalid calls and values (always logged)"),
    ("logSolver", "solver statistics"),
)
