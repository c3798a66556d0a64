"""Where loomfmu keeps what it can compute again: the folders of its on-disk
caches, and the text of a declaration their keys are made of.

Both follow ``$LOOMFMU_BUILD_CACHE``: if set, it names the object cache
(``off``, ``0``, ``no``, ``false``, ``none`` or an empty value turns every
cache off; ``~`` is expanded); else the objects go to
``$XDG_CACHE_HOME/loomfmu/objects`` or ``~/.cache/loomfmu/objects``. The
scipy references sit beside the objects, not inside (that folder holds
objects only and is pruned by size): ``.../loomfmu/references`` next to the
default, else ``<$LOOMFMU_BUILD_CACHE>-references``.
"""
from __future__ import annotations

import os
from pathlib import Path

_OFF = {"off", "0", "no", "false", "none"}


def cache_dir() -> Path | None:
    """The object cache folder, or None when ``LOOMFMU_BUILD_CACHE=off``."""
    env = os.environ.get("LOOMFMU_BUILD_CACHE")
    if env is not None:
        if env.strip().lower() in _OFF or not env.strip():
            return None
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "loomfmu" / "objects"


def reference_cache_dir() -> Path | None:
    """Where scipy references are cached, or None when the caches are off."""
    base = cache_dir()
    if base is None:
        return None
    return base.parent / "references" if base.name == "objects" else base.with_name(
        base.name + "-references")


def declaration_parts(decl) -> list[str]:
    """The text of what a declaration's generated code and its reference are
    made of: its DAE form (every expression the runtime and the reference
    evaluate), every variable (name, kind, start, unit, range), the validity
    conditions and the constraints.  Two declarations of the same equations
    give the same parts.  (The DAE form's tearing is derived from the rest
    and left out.)"""
    from loomfmu.export.dae import dae_form
    dae = dae_form(decl)
    parts = [f"{k}={v}" for k, v in sorted(vars(dae).items()) if k not in ("model", "tearing")]
    parts += [f"{v.name}:{v.kind}:{v.start}:{v.unit}:{getattr(v, 'min', '')}:"
              f"{getattr(v, 'max', '')}" for v in decl.variables]
    parts += [f"{c.name}:{c.expr}:{c.message}" for what in ("validity", "constraints")
              for c in getattr(decl, what, [])]
    return parts
