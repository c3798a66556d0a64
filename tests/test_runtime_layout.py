"""The C runtime's layout: no dependency cycle between its files outside the
documented units, and no source or header file longer than MAX_LINES.

Every runtime file, header or source, is a file of the graph; a header and
the .c file of the same name (lf_eval.h and lf_eval.c) are one unit.  A
file depends on another when it takes a name from it:
- a global lf_ function or table the other .c file defines, referred to (a
  call, an address) in a body or an initializer; a header's static inline
  functions and macros refer on the header's behalf; declarations
  (prototypes, extern) are not references;
- a macro, type (typedef, struct, union or enum tag), enumeration constant
  or static inline function the other header defines, used anywhere
  (prototypes, struct members, macro bodies and #if lines too).
Files that depend on each other on purpose form a unit, listed in UNITS and
described in docs/guides/runtime.md and in their headers; a cycle inside
one unit is allowed, any other fails.

Run against another runtime folder (e.g. to see the check fail on an older
tree):

    python tests/test_runtime_layout.py PATH/TO/runtime
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

from graphs import circles

RUNTIME_DIR = Path(__file__).resolve().parents[1] / "src" / "loomfmu" / "runtime"

MAX_LINES = 600

#: Files that may call each other (each a unit of one concern, documented
#: as such in docs/guides/runtime.md and in the files' headers).
#: None today: the runtime's files are layered (docs/guides/runtime.md).
UNITS: tuple[frozenset[str], ...] = ()

# a global definition at file scope (the runtime's style: column 0, not
# static), as runtime_files.RUNTIME_SYMBOLS reads them
_GLOBAL_DEF = re.compile(r"^(?!static\b|typedef\b|extern\b|return\b)[A-Za-z_][^;(=]*?"
                         r"\b(lf_\w+)\s*[\(\[=]", re.M)
_COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)
_IDENT = re.compile(r"\blf_\w+\b")


_DEFINE = re.compile(r"^[ \t]*#[ \t]*define[ \t]+(\w+)((?:[^\n]*\\\n)*[^\n]*)", re.M)


def _strip(text: str) -> str:
    """Without comments and preprocessor lines (macros: _macros)."""
    text = _COMMENT.sub(" ", text)
    text = _DEFINE.sub(" ", text)
    return re.sub(r"^[ \t]*#[^\n]*", " ", text, flags=re.M)


def _macros(text: str) -> dict[str, set[str]]:
    """The lf_ identifiers each macro of a file refers to."""
    return {m.group(1): set(_IDENT.findall(m.group(2)))
            for m in _DEFINE.finditer(_COMMENT.sub(" ", text))}


def _definitions(text: str) -> set[str]:
    """Global functions and tables defined by a .c file (with a body or an
    initializer: not a prototype)."""
    names = set()
    for m in _GLOBAL_DEF.finditer(text):
        rest = text[m.end() - 1:]
        if rest[0] == "(":  # a function: a body follows, not a ';'
            depth, i = 0, 0
            for i, ch in enumerate(rest):  # noqa: B007 (i is read after the loop)
                depth += ch == "("
                depth -= ch == ")"
                if depth == 0:
                    break
            if rest[i + 1:].lstrip().startswith("{"):
                names.add(m.group(1))
        else:
            names.add(m.group(1))
    return names


def _references(text: str, macros: dict[str, set[str]]) -> set[str]:
    """lf_ identifiers used in bodies and initializers (also through the
    macros used there); top-level declarations without an initializer
    (prototypes, extern) do not count."""
    used = _direct_references(text)
    names = set(re.findall(r"\b\w+\b", text)) & set(macros)
    seen: set[str] = set()
    while names:
        name = names.pop()
        seen.add(name)
        used |= macros[name]
        names |= (macros[name] & set(macros)) - seen
    return used


def _direct_references(text: str) -> set[str]:
    used, depth, stmt = set(), 0, []
    for ch in text:
        if depth == 0:
            stmt.append(ch)
            if ch == ";":
                s = "".join(stmt)
                if "=" in s:  # a table or variable with its initializer
                    used.update(_IDENT.findall(s.split("=", 1)[1]))
                stmt = []
            elif ch == "{":
                s = "".join(stmt)
                if "=" in s:  # an initializer in braces
                    used.update(_IDENT.findall(s.split("=", 1)[1]))
                stmt = []
                depth = 1
            continue
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
            if depth == 0:
                stmt = []
                continue
        stmt.append(ch)
        if depth > 0 and ch in ";{}":
            used.update(_IDENT.findall("".join(stmt)))
            stmt = []
    used.update(_IDENT.findall("".join(stmt)))
    return used


def _inline_functions(text: str) -> dict[str, str]:
    """The static inline functions of a header by name, with their bodies
    (they refer to symbols on behalf of the files that call them)."""
    out = {}
    for m in re.finditer(r"^static\s+inline\b[^{;]*?\b(\w+)\s*\([^{;]*\{", text, re.M):
        i = m.end() - 1
        depth = 0
        for j in range(i, len(text)):
            depth += text[j] == "{"
            depth -= text[j] == "}"
            if depth == 0:
                out[m.group(1)] = text[i:j + 1]
                break
    return out


# literal strings and comments, in one pass (a comment opener inside a
# string is text, not a comment)
_LEXEMES = re.compile(r'"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'|/\*.*?\*/|//[^\n]*', re.S)
_WORD = re.compile(r"\b[A-Za-z_]\w*\b")
_TAG = re.compile(r"\b(?:struct|union|enum)\s+(\w+)\s*\{")
_ENUM_BODY = re.compile(r"\benum\b[^{;]*\{([^}]*)\}")
_FN_PTR_TYPEDEF = re.compile(r"\(\s*\*\s*(\w+)\s*\)")


def _clean(text: str) -> str:
    """Without comments and string literals (an include's file name is a
    string: no name is read from it)."""
    return _LEXEMES.sub(lambda m: '""' if m.group(0)[0] in "\"'" else " ", text)


def _top_level_statements(text: str) -> list[str]:
    """The statements at file scope of a preprocessed-looking text, braces
    included (a function's body ends its statement)."""
    out, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        elif ch == ";" and depth == 0:
            out.append(text[start:i + 1])
            start = i + 1
    return out


def header_names(text: str) -> set[str]:
    """The names a header defines for the files that use it: macros, types
    (typedef names, struct, union and enum tags), enumeration constants and
    static inline functions.  Prototypes and extern declarations define
    nothing: their names belong to the .c file that defines them."""
    text = _clean(text)
    names = {m.group(1) for m in _DEFINE.finditer(text)}
    body = _strip(text)
    names |= set(_inline_functions(body))
    names |= set(_TAG.findall(body))
    for m in _ENUM_BODY.finditer(body):
        names |= {e.split("=")[0].strip() for e in m.group(1).split(",") if e.strip()}
    for stmt in _top_level_statements(body):
        stmt = stmt.strip()
        if not stmt.startswith("typedef"):
            continue
        m = _FN_PTR_TYPEDEF.search(stmt)
        if m:
            names.add(m.group(1))
            continue
        tail = re.sub(r"\[[^\]]*\]", " ", stmt[stmt.rfind("}") + 1:] if "}" in stmt else stmt)
        words = _WORD.findall(tail)
        if words:
            names.add(words[-1])
    return names


def unit_of_file(name: str, names: set[str]) -> str:
    """A header and the .c file of the same name are one unit (named by the
    .c file): the header declares what the file defines."""
    if name.endswith(".h") and name[:-2] + ".c" in names:
        return name[:-2] + ".c"
    return name


def dependencies(runtime_dir: Path) -> dict[str, set[str]]:
    """For each runtime unit (a .c file with its header of the same name, or
    a header without a .c file): the other units it takes a name from.

    A unit takes a name from the .c file that defines a global function or
    table it refers to in a body or an initializer (a call, an address; a
    header's static inline functions and macros refer on the header's
    behalf, declarations do not refer), and from the header that defines a
    macro, a type, an enumeration constant or a static inline function it
    uses anywhere (prototypes, struct members, macros and #if lines too)."""
    runtime_dir = Path(runtime_dir)
    raw = {p.name: p.read_text() for p in runtime_dir.glob("lf_*.[ch]")}
    files = set(raw)
    clean = {name: _clean(t) for name, t in raw.items()}
    stripped = {name: _strip(t) for name, t in clean.items()}
    fn_owner: dict[str, str] = {}    # global functions and tables: their .c file
    name_owner: dict[str, str] = {}  # macros, types, inline functions: their header
    for name in sorted(raw):
        if name.endswith(".c"):
            for sym in _definitions(stripped[name]):
                fn_owner[sym] = unit_of_file(name, files)
        else:
            for sym in header_names(raw[name]):
                name_owner.setdefault(sym, unit_of_file(name, files))
    deps: dict[str, set[str]] = {unit_of_file(n, files): set() for n in raw}
    for name in sorted(raw):
        unit = unit_of_file(name, files)
        refs = _direct_references(stripped[name])
        for body in _macros(clean[name]).values():
            refs |= body
        words = set(_WORD.findall(re.sub(r"^[ \t]*#[ \t]*(?:define|undef)[ \t]+\w+", " ",
                                         clean[name], flags=re.M)))
        deps[unit] |= {fn_owner[s] for s in refs if s in fn_owner}
        deps[unit] |= {name_owner[s] for s in words if s in name_owner}
        deps[unit].discard(unit)
    return deps


def _unit_of(name: str) -> frozenset[str]:
    for unit in UNITS:
        if name in unit:
            return unit
    return frozenset({name})


def cycles(deps: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one file that are not
    inside one documented unit."""
    return [c for c in circles(deps) if not set(c) <= _unit_of(c[0])]


def long_files(runtime_dir: Path) -> dict[str, int]:
    return {p.name: n for p in sorted(Path(runtime_dir).glob("lf_*.[ch]"))
            if (n := len(p.read_text().splitlines())) > MAX_LINES}


def _describe(comp: list[str], deps: dict[str, set[str]]) -> str:
    edges = [f"{a} -> {b}" for a in comp for b in sorted(deps[a]) if b in comp]
    return f"{', '.join(comp)}: " + "; ".join(edges)


def test_no_call_cycle_between_runtime_files():
    deps = dependencies(RUNTIME_DIR)
    found = cycles(deps)
    assert not found, "dependency cycles between runtime files outside a documented unit:\n" + \
        "\n".join(_describe(c, deps) for c in found)


def test_runtime_files_are_short():
    assert not long_files(RUNTIME_DIR), f"runtime files past {MAX_LINES} lines"


def test_units_are_documented():
    doc = (RUNTIME_DIR.parents[2] / "docs" / "guides" / "runtime.md").read_text()
    for unit in UNITS:
        for name in unit:
            assert name in doc
            head = (RUNTIME_DIR / name).read_text()[:1500]
            others = sorted(unit - {name})
            assert all(o in head for o in others), f"{name}'s header names its unit {others}"


def test_the_check_sees_a_cycle(tmp_path):
    (tmp_path / "lf_a.c").write_text("int lf_a(void) {\n    return lf_b();\n}\n")
    (tmp_path / "lf_b.c").write_text("int lf_b(void) {\n    return lf_c() + 1;\n}\n")
    (tmp_path / "lf_c.c").write_text('#include "lf_c.h"\nint lf_c(void) {\n    return 2;\n}\n')
    # a header's inline function calls on the header's behalf; the header
    # is one unit with lf_c.c
    (tmp_path / "lf_c.h").write_text("int lf_a(void);\nstatic inline int lf_d(void) "
                                     "{ return lf_a(); }\n")
    # a prototype takes no name from the .c file that defines it
    (tmp_path / "lf_g.c").write_text('#include "lf_c.h"\nint lf_g(void) {\n    return 3;\n}\n')
    # types and macros of a header: a dependency on the header
    (tmp_path / "lf_t.h").write_text("#define LF_T_N 3\ntypedef struct { int v[LF_T_N]; } LfT;\n"
                                     "typedef enum { LF_T_A = 1, LF_T_B } LfTKind;\n")
    (tmp_path / "lf_u.h").write_text('#include "lf_t.h"\nint lf_u(LfT *t);\n')
    (tmp_path / "lf_u.c").write_text('#include "lf_u.h"\nint lf_u(LfT *t) {\n'
                                     "    return t->v[0] + LF_T_B;\n}\n")
    deps = dependencies(tmp_path)
    assert deps == {"lf_a.c": {"lf_b.c"}, "lf_b.c": {"lf_c.c"}, "lf_c.c": {"lf_a.c"},
                    "lf_g.c": set(), "lf_t.h": set(), "lf_u.c": {"lf_t.h"}}
    assert cycles(deps) == [["lf_a.c", "lf_b.c", "lf_c.c"]]
    # a bottom header whose inline function calls a file that uses its types
    (tmp_path / "lf_t.h").write_text("#define LF_T_N 3\ntypedef struct { int v[LF_T_N]; } LfT;\n"
                                     "typedef enum { LF_T_A = 1, LF_T_B } LfTKind;\n"
                                     "int lf_u(LfT *t);\n"
                                     "static inline int lf_t_of(LfT *t) { return lf_u(t); }\n")
    assert sorted(cycles(dependencies(tmp_path))) == [["lf_a.c", "lf_b.c", "lf_c.c"],
                                                       ["lf_t.h", "lf_u.c"]]
    # the same through a macro of the header
    (tmp_path / "lf_t.h").write_text("#define LF_T_N 3\n#define LF_T_OF(t) lf_u(t)\n"
                                     "typedef struct { int v[LF_T_N]; } LfT;\n")
    (tmp_path / "lf_u.c").write_text('#include "lf_u.h"\nint lf_u(LfT *t) {\n'
                                     "    return t->v[0];\n}\n")
    assert sorted(cycles(dependencies(tmp_path))) == [["lf_a.c", "lf_b.c", "lf_c.c"],
                                                       ["lf_t.h", "lf_u.c"]]


def main(argv: list[str]) -> int:
    paths = [a for a in argv[1:] if not a.startswith("-")]
    runtime_dir = Path(paths[0]) if paths else RUNTIME_DIR
    deps = dependencies(runtime_dir)
    if "-v" in argv:
        for name, ds in sorted(deps.items()):
            print(f"{name}: {' '.join(sorted(ds))}")
    bad = 0
    for comp in cycles(deps):
        print("cycle:", _describe(comp, deps))
        bad = 1
    for name, n in long_files(runtime_dir).items():
        print(f"too long: {name} has {n} lines (at most {MAX_LINES})")
        bad = 1
    print("runtime layout:", "problems found" if bad else "ok")
    return bad


if __name__ == "__main__":
    sys.exit(main(sys.argv))
