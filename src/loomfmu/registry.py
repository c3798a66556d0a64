"""The mechanisms loomfmu builds, by name.

Model modules live in ``models/`` at the top of the repository and are
installed as the package ``loomfmu.models``; each has ``build(**options)``.
"""
from __future__ import annotations

import importlib

from .declare import Model

#: model name -> (module in loomfmu.models, build options)
MODELS: dict[str, tuple[str, dict]] = {
    "heald_frame": ("heald_frame", {}),
    "backrest": ("backrest", {}),
    "backrest_regularized": ("backrest", {"friction": "regularized"}),
    "drive": ("drive", {}),
    "heald_frame_planar": ("heald_frame_planar", {}),
    "heald_frame_rigid": ("heald_frame_rigid", {}),
    "spindle": ("spindle", {}),
    "spindle_modal": ("spindle_modal", {}),
}


def load_model(name: str, **options) -> Model:
    """Declare model ``name`` (a key of MODELS) with build ``options``."""
    if name not in MODELS:
        raise ValueError(f"model = {name!r}; allowed: {sorted(MODELS)}")
    module, defaults = MODELS[name]
    mod = importlib.import_module(f"loomfmu.models.{module}")
    return mod.build(**{**defaults, **options})
