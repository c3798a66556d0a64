"""``loomfmu inspect MODEL``: a model's equations as a machine designer reads them.

Writes one report: the variables with units, the derivation (the model's
named quantities under their group headings, see
:mod:`loomfmu.inspection.derivation`), the equations (shared
subexpressions named once, see :mod:`loomfmu.inspection.readable`), and how the runtime
solves the model: the unknowns, whether they come in closed form or by
Newton, the Jacobian's sparsity, the event indicators and modes, the delays,
the parameter constraints and the size of the generated C.

Formats: ``html`` (MathML, no JavaScript, no network: renders in every
current browser), ``md`` (LaTeX between ``$$`` for GitHub and Jupyter),
``tex`` (a LaTeX document for papers).
"""
from __future__ import annotations

import re
import sys
import tempfile
from pathlib import Path

import casadi as ca
import sympy

from loomfmu.declare.checks import OneLineParser, check_writable
from loomfmu.export.codegen import generate_sources
from loomfmu.export.dae import DaeForm, dae_form
from loomfmu.inspection import readable
from loomfmu.inspection.derivation import derivation
from loomfmu.inspection.document import (
    RENDERERS,
    Code,
    Equations,
    Math,
    Pre,
    Section,
    Table,
    _html_blocks,
    _scoped_css,
    render_html,
    render_md,
    render_tex,
)
from loomfmu.registry import MODELS, load_model

__all__ = ["FORMATS", "document", "report", "write_reports", "html_fragment", "main",
           "render_html", "render_md", "render_tex", "Section", "Equations"]

FORMATS = tuple(RENDERERS)
KIND_TITLES = {"parameter": "Parameters", "state": "States", "input": "Inputs",
               "output": "Outputs", "algebraic": "Algebraic variables", "mode": "Modes"}


# -- content -------------------------------------------------------------------

def _fmt(v) -> str:
    if v is None:
        return ""
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def _sym(name: str) -> Math:
    return Math(readable.Var(name))


def _eq(lhs, rhs) -> sympy.Eq:
    return sympy.Eq(lhs, rhs, evaluate=False)


#: parameters named prefix + index (cam_A1 ... cam_A96) with one unit, one
#: source and one description up to the index form a family; a family of at
#: least this many is one row of the parameter table, its values a table of
#: their own (the drive's 192 cam coefficients were 192 rows)
FAMILY_MIN = 8


def _families(params) -> dict[str, list]:
    """prefix -> [(index, variable), ...] of the parameter families (FAMILY_MIN)."""
    groups: dict[tuple, list] = {}
    for v in params:
        m = re.fullmatch(r"(.*\D)(\d+)", v.name)
        if m:
            template = re.sub(rf"(?<!\d){m.group(2)}(?!\d)", "j", v.description)
            groups.setdefault((m.group(1), v.unit, v.source, template), []).append(
                (int(m.group(2)), v))
    return {key[0]: members for key, members in groups.items() if len(members) >= FAMILY_MIN}


def _range(v) -> str:
    """A parameter's allowed range, as the FMU checks it ([min, max])."""
    return f"[{_fmt(float(v.min))}, {_fmt(float(v.max))}]"


def _family_row(prefix: str, members: list) -> list:
    first, last = members[0][1], members[-1][1]
    template = re.sub(rf"(?<!\d){members[0][0]}(?!\d)", "j", first.description)
    ranges = {_range(v) for _, v in members}
    return [Code(f"{first.name} \u2026 {last.name}"), _sym(f"{prefix}j"), first.unit,
            f"{len(members)} values (table below)",
            ranges.pop() if len(ranges) == 1 else "each its own", template, first.source]


def _family_tables(families: dict[str, list]) -> list:
    """The families' values, one table per set of indices (cam_Aj beside cam_Bj)."""
    by_index: dict[tuple, list[str]] = {}
    for prefix, members in families.items():
        by_index.setdefault(tuple(i for i, _ in members), []).append(prefix)
    out = []
    for indices, prefixes in by_index.items():
        values = {p: {i: v.start for i, v in families[p]} for p in prefixes}
        out.append(f"Values of {', '.join(p + 'j' for p in prefixes)}:")
        out.append(Table(["j"] + [f"{p}j" for p in prefixes],
                         [[str(i)] + [_fmt(values[p][i]) for p in prefixes] for i in indices]))
    return out


