"""The printed equations are the equations that run.

For every model in loomfmu.MODELS: every equation residual, every output's
defining expression, every event indicator, mode rule, reinit, start
expression, delay and constraint is converted to SymPy (loomfmu.inspection.readable),
then the printed form (the Listing: shared subexpressions named once, the
equations as lhs = rhs, the outputs, event indicators, mode rules and
delayed expressions; the
rest converted directly) and the CasADi form are evaluated at
random points and must agree to rounding.  A tampered op table must be
caught by the same comparison.
"""
from __future__ import annotations

import functools
import math
import re
import time
import xml.dom.minidom

import casadi as ca
import numpy as np
import pytest
import sympy

from loomfmu import MODELS, load_model
from loomfmu.inspection import readable
from loomfmu.inspection.readable.listing import _lift


@functools.lru_cache(maxsize=None)
def shared_model(name: str):
    """One declaration of ``name`` for the tests of this file that only read it:
    the SymPy forms of its quantities (tens of seconds for the spindles) are
    kept per Model object, so they are computed once per process."""
    return load_model(name)


RTOL = 1e-9
N_POINTS = 4
MAX_TRIES = 12


def _extras(model) -> list[ca.SX]:
    """Every other expression of the declaration (besides the listing's
    equations, outputs, event indicators, mode rules and delayed expressions)."""
    out = list(model.reinits.values()) + list(model.initials.values())
    out += [d.tau for d in model.delays]
    out += [c.expr for c in model.constraints]
    return [ca.SX(e) for e in out]


def _scale(model, name: str) -> tuple[float, float, bool]:
    """(centre, spread, is_parameter) of a sensible random value for symbol ``name``."""
    if name == model.t.name():
        return 0.5, 0.5, False
    inner = name[4:-1] if name.startswith("der(") else name
    if inner.startswith("delay("):
        inner = next(d.expr for d in model.delays if d.sym.name() == inner)
        inner = ca.symvar(ca.SX(inner))[0].name()
    var = model.var(inner)
    size = abs(var.start) if var.start else (var.nominal or 1.0)
    if var.kind == "parameter":
        return var.start, 0.2 * abs(var.start), True
    if var.kind == "mode":
        return 0.0, 0.0, False
    return 0.0, size, False


@functools.lru_cache(maxsize=None)
def _listing(name: str) -> readable.Listing:
    """The listing of model ``name`` (cached: the spindle's takes seconds)."""
    return readable.listing(load_model(name))


def _points(model, names: list[str], rng: np.random.Generator, shrink: float) -> np.ndarray:
    """One random point per row: parameters within +-20 % of their defaults
    (clipped to their range), other variables within their own magnitude
    (times ``shrink``), modes at one of their allowed values."""
    pts = np.empty((N_POINTS, len(names)))
    for j, name in enumerate(names):
        centre, spread, is_par = _scale(model, name)
        if name in model.mode_values:
            pts[:, j] = rng.choice(model.mode_values[name], N_POINTS)
            continue
        pts[:, j] = centre + spread * (1 if is_par else shrink) * rng.uniform(-1, 1, N_POINTS)
        if name in (v.name for v in model.variables):
            var = model.var(name)
            pts[:, j] = np.clip(pts[:, j], var.min, var.max)
    return pts


def _printed_function(model, lst: readable.Listing, extras_sym, args):
    """The Listing (what the reports print) as one numeric function of args:
    the named quantities it uses and the shared definitions in order, then
    each residual lhs - rhs, each output expression and each extra expression."""
    exprs = [lhs - rhs for lhs, rhs in lst.equations]
    exprs += [e for group in (lst.outputs, lst.events, lst.modes, lst.delays) for _, e in group]
    exprs += extras_sym
    ren = {s: sympy.Dummy() for s, _ in lst.named}  # "r_O2[0,0]" is no Python name
    defs = [(ren.get(s, s), d.xreplace(ren)) for s, d in list(lst.named) + list(lst.shared)]
    exprs = [e.xreplace(ren) for e in exprs]
    return sympy.lambdify(args, exprs, modules="numpy", cse=lambda es: (defs, list(es)))


def _compare(model, *, ops=None, lst=None) -> tuple[int, int, list[str]]:
    """Evaluate CasADi and the printed SymPy form (``lst``, default the
    model's listing); return (rows, least points compared, mismatches)."""
    casadi_rows = list(model.equations) + [ca.SX(v.expr) for v in model.of_kind("output")]
    casadi_rows += [e.expr for e in model.events]
    casadi_rows += [model.mode_valid[v.name] for v in model.of_kind("mode")
                    if v.name in model.mode_valid]
    casadi_rows += [d.expr for d in model.delays]
    extras = _extras(model)
    every = ca.vertcat(*casadi_rows, *extras)
    syms = ca.symvar(every)
    names = [s.name() for s in syms]
    f = ca.Function("f", [ca.vertcat(*syms)], [ca.densify(every)])
    table = readable.symbols(model)
    if ops is None:
        lst = lst or _listing(model.name)
        extras_sym = [readable.to_sympy(e, table) for e in extras]
    else:  # the tampered path: convert without the listing
        residuals = readable.to_sympy(ca.vertcat(*casadi_rows), table, ops=ops)
        lst = readable.Listing([], [(r, 0) for r in residuals[:len(model.equations)]],
                               [(None, r) for r in residuals[len(model.equations):]])
        extras_sym = [readable.to_sympy(e, table, ops=ops) for e in extras]
    args = [table[n] for n in names]
    g = _printed_function(model, lst, extras_sym, args)
    rng = np.random.default_rng(14)
    rows = every.numel()
    ok = np.zeros(rows, dtype=int)
    bad: list[str] = []
    shrink = 1.0
    for _attempt in range(MAX_TRIES):
        pts = _points(model, names, rng, shrink)
        for p in pts:
            want = f(p).full().ravel()
            with np.errstate(all="ignore"):
                got = np.array([float(v) for v in g(*p)], dtype=float)
            finite = np.isfinite(want)
            close = np.abs(got - want) <= RTOL * np.maximum(np.abs(want), 1e-300) + 1e-15
            for i in np.flatnonzero(finite & ~close):
                bad.append(f"row {i} at {dict(zip(names, p))}: casadi {want[i]!r}, "
                           f"sympy {got[i]!r}")
            ok += finite & close
        if bad or ok.min() >= N_POINTS:
            break
        shrink *= 0.3  # singular somewhere (e.g. a film formula): come closer to rest
    return rows, int(ok.min()), bad


