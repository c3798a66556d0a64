"""The mechanisms loomfmu builds, by name.

Model modules live in ``models/`` at the top of the repository and are
installed as the package ``loomfmu.models``; each has ``build(**options)``.
"""
from __future__ import annotations

import importlib
import inspect
import re

from loomfmu.declare.checks import check_names
from loomfmu.declare.model import Model

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
    "loom_shaft": ("loom_shaft", {}),
    # the co-simulation benchmark split into two FMUs (loomfmu.machines.two_mass)
    "two_mass_force": ("two_mass", {"side": "force"}),
    "two_mass_displacement": ("two_mass", {"side": "displacement"}),
}

#: model name -> the build options that change its interface (inputs,
#: outputs, ports), one dict per variant: ``loomfmu docs`` lists each
#: variant's name and interface on the model's page.
VARIANTS: dict[str, list[dict]] = {
    "heald_frame": [{"warp_tension": "input"}],
    "heald_frame_planar": [{"warp_tension": "input"}],
    "heald_frame_rigid": [{"warp_tension": "input"}],
    "backrest": [{"fronts": 2}],
    "backrest_regularized": [{"fronts": 2}],
}

#: mechanism -> its models, lowest fidelity first (a scene picks one level)
FIDELITY: dict[str, list[str]] = {
    "heald frame": ["heald_frame_rigid", "heald_frame_planar", "heald_frame"],
    "backrest": ["backrest_regularized", "backrest"],
    "spindle rotor": ["spindle_modal", "spindle"],
    "spindle drive": ["drive"],
    "loom main shaft": ["loom_shaft"],
    # the benchmark's two halves: one level each (a scene picks both)
    "two-mass benchmark, force side": ["two_mass_force"],
    "two-mass benchmark, displacement side": ["two_mass_displacement"],
}


def build_options(name: str) -> list[str]:
    """The build options ``load_model(name, ...)`` accepts (keyword names of
    the model module's ``build``)."""
    if not isinstance(name, str) or name not in MODELS:
        raise ValueError(f"name = {name!r:.60}; allowed: a model name, one of "
                         f"{', '.join(sorted(MODELS))}")
    module, _ = MODELS[name]
    build = importlib.import_module(f"loomfmu.models.{module}").build
    return [p.name for p in inspect.signature(build).parameters.values()
            if p.kind is inspect.Parameter.KEYWORD_ONLY]


def load_model(name: str, **options) -> Model:
    """Declare model ``name`` (a key of MODELS) with build ``options``.

    Unknown option names are refused (ValueError listing the allowed ones),
    and so is an option that contradicts the registry entry (e.g.
    ``load_model("backrest_regularized", friction="events")``: that is the
    model "backrest").  Each model's ``build`` checks the option values.
    """
    if not isinstance(name, str) or name not in MODELS:
        raise ValueError(f"name = {name!r:.60}; allowed: a model name, one of "
                         f"{', '.join(sorted(MODELS))}")
    module, defaults = MODELS[name]
    check_names(f"load_model({name!r}) options", options, build_options(name),
                what="build options")
    for key, fixed in defaults.items():
        if key in options and options[key] != fixed:
            others = [n for n, (mod_, d) in MODELS.items()
                      if mod_ == module and d.get(key) == options[key]]
            if not others and module in MODELS and key not in MODELS[module][1]:
                others = [module]
            raise ValueError(f"{key} = {options[key]!r}: model {name!r} is built with "
                             f"{key} = {fixed!r}; allowed: {fixed!r}"
                             + (f" (for {key} = {options[key]!r} load {others[0]!r})"
                                if others else ""))
    mod = importlib.import_module(f"loomfmu.models.{module}")
    model = mod.build(**{**defaults, **options})
    # The build names the registry entry whose fixed options it was given
    # (load_model("backrest", friction="regularized") is backrest_regularized):
    # those options are in that name already.
    base = model.name if model.name in MODELS else name
    fixed = MODELS[base][1]
    changed = {k: v for k, v in non_default_options(name, options).items()
               if not (k in fixed and _same(v, fixed[k]))}
    if changed:
        model.variant_of, model.name = base, variant_name(base, changed)
    return model


def option_defaults(name: str) -> dict[str, object]:
    """The build options of model ``name`` with their default values (the
    registry's fixed options left out)."""
    module, fixed = MODELS[name]
    build = importlib.import_module(f"loomfmu.models.{module}").build
    return {p.name: p.default for p in inspect.signature(build).parameters.values()
            if p.kind is inspect.Parameter.KEYWORD_ONLY and p.name not in fixed}


def non_default_options(name: str, options: dict) -> dict:
    """The ``options`` of model ``name`` whose values differ from the
    defaults, in the order of the model's build() signature."""
    defaults = option_defaults(name)
    return {k: options[k] for k in defaults
            if k in options and not _same(options[k], defaults[k])}


def _same(a, b) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return float(a) == float(b)
    return a == b


def variant_name(name: str, changed: dict) -> str:
    """The model identifier (and FMU file stem) of model ``name`` built with
    the non-default options ``changed``: the name, then each option and its
    value, e.g. ``heald_frame_warp_tension_input``, ``backrest_fronts_2``,
    ``backrest_eps_0p01`` ('.' reads 'p', '-' reads 'm')."""
    parts = [name]
    for key, value in changed.items():
        text = str(value).lower() if isinstance(value, bool) or value is None else str(value)
        if isinstance(value, float):
            text = f"{value:g}"
        text = re.sub(r"[^A-Za-z0-9]", lambda m: {".": "p", "-": "m"}.get(m.group(0), "_"),
                      text.replace("+", ""))
        parts += [key, text]
    return "_".join(parts)
