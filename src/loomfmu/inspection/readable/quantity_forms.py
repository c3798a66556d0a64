"""The derivation's named quantities (``model.quantities``) in SymPy, and
their symbols printed as the model writes them.

A quantity's ``symbol`` is LaTeX (e.g. ``r"\\delta_{11}"``, ``r"\\mathbf{C}"``);
:class:`QuantitySymbol` prints it as given in LaTeX and, through the small
LaTeX subset :func:`symbol_mathml` reads (letters, digits, Greek, ``_``,
``^``, ``'``, ``\\mathrm``, ``\\mathbf``, ``\\boldsymbol``, ``\\text``, accents),
as MathML; a symbol outside that subset prints, in MathML, as the quantity's
name.
"""
from __future__ import annotations

import contextlib
import re
import signal
import threading
import weakref
from xml.dom import minidom
from xml.sax.saxutils import escape

import casadi as ca
import numpy as np
import sympy
from sympy.printing.pretty.pretty_symbology import greek_unicode

from loomfmu.inspection.readable.convert import symbols, to_sympy_matrix
from loomfmu.inspection.readable.names import _mathml_name, latex_name

#: a matrix quantity up to this size lends its entries' symbols to later quantities
ENTRY_VOCABULARY = 8
#: ... those entries with at least this many operations
ENTRY_MIN_OPS = 3
#: ... and fewer nodes than this (an entry thousands of nodes long is no word to read by)
ENTRY_MAX_NODES = 400

_GREEK_CMDS = {n: greek_unicode[n] for n in greek_unicode
               if n.isalpha() and n.lower() != "lamda"}
_GREEK_CMDS |= {"varepsilon": "\u03b5", "epsilon": "\u03f5", "vartheta": "\u03d1",
                "varphi": "\u03c6", "phi": "\u03d5", "varrho": "\u03f1", "varsigma": "\u03c2"}
_ACCENT_MARKS = {"dot": "\u02d9", "ddot": "\u00a8", "hat": "^", "bar": "\u00af",
                 "tilde": "~", "vec": "\u2192", "check": "\u02c7"}
_FONTS = {"mathrm", "mathbf", "boldsymbol", "text", "mathit", "operatorname"}
_TOKEN = re.compile(r"\\[A-Za-z]+|\\.|[A-Za-z]|\d+(?:\.\d+)?|\s+|.")


MINUS = "\u2212"  # a hyphen-minus in MathML is a hyphen: short, and lost in a superscript


class _Unsupported(ValueError):
    """A symbol outside the LaTeX subset symbol_mathml reads."""


def _bold(text: str) -> str:
    """Text in Unicode's mathematical bold letters (MathML Core has no
    mathvariant="bold"; browsers show these characters bold)."""
    out = []
    for c in text:
        if "A" <= c <= "Z":
            out.append(chr(0x1D400 + ord(c) - ord("A")))
        elif "a" <= c <= "z":
            out.append(chr(0x1D41A + ord(c) - ord("a")))
        elif "0" <= c <= "9":
            out.append(chr(0x1D7CE + ord(c) - ord("0")))
        elif "\u0391" <= c <= "\u03a9":
            out.append(chr(0x1D6A8 + ord(c) - 0x391))
        elif "\u03b1" <= c <= "\u03c9":
            out.append(chr(0x1D6C2 + ord(c) - 0x3B1))
        else:
            out.append(c)
    return "".join(out)


