"""Argument checks shared by every public function of loomfmu.

Each check raises ``ValueError`` whose message starts with the argument's
name and says what is allowed, e.g. ``rtol = inf; allowed: a finite number
in (0, 1)``; it returns the value converted (a float, an int, a dict), so a
function checks and normalizes in one line::

    t_end = check_number("t_end", t_end, lo=0, lo_open=True)

Booleans are not numbers here (``harmonics=True`` is a mistake, not 1),
strings are not numbers, NaN and +-inf are outside every range.
"""
from __future__ import annotations

import argparse
import difflib
import math
import numbers
import re
from collections.abc import Iterable, Mapping

import numpy as np

#: how many allowed names a message lists before it abbreviates
_LIST_NAMES = 12

#: most communication points one run records (a simulation, a scene, a
#: study's case): more would hold the memory of a run that cannot finish
MAX_POINTS = 1_000_000


def _interval(lo: float, hi: float, lo_open: bool, hi_open: bool) -> str:
    if lo == -math.inf and hi == math.inf:
        return "a finite number"
    if hi == math.inf:
        return f"a finite number {'>' if lo_open else '>='} {lo:g}"
    if lo == -math.inf:
        return f"a finite number {'<' if hi_open else '<='} {hi:g}"
    return (f"a finite number in {'(' if lo_open else '['}{lo:g}, {hi:g}"
            f"{')' if hi_open else ']'}")


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def is_real(value) -> bool:
    """A real scalar: int, float, numpy number; not bool, str, complex, None."""
    return (isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)))


def check_number(name: str, value, *, lo: float = -math.inf, hi: float = math.inf,
                 lo_open: bool = False, hi_open: bool = False, unit: str = "") -> float:
    """``value`` as a float, finite and in the interval [lo, hi] (ends open if
    lo_open / hi_open); otherwise ValueError naming ``name`` and the interval."""
    allowed = _interval(lo, hi, lo_open, hi_open) + (f" {unit}" if unit else "")
    if not is_real(value):
        raise ValueError(f"{name} = {_short(value)}; allowed: {allowed}")
    try:
        v = float(value)
    except OverflowError:
        v = math.inf
    if not math.isfinite(v) or v < lo or v > hi or (lo_open and v == lo) or (
            hi_open and v == hi):
        raise ValueError(f"{name} = {_short(value)}; allowed: {allowed}")
    return v


def check_optional_number(name: str, value, **kw) -> float | None:
    """None, or :func:`check_number`."""
    return None if value is None else check_number(name, value, **kw)


def check_int(name: str, value, *, lo: int | None = None, hi: int | None = None) -> int:
    """``value`` as an int in [lo, hi]: an int, a numpy integer or an integral
    float; not a bool."""
    lo_s = "-inf" if lo is None else str(lo)
    hi_s = "inf" if hi is None else str(hi)
    allowed = f"an integer in [{lo_s}, {hi_s}]"
    if not is_real(value):
        raise ValueError(f"{name} = {_short(value)}; allowed: {allowed}")
    if isinstance(value, (int, np.integer)):
        v = int(value)
    else:
        f = float(value)
        if not math.isfinite(f) or f != int(f):
            raise ValueError(f"{name} = {_short(value)}; allowed: {allowed}")
        v = int(f)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueError(f"{name} = {_short(value)}; allowed: {allowed}")
    return v


