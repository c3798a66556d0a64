"""The shared C runtime's files and the facts Python needs about it."""
from __future__ import annotations

import re
from pathlib import Path

RUNTIME_DIR = Path(__file__).resolve().parent.parent / "runtime"

#: The FMI facades: files named lf_fmi2*.c belong to FMI 2.0, lf_fmi3*.c to
#: FMI 3.0; every other lf_*.c is the version-independent runtime.
FACADE_PREFIX = {2: "lf_fmi2", 3: "lf_fmi3"}


def _runtime_files(pattern: str, fmi_version) -> tuple[str, ...]:
    if type(fmi_version) is not int or fmi_version not in FACADE_PREFIX:
        raise ValueError(f"fmi_version = {fmi_version!r}; allowed: 2 or 3")
    others = tuple(v for k, v in FACADE_PREFIX.items() if k != fmi_version)
    return tuple(sorted(p.name for p in RUNTIME_DIR.glob(pattern)
                        if not p.name.startswith(others)))


def runtime_sources(fmi_version: int = 2) -> tuple[str, ...]:
    """The runtime's C sources an FMU of ``fmi_version`` compiles: the common
    ones and that version's facade (found in the folder, so that a new file
    needs no list kept by hand)."""
    return _runtime_files("lf_*.c", fmi_version)


def runtime_headers(fmi_version: int = 2) -> tuple[str, ...]:
    """The runtime's headers an FMU of ``fmi_version`` ships: the common ones
    and that version's facade headers (lf_fmi2*.h, lf_fmi3*.h)."""
    return _runtime_files("lf_*.h", fmi_version)


#: Sources of the shared runtime for FMI 2.0 (compiled with -Wall -Wextra -Werror).
RUNTIME_SOURCES = runtime_sources(2)
RUNTIME_HEADERS = runtime_headers(2)

# a definition at file scope of a global lf_ name: not static, not a type,
# starting in column 0 (the runtime's style), followed by ( [ or =
_GLOBAL_DEF = re.compile(r"^(?!static\b|typedef\b|extern\b|return\b)[A-Za-z_][^;(=]*?"
                         r"\b(lf_\w+)\s*[\(\[=]", re.M)


def _runtime_symbols() -> tuple[str, ...]:
    names = {"lf_model"}  # defined by the generated declaration (model_decl.c)
    for p in RUNTIME_DIR.glob("lf_*.c"):
        names.update(_GLOBAL_DEF.findall(p.read_text()))
    return tuple(sorted(names))


#: Global symbols of the runtime and the generated declaration; an FMU's
#: lf_prefix.h renames each to <modelIdentifier>_<symbol> (the builder checks
#: with nm that no other global symbol is left). Read from the sources.
RUNTIME_SYMBOLS = _runtime_symbols()

#: Log categories, in the order of LfLogCategory in lf_instance.h; written into
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
