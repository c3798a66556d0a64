"""The package layers of loomfmu (CONTRIBUTING.md draws them), enforced.

Every import counts, the ones inside functions too: an import moved into a
function to dodge a circle still ties the two modules together.  A module
may import modules of its own package and of packages on a lower layer;
packages on one layer do not import each other.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
from graphs import circles

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "loomfmu"
MODELS = ROOT / "models"

#: bottom first; each entry is one layer: its packages (or modules)
LAYERS: list[tuple[str, ...]] = [
    ("loomfmu.declare", "loomfmu.progress"),
    ("loomfmu.mechanics",),
    ("loomfmu.models",),
    ("loomfmu.registry",),
    ("loomfmu.fidelity",),
    ("loomfmu.export",),
    ("loomfmu.verification", "loomfmu.inspection"),
    ("loomfmu.fmu",),
    ("loomfmu.scene", "loomfmu.sweep"),
    ("loomfmu.heald", "loomfmu.backrest", "loomfmu.drive", "loomfmu.spindle"),
    ("loomfmu.machines",),
    ("loomfmu.bench",),
    ("loomfmu.cli",),
    ("loomfmu.__main__", "loomfmu"),
]

#: at most this many plain modules directly under src/loomfmu (besides
#: __init__ and __main__): the rest live in packages by role
MAX_TOP_MODULES = 8


def modules() -> dict[str, Path]:
    """Module name -> file, for src/loomfmu and models/ (installed as loomfmu.models)."""
    found = {}
    for base, prefix in ((SRC, "loomfmu"), (MODELS, "loomfmu.models")):
        for path in base.rglob("*.py"):
            parts = list(path.relative_to(base).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join([prefix, *parts])] = path
    return found


def imports(name: str, path: Path, known: set[str]) -> set[str]:
    """Every loomfmu module ``name`` imports, at any depth of the file."""
    is_pkg = path.name == "__init__.py"
    package = name if is_pkg else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[:len(parts) - node.level + 1]
                base = ".".join(parts + ([node.module] if node.module else []))
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base
                       for a in node.names]
        elif isinstance(node, ast.Call) and _dynamic_import(node):
            targets = [_import_target(node.args[0]) if node.args else ""]
        elif (isinstance(node, ast.Constant) and isinstance(node.value, str)
              and MODULE_NAME.match(node.value)):
            targets = [node.value]   # a module named in a string: a dispatch table, -m
        else:
            continue
        for t in targets:
            if t == "" and name not in DYNAMIC_IMPORTERS:
                raise AssertionError(f"{path}:{node.lineno}: an import by a computed name; "
                                     "name the module, or add the module to DYNAMIC_IMPORTERS "
                                     "with the reason")
            while t and t not in known:  # "loomfmu.x.attr" -> the module "loomfmu.x"
                t = t.rpartition(".")[0]
            if t and t.startswith("loomfmu") and t != name:
                out.add(t)
    return out


#: a string that is a whole loomfmu module name ("loomfmu.heald.claims")
MODULE_NAME = re.compile(r"^loomfmu(\.\w+)+$")


def _dynamic_import(node: ast.Call) -> bool:
    """importlib.import_module(...), import_module(...) or __import__(...)."""
    name = getattr(node.func, "attr", None) or getattr(node.func, "id", None)
    return name in ("import_module", "__import__")


def _import_target(arg) -> str:
    """The module a dynamic import names: a constant, or an f-string's
    constant prefix (``f"loomfmu.models.{m}"`` names the package
    ``loomfmu.models``); anything else names "" (refused below)."""
    if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
        return arg.value
    if isinstance(arg, ast.JoinedStr) and arg.values and isinstance(arg.values[0], ast.Constant):
        return arg.values[0].value.rstrip(".")
    return ""


#: modules that import by a name computed at run time, and why
DYNAMIC_IMPORTERS = {
    "loomfmu.cli.dispatch": "hands a subcommand to the module ANALYSES names",
    "loomfmu": "loads the lazy names of its front door (_LAZY) on first use",
    "loomfmu.sweep.run": "imports, in each worker, the modules its study names",
}


def graph() -> dict[str, set[str]]:
    mods = modules()
    return {n: imports(n, p, set(mods)) for n, p in mods.items()}


def layer_of(module: str) -> tuple[int, str]:
    """(layer index, the package it belongs to) of ``module``."""
    best = None
    for i, packages in enumerate(LAYERS):
        for p in packages:
            if module == p or (p != "loomfmu" and module.startswith(p + ".")):
                if best is None or len(p) > len(best[1]):
                    best = (i, p)
    if best is None:
        raise AssertionError(f"{module}: on no layer; add its package to LAYERS")
    return best


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module."""
    return circles(g)