def _variables(model) -> list[Section]:
    out = []
    for kind, title in KIND_TITLES.items():
        vs = model.of_kind(kind)
        if not vs:
            continue
        head = (["name", "symbol", "unit", "value", "range", "description", "source"]
                if kind == "parameter" else ["name", "symbol", "unit", "start", "description"])
        families = _families(vs) if kind == "parameter" else {}
        member = {v.name: p for p, ms in families.items() for _, v in ms}
        rows = []
        for v in vs:
            if v.name in member:   # the family's row where its first member stood
                prefix = member[v.name]
                if families[prefix][0][1] is v:
                    rows.append(_family_row(prefix, families[prefix]))
                continue
            start = _fmt(v.start)
            if kind == "mode":
                start += f" (values {', '.join(map(str, model.mode_values[v.name]))})"
            rows.append([Code(v.name), _sym(v.name), v.unit, start, _range(v), v.description,
                         v.source] if kind == "parameter" else
                        [Code(v.name), _sym(v.name), v.unit, start, v.description])
        out.append(Section(f"{title} ({len(vs)})", [Table(head, rows)] +
                           _family_tables(families), level=3))
    return out


#: the prefix of the report's own equation labels, E1, E2, ... (the seeds number
#: theirs (1), (2), ...; docs/guides/derivation.md gives the convention)
EQUATION_TAG = "E"


def _equations(model, lst: readable.Listing) -> Section:
    sec = Section("Equations")
    used = _quantities_used(model, lst)
    if used:
        sec.blocks += [f"Written with the derivation's named quantities wherever the model "
                       f"uses them; those used below ({len(used)}, each defined in the "
                       "Derivation above, a matrix's entries by their indices):",
                       Table(["symbol", "quantity", "group"],
                             [[Math(readable.QuantitySymbol(q.name, q.symbol)), Code(q.name),
                               q.group] for q in used])]
    if lst.shared:
        sec.blocks += [f"Shared subexpressions that have no name in the derivation, each "
                       f"defined once and used by name below ({len(lst.shared)}):",
                       Equations([(_eq(s, d), "") for s, d in lst.shared])]
    sec.blocks += [f"The {len(lst.equations)} equations (terms with the unknowns "
                   "der(x) and the algebraic variables on the left), numbered "
                   f"{EQUATION_TAG}1, {EQUATION_TAG}2, ... apart from the seed's own "
                   "equation numbers:",
                   Equations([(_eq(lhs, rhs), f"{EQUATION_TAG}{k}")
                              for k, (lhs, rhs) in enumerate(lst.equations, 1)])]
    if lst.outputs:
        sec.blocks += [f"The {len(lst.outputs)} outputs:",
                       Equations([(_eq(y, e), "") for y, e in lst.outputs])]
    return sec


def _quantities_used(model, lst: readable.Listing) -> list:
    """The quantities whose symbols (or entries' symbols) the printed lines
    use directly, in declaration order."""
    lines = [e for pair in lst.shared + lst.equations + lst.outputs + lst.events
             + lst.modes + lst.delays for e in pair]
    names, seen, todo = set(), set(), list(lines)
    while todo:  # each node once (a DAG walked as a tree is exponential)
        e = todo.pop()
        if e in seen:
            continue
        seen.add(e)
        if isinstance(e, readable.QuantitySymbol):
            names.add(e.name.split("[")[0])
        todo += e.args
    return [q for q in model.quantities if q.name in names]


def _sparsity(jac: ca.Sparsity, rows: int, cols: int) -> str:
    grid = [["\u00b7"] * cols for _ in range(rows)]
    for r, c in zip(jac.row(), jac.get_col()):
        grid[r][c] = "\u25a0"
    width = len(str(rows))
    return "\n".join(f"{k + 1:>{width}} " + "".join(line) for k, line in enumerate(grid))


def _solving(model, dae: DaeForm) -> Section:
    nw, nx = dae.w.numel(), dae.nx
    names = [s.name() for s in ca.vertsplit(dae.w)]
    A = ca.jacobian(dae.F, dae.w)
    sec = Section("How the runtime solves the model")
    sec.blocks.append(
        f"Unknowns at each instant: w = [der(x); z], {nx} state derivatives and "
        f"{nw - nx} algebraic variables, from the {nw} equations F(t, x, w, u, p, q, d) = 0.")
    if not dae.implicit:
        sec.blocks.append(
            "F is linear in w: every unknown is in closed form, w = -A\u207b\u00b9 F(w = 0) "
            "with A = \u2202F/\u2202w formed symbolically; no Newton iteration.")
    else:
        second = [i for i in range(nw) if ca.depends_on(A[i, :], dae.w)]
        nonlin = sorted({names[j] for i in second for j in range(nw)
                         if ca.depends_on(A[i, :], dae.w[j])})
        sec.blocks.append(
            f"F is nonlinear in w: the runtime solves all {nw} unknowns together by "
            "Newton's method with the exact Jacobian \u2202F/\u2202w, at every right-hand "
            f"side evaluation. Equations nonlinear in w: "
            f"{', '.join(f'{EQUATION_TAG}{i + 1}' for i in second)}; "
            "unknowns that enter them nonlinearly:")
        sec.blocks.append(Table(["name", "symbol"], [[Code(n), _sym(n)] for n in nonlin]))
    sp = A.sparsity()
    sec.blocks += [f"Sparsity of \u2202F/\u2202w ({nw} \u00d7 {nw}, {sp.nnz()} structural "
                   "non-zeros; rows: equations, columns: unknowns in this order):",
                   Table(["column", "unknown", "symbol"],
                         [[str(j + 1), Code(n), _sym(n)] for j, n in enumerate(names)]),
                   Pre(_sparsity(sp, nw, nw))]
    return sec