class _Reader:
    """Recursive descent over the tokens of a LaTeX symbol, writing MathML."""

    def __init__(self, latex: str):
        self.toks = [t for t in _TOKEN.findall(latex) if not t.isspace()]
        self.k = 0

    def peek(self):
        return self.toks[self.k] if self.k < len(self.toks) else None

    def take(self):
        tok = self.peek()
        if tok is None:
            raise _Unsupported("unexpected end")
        self.k += 1
        return tok

    def seq(self, closing=None) -> str:
        parts = []
        while self.peek() is not None and self.peek() != closing:
            parts.append(self.atom())
        if closing is not None:
            if self.take() != closing:
                raise _Unsupported("unbalanced braces")
        return parts[0] if len(parts) == 1 else "<mrow>%s</mrow>" % "".join(parts)

    def raw_group(self) -> str:
        """The text of a ``{...}`` argument (no nesting beyond plain text)."""
        if self.take() != "{":
            raise _Unsupported("a font command needs {...}")
        text = []
        while self.peek() != "}":
            tok = self.take()
            if tok.startswith("\\"):
                name = tok[1:]
                if name not in _GREEK_CMDS:
                    raise _Unsupported(tok)
                tok = _GREEK_CMDS[name]
            text.append(tok)
        self.take()
        return "".join(text)

    def group(self) -> str:
        if self.peek() == "{":
            self.take()
            return self.seq("}")
        return self.base()

    def base(self) -> str:
        tok = self.take()
        if tok == "{":
            return self.seq("}")
        if tok.startswith("\\") and len(tok) > 1:
            name = tok[1:]
            if name in _GREEK_CMDS:
                return f"<mi>{_GREEK_CMDS[name]}</mi>"
            if name in _FONTS:
                text = escape(self.raw_group())
                if name in ("mathbf", "boldsymbol"):
                    return f"<mi>{_bold(text)}</mi>"
                if name == "text":
                    return f"<mtext>{text}</mtext>"
                if name == "mathit":
                    return f"<mi>{text}</mi>"
                return f'<mi mathvariant="normal">{text}</mi>'
            if name in _ACCENT_MARKS:
                return (f'<mover accent="true">{self.group()}'
                        f"<mo>{_ACCENT_MARKS[name]}</mo></mover>")
            if name == "prime":
                return "<mo>\u2032</mo>"
            raise _Unsupported(tok)
        if tok.isalpha():
            return f"<mi>{tok}</mi>"
        if tok[0].isdigit():
            return f"<mn>{tok}</mn>"
        if tok in "_^}":
            raise _Unsupported(tok)
        return f"<mo>{escape(MINUS if tok == '-' else tok)}</mo>"

    def atom(self) -> str:
        base, sub, sup = self.base(), None, None
        while self.peek() in ("_", "^", "'"):
            tok = self.take()
            if tok == "'":
                sup = (sup or "") + "<mo>\u2032</mo>"
            elif tok == "_":
                sub = self.group()
            else:
                sup = (sup or "") + self.group()
        if sub is not None and sup is not None:
            return f"<msubsup>{base}{sub}<mrow>{sup}</mrow></msubsup>"
        if sub is not None:
            return f"<msub>{base}{sub}</msub>"
        if sup is not None:
            return f"<msup>{base}<mrow>{sup}</mrow></msup>"
        return base


def symbol_mathml(latex: str) -> str:
    """Presentation MathML (no ``<math>`` element) of a LaTeX symbol such as
    ``\\delta_{11}``, ``\\mathbf{K}_e`` or ``\\dot{x}'``.  Raises ValueError for
    LaTeX outside the subset (see the module's docstring)."""
    reader = _Reader(latex)
    try:
        out = reader.seq()
    except _Unsupported as exc:
        raise ValueError(f"symbol = {latex!r}: {exc} is outside the LaTeX subset "
                         "loomfmu.inspection.readable prints as MathML (letters, digits, Greek, _ ^ ', "
                         "\\mathrm \\mathbf \\boldsymbol \\text \\mathit, accents)") from None
    return out


class QuantitySymbol(sympy.Symbol):
    """A named quantity's symbol: ``name`` is the quantity's name; it prints
    as the quantity's LaTeX ``symbol`` (or as a variable name would, when the
    quantity gives none)."""

    def __new__(cls, name: str, latex: str = ""):
        obj = sympy.Symbol.__xnew__(cls, name)  # uncached: the symbol text is ours
        obj._symbol_latex = latex
        return obj

    def __getnewargs_ex__(self):
        return (self.name, self._symbol_latex), {}

    def _hashable_content(self):
        return super()._hashable_content() + (self._symbol_latex,)

    def _latex(self, printer):
        return self._symbol_latex or latex_name(self.name)

    def _mathml_presentation(self, printer):
        if self._symbol_latex:
            try:
                xml = symbol_mathml(self._symbol_latex)
            except ValueError:
                return _mathml_name(self.name, printer.dom)
            node = minidom.parseString(
                f'<math xmlns="http://www.w3.org/1998/Math/MathML">{xml}</math>')
            return printer.dom.importNode(node.documentElement.firstChild, True)
        return _mathml_name(self.name, printer.dom)


