"""The platforms an FMU carries binaries for, and which of them a build makes.

Every FMU holds one shared library per platform, each compiled from the
same sources/ by gcc (natively or as a cross compiler) with the same flags:

=========  ===================  ==================  =======================  ==============
name       FMI 2.0 folder       FMI 3.0 folder      compiler (Debian pkg)    run here under
=========  ===================  ==================  =======================  ==============
linux64    ``linux64``          ``x86_64-linux``    gcc                      (native)
win64      ``win64``            ``x86_64-windows``  x86_64-w64-mingw32-gcc   wine
                                                    (gcc-mingw-w64-x86-64)   (wine64)
aarch64    (none in FMI 2.0)    ``aarch64-linux``   aarch64-linux-gnu-gcc    qemu-aarch64
                                                    (gcc-aarch64-linux-gnu)  (qemu-user)
=========  ===================  ==================  =======================  ==============

Which platforms a build makes (:func:`select`): the ``platforms`` argument
(``build_fmu(..., platforms=...)``, ``loomfmu build --platforms``) if given;
else the environment variable ``LOOMFMU_PLATFORMS`` (same syntax; the test
suite sets it to ``linux64`` so that only the tests about platforms
cross-compile); else every platform whose compiler is on PATH, and one line
on stderr names those skipped and the Debian package that adds each. Names:
``linux64``, ``win64``, ``aarch64``, or FMI 3.0's ``x86_64-linux``,
``x86_64-windows``, ``aarch64-linux``; a comma-separated string or a list.
FMI 2.0 names no folder for 64-bit ARM: an FMI 2.0 build leaves aarch64 out
by default and refuses it when asked (rebuild from sources/ instead, see the
FMU's documentation page).
"""
from __future__ import annotations

import functools
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass

#: The environment variable that sets the default platforms
ENV = "LOOMFMU_PLATFORMS"


@dataclass(frozen=True)
class Platform:
    """One target: its folders, its compiler and how a program built for it
    runs on this (x86-64 Linux) machine."""

    name: str
    fmi2_folder: str | None
    fmi3_folder: str
    #: binutils prefix: the compiler is ``<prefix>gcc``, nm ``<prefix>nm``
    prefix: str
    suffix: str
    #: the Debian package that installs the compiler
    package: str
    #: the command that runs a program built for it here (empty: natively)
    emulator: tuple[str, ...] = ()
    #: the Debian package that installs the emulator
    emulator_package: str = ""
    #: what ``cc -dumpmachine`` starts with
    machine: str = ""

    @property
    def cc(self) -> str:
        return self.prefix + "gcc"

    def tool(self, name: str) -> str:
        """``nm``, ``objdump``, ... of this platform's binutils."""
        return self.prefix + name

    def folder(self, fmi_version: int) -> str | None:
        return self.fmi2_folder if fmi_version == 2 else self.fmi3_folder

    @property
    def windows(self) -> bool:
        return self.suffix == ".dll"


PLATFORMS: dict[str, Platform] = {
    "linux64": Platform("linux64", "linux64", "x86_64-linux", "", ".so", "gcc",
                        machine="x86_64"),
    "win64": Platform("win64", "win64", "x86_64-windows", "x86_64-w64-mingw32-", ".dll",
                      "gcc-mingw-w64-x86-64", ("wine",), "wine64", machine="x86_64-w64-mingw32"),
    "aarch64": Platform("aarch64", None, "aarch64-linux", "aarch64-linux-gnu-", ".so",
                        "gcc-aarch64-linux-gnu",
                        ("qemu-aarch64", "-L", "/usr/aarch64-linux-gnu"), "qemu-user",
                        machine="aarch64"),
}
#: FMI 3.0's folder names, accepted as well
ALIASES = {p.fmi3_folder: name for name, p in PLATFORMS.items()}

#: The platform whose binaries FMPy loads here: a build that is only run on
#: this machine (a simulation, an analysis, a benchmark) passes
#: ``platforms=HOST`` and compiles nothing else
HOST = "linux64"

_noted: set[str] = set()


def allowed_text(fmi_version: int | None = None) -> str:
    names = [n for n, p in PLATFORMS.items() if fmi_version != 2 or p.fmi2_folder]
    aliases = [a for a, n in ALIASES.items() if n in names]
    return (", ".join(names) + " (or " + ", ".join(aliases) + ")"
            + ("; FMI 2.0 names no folder for aarch64" if fmi_version == 2 else ""))


def parse(value, fmi_version: int, arg: str = "platforms") -> tuple[str, ...]:
    """``value`` (a comma-separated string or a list of names) as canonical
    platform names in table order; ValueError naming ``arg`` otherwise."""
    if isinstance(value, str):
        items = [s.strip() for s in value.split(",")]
    elif isinstance(value, (list, tuple, set, frozenset)) and all(isinstance(s, str)
                                                                 for s in value):
        items = [s.strip() for s in value]
    else:
        raise ValueError(f"{arg} = {value!r:.60}; allowed: a list or a comma-separated "
                         f"string of {allowed_text(fmi_version)}")
    items = [s for s in items if s]
    if not items:
        raise ValueError(f"{arg} = {value!r:.60} names no platform; allowed: "
                         f"{allowed_text(fmi_version)}")
    names = set()
    for s in items:
        name = ALIASES.get(s, s)
        if name not in PLATFORMS:
            raise ValueError(f"{arg}: unknown platform {s!r}; allowed: "
                             f"{allowed_text(fmi_version)}")
        if PLATFORMS[name].folder(fmi_version) is None:
            raise ValueError(f"{arg}: {s!r} has no binaries folder in FMI 2.0; allowed with "
                             f"fmi_version=2: {allowed_text(2)} (build FMI 3.0 for "
                             "aarch64-linux, or rebuild from sources/ on the ARM machine)")
        names.add(name)
    return tuple(n for n in PLATFORMS if n in names)


@functools.lru_cache(maxsize=None)
def installed(name: str) -> bool:
    """True if the platform's compiler is on PATH and targets it."""
    p = PLATFORMS[name]
    if shutil.which(p.cc) is None:
        return False
    try:
        proc = subprocess.run([p.cc, "-dumpmachine"], capture_output=True, text=True,
                              timeout=30)
    except (OSError, subprocess.SubprocessError):
        return False
    return proc.returncode == 0 and proc.stdout.strip().startswith(p.machine)


def select(platforms, fmi_version: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The platforms to build and those left out for want of a compiler (only
    when neither ``platforms`` nor ``LOOMFMU_PLATFORMS`` names them)."""
    if platforms is not None:
        return parse(platforms, fmi_version), ()
    env = os.environ.get(ENV, "").strip()
    if env:
        return parse(env, fmi_version, arg=ENV), ()
    wanted = [n for n, p in PLATFORMS.items() if p.folder(fmi_version) is not None]
    return (tuple(n for n in wanted if installed(n)),
            tuple(n for n in wanted if not installed(n)))


def skipped_line(skipped) -> str:
    """The one line naming the platforms skipped and the package adding each."""
    return ("loomfmu: platforms skipped (no compiler): " + ", ".join(
        f"{n} (Debian: apt-get install {PLATFORMS[n].package})" for n in skipped))


def note_skipped(skipped) -> None:
    """Print :func:`skipped_line` on stderr, once per process and set of platforms."""
    if not skipped:
        return
    line = skipped_line(skipped)
    if line not in _noted:
        _noted.add(line)
        print(line, file=sys.stderr)