def _events(model, lst: readable.Listing) -> Section | None:
    if not model.events and not model.mode_values:
        return None
    sec = Section("Event indicators and modes")
    table = readable.symbols(model)
    if model.events:
        sec.blocks += ["The solvers locate each sign change of an indicator inside the "
                       "step (on the interpolant) and restart there; the indicators, "
                       "written with the shared subexpressions above:",
                       Equations([(_eq(y, e), "") for y, e in lst.events]),
                       Table(["indicator", "symbol", "description", "re-chooses mode"],
                             [[Code(e.name), _sym(e.name), e.description,
                               model.event_modes.get(e.name, "")] for e in model.events])]
    rules = dict((y.name, e) for y, e in lst.modes)
    for v in model.of_kind("mode"):
        sec.blocks += [f"Mode {v.name} ({v.description}): at an event the runtime takes "
                       f"the first value, in the order {model.mode_values[v.name]}, at which "
                       "this validity expression is \u2265 0:",
                       Equations([(_eq(readable.Var(f"valid_{v.name}"), rules[v.name]), "")])]
    if model.reinits:
        sec.blocks += ["States after a mode change:",
                       Equations([(_eq(readable.Var(n), readable.to_sympy(e, table)), "")
                                  for n, e in model.reinits.items()])]
    return sec


def _delays(model, lst: readable.Listing) -> Section | None:
    if not model.delays:
        return None
    table = readable.symbols(model)
    rows = [[Code(d.name), Math(readable.Var(d.sym.name())),
             Math(readable.to_sympy(d.tau, table)), _fmt(d.max_delay), d.description]
            for d in model.delays]
    return Section("Delays", [
        "Each delayed value is its expression taken \u03c4 seconds ago; the runtime keeps "
        "its history (constant at the start value before the start time) and restarts "
        "the step at the breakpoints t\u2080 + k\u03c4.",
        Table(["delay", "symbol", "\u03c4", "longest \u03c4 held (s)", "description"], rows),
        "The delayed expressions (with the shared subexpressions above), each taken at "
        "t \u2212 \u03c4:",
        Equations([(_eq(y, e), "") for y, e in lst.delays])])


def _constraints(model) -> Section | None:
    if not model.constraints:
        return None
    table = readable.symbols(model)
    return Section("Constraints on the parameters", [
        "Checked at initialization (the FMU refuses to start otherwise):",
        Table(["name", "must be \u2265 0", "message"],
              [[Code(c.name), Math(readable.to_sympy(c.expr, table)), c.message]
               for c in model.constraints])])


def _validity(model) -> Section | None:
    if not model.validity:
        return None
    forms = readable.written_with_quantities(model, [c.expr for c in model.validity])
    return Section("Validity conditions", [
        "Checked while the model runs, on every accepted step like an event indicator; "
        "where one turns negative the step ends there with fmi2Discard and a log line "
        "(its message, value and time). Each must stay \u2265 0 (written with the "
        "derivation's quantities):",
        Equations([(sympy.Ge(f, 0, evaluate=False), f"v{k}")  # tags: no "_" for TeX
                   for k, f in enumerate(forms, 1)]),
        Table(["tag", "condition", "message"],
              [[f"v{k}", Code(c.name), c.message] for k, c in enumerate(model.validity, 1)])])


def _c_size(model, dae: DaeForm) -> Section:
    with tempfile.TemporaryDirectory() as tmp:
        files, _ = generate_sources(model, dae, Path(tmp))
        rows = []
        for f in files:
            text = (Path(tmp) / f).read_text()
            rows.append([Code(f), str(text.count("\n")), str(len(text.encode()))])
    return Section("Generated C", [
        "The model's C files (the shared runtime comes on top):",
        Table(["file", "lines", "bytes"], rows)])