def quantity(model, q) -> sympy.Expr | sympy.Matrix:
    """The SymPy form of quantity ``q`` (a ``declare.Quantity`` of ``model``):
    a scalar expression for a 1x1 quantity, else a ``sympy.Matrix`` of its
    shape."""
    mat = to_sympy_matrix(q.expr, symbols(model))
    return mat[0, 0] if mat.shape == (1, 1) else mat


def quantities(model) -> list[tuple[object, sympy.Expr | sympy.Matrix]]:
    """Each of the model's named quantities in declaration order, with its
    SymPy form: [(Quantity, expr or Matrix), ...]."""
    return [(q, quantity(model, q)) for q in model.quantities]


def entry_symbol(sym: QuantitySymbol, i: int, j: int, shape) -> QuantitySymbol:
    """The symbol of one entry of a matrix quantity: ``{{}C}_{12}`` (column:
    ``{{}v}_{2}``), ``(r_{O})_{2}`` when the symbol has a subscript of its own."""
    idx = f"{i + 1}" if shape[1] == 1 else f"{i + 1}{j + 1}" if max(shape) < 10 else \
        f"{i + 1},{j + 1}"
    base = (sym._symbol_latex or latex_name(sym.name)).split("=")[0].strip()
    if "_" in base and base[:1] not in "([":  # (r_{O_2})_1, not r_{O_2 1}
        return QuantitySymbol(f"{sym.name}[{i},{j}]", f"({base})_{{{idx}}}")
    # {{}...}: two atoms, else TeX unpacks a group of one accent (\vec r) and the
    # index becomes a double subscript
    return QuantitySymbol(f"{sym.name}[{i},{j}]", f"{{{{}}{base}}}_{{{idx}}}")


class _Vocabulary:
    """The scalar quantities declared so far, to write later ones with.

    An earlier quantity's form ``c * Y`` (c a rational number) found in a
    later expression is replaced by its symbol: whole, as an integer power of
    its factors inside a product (``E (b h^3 - ...)`` -> ``12 E J_x``,
    ``H / sqrt(l^2 + h^2)`` -> ``H / L``), or as some of the terms of a sum.
    Each replacement is an identity (integer powers only), so substituting
    the definitions back gives the declared expression."""

    def __init__(self, min_ops: int):
        self.min_ops = min_ops
        self.exact: dict = {}
        self.products: list[tuple[dict, object]] = []  # (factor -> power, Y's value)
        self.sums: list[tuple[frozenset, object]] = []  # (terms, their sum's value)

    def learn(self, form, sym) -> None:
        if isinstance(form, sympy.MatrixBase) or form.is_Atom or form in self.exact \
                or sympy.count_ops(form) < self.min_ops:
            return
        self.exact[form] = sym
        c, rest = form.as_coeff_Mul()
        if not (c.is_Rational and c != 0) or rest.is_Atom:
            return
        self.exact.setdefault(rest, sym / c)
        if isinstance(rest, (sympy.Mul, sympy.Pow)):
            self.products.append((rest.as_powers_dict(), sym / c))
        if isinstance(rest, sympy.Add):
            self.sums.append((frozenset(rest.args), sym / c))
            self.products.append(({rest: sympy.Integer(1)}, sym / c))

    def write(self, e, memo: dict):
        if isinstance(e, sympy.MatrixBase):
            return e.applyfunc(lambda x: self.write(x, memo))
        if e in memo:
            return memo[e]
        out = e
        if not e.is_Atom and not isinstance(e, sympy.Expr) and e.args:
            # a case's condition (phi_a > 0) or a Piecewise's (value, condition) pair
            args = [self.write(a, memo) for a in e.args]
            out = e.func(*args) if args != list(e.args) else e
        elif not e.is_Atom and isinstance(e, sympy.Expr):
            args = [self.write(a, memo) for a in e.args]
            out = e.func(*args) if args != list(e.args) else e
            out = self.exact.get(out, out)
            if isinstance(out, (sympy.Mul, sympy.Pow)):
                out = self._product(out)
            elif isinstance(out, sympy.Add):
                out = self._sum(out)
        memo[e] = out
        return out

    def _product(self, e):
        for want, value in self.products:  # every earlier quantity, in order
            if not isinstance(e, (sympy.Mul, sympy.Pow)):
                break
            have = e.as_powers_dict()
            k = _common_ratio(have, want)
            if k is not None:
                rest = {f: p for f, p in have.items() if f not in want}
                e = sympy.Mul(value**k, *(f**p for f, p in rest.items()))
        return e

    def _sum(self, e):
        for want, value in self.sums:  # some terms of e make an earlier quantity, or minus it
            if not isinstance(e, sympy.Add):
                break
            terms = set(e.args)
            negated = {-t for t in want}
            if want < terms:
                e = sympy.Add(value, *(terms - want))
            elif negated < terms:
                e = sympy.Add(-value, *(terms - negated))
        return e


