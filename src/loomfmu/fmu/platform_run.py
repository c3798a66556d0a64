"""Run an FMU's binary for each platform where this machine can: natively,
under wine (x86-64 Windows) or under qemu-aarch64 (aarch64 Linux).

Our own importer, ``platform_driver.c`` (this folder), is compiled for the
platform with the platform's compiler and runs the FMU's default experiment
through the FMI functions: co-simulation one doStep per output interval,
model exchange with explicit Euler (:data:`EULER_SUBSTEPS` steps per output
interval). It writes each double's 64 bits, so that two platforms' runs
compare exactly (:func:`compare`). One driver process runs every FMU given
to :func:`run_on` (wine starts once).

wine: ``WINEPREFIX`` if set, else ``<cache>/loomfmu/wine`` (made at the
first start, a minute or so: wineboot), with ``WINEDEBUG=-all``.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from fmpy import read_model_description

from loomfmu.fmu.builder import fmi_headers_dir
from loomfmu.fmu.compile_cache import BuildError, run
from loomfmu.fmu.platforms import PLATFORMS, Platform, installed

DRIVER_SOURCE = Path(__file__).with_name("platform_driver.c")
DRIVER_FLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-Werror",
                "-pedantic")
#: explicit Euler steps per output interval in model exchange
EULER_SUBSTEPS = 10
#: the sysroot qemu-aarch64 loads the aarch64 C library from
AARCH64_SYSROOT = Path("/usr/aarch64-linux-gnu")


def missing_tools(name: str) -> str | None:
    """Why programs for platform ``name`` cannot be built and run here
    (naming the Debian package), or None if they can."""
    p = PLATFORMS[name]
    if not installed(name):
        return f"{p.cc} not installed (Debian: apt-get install {p.package})"
    if p.emulator and shutil.which(p.emulator[0]) is None:
        return f"{p.emulator[0]} not installed (Debian: apt-get install {p.emulator_package})"
    if name == "aarch64" and not (AARCH64_SYSROOT / "lib").is_dir():
        return (f"no aarch64 C library under {AARCH64_SYSROOT} (Debian: apt-get install "
                "libc6-arm64-cross, which gcc-aarch64-linux-gnu pulls in)")
    return None


def wine_env() -> dict[str, str]:
    env = dict(os.environ)
    if not env.get("WINEPREFIX"):
        base = env.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        env["WINEPREFIX"] = str(Path(base) / "loomfmu" / "wine")
    Path(env["WINEPREFIX"]).parent.mkdir(parents=True, exist_ok=True)
    env["WINEDEBUG"] = "-all"
    return env


def build_driver(platform: Platform, out_dir: Path) -> Path:
    """``platform_driver.c`` compiled for ``platform`` into ``out_dir``."""
    exe = out_dir / f"platform_driver_{platform.name}{'.exe' if platform.windows else ''}"
    libs = ["-static-libgcc"] if platform.windows else ["-ldl", "-lm"]
    run([platform.cc, *DRIVER_FLAGS, "-I", str(fmi_headers_dir()), "-o", str(exe),
         str(DRIVER_SOURCE), *libs], out_dir)
    return exe


@dataclass
class DriverRun:
    """One FMU run by the driver on one platform."""

    fmu: Path
    interface: str
    ok: bool
    message: str
    #: output names, in the columns' order
    names: list[str] = field(default_factory=list)
    time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: one column per output
    values: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))


def _path_for(platform: Platform, path: Path) -> str:
    """``path`` as the platform's program sees it (wine: drive Z: is /)."""
    path = Path(path).resolve()
    return "Z:" + str(path).replace("/", "\\") if platform.windows else str(path)