def document(model) -> tuple[str, list[Section]]:
    """The report's title and sections for a declared model."""
    dae = dae_form(model)
    about = Section("Model", [model.description or model.name])
    if model.options:
        about.blocks.append("Built with " + ", ".join(f"{k} = {v!r}"
                                                       for k, v in model.options.items()))
    lst = readable.listing(model)
    sections = [about, Section("Variables", _variables(model)), derivation(model),
                _equations(model, lst),
                _solving(model, dae), _events(model, lst), _delays(model, lst),
                _constraints(model), _validity(model), _c_size(model, dae)]
    what = "derivation, equations and solution" if model.quantities else \
        "equations and solution"
    return f"{model.name}: {what}", [s for s in sections if s]


#: the sections of the report that another page (the FMU's documentation)
#: takes over; it has its own about and variables sections
DERIVATION_SECTIONS = ("Derivation", "Equations", "How the runtime solves the model",
                       "Event indicators and modes", "Delays",
                       "Constraints on the parameters", "Validity conditions")


def html_fragment(model, *, level: int = 3) -> str:
    """The derivation (named quantities), equations, how the runtime solves
    them, events, delays and constraints of ``model`` as an HTML fragment
    (MathML, its own scoped style, no script) for embedding in another page,
    headings from <h{level}> (a section's groups one level below)."""
    _, sections = document(model)
    kept = [_relevel(s, level) for s in sections if s.title in DERIVATION_SECTIONS]
    return (f'<div class="lf-derivation"><style>{_scoped_css(".lf-derivation")}</style>'
            + "\n".join(_html_blocks(kept)) + "</div>")


def _relevel(s: Section, level: int) -> Section:
    return Section(s.title, [_relevel(b, min(level + 1, 6)) if isinstance(b, Section) else b
                             for b in s.blocks], level)


def report(model, fmt: str = "html") -> str:
    """The report of a declared model in format ``fmt`` (one of FORMATS)."""
    if fmt not in RENDERERS:
        raise ValueError(f"fmt = {fmt!r}; allowed: {', '.join(FORMATS)}")
    return RENDERERS[fmt](*document(model))


#: where ``loomfmu inspect --all`` writes (the reports kept in the repository)
ALL_OUT = Path("docs/reference/inspect")
#: the formats ``--all`` writes unless --format says otherwise
ALL_FORMATS = ("html", "md")


def write_reports(names, formats, out_dir: Path) -> list[Path]:
    """Write ``out_dir/<model>.<format>`` for every model name and format
    (each model declared and its document built once); returns the paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in names:
        doc = document(load_model(name))
        for fmt in formats:
            path = out_dir / f"{name}.{fmt}"
            path.write_text(RENDERERS[fmt](*doc), encoding="utf-8")
            paths.append(path)
    return paths


def main(argv=None, prog: str = "loomfmu inspect") -> int:
    ap = OneLineParser(prog=prog, description="A model's derivation and equations "
                                 "as a machine designer reads them: HTML with MathML, "
                                 "Markdown with LaTeX, or LaTeX.")
    ap.add_argument("model", metavar="MODEL", nargs="?", choices=sorted(MODELS),
                    help=f"one of {', '.join(sorted(MODELS))} (or --all)")
    ap.add_argument("--all", action="store_true",
                    help=f"every model: OUT/<model>.<format> (default OUT: {ALL_OUT}, "
                         f"formats: {' and '.join(ALL_FORMATS)})")
    ap.add_argument("--format", choices=FORMATS, action="append", default=None,
                    help="html (MathML), md (Markdown with LaTeX) or tex; repeatable "
                         "(default: html; with --all: html and md)")
    ap.add_argument("--out", type=Path, default=None,
                    help="file to write (default: MODEL.FORMAT in the working directory; "
                         "'-' prints to standard output); a directory with --all or "
                         "several formats")
    args = ap.parse_args(argv)
    if args.all == (args.model is not None):
        ap.error("give either MODEL or --all")
    formats = list(dict.fromkeys(args.format or (ALL_FORMATS if args.all else ["html"])))
    if args.all or len(formats) > 1:
        if str(args.out) == "-":
            ap.error("--out - prints one report: give one MODEL and one --format")
        out_dir = args.out or (ALL_OUT if args.all else Path("."))
        try:  # a directory with --all or several formats
            check_writable("--out", out_dir, folder=True)
        except ValueError as exc:
            ap.exit(2, f"{ap.prog}: error: {exc}\n")
        names = sorted(MODELS) if args.all else [args.model]
        for path in write_reports(names, formats, out_dir):
            print(f"written: {path}")
        return 0
    if args.out is not None and str(args.out) != "-":
        try:
            check_writable("--out", args.out)
        except ValueError as exc:
            ap.exit(2, f"{ap.prog}: error: {exc}\n")
    text = report(load_model(args.model), formats[0])
    if str(args.out) == "-":
        sys.stdout.write(text)
        return 0
    path = args.out or Path(f"{args.model}.{formats[0]}")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    print(f"written: {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
