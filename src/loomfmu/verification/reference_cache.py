"""The scipy reference's results kept on disk, so that one reference serves
every caller that asks for the same one.

A reference of the heavier models takes a minute or more (backrest_regularized by
Radau at rtol 1e-11) and is asked for by the build's verification, by the
FMI-LS-REF result inside each FMI variant of the model, by ``loomfmu
verify`` and ``loomfmu check`` runs and by the tests: each computed it
anew. An entry is keyed by a SHA-256 of everything the result is made of:
the declaration (its DAE form, variables with their start values and
bounds, validity conditions, modes, default experiment), every argument
of :func:`~loomfmu.verification.reference.reference` after checking (end
time, the output times bit for bit, tolerances, method, start values,
input steps), and the text of the code that computes it with the numerical
packages' versions. A call with ``input_functions`` (Python callables) is
never cached. Entries live in :func:`loomfmu.export.caches.reference_cache_dir`
(off with ``LOOMFMU_BUILD_CACHE=off``), written atomically (several
processes may compute the same one); a damaged or unreadable entry is
computed again and overwritten; a cache that cannot be written is skipped.
"""
from __future__ import annotations

import functools
import hashlib
import io
import json
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from loomfmu.export.caches import declaration_parts, reference_cache_dir

#: the entry's format; a new one makes older entries misses
FORMAT = 1


def model_key(model) -> str:
    """SHA-256 (hex) of what a reference of ``model`` depends on in its
    declaration: the same for two declarations of the same equations."""
    parts = declaration_parts(model)
    parts += [json.dumps(model.mode_values, sort_keys=True, default=repr),
              json.dumps(model.event_modes, sort_keys=True, default=repr),
              repr((model.name, model.stop_time, model.step_size, model.reference_method))]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


@functools.lru_cache(maxsize=4)
def code_fingerprint(files: tuple[str, ...]) -> str:
    """The text of ``files`` (the code that computes the reference), of this
    module and the numerical packages' versions, read once per process: a file
    edited while a process runs does not change the keys that process computes."""
    import casadi
    import scipy
    parts = [hashlib.sha256(Path(f).read_bytes()).hexdigest() for f in (*files, __file__)]
    parts.append(f"numpy {np.__version__} scipy {scipy.__version__} casadi "
                 f"{casadi.__version__} format {FORMAT}")
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def call_key(model, code: tuple[str, ...], *, t_end: float, t_eval: np.ndarray, rtol: float, atol: float,
             method: str, values: dict, steps: list) -> str:
    """The key of one checked call of the reference; ``code``: the files of
    the code that computes it."""
    h = hashlib.sha256()
    for part in (model_key(model), code_fingerprint(tuple(code)), repr(float(t_end)),
                 repr((float(rtol), float(atol), method)),
                 repr(sorted((k, float(v)) for k, v in values.items())),
                 repr([(float(t), sorted((k, float(v)) for k, v in new.items()))
                       for t, new in steps])):
        h.update(part.encode() + b"\0")
    h.update(np.ascontiguousarray(t_eval, dtype=float).tobytes())
    return h.hexdigest()


def _entry(key: str) -> Path | None:
    base = reference_cache_dir()
    return None if base is None else base / f"ref-{key}.npz"


def load(key: str) -> dict | None:
    """The fields of the cached :class:`~loomfmu.verification.reference.Reference`
    of ``key`` (``cached`` set), or None."""
    entry = _entry(key)
    if entry is None or not entry.is_file():
        return None
    try:
        with np.load(io.BytesIO(entry.read_bytes()), allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            t, y = np.array(data["t"]), np.array(data["y"])
        names = meta["names"]
        if meta.get("format") != FORMAT or y.shape != (len(names), len(t)):
            return None
        violation = meta["violation"]
        return {"t": t, "y": {n: y[i].copy() for i, n in enumerate(names)},
                "wall_seconds": float(meta["wall_seconds"]), "n_rhs": int(meta["n_rhs"]),
                "n_segments": int(meta["n_segments"]),
                "switches": [(float(a), str(b), int(c), int(d))
                             for a, b, c, d in meta["switches"]],
                "violation": None if violation is None else (
                    str(violation[0]), str(violation[1]), float(violation[2]),
                    float(violation[3])),
                "cached": True}
    except (OSError, ValueError, KeyError, TypeError, IndexError, EOFError,
            zipfile.BadZipFile):
        return None  # damaged: computed again and overwritten


def store(key: str, ref) -> None:
    """Write ``ref`` as the entry of ``key`` (atomically; skipped when the
    cache is off or cannot be written)."""
    entry = _entry(key)
    if entry is None:
        return
    names = list(ref.y)
    meta = {"format": FORMAT, "names": names, "wall_seconds": ref.wall_seconds,
            "n_rhs": ref.n_rhs, "n_segments": ref.n_segments,
            "switches": [list(s) for s in ref.switches],
            "violation": None if ref.violation is None else list(ref.violation)}
    y = np.array([np.asarray(ref.y[n], dtype=float) for n in names]).reshape(
        len(names), len(ref.t))
    buf = io.BytesIO()
    np.savez(buf, t=np.asarray(ref.t, dtype=float), y=y, meta=np.array(json.dumps(meta)))
    try:
        entry.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=entry.parent, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(buf.getvalue())
            os.replace(tmp, entry)
        except OSError:
            Path(tmp).unlink(missing_ok=True)
    except OSError:
        pass