@pytest.mark.parametrize("name", sorted(MODELS))
@pytest.mark.slow  # SymPy on every model: seconds to a minute each
def test_printed_form_evaluates_as_casadi(name):
    model = shared_model(name)
    t0 = time.process_time()  # CPU time: other jobs on the machine do not count
    rows, least, bad = _compare(model)
    assert not bad, f"{name}: {len(bad)} mismatches, first: {bad[:3]}"
    assert least >= N_POINTS, f"{name}: some row was finite at only {least} points"
    assert rows >= len(model.equations) + len(model.of_kind("output"))
    assert time.process_time() - t0 < 30


_NUMPY = {sympy.sin: np.sin, sympy.cos: np.cos, sympy.tan: np.tan, sympy.asin: np.arcsin,
          sympy.acos: np.arccos, sympy.atan: np.arctan, sympy.sinh: np.sinh,
          sympy.cosh: np.cosh, sympy.tanh: np.tanh, sympy.asinh: np.arcsinh,
          sympy.acosh: np.arccosh, sympy.atanh: np.arctanh, sympy.exp: np.exp,
          sympy.log: np.log, sympy.Abs: np.abs, sympy.sign: np.sign, sympy.floor: np.floor,
          sympy.ceiling: np.ceil, sympy.atan2: np.arctan2,
          sympy.Min: lambda *a: functools.reduce(np.minimum, a),
          sympy.Max: lambda *a: functools.reduce(np.maximum, a),
          sympy.Lt: np.less, sympy.Le: np.less_equal, sympy.Gt: np.greater,
          sympy.Ge: np.greater_equal, sympy.Eq: np.equal, sympy.Ne: np.not_equal,
          sympy.And: lambda *a: functools.reduce(np.logical_and, a),
          sympy.Or: lambda *a: functools.reduce(np.logical_or, a), sympy.Not: np.logical_not,
          sympy.Add: lambda *a: functools.reduce(np.add, a),
          sympy.Mul: lambda *a: functools.reduce(np.multiply, a), sympy.Pow: np.power}


def _numeric(e, env: dict, memo: dict):
    """A SymPy expression evaluated at many points at once (numpy arrays in
    ``env``, by symbol), visiting each shared node once (SymPy's printers,
    hence lambdify, walk a DAG as a tree: minutes for the spindle's matrices)."""
    if e in memo:
        return memo[e]
    if e.is_Symbol:
        out = env[e]
    elif e.is_Number or e.is_NumberSymbol:
        out = float(e)
    elif e is sympy.true or e is sympy.false:
        out = bool(e)
    elif isinstance(e, sympy.Piecewise):
        conds = [np.broadcast_to(_numeric(c, env, memo), env["shape"]) for _, c in e.args]
        vals = [np.broadcast_to(_numeric(x, env, memo), env["shape"]) for x, _ in e.args]
        out = np.select(conds, vals, np.nan)
    elif e.func in _NUMPY:
        out = _NUMPY[e.func](*(_numeric(a, env, memo) for a in e.args))
    else:
        raise AssertionError(f"no numeric form for {e.func} in the test")
    memo[e] = out
    return out