def _job_line(platform: Platform, fmu: Path, interface: str, unzip: Path, out_csv: Path,
              start_values: dict | None = None) -> tuple[str, list[str]]:
    md = read_model_description(str(fmu))
    fmi = int(md.fmiVersion[0])
    folder = platform.folder(fmi)
    if folder is None:
        raise ValueError(f"platform = {platform.name!r}: FMI {md.fmiVersion} has no folder "
                         "for it")
    kind = md.coSimulation if interface == "cs" else md.modelExchange
    if kind is None:
        raise ValueError(f"interface = {interface!r}: {fmu.name} does not declare it")
    lib = unzip / "binaries" / folder / (kind.modelIdentifier + platform.suffix)
    if not lib.is_file():
        raise ValueError(f"{fmu.name} has no binary for {platform.name} "
                         f"(binaries/{folder}/{lib.name})")
    outputs = [v for v in md.modelVariables
               if v.causality == "output" and v.type in ("Real", "Float64")]
    ex = md.defaultExperiment
    start = float(ex.startTime or 0.0)
    stop = float(ex.stopTime)
    step = float(ex.stepSize) if ex.stepSize else (stop - start) / 500
    res = unzip / "resources"
    res.mkdir(exist_ok=True)
    resources = (res.resolve().as_uri() if fmi == 2
                 else _path_for(platform, res) + ("\\" if platform.windows else "/"))
    token = md.guid if fmi == 2 else md.instantiationToken
    by_name = {v.name: v for v in md.modelVariables}
    sets = []
    for var, value in (start_values or {}).items():
        v = by_name.get(var)
        if v is None or v.type not in ("Integer", "Int32", "Real", "Float64"):
            raise ValueError(f"start_values: {var!r} is not a Real/Float64 or Integer/Int32 "
                             f"variable of {fmu.name}")
        kind = "i" if v.type in ("Integer", "Int32") else "r"
        sets += [kind, str(v.valueReference), repr(int(value) if kind == "i" else float(value))]
    fields = [_path_for(platform, lib), str(fmi), interface, token, resources,
              repr(start), repr(stop), repr(step), str(EULER_SUBSTEPS),
              str(len(md.derivatives)), str(md.numberOfEventIndicators or 0),
              _path_for(platform, out_csv), str(len(sets) // 3), *sets, str(len(outputs)),
              *[str(v.valueReference) for v in outputs]]
    if any(not f or any(c.isspace() for c in f) for f in fields):
        raise ValueError(f"fmu = {str(fmu)!r}: a path or token with a space cannot be "
                         "passed to the driver")
    return " ".join(fields), [v.name for v in outputs]


def _read_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    lines = path.read_text().split()
    bits = np.array([[int(x, 16) for x in ln.split(",")] for ln in lines[1:]], dtype=np.uint64)
    data = bits.view(np.float64).reshape(len(lines) - 1, -1)
    return data[:, 0], data[:, 1:]


def run_on(platform_name: str, runs: list[tuple], work_dir: Path | None = None,
           timeout: float = 3600.0) -> list[DriverRun]:
    """Run each ``(fmu, interface)`` ("cs" or "me") over its default
    experiment with the FMU's binary for ``platform_name``, in one driver
    process; one :class:`DriverRun` each, in order. A third element, a dict
    of start values by variable name (Real/Float64 or Integer/Int32, e.g.
    ``{"solver_index": 3}`` for rk4), is set before initialization. Raises BuildError if the
    platform's compiler or emulator is missing (:func:`missing_tools`)."""
    platform = PLATFORMS[platform_name]
    why = missing_tools(platform_name)
    if why:
        raise BuildError(f"cannot run {platform_name} binaries here: {why}")
    with tempfile.TemporaryDirectory(dir=work_dir) as tmp:
        tmp = Path(tmp)
        exe = build_driver(platform, tmp)
        lines, names, csvs = [], [], []
        for i, (fmu, interface, *start) in enumerate(runs):
            unzip = tmp / f"fmu{i}"
            with zipfile.ZipFile(fmu) as z:
                z.extractall(unzip)
            csv = tmp / f"run{i}.csv"
            line, outs = _job_line(platform, Path(fmu), interface, unzip, csv,
                                   start[0] if start else None)
            lines.append(line)
            names.append(outs)
            csvs.append(csv)
        jobs = tmp / "jobs.txt"
        jobs.write_text("\n".join(lines) + "\n")
        env = wine_env() if platform.windows else None
        cmd = [*platform.emulator, str(exe), _path_for(platform, jobs)]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout,
                              cwd=tmp)
        status = {}
        for ln in proc.stdout.splitlines():
            parts = ln.split(" ", 3)
            if len(parts) >= 3 and parts[0] == "RUN":
                status[int(parts[1]) - 1] = (parts[2] == "OK", " ".join(parts[3:]))
        out = []
        for i, (fmu, interface, *_) in enumerate(runs):
            ok, msg = status.get(i, (False, f"no result (exit {proc.returncode}): "
                                            f"{proc.stderr.strip()[-500:]}"))
            r = DriverRun(Path(fmu), interface, ok, msg, names[i])
            if csvs[i].is_file() and csvs[i].stat().st_size:
                r.time, r.values = _read_csv(csvs[i])
            out.append(r)
        return out


def compare(native: DriverRun, other: DriverRun) -> dict:
    """How far ``other`` is from ``native``: identical bits or not, and the
    largest |difference| of any output relative to that output's range over
    the native run (with the output's name)."""
    if native.values.shape != other.values.shape or not np.array_equal(
            native.time.view(np.uint64), other.time.view(np.uint64)):
        return {"identical": False, "max_rel_range": float("inf"), "output": "(time grid)"}
    identical = bool(np.array_equal(native.values.view(np.uint64), other.values.view(np.uint64)))
    worst, name = 0.0, ""
    for k, n in enumerate(native.names):
        a, b = native.values[:, k], other.values[:, k]
        span = float(np.ptp(a)) or max(float(np.max(np.abs(a))), 1.0)
        d = float(np.max(np.abs(a - b))) / span if len(a) else 0.0
        if not np.isfinite(d):
            d = float("inf")
        if d > worst or not name:
            worst, name = d, n
    return {"identical": identical, "max_rel_range": worst, "output": name}