def _common_ratio(have: dict, want: dict):
    """The integer k != 0 with have[f] == k * want[f] for every factor f of
    ``want``, else None."""
    k = None
    for f, p in want.items():
        q = have.get(f, 0)
        if q == 0 or not p:
            return None
        r = q / p
        if not r.is_Integer or (k is not None and r != k):
            return None
        k = r
    return k


def quantities_written(model, *, min_ops: int = 1) -> list[tuple[object, QuantitySymbol,
                                                                  object]]:
    """Each named quantity as the report writes it: [(Quantity, its symbol,
    its definition), ...] in declaration order, each definition written with
    the symbols of the scalar quantities declared before it (an earlier
    quantity's expression with at least ``min_ops`` operations, found inside
    a later one, alone or as factors of a product, is replaced by its symbol),
    so that e.g. C = delta^-1 shows in terms of the deltas.  Substituting the
    earlier definitions back gives the quantity (the round-trip test does)."""
    return list(_written(model, min_ops)[0])


def written_with_quantities(model, exprs, *, min_ops: int = 1) -> list:
    """CasADi expressions of ``model`` (e.g. its validity conditions) in SymPy,
    written with the symbols of its named quantities as
    :func:`quantities_written` writes a later quantity."""
    if not exprs:
        return []
    forms = to_sympy_matrix(ca.vertcat(*[ca.SX(e) for e in exprs]), symbols(model))
    vocab = _written(model, min_ops)[1]
    return [vocab.write(f, {}) if vocab.exact else f for f in forms]


#: id(model) -> (its quantities' count, min_ops, the written forms and vocabulary):
#: the report's derivation and equations both need them (tens of seconds for
#: the larger models); an entry goes with its model (weakref.finalize)
_CACHE: dict[int, tuple] = {}


def _written(model, min_ops: int):
    key = (len(model.quantities), min_ops)
    hit = _CACHE.get(id(model))
    if hit is not None and hit[0] == key:
        return hit[1]
    result = _write_all(model, min_ops)
    if id(model) not in _CACHE:
        weakref.finalize(model, _CACHE.pop, id(model), None)
    _CACHE[id(model)] = (key, result)
    return result


def _write_all(model, min_ops: int):
    out, vocab = [], _Vocabulary(min_ops)
    for q, form in quantities(model):
        sym = QuantitySymbol(q.name, q.symbol)
        if isinstance(form, sympy.MatrixBase) and max(form.shape) > ENTRY_VOCABULARY:
            shown = plain = vocab.write(form, {}) if vocab.exact else form  # a picture
        elif isinstance(form, sympy.MatrixBase):
            memo: dict = {}  # entries share subexpressions: write each once
            pairs = [_shortest(e, vocab, memo) for e in form]
            shown = sympy.Matrix(form.rows, form.cols, [p[0] for p in pairs])
            plain = sympy.Matrix(form.rows, form.cols, [p[1] for p in pairs])
        else:
            shown, plain = _shortest(form, vocab, {})
        out.append((q, sym, shown))
        _learn(vocab, sym, plain)  # both forms name the quantity
        if shown != plain:
            _learn(vocab, sym, shown)
    return out, vocab


