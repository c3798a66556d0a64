"""Compile C files in parallel, reusing objects from an on-disk cache.

An FMU's binary is built from ~30 runtime files and the generated code of
one model (the spindle's CasADi file alone is 1.2 MB and takes gcc ~25 s at
-O2). The runtime files are the same for every model and the generated code
the same for every FMI variant of a model, so most objects of a build were
already compiled by an earlier one. Like ccache's preprocessor mode, the key
of an object is a SHA-256 of the compiler's identity (``cc --version`` and
``cc -dumpmachine``), the flags, and the file *after preprocessing* (``-E -P``,
no line markers, so neither the temporary folder nor the file's name enters):
a changed header, macro or flag is a different key, and an object is reused
only where gcc would read exactly the same text.

Where the cache lives: :func:`loomfmu.export.caches.cache_dir`
(``$LOOMFMU_BUILD_CACHE``, else ``~/.cache/loomfmu/objects``). Entries are written atomically (several
processes may build at once) and the oldest are deleted past
:data:`MAX_CACHE_BYTES`. A cache that cannot be written is skipped: the build
compiles everything, as without a cache; a cache that can be read but not
written (read-only) is still used. If the objects link into nothing
(an entry poisoned by hand, an assembler changed under the same compiler),
the builder compiles everything again, overwriting the entries, and links
once more (:func:`loomfmu.fmu.builder.compile_binaries`). The builder compiles
every platform's files in one pool (:func:`compile_jobs`).
"""
from __future__ import annotations

import functools
import hashlib
import os
import subprocess
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from loomfmu.export.caches import cache_dir

#: The cache is pruned to this size, oldest entries (by use) first.
MAX_CACHE_BYTES = 512 * 2**20


class BuildError(RuntimeError):
    """gcc failed; the message carries the command and the compiler's output."""


@dataclass
class CompileStats:
    """What one build compiled and what it reused."""
    compiled: int = 0
    reused: int = 0


def run(cmd: list[str], cwd: Path) -> subprocess.CompletedProcess:
    try:
        proc = subprocess.run(cmd, cwd=cwd, capture_output=True)
    except OSError as exc:  # the compiler is not there or cannot run
        raise BuildError(f"command failed: {' '.join(cmd)}: {cmd[0]!r} cannot be run "
                         f"({exc.strerror or exc}); a C compiler (gcc) must be on PATH") from None
    if proc.returncode != 0:
        raise BuildError(f"command failed ({proc.returncode}): {' '.join(cmd)}\n"
                           f"{proc.stdout.decode(errors='replace')}"
                           f"{proc.stderr.decode(errors='replace')}")
    return proc


@functools.lru_cache(maxsize=8)
def _compiler_identity(cc: str) -> bytes:
    ident = b""
    for arg in ("--version", "-dumpmachine"):
        proc = subprocess.run([cc, arg], capture_output=True)
        ident += proc.stdout + b"\0"
    return ident


def _key(cc: str, flags: tuple[str, ...], include: list[str], c_file: Path) -> str:
    pre = run([cc, *flags, *include, "-E", "-P", str(c_file)], c_file.parent).stdout
    h = hashlib.sha256()
    for part in (_compiler_identity(cc), "\0".join(flags).encode(), pre):
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    return h.hexdigest()


def _compile_one(cc: str, flags: tuple[str, ...], include: list[str], c_file: Path,
                 obj: Path, cache: Path | None, refresh: bool) -> bool:
    """Compile ``c_file`` into ``obj``; True if the object came from the cache
    (never with ``refresh``: compiled, and the entry overwritten)."""
    entry = None
    if cache is not None:
        entry = cache / (_key(cc, flags, include, c_file) + ".o")
        data = None if refresh else _read_entry(entry)
        if data is not None:
            obj.write_bytes(data)
            return True
    run([cc, *flags, *include, "-c", str(c_file), "-o", str(obj)], c_file.parent)
    if not obj.is_file():
        raise BuildError(f"{cc} -c {c_file.name} wrote no object (is {cc!r} a C compiler?)")
    if entry is not None:
        _write_entry(entry, obj.read_bytes())
    return False


def _read_entry(entry: Path) -> bytes | None:
    """The object stored in ``entry``, or None if missing or corrupted (an
    entry is the object followed by its SHA-256; a truncated or altered file
    is compiled again and overwritten)."""
    try:
        blob = entry.read_bytes()
    except OSError:
        return None
    try:
        os.utime(entry)  # last use, for pruning
    except OSError:
        pass  # a read-only cache is still a cache
    data, digest = blob[:-32], blob[-32:]
    if len(blob) <= 32 or hashlib.sha256(data).digest() != digest:
        return None
    return data


def _write_entry(entry: Path, data: bytes) -> None:
    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=entry.parent, suffix=".tmp")
    except OSError:
        return  # a cache that cannot be written is no cache
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data + hashlib.sha256(data).digest())
        os.replace(tmp, entry)
    except BaseException as exc:  # a full disk, an interrupt: leave no partial file
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if not isinstance(exc, OSError):
            raise


@dataclass(frozen=True)
class CompileJob:
    """One C file to compile: with which compiler, flags and include path,
    into which object."""
    c_file: Path
    flags: tuple[str, ...]
    include: tuple[str, ...]
    obj: Path
    cc: str = "gcc"


def compile_objects(jobs: list[tuple[Path, tuple[str, ...]]], include: list[str],
                    out_dir: Path, cc: str = "gcc", *,
                    refresh: bool = False) -> tuple[list[str], CompileStats]:
    """Compile each ``(c_file, flags)`` into ``out_dir/<stem>.o``, as many at
    once as there are cores; returns the object paths (in the order of
    ``jobs``) and how many were compiled or reused. ``refresh``: reuse
    nothing, overwrite the cache's entries."""
    todo = [CompileJob(c, tuple(flags), tuple(include), out_dir / (c.stem + ".o"), cc)
            for c, flags in jobs]
    return [str(j.obj) for j in todo], compile_jobs(todo, refresh=refresh)


def compile_jobs(jobs: list[CompileJob], *, refresh: bool = False) -> CompileStats:
    """Compile every job, as many at once as there are cores, whatever its
    compiler (one pool for all the platforms of a build); returns how many
    objects were compiled and how many reused from the cache."""
    cache = cache_dir()
    # the biggest files first, so that the longest compile does not start last
    order = sorted(jobs, key=lambda j: -j.c_file.stat().st_size)
    with ThreadPoolExecutor(max_workers=max(1, os.cpu_count() or 1)) as pool:
        futures = [pool.submit(_compile_one, j.cc, j.flags, list(j.include), j.c_file, j.obj,
                               cache, refresh) for j in order]
        reused = [f.result() for f in futures]
    if cache is not None and not all(reused):
        prune(cache)
    return CompileStats(compiled=reused.count(False), reused=reused.count(True))


def prune(cache: Path, max_bytes: int = MAX_CACHE_BYTES) -> None:
    """Delete the least recently used objects until the cache is under ``max_bytes``."""
    try:
        entries = [(p.stat().st_mtime, p.stat().st_size, p) for p in cache.glob("*.o")]
        stale = [p for p in cache.glob("*.tmp") if time.time() - p.stat().st_mtime > 3600]
    except OSError:
        return
    for path in stale:  # left by a process killed while writing
        try:
            path.unlink()
        except OSError:
            pass
    total = sum(size for _, size, _ in entries)
    for _, size, path in sorted(entries):
        if total <= max_bytes:
            break
        try:
            path.unlink()
            total -= size
        except OSError:
            pass