def violations(g: dict[str, set[str]]) -> list[str]:
    bad = []
    for mod, targets in sorted(g.items()):
        i, pkg = layer_of(mod)
        for t in sorted(targets):
            j, tpkg = layer_of(t)
            if tpkg == pkg or j < i:
                continue
            bad.append(f"{mod} (layer {i}, {pkg}) imports {t} (layer {j}, {tpkg})")
    return bad


def test_no_import_circle():
    found = cycles(graph())
    assert not found, "import circles (imports inside functions count):\n" + "\n".join(
        " <-> ".join(c) for c in found)


def test_imports_follow_the_layers():
    bad = violations(graph())
    assert not bad, "imports against the layer order:\n" + "\n".join(bad)


def test_every_module_is_on_a_layer():
    for mod in modules():
        layer_of(mod)


def test_few_modules_at_the_top():
    top = sorted(p.name for p in SRC.glob("*.py") if p.name not in ("__init__.py", "__main__.py"))
    assert len(top) <= MAX_TOP_MODULES, f"{len(top)} modules directly under src/loomfmu: {top}"


@pytest.mark.parametrize("case", ["circle", "upward"])
def test_the_checks_can_fail(case):
    """The checkers find what they are for, on a made-up graph."""
    if case == "circle":
        g = {"loomfmu.export.a": {"loomfmu.export.b"}, "loomfmu.export.b": {"loomfmu.export.a"}}
        assert cycles(g) == [["loomfmu.export.a", "loomfmu.export.b"]]
    else:
        g = {"loomfmu.declare.model": {"loomfmu.export.codegen"}, "loomfmu.export.codegen": set()}
        assert len(violations(g)) == 1


def test_every_package_says_what_it_owns():
    """Each package's docstring names what it owns and what it may import."""
    for init in sorted(SRC.rglob("__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text())) or ""
        assert doc, f"{init.relative_to(ROOT)}: no docstring"
        if init.parent != SRC and init.parent.parent == SRC:
            assert "import" in doc.lower(), (
                f"{init.relative_to(ROOT)}: the docstring does not say what it may import")


def test_every_folder_of_code_is_a_package():
    """A folder of modules without __init__.py passes the layer checks but is
    left out of the wheel (setup.py finds packages by their __init__.py)."""
    for base in (SRC, MODELS):
        for folder in [base, *(p for p in base.rglob("*") if p.is_dir())]:
            if "__pycache__" in folder.parts or not any(folder.glob("*.py")):
                continue
            assert (folder / "__init__.py").is_file(), f"{folder.relative_to(ROOT)}: no __init__.py"


def test_dynamic_imports_are_seen(tmp_path):
    """Imports by import_module, __import__, an f-string prefix or a module
    name in a string count; an import by a computed name is refused."""
    probe = tmp_path / "probe.py"
    probe.write_text("from importlib import import_module\n"
                     "import_module('loomfmu.heald')\n__import__('loomfmu.drive')\n"
                     "import importlib\nimportlib.import_module(f'loomfmu.spindle.{1}')\n"
                     "TABLE = {'h': 'loomfmu.machines.loom'}\n")
    known = set(modules())
    got = imports("loomfmu.scene.probe", probe, known)
    assert {"loomfmu.heald", "loomfmu.drive", "loomfmu.spindle", "loomfmu.machines.loom"} <= got
    probe.write_text("import importlib\nM = 'x'\nimportlib.import_module(M)\n")
    with pytest.raises(AssertionError, match="computed name"):
        imports("loomfmu.scene.probe", probe, known)


def _may_import(doc: str) -> str | None:
    """The text of a package docstring's "May import:" paragraph; None where
    it says a rule ("every layer ...") instead of a list."""
    m = re.search(r"May import:(.*?)(?:\n\s*\n|$)", doc, flags=re.S)
    if m is None or "every layer" in m.group(1) or "all below" in m.group(1):
        return None
    return m.group(1)


def test_each_package_lists_what_it_imports():
    """A package whose docstring lists what it may import lists every loomfmu
    package its modules do import (the test above checks the order; this one
    that the docstring a maintainer reads is true)."""
    g = graph()
    bad = []
    for init in sorted(SRC.glob("*/__init__.py")) + [MODELS / "__init__.py"]:
        pkg = f"loomfmu.{init.parent.name}"
        listed = _may_import(ast.get_docstring(ast.parse(init.read_text())) or "")
        if listed is None:
            continue
        used = {t.split(".")[1] for mod, targets in g.items()
                if mod == pkg or mod.startswith(pkg + ".") for t in targets
                if t.count(".") >= 1 and not t.startswith(pkg)}
        missing = sorted(u for u in used if not re.search(rf"\b{u}\b", listed))
        if missing:
            bad.append(f"{init.relative_to(ROOT)}: imports {', '.join(missing)} but its "
                       "docstring's 'May import:' does not name them")
    assert not bad, "\n".join(bad)
