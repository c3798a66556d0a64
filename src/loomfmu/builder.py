"""The FMU builder: generate, compile with gcc, package, validate with FMPy."""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import fmpy
from fmpy.validation import validate_fmu

from .checks import check_bool
from .codegen import generate_sources
from .declare import Model
from .fmi2_xml import model_description
from .fmu_doc import write_documentation
from .ode import dae_form
from .runtime_files import RUNTIME_DIR, RUNTIME_HEADERS, RUNTIME_SOURCES

#: Flags for code we write (the runtime and the generated declaration).
STRICT_FLAGS = ("-std=c99", "-O2", "-fPIC", "-fvisibility=hidden", "-Wall", "-Wextra",
                "-Werror", "-pedantic")
#: CasADi's generated code: warnings on, but not our code to keep -Werror clean.
GENERATED_FLAGS = ("-std=c99", "-O2", "-fPIC", "-fvisibility=hidden", "-Wall",
                   "-Wno-unused-parameter", "-Wno-unused-function")


def fmi_headers_dir() -> Path:
    """The FMI 2.0/3.0 headers shipped with the installed FMPy."""
    return Path(fmpy.__file__).parent / "c-code"


@dataclass
class BuildResult:
    model: str
    path: Path
    guid: str
    build_seconds: float
    problems: list[str] = field(default_factory=list)


class BuildError(RuntimeError):
    """gcc failed; the message carries the command and the compiler's output."""


def _run(cmd: list[str], cwd: Path) -> None:
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise BuildError(f"command failed ({proc.returncode}): {' '.join(cmd)}\n"
                         f"{proc.stdout}{proc.stderr}")


def compile_binary(src: Path, out: Path, generated_c: list[str], cc: str = "gcc") -> None:
    """Compile every .c in ``src`` into the shared library ``out``."""
    include = ["-I", str(src), "-I", str(fmi_headers_dir())]
    objs = []
    with tempfile.TemporaryDirectory() as tmp:
        for c_file in sorted(src.glob("*.c")):
            flags = GENERATED_FLAGS if c_file.name in generated_c else STRICT_FLAGS
            obj = Path(tmp) / (c_file.stem + ".o")
            _run([cc, *flags, *include, "-c", str(c_file), "-o", str(obj)], src)
            objs.append(str(obj))
        out.parent.mkdir(parents=True, exist_ok=True)
        _check_symbols(objs, model_identifier=out.stem)
        _run([cc, "-shared", "-o", str(out), *objs, "-lm"], src)


def _check_symbols(objs: list[str], model_identifier: str) -> None:
    """Every global symbol is an FMI function or carries the model's prefix,
    so the sources of several FMUs can be linked into one program."""
    proc = subprocess.run(["nm", "-g", "--defined-only", *objs], capture_output=True,
                          text=True)
    if proc.returncode != 0:
        raise BuildError(f"nm failed: {proc.stderr}")
    bad = sorted({ln.split()[2] for ln in proc.stdout.splitlines() if len(ln.split()) == 3}
                 - {""})
    bad = [s for s in bad if not s.startswith(("fmi2", f"{model_identifier}_"))]
    if bad:
        raise BuildError(f"global symbols without the prefix {model_identifier}_: {bad} "
                         "(define them in column 0 of a runtime .c file, so that runtime_files finds them)")


def build_fmu(model: Model, *, out_dir: Path | str = "dist", fmi_version: int = 2,
              validate: bool = True) -> BuildResult:
    """Build ``model`` into ``<out_dir>/<model.name>.fmu``, with its
    documentation page (``documentation/index.html``, not yet verified: see
    :func:`loomfmu.fmu_doc.write_documentation`).

    out_dir: a folder, made if missing (not an existing file).
    fmi_version: only 2 (FMI 2.0 Co-Simulation) is implemented so far.
    validate: run ``fmpy.validate_fmu`` and return its problems in the result.
    """
    if not isinstance(model, Model):
        raise ValueError(f"model = {model!r:.60}; allowed: a loomfmu Model (load_model(name))")
    if type(fmi_version) is not int or fmi_version != 2:
        raise ValueError(f"fmi_version = {fmi_version!r}; allowed: 2")
    check_bool("validate", validate)
    t0 = time.perf_counter()
    out_dir = _out_dir(out_dir)
    dae = dae_form(model)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / model.name
        src = root / "sources"
        src.mkdir(parents=True)
        for f in RUNTIME_SOURCES + RUNTIME_HEADERS:
            shutil.copy(RUNTIME_DIR / f, src / f)
        gen_files, guid = generate_sources(model, dae, src)
        sources = list(RUNTIME_SOURCES) + [f for f in gen_files if f.endswith(".c")]
        (root / "modelDescription.xml").write_text(
            model_description(model, dae, guid, sorted(sources)))
        generated_c = [f for f in gen_files if f.endswith("_casadi.c")]
        compile_binary(src, root / "binaries" / "linux64" / f"{model.name}.so", generated_c)
        fmu = out_dir / f"{model.name}.fmu"
        _zip_dir(root, fmu)
    # documentation/index.html; `loomfmu build` rewrites it with the verification
    write_documentation(fmu, model, verification=None)
    problems = list(validate_fmu(str(fmu))) if validate else []
    return BuildResult(model.name, fmu, guid, time.perf_counter() - t0, problems)


def _out_dir(out_dir) -> Path:
    """``out_dir`` as an existing folder (made with its parents if missing)."""
    if not isinstance(out_dir, (str, os.PathLike)) or not str(out_dir) or "\0" in str(out_dir):
        raise ValueError(f"out_dir = {out_dir!r:.80}; allowed: the path of a folder")
    path = Path(out_dir)
    if path.exists() and not path.is_dir():
        raise ValueError(f"out_dir = {str(out_dir)!r} is an existing file; allowed: a folder "
                         "(made if missing)")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"out_dir = {str(out_dir)!r} cannot be made ({e.strerror}); allowed: "
                         "a folder that exists or can be made") from None
    return path


def _zip_dir(root: Path, fmu: Path) -> None:
    tmp = fmu.with_suffix(".fmu.tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for path in sorted(root.rglob("*")):
            if path.is_file():
                z.write(path, path.relative_to(root).as_posix())
    os.replace(tmp, fmu)
