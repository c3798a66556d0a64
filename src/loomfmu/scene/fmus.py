"""The FMU file of each component: a model is built once per model and
build options into a folder (a cache); an FMU given by path is used as is."""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from fmpy import read_model_description

from .declare import Component, Scene, declare_model


def fmu_file_name(comp: Component) -> str:
    """``<model>-<hash of the build options>.fmu``: one file per model and
    options; a declared model's hash is of its equations, outputs, events and
    variables (what the generated code is made of)."""
    if comp.declaration is not None:
        from ..ode import dae_form
        dae = dae_form(comp.declaration)
        key = "\n".join(f"{k}={v}" for k, v in sorted(vars(dae).items()) if k != "model")
        key += "\n" + "\n".join(f"{v.name}:{v.kind}:{v.start}:{v.unit}"
                                for v in comp.declaration.variables)
    else:
        key = json.dumps(comp.options, sort_keys=True, default=repr)
    return f"{comp.model}-{hashlib.sha1(key.encode()).hexdigest()[:8]}.fmu"


def _matches(path: Path, comp: Component) -> bool:
    """The FMU at ``path`` has the variables (names, value references,
    causalities) the component's declaration gives."""
    try:
        md = read_model_description(str(path))
    except Exception:
        return False
    have = {v.name: (int(v.valueReference), v.causality) for v in md.modelVariables}
    want = {n: (v.vr, v.causality) for n, v in comp.interface.variables.items()}
    return have == want


def build_fmus(scene: Scene, fmu_dir, *, rebuild: bool = False, progress=None
               ) -> dict[str, Path]:
    """Component name -> FMU path.  Models are built into ``fmu_dir`` (reused
    when a file of the same model, options and variables is there, unless
    ``rebuild``)."""
    from ..builder import build_fmu
    fmu_dir = Path(fmu_dir)
    paths: dict[str, Path] = {}
    for comp in scene.components.values():
        if comp.fmu is not None:
            paths[comp.name] = comp.fmu
            continue
        path = fmu_dir / fmu_file_name(comp)
        if rebuild or not path.is_file() or not _matches(path, comp):
            if progress is not None:
                progress.stage(f"{comp.name}: building {comp.model}")
            result = build_fmu(declare_model(comp.model if comp.declaration is None else comp.declaration,
                                             comp.options),
                               out_dir=fmu_dir,
                               validate=False)
            result.path.replace(path)
        paths[comp.name] = path
    return paths