def check_bool(name: str, value) -> bool:
    """``value`` if it is True or False (numpy bools too)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} = {_short(value)}; allowed: True or False")
    return bool(value)


def check_choice(name: str, value, allowed: Iterable):
    """``value`` if it is one of ``allowed`` (compared by type and equality,
    so True is not 1 and 1.0 is not '1')."""
    allowed = tuple(allowed)
    for a in allowed:
        if type(a) is type(value) and a == value:
            return value
    raise ValueError(f"{name} = {_short(value)}; allowed: {', '.join(map(repr, allowed))}")


def _names_text(allowed: list[str]) -> str:
    if len(allowed) <= _LIST_NAMES:
        return ", ".join(allowed)
    return ", ".join(allowed[:_LIST_NAMES]) + f", ... ({len(allowed)} names)"


def check_names(name: str, given: Iterable, allowed: Iterable[str], *, what: str = "names"
                ) -> None:
    """Every element of ``given`` is a string in ``allowed``; the message lists
    the unknown ones with the closest allowed names."""
    allowed = list(allowed)
    given = list(given)
    wrong_type = [g for g in given if not isinstance(g, str)]
    if wrong_type:
        raise ValueError(f"{name}: {_short(wrong_type)} are not strings; allowed: {what} "
                         f"{_names_text(allowed)}")
    known = set(allowed)
    unknown = [g for g in given if g not in known]
    if unknown:
        hints = []
        for u in unknown:
            close = difflib.get_close_matches(u, allowed, n=2)
            hints.append(f"{u!r}" + (f" (did you mean {' or '.join(map(repr, close))}?)"
                                     if close else ""))
        raise ValueError(f"{name}: unknown {', '.join(hints)}: not {what}; allowed: "
                         f"{_names_text(allowed)}")


def check_mapping(name: str, value, allowed: Iterable[str] | None = None, *,
                  what: str = "names", numbers_only: bool = True) -> dict:
    """A dict copy of ``value`` (None: empty): keys in ``allowed`` (if given),
    values finite numbers (if ``numbers_only``)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ValueError(f"{name} = {_short(value)}; allowed: a dict {{name: value}}")
    out = dict(value)
    if allowed is not None:
        check_names(name, out, allowed, what=what)
    if numbers_only:
        for key, v in out.items():
            out[key] = check_number(f"{name}[{key!r}]", v)
    return out


def check_name_list(name: str, value, allowed: Iterable[str], *, what: str = "names"
                    ) -> list[str] | None:
    """None, or a list of distinct names from ``allowed`` (a lone string is
    refused: it would be read as its letters)."""
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        raise ValueError(f"{name} = {_short(value)}; allowed: a list of {what}")
    out = list(value)
    check_names(name, out, allowed, what=what)
    if len(set(out)) != len(out):
        raise ValueError(f"{name}: {_short(out)} names a variable twice; allowed: distinct "
                         f"{what}")
    return out


