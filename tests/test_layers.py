"""The package layers of loomfmu (CONTRIBUTING.md draws them), enforced.

Every import counts, the ones inside functions too: an import moved into a
function to dodge a circle still ties the two modules together.  A module
may import modules of its own package and of packages on a lower layer;
packages on one layer do not import each other.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

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
        elif (isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "import_module"
              and node.args and isinstance(node.args[0], ast.Constant)):
            targets = [node.args[0].value]
        else:
            continue
        for t in targets:
            while t and t not in known:  # "loomfmu.x.attr" -> the module "loomfmu.x"
                t = t.rpartition(".")[0]
            if t and t.startswith("loomfmu") and t != name:
                out.add(t)
    return out


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
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


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
