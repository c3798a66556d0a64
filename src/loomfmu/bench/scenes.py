"""The scenes the work-precision charts run, one line per model.

A :class:`Scene` names a model (a key of :data:`loomfmu.registry.MODELS`),
the 2-4 outputs whose error is measured, the run's length and start values,
and how the tight reference is solved.  Adding a model to every chart is one
line in :data:`BENCH`.  A scene whose model is not registered yet is skipped
with a printed note (see :func:`load_scene_model`).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field

from loomfmu.declare.model import Model
from loomfmu.registry import MODELS, load_model


@dataclass(frozen=True)
class Scene:
    """One benchmark run of one model.

    model: registry name.  outputs: the key outputs whose error is measured.
    stop, interval: run length and communication step in s (None: the
    model's default experiment); quick_stop: the length under ``--quick``.
    values: start values (parameters, inputs held constant).
    atol_scale: atol = rtol * atol_scale for every adaptive method (the
    magnitude of the smallest state that matters).
    reference: "scipy" (DOP853 through loomfmu.verification.reference, with the model's
    events, modes and delays) or "cvodes" (CasADi's CVODES on the same
    symbolic right-hand side; for large stiff models).
    """

    model: str
    outputs: tuple[str, ...]
    stop: float | None = None
    interval: float | None = None
    quick_stop: float | None = None
    values: dict = field(default_factory=dict)
    atol_scale: float = 1e-3
    reference: str = "scipy"
    note: str = ""


#: Every model on the charts.  One line per model.
BENCH: dict[str, Scene] = {
    "heald_frame": Scene("heald_frame", ("h", "x2_out", "y2_out", "T")),
    "backrest": Scene("backrest", ("phi1_out", "omega1_out", "omega2_out", "S2"),
                      quick_stop=0.5, note="event-driven Coulomb friction"),
    "backrest_regularized": Scene("backrest_regularized", ("phi1_out", "omega1_out",
                                  "omega2_out", "S2"), quick_stop=0.5, values={"eps": 1e-2},
                                  note="tanh friction, eps = 1e-2 rad/s, k_static = 1.3"),
    "drive": Scene("drive", ("n_out", "phi_out"), stop=15.0, quick_stop=3.0,
                   atol_scale=1.0, note="compensated cam, tau = 0.5 s"),
    "spindle": Scene("spindle", ("x_top", "x_footstep", "F_upper"), atol_scale=1e-7,
                     reference="cvodes", note="16 000 rpm, 5 um unbalance, from rest"),
    "spindle_modal": Scene("spindle_modal", ("x_top", "x_footstep", "F_upper"),
                           atol_scale=1e-7, reference="cvodes",
                           note="4 modes per plane"),
}


def load_scene_model(name: str) -> Model | None:
    """The model of scene ``name``, or None with a printed note when it is not
    available yet.  A model not in the registry but present as
    ``loomfmu.models.<name>`` is built from there (with a note)."""
    scene = BENCH[name]
    if scene.model in MODELS:
        return load_model(scene.model)
    try:
        module = importlib.import_module(f"loomfmu.models.{scene.model}")
    except ImportError:
        print(f"note: model {scene.model!r} is neither registered nor in loomfmu.models; "
              "scene skipped")
        return None
    print(f"note: model {scene.model!r} is not in loomfmu.registry.MODELS; built from "
          f"loomfmu.models.{scene.model} with its default options")
    return module.build()