def _learn(vocab: _Vocabulary, sym, shown) -> None:
    if not isinstance(shown, sympy.MatrixBase):
        vocab.learn(shown, sym)
    elif max(shown.shape) <= ENTRY_VOCABULARY:  # R_1 = (R_11, R_12): |R_1| from them
        for (i, j), entry in np.ndenumerate(np.array(shown, dtype=object)):
            if _nodes(entry, ENTRY_MAX_NODES) < ENTRY_MAX_NODES and \
                    sympy.count_ops(entry) >= ENTRY_MIN_OPS:
                vocab.learn(entry, entry_symbol(sym, i, j, shown.shape))


#: an expression is simplified only below this many operations and nodes
#: (``sympy.simplify`` takes seconds on a hundred operations) ...
SIMPLIFY_MAX_OPS, SIMPLIFY_MAX_NODES = 30, 100
#: ... and within this many seconds of process time (a bound that a size below
#: the limits never reaches; where it is reached the form stays as it was)
SIMPLIFY_SECONDS = 10.0


def _shortest(form, vocab: _Vocabulary, memo: dict):
    """(the printed form of scalar ``form``, its form written with the earlier
    quantities as declared): the shortest (fewest operations) of the declared
    form written with the earlier quantities, the simplified form so written
    and the simplified written form; the declared one where none is shorter."""
    plain = vocab.write(form, memo) if vocab.exact else form
    sources = [(e, write) for e, write in ((form, True), (plain, False)) if _small(e)]
    if not sources:
        return plain, plain
    best, ops = plain, sympy.count_ops(plain)
    for source, write in sources:
        simpler = _simplified(source)
        if simpler is None:
            continue
        if write and vocab.exact:
            simpler = vocab.write(simpler, {})
        n = sympy.count_ops(simpler)
        if n < ops:
            best, ops = simpler, n
    return best, plain


def _small(e) -> bool:
    """Whether ``e`` is small enough to simplify (and not a case distinction)."""
    return isinstance(e, sympy.Expr) and not e.is_Atom and \
        _nodes(e, SIMPLIFY_MAX_NODES) < SIMPLIFY_MAX_NODES and \
        sympy.count_ops(e) <= SIMPLIFY_MAX_OPS and not e.has(sympy.Piecewise)


def _simplified(e):
    """``sympy.simplify(e)`` when it finishes in time, else None."""
    try:
        with _time_limit(SIMPLIFY_SECONDS):
            return sympy.simplify(e)
    except _TimeUp:
        return None


class _TimeUp(Exception):
    pass


@contextlib.contextmanager
def _time_limit(seconds: float):
    """Raise _TimeUp inside the block after ``seconds`` of process time (in
    the main thread of a POSIX process; elsewhere the block runs unbounded and
    only the size limits hold)."""
    usable = hasattr(signal, "setitimer") and \
        threading.current_thread() is threading.main_thread()
    if not usable:
        yield
        return

    def stop(_signum, _frame):
        raise _TimeUp

    previous = signal.signal(signal.SIGPROF, stop)
    signal.setitimer(signal.ITIMER_PROF, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGPROF, previous)


def _nodes(e, limit: int) -> int:
    """The number of nodes of ``e`` (as a tree), counted up to ``limit``."""
    n = 0
    for _ in sympy.preorder_traversal(e):
        n += 1
        if n >= limit:
            break
    return n


def entry_symbols(written) -> list[tuple[QuantitySymbol, object]]:
    """Every symbol the written forms of :func:`quantities_written` may use,
    in order, with the (written) expression it stands for: the scalar
    quantities and the entries of the small matrices."""
    out = []
    for _q, sym, shown in written:
        if not isinstance(shown, sympy.MatrixBase):
            out.append((sym, shown))
        elif max(shown.shape) <= ENTRY_VOCABULARY:
            out += [(entry_symbol(sym, i, j, shown.shape), e)
                    for (i, j), e in np.ndenumerate(np.array(shown, dtype=object))]
    return out
