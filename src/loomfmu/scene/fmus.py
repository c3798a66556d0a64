"""The FMU file of each component: a model is built once per model and
build options into a folder (a cache); an FMU given by path is used as is.

The cache key (the hash in the file name) is made of what the generated
code is made of: the declaration's equations, outputs, events, validity
conditions and variables (with starts, units), the build options, and the
text of the C runtime and of the code generator.  A model edit that keeps
its variables, or a runtime change, gives a new file name: no stale FMU is
reused."""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from fmpy import read_model_description

from loomfmu.scene.declare import Component, Scene, declare_model

#: files whose text goes into every FMU (the runtime) or makes its code
_GENERATOR = ("export/codegen.py", "export/fmi_xml.py", "export/fmi_structure.py",
              "fmu/builder.py", "export/dae.py")


def _generator_text() -> str:
    pkg = Path(__file__).resolve().parent.parent
    files = sorted((pkg / "runtime").glob("*.[ch]")) + [pkg / n for n in _GENERATOR]
    return "\n".join(f"{f.name}:{hashlib.sha1(f.read_bytes()).hexdigest()}"
                     for f in files if f.is_file())


def fmu_file_name(comp: Component) -> str:
    """``<model>-<hash>.fmu``: one file per model, options and code (see the
    module's doc)."""
    decl = (comp.declaration if comp.declaration is not None
            else declare_model(comp.model, comp.options))
    return f"{comp.model}-{declaration_key(decl, comp.options)}.fmu"


def declaration_key(decl, options: dict) -> str:
    """Eight hex digits of a hash of what the generated code of declaration
    ``decl`` (built with ``options``) is made of (see the module's doc)."""
    from loomfmu.export.caches import declaration_parts
    key = "\n".join(declaration_parts(decl))
    key += "\n" + json.dumps(options, sort_keys=True, default=repr)
    key += "\n" + _generator_text()
    return hashlib.sha1(key.encode()).hexdigest()[:8]


def check_fmus(scene: Scene, fmus) -> None:
    """ValueError naming ``fmus`` unless it gives, for every component, an
    existing FMU file with the variables (names, value references,
    causalities) the component's interface has."""
    if not isinstance(fmus, dict):
        raise ValueError(f"fmus = {fmus!r:.60}; allowed: a dict component -> FMU path")
    missing = sorted(set(scene.components) - set(fmus))
    if missing:
        raise ValueError(f"fmus: no FMU for components {missing}; allowed: a dict "
                         f"with a path for each of {sorted(scene.components)}")
    for name, comp in scene.components.items():
        path = Path(fmus[name])
        if not path.is_file():
            raise ValueError(f"fmus[{name!r}] = {str(path)!r}: no such file; allowed: the "
                             f"FMU of component {name} ({comp.source})")
        if not _matches(path, comp):
            raise ValueError(f"fmus[{name!r}] = {str(path)!r}: its variables (names, value "
                             f"references, causalities) are not those of component {name} "
                             f"({comp.source}); allowed: an FMU built from that model")


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
    from loomfmu.fmu.builder import build_fmu
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
                               validate=False, reference_results=False)
            result.path.replace(path)
        paths[comp.name] = path
    return paths