def _compare_quantities(model, written) -> tuple[int, int, list[str]]:
    """Evaluate every named quantity through CasADi and through the printed
    forms ``written`` [(Quantity, symbol, form)]: each form evaluated with the
    earlier quantities' symbols bound to their printed values, and the
    direct SymPy form (``readable.quantity``) too; return (entries, least
    points at which every entry was finite and compared, mismatches)."""
    exprs = [ca.vec(ca.densify(q.expr)) for q, _, _ in written]
    every = ca.vertcat(*exprs)
    syms = ca.symvar(every)
    names = [s.name() for s in syms]
    f = ca.Function("q", [ca.vertcat(*syms) if syms else ca.SX(0, 1)], [every])
    table = readable.symbols(model)
    direct = [readable.quantity(model, q) for q, _, _ in written]
    rng = np.random.default_rng(15)
    ok = np.zeros(every.numel(), dtype=int)
    bad: list[str] = []
    shrink = 1.0
    for _attempt in range(MAX_TRIES):
        pts = _points(model, names, rng, shrink)
        want = np.hstack([np.array(f(p).full()) for p in pts])  # entries x points
        env = {table[n]: pts[:, j] for j, n in enumerate(names)}
        env["shape"] = (len(pts),)
        memo_p: dict = {}
        memo_d: dict = {}
        got_p, got_d = [], []
        with np.errstate(all="ignore"):
            for (q, sym, form), d in zip(written, direct):
                for forms, got, memo in (((form,), got_p, memo_p), ((d,), got_d, memo_d)):
                    m = forms[0]
                    entries = m.T if isinstance(m, sympy.MatrixBase) else [m]  # column-major
                    got += [np.broadcast_to(np.asarray(_numeric(x, env, memo), dtype=float),
                                            env["shape"]) for x in entries]
                n = q.expr.numel()
                if n == 1 or max(q.expr.shape) <= readable.ENTRY_VOCABULARY:
                    shape = q.expr.shape
                    for k, x in enumerate(got_p[-n:]):  # column-major entries
                        env[readable.entry_symbol(sym, k % shape[0], k // shape[0], shape)
                            if n > 1 else sym] = x
        finite = np.isfinite(want)
        tol = RTOL * np.maximum(np.abs(want), 1e-300) + 1e-15
        for label, got in (("printed", np.array(got_p)), ("sympy", np.array(got_d))):
            close = np.abs(got - want) <= tol
            for i, k in zip(*np.nonzero(finite & ~close)):
                bad.append(f"{label} entry {i} at {dict(zip(names, pts[k]))}: casadi "
                           f"{want[i, k]!r}, {label} {got[i, k]!r}")
        ok += (finite & (np.abs(np.array(got_p) - want) <= tol)).sum(axis=1)
        if bad or ok.min() >= N_POINTS:
            break
        shrink *= 0.3
    return every.numel(), int(ok.min()) if ok.size else 0, bad


@pytest.mark.parametrize("name", sorted(MODELS))
@pytest.mark.slow  # SymPy on every model: seconds to a minute each
def test_quantities_evaluate_as_casadi(name):
    """Every named quantity of every model, as the report writes it (with the
    earlier quantities' symbols) and as loomfmu.inspect's .sympy gives it."""
    model = shared_model(name)
    if not model.quantities:
        pytest.skip(f"{name} declares no named quantities (Model.quantity) yet")
    t0 = time.process_time()
    written = readable.quantities_written(model)
    assert [q.name for q, _, _ in written] == [q.name for q in model.quantities]
    rows, least, bad = _compare_quantities(model, written)
    assert not bad, f"{name}: {len(bad)} mismatches, first: {bad[:3]}"
    assert least >= N_POINTS, f"{name}: some quantity entry was finite at only {least} points"
    assert time.process_time() - t0 < 60


def _springs():
    """A model declared here: two springs in series and a mass, with scalar,
    vector and matrix quantities that build on each other."""
    from loomfmu import Model
    m = Model("springs", description="a mass on two springs in series")
    src = "assumption: test model"
    k1 = m.parameter("k1", 100.0, unit="N/m", description="first spring", min=1.0, source=src)
    k2 = m.parameter("k2", 300.0, unit="N/m", description="second spring", min=1.0, source=src)
    mass = m.parameter("mass", 2.0, unit="kg", description="mass", min=0.1, source=src)
    x = m.state("x", 0.01, unit="m", description="position")
    v = m.state("v", 0.0, unit="m/s", description="velocity")
    g = "1. springs"
    m.quantity("c1", 1 / k1, unit="m/N", description="compliance of spring 1", symbol="c_1",
               group=g)
    k = m.quantity("k", 1 / (1 / k1 + 1 / k2), unit="N/m", description="series stiffness",
                   symbol=r"k_{\mathrm{s}}", source="derived: compliances add", group=g)
    m.quantity("K", ca.vertcat(ca.horzcat(k1 + k2, -k2), ca.horzcat(-k2, 3 * k2)),
               unit="N/m", description="stiffness matrix", symbol=r"\mathbf{K}", group=g)
    m.quantity("T", 0.5 * mass * v**2, unit="N.m", description="kinetic energy", group="2. energy")
    m.quantity("V", 0.5 * k * x**2, unit="N.m", description="potential energy",
               symbol=r"V", group="2. energy")
    m.quantity("Kbig", np.diag(np.arange(1.0, 13.0)) + np.diag(np.full(11, 0.5), 1), unit="N/m",
               description="a large numeric matrix", symbol=r"\mathbf{K}_{12}", group="3. big")
    m.eq(m.der(x), v)
    m.eq(mass * m.der(v), -k * x)
    m.output("x_out", x, unit="m", description="position")
    return m


def test_quantities_of_a_declared_model_evaluate_as_casadi():
    model = _springs()
    written = readable.quantities_written(model)
    forms = {q.name: form for q, _, form in written}
    assert forms["V"].has(readable.QuantitySymbol("k", r"k_{\mathrm{s}}")), forms["V"]
    rows, least, bad = _compare_quantities(model, written)
    assert not bad and least >= N_POINTS and rows == 1 + 1 + 4 + 1 + 1 + 144


def test_tampered_quantity_form_is_detected():
    """A written form off by one part in a million must be caught."""
    model = _springs()
    written = readable.quantities_written(model)
    q, sym, form = written[4]  # V, written with k
    written[4] = (q, sym, form * (1 + sympy.Rational(1, 10**6)))
    _, _, bad = _compare_quantities(model, written)
    assert bad and all("printed" in b for b in bad)


def test_tampered_op_is_detected():
    """Mapping one op wrongly (sin as cos) must make the comparison fail."""
    tampered = {**readable.OPS, ca.OP_SIN: sympy.cos}
    _, _, bad = _compare(shared_model("backrest"), ops=tampered)
    assert bad, "a wrong sin mapping went unnoticed"
    tampered = {**readable.OPS, ca.OP_SUB: lambda a, b: a + b}
    _, _, bad = _compare(load_model("heald_frame_rigid"), ops=tampered)
    assert bad, "a wrong sub mapping went unnoticed"


def test_tampered_listing_is_detected():
    """A shared definition, or a named quantity's definition, off by one part
    in a million must be caught."""
    model = load_model("heald_frame")
    lst = readable.listing(model)
    sym, definition = lst.shared[0]
    lst.shared[0] = (sym, definition * (1 + sympy.Rational(1, 10**6)))
    _, _, bad = _compare(model, lst=lst)
    assert bad, "a wrong shared definition went unnoticed"
    model = shared_model("backrest")
    lst = readable.listing(model)
    k = next(k for k, (s, _) in enumerate(lst.named) if s.name == "S_1")
    sym, definition = lst.named[k]
    lst.named[k] = (sym, definition * (1 + sympy.Rational(1, 10**6)))
    _, _, bad = _compare(model, lst=lst)
    assert bad, "a wrong named definition went unnoticed"


def test_untampered_compare_path_agrees():
    """The same comparison without the listing passes with the true table."""
    _, least, bad = _compare(shared_model("backrest"), ops=dict(readable.OPS))
    assert not bad and least >= N_POINTS


def test_unsupported_op_is_named():
    x = ca.SX.sym("x")
    with pytest.raises(ValueError, match="OP_FMOD"):
        readable.to_sympy(ca.fmod(x, 2.0))
    ops = {k: v for k, v in readable.OPS.items() if k != ca.OP_TANH}
    with pytest.raises(ValueError, match="OP_TANH"):
        readable.to_sympy(ca.tanh(x), ops=ops)


def test_to_sympy_rejects_a_matrix():
    with pytest.raises(ValueError, match="expr"):
        readable.to_sympy(ca.SX.sym("A", 2, 2))


def test_comparisons_print_as_iverson_brackets():
    x, y = ca.SX.sym("phi"), ca.SX.sym("omega")
    e = readable.to_sympy(ca.if_else(x < y, x, 0) + (x >= 1))
    tex = readable.to_latex(e)
    assert r"\left[\phi \geq 1\right]" in tex and r"\begin{cases}" in tex
    ml = readable.mathml_line(e)
    xml.dom.minidom.parseString(ml)
    assert "<mtable" in ml and "piecewise" not in ml.lower()


def test_logic_and_constants_convert_exactly():
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    e = readable.to_sympy(ca.vertcat(ca.if_else(x < y, x * math.pi / 30, 0.1 * y),
                                     ca.logic_and(x > 0, ca.logic_not(y >= 1))))
    sx, sy = readable.Var("x"), readable.Var("y")
    assert sympy.simplify(e[0].subs({sx: 1, sy: 2}) - sympy.pi / 30) == 0
    assert e[0].subs({sx: 3, sy: 2}) == sympy.Rational(1, 5)
    assert e[1].subs({sx: 1, sy: 0.5}) == 1 and e[1].subs({sx: 1, sy: 2}) == 0


@pytest.mark.parametrize("name, latex", [
    ("der(phi)", r"\dot{\phi}"), ("alpha1", r"\alpha_{1}"), ("T_min", r"T_{\mathrm{min}}"),
    ("der(n3.vax)", r"\dot{v}_{\mathrm{ax},\mathrm{n3}}"), ("delay(u)", r"u^{\mathrm{del}}"),
    ("h_ddot", r"\ddot{h}"), ("dphi1", r"d\phi_{1}"), ("eps", r"\varepsilon"),
    ("time", "t"), ("delta0", r"\delta_{0}"), ("mu", r"\mu"), ("tau", r"\tau"),
])
def test_names_print_as_written(name, latex):
    assert readable.latex_name(name) == latex


def test_reports_print_every_line():
    model = load_model("heald_frame_rigid")
    lst = readable.listing(model)
    n = sum(map(len, (lst.shared, lst.equations, lst.outputs, lst.events, lst.modes,
                      lst.delays)))
    assert len(lst.events) == 3
    tex = readable.latex(model).splitlines()
    assert len(tex) == n and r"\dot{\phi} = \omega" in tex
    html = readable.mathml(model)
    maths = html.splitlines()
    assert len(maths) == n
    for m in maths:  # each line is well-formed XML
        xml.dom.minidom.parseString(m)
    assert "\u03c6" in html or "&#966;" in html  # phi printed as the Greek letter


def test_shared_subexpressions_are_named_once():
    model = load_model("heald_frame")
    lst = readable.listing(model)
    assert lst.shared, "the heald frame's equations share subexpressions"
    for _sym, definition in lst.shared:
        assert sympy.count_ops(definition) >= 3
    used = [e for pair in lst.equations for e in pair] + [e for _, e in lst.outputs]
    used += [d for _, d in lst.shared]
    for sym, _ in lst.shared:
        assert any(sym in e.free_symbols for e in used)


def test_listing_rejects_bad_min_ops():
    with pytest.raises(ValueError, match="min_ops"):
        readable.listing(load_model("heald_frame_rigid"), min_ops=-1)
    with pytest.raises(ValueError, match="max_len"):
        readable.listing(load_model("heald_frame_rigid"), max_len=10)


def test_long_lines_are_broken_into_named_parts():
    """The spindle's squeeze-film formula is one term thousands of characters
    long: the listing names its parts so that each line fits, or is a sum the
    report breaks after a term."""
    x = [readable.Var(f"x{k}") for k in range(40)]
    deep = sympy.sqrt(sum(xk * sympy.sin(xk) ** 2 for xk in x)) / (1 + sympy.Mul(*x))
    defs: list = []
    short = _lift(deep, 120, defs, (sympy.Symbol(f"t{k}") for k in range(99)))
    assert len(str(deep)) > 700 and defs and len(str(short)) <= 120
    back = short
    for _ in defs:  # undo the naming: each pass resolves one level
        back = back.xreplace(dict(defs))
    assert back == deep
    lst = _listing("spindle")
    for a, b in lst.shared + lst.equations + lst.outputs:
        e = sympy.Eq(a, b, evaluate=False)
        assert len(str(e)) <= 240 or inspect_doc._rows(e), str(e)[:200]


# -- loomfmu inspect ------------------------------------------------------------

from html.parser import HTMLParser  # noqa: E402

from loomfmu.export.dae import dae_form  # noqa: E402
from loomfmu.inspection import document as inspect_doc  # noqa: E402
from loomfmu.inspection import report as inspect_report  # noqa: E402


class _Tags(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags: list[str] = []
        self.urls: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.urls += [v for k, v in attrs if k in ("src", "href") and v]


@pytest.mark.parametrize("name", ["backrest", "drive", "heald_frame_rigid"])
@pytest.mark.slow  # SymPy on every model: seconds to a minute each
def test_inspect_report_in_every_format(name, tmp_path):
    model = shared_model(name)
    title, sections = inspect_report.document(model)
    page = inspect_report.render_html(title, sections)
    tags = _Tags()
    tags.feed(page)
    assert "script" not in tags.tags and "link" not in tags.tags
    assert all(u.startswith("#lf-") for u in tags.urls)  # in-page links only
    for u in tags.urls:
        assert f' id="{u[1:]}"' in page, u
    maths = page.count("<math ")
    lst = readable.listing(model)
    assert maths >= sum(map(len, (lst.shared, lst.equations, lst.outputs, lst.events)))
    families = inspect_report._families(model.of_kind("parameter"))
    member = {v.name: ms for ms in families.values() for _, v in ms}
    for v in model.variables:  # every variable is listed with its unit
        if v.name in member:   # or in its family's row and values table
            ms = member[v.name]
            assert f"<code>{ms[0][1].name} \u2026 {ms[-1][1].name}</code>" in page
            assert f"<td>{inspect_report._fmt(v.start)}</td>" in page, v.name
        else:
            assert f"<code>{v.name}</code>" in page
    dae = dae_form(model)
    nnz = ca.jacobian(dae.F, dae.w).nnz()
    assert f"{nnz} structural non-zeros" in page
    assert ("by Newton" in page) == dae.implicit
    md = inspect_report.render_md(title, sections)
    assert md.count("$$") == 2 * sum(len(b.lines) for s in sections for b in _blocks(s)
                                      if isinstance(b, inspect_report.Equations))
    tex = inspect_report.render_tex(title, sections)
    assert tex.startswith(r"\documentclass") and tex.rstrip().endswith(r"\end{document}")
    assert tex.count(r"\begin{equation*}") == tex.count(r"\end{equation*}") > 0
    inside = False  # text is escaped: no bare underscore outside math and verbatim
    for line in tex.splitlines():
        if line in (r"\begin{equation*}", r"{\scriptsize\begin{verbatim}"):
            inside = True
        elif line in (r"\end{equation*}", r"\end{verbatim}}"):
            inside = False
        elif not inside:
            text = re.sub(r"\$[^$]*\$", "", line).replace(r"\_", "")
            assert "_" not in text, line
    if model.delays:
        assert "Delays" in md and r"\tau" in md
    if model.events:
        assert all(e.name in md for e in model.events)


def _blocks(section):
    for b in section.blocks:
        if isinstance(b, inspect_report.Section):
            yield from _blocks(b)
        else:
            yield b


def test_inspect_main_writes_the_file(tmp_path, capsys):
    out = tmp_path / "sub" / "r.md"
    assert inspect_report.main(["heald_frame_rigid", "--format", "md", "--out", str(out)]) == 0
    assert out.read_text().startswith("# heald_frame_rigid")
    assert str(out) in capsys.readouterr().out


@pytest.mark.parametrize("argv", [["no_such_model"], ["backrest", "--format", "pdf"], []])
def test_inspect_usage_errors_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        inspect_report.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("loomfmu inspect: error: ") and len(err.strip().splitlines()) == 1, err


def test_inspect_report_rejects_unknown_format():
    with pytest.raises(ValueError, match="fmt"):
        inspect_report.report(load_model("heald_frame_rigid"), "pdf")


def test_long_equations_break_without_changing_them():
    """drive's cam series is a long sum (in the derivation; the equations
    name it r(phi)): its rows hold every term once, and the broken MathML and
    LaTeX are well-formed."""
    model = load_model("drive")
    lst = readable.listing(model)
    lines = [sympy.Eq(a, b, evaluate=False) for a, b in lst.shared + lst.outputs]
    lines += [sympy.Eq(sym, form, evaluate=False) for _, sym, form
              in readable.quantities_written(model) if not isinstance(form, sympy.MatrixBase)]
    broken = [(e, inspect_doc._rows(e)) for e in lines]
    broken = [(e, rows) for e, rows in broken if rows]
    assert broken, "no line of the drive was long enough to break"
    for e, rows in broken:
        terms = [t for row in rows for t in row]
        assert len(terms) == len(e.rhs.args) and sympy.Add(*terms) == e.rhs
        xml.dom.minidom.parseString(inspect_doc._mathml_display(e))
        tex = inspect_doc._latex_display(e)
        assert tex.count(r"\\") == len(rows) - 1 and tex.startswith(r"\begin{aligned}")


# -- the Derivation section -------------------------------------------------------

import shutil  # noqa: E402
import subprocess  # noqa: E402


def test_derivation_section_in_every_format():
    model = _springs()
    title, sections = inspect_report.document(model)
    titles = [s.title for s in sections]
    assert titles.index("Derivation") == titles.index("Variables") + 1
    der = sections[titles.index("Derivation")]
    groups = [b.title for b in der.blocks if isinstance(b, inspect_report.Section)]
    assert groups == ["1. springs", "2. energy", "3. big"]
    page = inspect_report.render_html(title, sections)
    body = page.split('<h2 id="lf-derivation">Derivation</h2>', 1)[1]
    body = body.split('<h2 id="lf-equations">Equations</h2>', 1)[0]
    assert '<a href="#lf-derivation">Derivation</a>' in page
    for q in model.quantities:
        assert f"<code>{q.name}</code>" in body, q.name
    assert body.index("<code>c1</code>") < body.index("<code>k</code>") < body.index(
        "<code>T</code>") < body.index("<code>Kbig</code>")
    # the 2x2 K as a matrix (display style), V written with the series stiffness k
    assert '<mtable displaystyle="true">' in body
    v_line = body.split("<code>V</code>", 1)[1].split("</div>", 1)[0]
    assert "<mi mathvariant=\"normal\">s</mi>" in v_line  # k_s, not 1/(1/k1 + 1/k2)
    # the 12x12 numeric matrix as a picture: 23 coloured cells, facts in the caption
    svg = body.split("<svg", 1)[1].split("</svg>", 1)[0]
    assert svg.count("<rect") == 1 + 23 + 3  # frame, non-zeros, legend decades 1e-1..1e1
    assert "Kbig: 12 \u00d7 12, 23 non-zeros; not symmetric (symmetric pattern)" not in body
    assert "Kbig: 12 \u00d7 12, 23 non-zeros; not symmetric;" in body
    assert "from 0.5 to 12 N/m" in body
    md = inspect_report.render_md(title, sections)
    assert r"k_{\mathrm{s}}" in md and "## Derivation" in md and "### 3. big" in md
    pic = md.split("### 3. big", 1)[1].split("```", 2)[1].strip().splitlines()
    assert len(pic) == 12 and all(len(line) == 12 for line in pic)
    assert pic[0] == "10" + "\u00b7" * 10 and pic[11][-1] == "2"  # 1 -> 1e0, 0.5 -> 1e-1, 12 -> 1e1
    tex = inspect_report.render_tex(title, sections)
    assert r"\subsection*{3. big}" in tex


def _pdflatex(tex: str, tmp_path) -> subprocess.CompletedProcess:
    src = tmp_path / "r.tex"
    src.write_text(tex)
    return subprocess.run(["pdflatex", "-interaction=nonstopmode", "-halt-on-error", "r.tex"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)


@pytest.mark.skipif(shutil.which("pdflatex") is None,
                    reason="pdflatex is not installed (apt-get install texlive-latex-extra)")
@pytest.mark.parametrize("name", ["backrest"])
def test_tex_report_compiles(name, tmp_path):
    """The LaTeX report compiles (backrest: vectors, matrices, their entries'
    symbols, cases); a broken one (a double subscript) is caught."""
    tex = inspect_report.report(load_model(name), "tex")
    run = _pdflatex(tex, tmp_path)
    assert run.returncode == 0, run.stdout[-2000:]
    assert (tmp_path / "r.pdf").stat().st_size > 10_000
    broken = tex.replace(r"\end{document}", r"$x_1_2$ \end{document}")
    assert _pdflatex(broken, tmp_path).returncode != 0


# -- loomfmu inspect --all and the reports kept in docs/reference/inspect --------------------

from pathlib import Path  # noqa: E402

DOCS = Path(__file__).resolve().parents[1] / "docs" / "reference" / "inspect"
#: models whose reports are quick to rebuild (the others take up to a minute of
#: CPU each: regenerate all with `loomfmu inspect --all`)
QUICK = ["heald_frame_rigid", "loom_shaft", "two_mass_force"]


def test_write_reports_and_the_all_option(tmp_path, capsys):
    paths = inspect_report.write_reports(["two_mass_force", "loom_shaft"], ["html", "md"],
                                         tmp_path / "r")
    assert sorted(p.name for p in paths) == ["loom_shaft.html", "loom_shaft.md",
                                             "two_mass_force.html", "two_mass_force.md"]
    assert (tmp_path / "r" / "loom_shaft.md").read_text().startswith("# loom_shaft")
    out = tmp_path / "two"
    assert inspect_report.main(["two_mass_force", "--format", "md", "--format", "tex",
                                "--out", str(out)]) == 0
    assert {p.name for p in out.iterdir()} == {"two_mass_force.md", "two_mass_force.tex"}
    assert "written:" in capsys.readouterr().out


@pytest.mark.parametrize("argv, says", [
    (["--all", "backrest"], "either MODEL or --all"),
    (["--all", "--out", "-"], "prints one report"),
    (["backrest", "--format", "md", "--format", "html", "--out", "-"], "prints one report"),
])
def test_inspect_all_usage_errors(argv, says, capsys):
    with pytest.raises(SystemExit) as exc:
        inspect_report.main(argv)
    assert exc.value.code == 2 and says in capsys.readouterr().err


def test_inspect_all_out_must_be_a_directory(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(SystemExit) as exc:
        inspect_report.main(["--all", "--out", str(f)])
    assert exc.value.code == 2 and "an existing file, not a directory" in capsys.readouterr().err


@pytest.mark.parametrize("name", QUICK)
@pytest.mark.slow
def test_reports_in_docs_are_current(name, tmp_path):
    """docs/reference/inspect holds every model's report; the quick ones are rebuilt
    here and must be identical (regenerate: loomfmu inspect --all)."""
    assert {f"{n}.{fmt}" for n in MODELS for fmt in inspect_report.ALL_FORMATS} <= \
        {p.name for p in DOCS.iterdir()}, "run: loomfmu inspect --all"
    for path in inspect_report.write_reports([name], inspect_report.ALL_FORMATS, tmp_path):
        kept = DOCS / path.name
        assert kept.read_text(encoding="utf-8") == path.read_text(encoding="utf-8"), \
            f"{kept} is out of date: run loomfmu inspect --all"


def test_picture_shows_round_off_apart():
    """Entries below 1e-12 of the largest (a projection's round-off) are
    grey and kept out of the colour scale; a symbolic large matrix is
    coloured at the parameters' defaults."""
    from loomfmu import Model
    from loomfmu.inspection.derivation import TINY_COLOUR, derivation
    m = Model("pic", description="pictures")
    k = m.parameter("k", 1e3, description="a stiffness", min=1.0, source="assumption: test")
    x = m.state("x", 0.0, description="x")
    a = np.eye(10)
    a[0, 9] = 1e-15
    m.quantity("A", a, description="identity and round-off")
    m.quantity("S", k * ca.DM.eye(10), unit="N/m", description="symbolic")
    m.quantity("v", k * ca.DM(np.arange(1.0, 11.0)), unit="N", description="a long column")
    m.eq(m.der(x), -k * x)
    sec = derivation(m)
    tables = [b for g in sec.blocks if isinstance(g, inspect_report.Section) for b in g.blocks
              if isinstance(b, inspect_report.Table)]
    assert [r[0] for r in tables[0].rows] == ["1-8", "9-10"]  # the column as values
    assert tables[0].rows[1][1:4] == ["9000", "10000", ""]
    pics = [b for g in sec.blocks if isinstance(g, inspect_report.Section) for b in g.blocks
            if isinstance(b, inspect_doc.Picture)]
    assert len(pics) == 2
    a_pic, s_pic = pics
    assert a_pic.text.splitlines()[0] == "0" + "\u00b7" * 8 + "~"
    assert "1 entries below 1e-12 times the largest (round-off)" in a_pic.caption
    assert a_pic.svg.count(TINY_COLOUR) == 1 and "from 1 to 1 at" in a_pic.caption
    assert "from 1e+03 to 1e+03 N/m" in s_pic.caption and "symmetric" in s_pic.caption


def test_validity_conditions_are_written_with_the_quantities():
    """A validity condition (Model.require) prints as its expression >= 0,
    written with the named quantities (here the tension S = k x as S)."""
    from loomfmu import Model
    m = Model("taut", description="a warp that must stay taut")
    k = m.parameter("k", 1e3, unit="N/m", description="stiffness", min=1.0,
                    source="assumption: test")
    x = m.state("x", 0.01, unit="m", description="elongation")
    S = m.quantity("S", k * x + 2 * k * x**2, unit="N", description="tension", symbol="S")
    m.require("taut", S, "warp in compression")
    m.eq(m.der(x), -x)
    title, sections = inspect_report.document(m)
    sec = next(s for s in sections if s.title == "Validity conditions")
    eqs = next(b for b in sec.blocks if isinstance(b, inspect_report.Equations))
    (ge, tag), = eqs.lines
    assert tag == "v1" and ge.lhs == readable.QuantitySymbol("S", "S") and ge.rhs == 0
    md = inspect_report.render_md(title, sections)
    assert r"S \geq 0 \tag{v1}" in md and "warp in compression" in md
    frag = inspect_report.html_fragment(m)
    assert "Validity conditions" in frag


def test_an_indexed_parameter_family_is_one_row_and_a_values_table():
    """Parameters a1 ... a9 with one unit, source and description up to the
    index are one row of the parameter table and a table of values (the
    drive's 192 cam coefficients were 192 rows); a family below
    FAMILY_MIN, and a member whose description differs, stay rows."""
    from loomfmu import Model
    m = Model("fam", description="families")
    for j in range(1, 10):
        m.parameter(f"a{j}", 0.5 * j, unit="m", description=f"cos({j} phi) coefficient",
                    source="assumption: test")
        m.parameter(f"b{j}", -float(j), unit="m", description=f"sin({j} phi) coefficient",
                    source="assumption: test")
    for j in range(1, 4):
        m.parameter(f"c{j}", 1.0, description=f"short family {j}", source="assumption: test")
    m.parameter("a0", 7.0, unit="m", description="mean radius", source="assumption: test",
                min=0.0, max=10.0)
    x = m.state("x", 0.0, description="x")
    m.eq(m.der(x), -x)
    md = inspect_report.report(m, "md")
    params = md.split("Parameters (22)", 1)[1].split("States", 1)[0]
    rows = [l for l in params.splitlines() if l.startswith("| `")]
    assert len(rows) == 2 + 3 + 1, rows        # a-family, b-family, c1-c3, a0
    assert "cos(j phi) coefficient" in params and "9 values (table below)" in params
    assert "Values of aj, bj:" in params
    assert "| 7 | 3.5 | -7 |" in params          # j, a7, b7
    assert "short family 2" in params and "mean radius" in params
    # each parameter's range, as the FMU checks it
    assert "| 7 | [0, 10] | mean radius |" in params


def test_printed_quantities_are_simplified_where_sympy_shortens_them():
    """T = m_c (w1^2 r1^2 sin^2 + w1^2 r1^2 cos^2) / 2 + ... prints as
    m_c r1^2 w1^2 / 2 + ...; a form that simplifying would lengthen (the
    spring moment written with the spring force) keeps its words."""
    model = shared_model("backrest")
    forms = {q.name: (sym, form) for q, sym, form in readable.quantities_written(model)}
    T = forms["T"][1]
    J_1, J_c, m_c, r1, w1, w2 = (readable.Var(n) for n in ("J_1", "J_c", "m_c", "r1",
                                                          "omega1", "omega2"))
    hand = J_1 * w1**2 / 2 + J_c * (w1 + w2)**2 / 2 + m_c * r1**2 * w1**2 / 2
    assert sympy.expand(T - hand) == 0, T
    assert sympy.count_ops(T) <= sympy.count_ops(hand), T
    assert forms["M_s"][1].has(forms["F_s"][0]), forms["M_s"][1]


@pytest.mark.slow  # a whole derivation report: seconds
def test_equations_are_numbered_apart_from_the_seeds_numbers():
    """The seeds number their equations (1), (2), ...; the report's own
    equations are (E1), (E2), ... so that "(7)" always means the seed's."""
    model = shared_model("backrest")
    _, sections = inspect_report.document(model)
    eqs = next(s for s in sections if s.title == "Equations")
    tags = [tag for b in eqs.blocks if isinstance(b, inspect_report.Equations)
            for _, tag in b.lines if tag]
    assert tags == [f"E{k}" for k in range(1, len(model.equations) + 1)]
    solving = next(s for s in sections if s.title.startswith("How the runtime"))
    text = " ".join(b for b in solving.blocks if isinstance(b, str))
    assert "nonlinear in w: E" in text, text
    lagrange = next(q for q in model.quantities if q.name == "lagrange")
    assert "equations E3 and E4" in lagrange.description


# The report as a designer reads it: labels and figures (here, beside the
# round trips, so that one process writes each model's quantities once).
SEEDS = Path(__file__).resolve().parents[2] / "shared" / "seeds"  # beside the repository


@pytest.mark.parametrize("name", sorted(MODELS))
@pytest.mark.slow  # a whole report per model
def test_labels_are_unique_and_apart_from_the_seeds_numbers(name):
    """The report's labels are E1..En (equations) and v1..vm (validity),
    each once; the seeds use plain numbers and none of these labels."""
    model = shared_model(name)
    _, sections = inspect_report.document(model)
    tags = []

    def walk(blocks):
        for b in blocks:
            if isinstance(b, inspect_report.Section):
                walk(b.blocks)
            elif isinstance(b, inspect_report.Equations):
                tags.extend(tag for _, tag in b.lines if tag)

    for s in sections:
        walk(s.blocks)
    assert len(tags) == len(set(tags)), tags
    eqs = [t for t in tags if t.startswith(inspect_report.EQUATION_TAG)]
    n_rows = sum(ca.SX(e).numel() for e in model.equations)
    assert eqs == [f"E{k}" for k in range(1, n_rows + 1)]
    assert all(re.fullmatch(r"(E|v)[1-9]\d*", t) for t in tags), tags
    seeds = " ".join(p.read_text(encoding="utf-8") for p in sorted(SEEDS.glob("*.txt")))
    if seeds:
        for t in set(tags):
            assert f"({t})" not in seeds, f"label ({t}) is used by a seed"


@pytest.mark.parametrize("name, marks", [
    ("heald_frame", ("x<tspan", "y<tspan", "h = H(", "l<tspan", "h<tspan", "f<tspan")),
    ("heald_frame_planar", ("y<tspan", "h = H(", "l<tspan", "f<tspan")),
    ("spindle", ('class="node"', "bolster", "footstep", "whorl", "bobbin", "L_s")),
    ("spindle_modal", ('class="node"', "bolster", "footstep", "whorl", "bobbin")),
])
@pytest.mark.slow  # a whole derivation report and the FMU page: seconds
def test_frame_and_mesh_are_drawn_in_the_report_and_on_the_page(name, marks):
    from loomfmu.fmu.documentation import html_for
    model = shared_model(name)
    for page in (inspect_report.report(model, "html"), html_for(model)):
        svg = page[page.index("<figure><svg"):]
        svg = svg[:svg.index("</svg>")]
        for mark in marks:
            assert mark in svg, (name, mark)
        assert model.figures[0].caption.split(" (")[0] in page
    assert "x<tspan" not in load_model("heald_frame_planar").figures[0].svg