def check_array(name: str, value, *, lo: float = -math.inf, hi: float = math.inf,
                ndim: int | None = 1, min_size: int = 1, increasing: bool = False,
                unit: str = "") -> np.ndarray:
    """``value`` as a float array: finite, in [lo, hi], of ``ndim`` dimensions
    (None: any) with at least ``min_size`` elements, non-decreasing if
    ``increasing``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {_short(value)}; allowed: an array of finite numbers"
                         ) from None
    if np.asarray(value).dtype.kind in "bUSOc" and np.asarray(value).size:
        raise ValueError(f"{name} = {_short(value)}; allowed: an array of finite numbers")
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name}: shape {arr.shape}; allowed: a {ndim}-D array")
    if arr.size < min_size:
        raise ValueError(f"{name}: {arr.size} elements; allowed: at least {min_size}")
    bad = ~np.isfinite(arr) | (arr < lo) | (arr > hi)
    if bad.any():
        first = arr.ravel()[np.argmax(bad.ravel())]
        raise ValueError(f"{name}: element {first!r}; allowed: "
                         f"{_interval(lo, hi, False, False)}{' ' + unit if unit else ''}")
    if increasing and arr.ndim == 1 and np.any(np.diff(arr) < 0):
        raise ValueError(f"{name}: not in increasing order; allowed: non-decreasing values")
    return arr


def check_order(lo_name: str, lo: float, hi_name: str, hi: float, *, strict: bool = True
                ) -> None:
    """``lo`` < ``hi`` (or <= if not strict), naming both."""
    if lo > hi or (strict and lo == hi):
        raise ValueError(f"{lo_name} = {lo!r}, {hi_name} = {hi!r}; allowed: "
                         f"{lo_name} {'<' if strict else '<='} {hi_name}")


#: characters XML 1.0 cannot hold (control characters other than tab, newline
#: and carriage return; surrogates; U+FFFE, U+FFFF)
_NOT_XML = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def check_text(name: str, value, *, c_string: bool = False) -> str:
    """``value`` if it is a string that the model description (XML 1.0) can
    hold; with ``c_string`` (text written into a C string literal) also no
    control characters at all and no ``??`` (a C trigraph)."""
    if not isinstance(value, str):
        raise ValueError(f"{name} = {_short(value)}; allowed: a string")
    bad = (re.compile(r"[\x00-\x1f\x7f]|\?\?") if c_string else _NOT_XML).search(value)
    if bad is None and c_string:
        bad = _NOT_XML.search(value)
    if bad is not None:
        allowed = ("printable text on one line, without '??'" if c_string else
                   "text XML 1.0 can hold: no control characters other than tab, newline "
                   "and carriage return")
        raise ValueError(f"{name} = {_short(value)}: {bad.group()!r} at position "
                         f"{bad.start()}; allowed: {allowed}")
    return value



def _probe(folder) -> str | None:
    """None if a file can be created in the existing ``folder``, else why not."""
    import tempfile
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        return exc.strerror or str(exc)
    return None


def check_writable(name: str, path, *, folder: bool = False):
    """``path`` as a ``pathlib.Path`` if an output can be written there,
    checked before any work is done: a file (``folder`` False) whose path is
    not a directory, or a directory (``folder`` True) that is not a file; in
    both cases the directory it goes in exists or can be made, and this user
    can write there.  Nothing is created.  ``name`` is the argument (``out``)
    or the command-line option (``--csv``)."""
    import os
    from pathlib import Path
    allowed = ("allowed: a directory that exists or can be made" if folder else
               "allowed: a file path whose directory exists or can be made") + \
        ", writable by this user"
    if not isinstance(path, (str, os.PathLike)) or not os.fspath(path):
        raise ValueError(f"{name} = {_short(path)}; {allowed}")
    p = Path(path)
    said = f"{name} {str(p)!r}" if name.startswith("-") else f"{name} = {str(p)!r}"
    if folder and p.exists() and not p.is_dir():
        raise ValueError(f"{said}: an existing file, not a directory; {allowed}")
    if not folder and p.is_dir():
        raise ValueError(f"{said}: an existing directory, not a file; {allowed}")
    if not folder and p.exists() and not os.access(p, os.W_OK):
        raise ValueError(f"{said}: not writable; {allowed}")
    here = p if folder else p.parent
    existing = next((up for up in (here, *here.parents) if up.exists()), Path("."))
    if not existing.is_dir():
        raise ValueError(f"{said}: cannot be made ({str(existing)!r} is a file); {allowed}")
    why = _probe(existing)
    if why is not None:
        where = "" if existing == here else f" in {str(existing)!r}"
        raise ValueError(f"{said}: not writable{where} ({why}); {allowed}")
    return p


def check_output_options(args, *, files: Iterable[str] = (), folders: Iterable[str] = (),
                         make: bool = True) -> None:
    """:func:`check_writable` on each output option of a parsed command line
    that is set (``files``, ``folders``: the argparse ``dest`` names, e.g.
    ``"out_dir"`` for ``--out-dir``), before the command does any work; then
    the missing directories are made (unless ``make`` is false: a command
    with more checks to do makes them after those), so that the writes at
    the end find them."""
    checked = []
    for names, folder in ((files, False), (folders, True)):
        for dest in names:
            value = getattr(args, dest, None)
            if value is not None:
                p = check_writable("--" + dest.replace("_", "-"), value, folder=folder)
                checked.append(p if folder else p.parent)
    for p in checked if make else ():
        p.mkdir(parents=True, exist_ok=True)


def path_arg(text: str):
    """argparse ``type=`` of a path option: a ``pathlib.Path``; an empty
    string is refused (``Path("")`` would be the current directory)."""
    from pathlib import Path
    if not text:
        raise argparse.ArgumentTypeError("an empty path; allowed: a file or directory name")
    return Path(text)


class OneLineParser(argparse.ArgumentParser):
    """argparse's parser with a usage error in one line (its message and where
    the help is) and exit status 2, as every loomfmu command line answers bad
    input; ``--help`` prints the whole usage as before. Subparsers made by
    ``add_subparsers`` are of the same class."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")
