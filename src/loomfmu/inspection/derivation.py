"""The "Derivation" section of ``loomfmu inspect``: a model's named quantities
(``Model.quantity``) in declaration order under their group headings, each
with its symbol, definition, unit, description and source.

Scalars and matrices up to :data:`SMALL` x :data:`SMALL` print entry by
entry (written with the earlier scalar quantities' symbols); longer columns
as a table of their values at the parameters' defaults; larger matrices as a
picture: the non-zero pattern coloured by magnitude at the parameters'
defaults (inline SVG for HTML, digits for Markdown and LaTeX), with size,
non-zeros and symmetry.
"""
from __future__ import annotations

import html
import math

import casadi as ca
import numpy as np
import sympy

from loomfmu.inspection import readable
from loomfmu.inspection.core import evaluate
from loomfmu.inspection.document import Code, Def, Equations, Math, Para, Picture, Section, Table

#: a matrix quantity with both dimensions up to this prints entry by entry
SMALL = 8
#: a small matrix prints as a matrix when its rows are at most this wide (characters
#: of SymPy's plain print of the widest entry of each column, added up)
MATRIX_WIDTH = 150
#: a small matrix whose plain print is longer than this shows as a picture too
HUGE_MATRIX = 12_000
#: a long column's values, this many to a table row
PER_ROW = 8
#: the picture's width and height in pixels, at most
PICTURE_PX = 480
#: colour stops from the smallest to the largest magnitude (viridis-like)
#: the legend's width in pixels, at least
LEGEND_PX = 160
#: a value below this times the matrix's largest is shown as round-off, in grey
ROUNDOFF = 1e-12
TINY_COLOUR = "#cfcfcf"
PALETTE = ((68, 1, 84), (59, 82, 139), (33, 145, 140), (94, 201, 98), (253, 231, 37))


def derivation(model) -> Section | None:
    """The Derivation section, or None when the model keeps no quantity."""
    if not model.quantities:
        return None
    sec = Section("Derivation", [
        f"The {len(model.quantities)} named quantities of the derivation, in the order the "
        "model declares them, each written with the quantities before it. They are kept "
        "for reading: the equations below are what runs."])
    sec.blocks += [Picture(f.svg, f"[figure {f.name}: drawn in the HTML report]", f.caption)
                   for f in model.figures]
    groups: dict[str, Section] = {}
    for q, sym, shown in readable.quantities_written(model):
        title = q.group or "Other quantities"
        if title not in groups:
            groups[title] = Section(title, level=3)
            sec.blocks.append(groups[title])
        groups[title].blocks += _quantity_blocks(model, q, sym, shown)
    return sec


def _about(q, sym) -> Para:
    parts = [Math(sym), " (", Code(q.name)]
    parts += [f", {q.unit})" if q.unit else ")", f": {q.description}"]
    if q.source:
        parts.append(f". Source: {q.source}")
    return Para(parts)


def _quantity_blocks(model, q, sym, shown) -> list:
    blocks = [_about(q, sym)]
    n1, n2 = q.expr.shape
    if (n1, n2) == (1, 1):
        return blocks + [Equations([(sympy.Eq(sym, shown, evaluate=False), "")])]
    if max(n1, n2) <= SMALL and not _printed_longer_than(shown, HUGE_MATRIX):
        if _fits(shown):
            return blocks + [Equations([(Def(sym, shown), "")])]
        lines = [(sympy.Eq(readable.entry_symbol(sym, i, j, (n1, n2)), shown[i, j],
                           evaluate=False), "")
                 for j in range(n2) for i in range(n1) if shown[i, j] != 0]
        return blocks + [f"{n1} \u00d7 {n2}, the non-zero entries one per line:",
                         Equations(lines)]
    if n2 == 1 and (vals := _values(model, q)) is not None:
        return blocks + _vector_table(q, vals[:, 0])
    return blocks + [_picture(model, q)]


def _printed_longer_than(m, limit: int) -> bool:
    """Whether SymPy's plain print of matrix ``m`` is longer than ``limit``
    characters. Every occurrence of a symbol in an entry's tree prints its
    (non-empty) name, so more than ``limit`` of them decide it without
    printing (a huge entry takes seconds to print); otherwise it is printed."""
    seen = 0
    for entry in m:
        for node in sympy.preorder_traversal(entry):
            if node.is_Symbol:
                seen += 1
                if seen > limit:
                    return True
    return len(str(m)) > limit


def _vector_table(q, vals: np.ndarray) -> list:
    """A long column's values at the defaults, :data:`PER_ROW` to a row."""
    n = len(vals)
    rows = [[f"{k + 1}-{min(k + PER_ROW, n)}"] + [f"{v:.5g}" for v in vals[k:k + PER_ROW]]
            + [""] * (PER_ROW - len(vals[k:k + PER_ROW])) for k in range(0, n, PER_ROW)]
    unit = f" ({q.unit})" if q.unit else ""
    return [f"{q.name}: {n} entries{unit} at the default parameters, {PER_ROW} to a row:",
            Table(["entries"] + [f"+{k}" for k in range(PER_ROW)], rows)]


def _fits(m: sympy.MatrixBase) -> bool:
    """Whether matrix ``m`` reads well as a matrix (else one entry per line)."""
    widths = [max(len(str(m[i, j])) for i in range(m.rows)) for j in range(m.cols)]
    return sum(widths) + 3 * m.cols <= MATRIX_WIDTH


def _values(model, q) -> np.ndarray | None:
    """The quantity at the variables' start values, or None when some symbol
    has none (e.g. der(x))."""
    try:
        return evaluate(model, q.expr)
    except ValueError:
        return None


def _colour(t: float) -> str:
    """The palette at t in [0, 1], as #rrggbb."""
    t = min(max(t, 0.0), 1.0) * (len(PALETTE) - 1)
    k = min(int(t), len(PALETTE) - 2)
    f = t - k
    rgb = (round(a + (b - a) * f) for a, b in zip(PALETTE[k], PALETTE[k + 1]))
    return "#%02x%02x%02x" % tuple(rgb)


def _picture(model, q) -> Picture:
    expr = ca.SX(q.expr)
    n1, n2 = expr.shape
    nonzero = np.array([[not expr[i, j].is_zero() for j in range(n2)] for i in range(n1)])
    vals = _values(model, q)
    tiny = np.zeros_like(nonzero)
    if vals is not None:
        nonzero &= vals != 0
        if nonzero.any():
            tiny = nonzero & (np.abs(vals) < ROUNDOFF * np.abs(vals).max())
    shown = nonzero & ~tiny
    mags = np.abs(vals[shown]) if vals is not None and shown.any() else np.array([])
    lo = math.floor(math.log10(mags.min())) if mags.size else 0
    hi = math.floor(math.log10(mags.max())) if mags.size else 0
    cell = max(1, min(24, PICTURE_PX // max(n1, n2)))
    rects, text = [], []
    for i in range(n1):
        row = []
        for j in range(n2):
            mark, colour, tip = _cell(vals, i, j, nonzero, tiny, lo, hi)
            row.append(mark)
            if colour:
                rects.append(f'<rect x="{j * cell}" y="{i * cell}" width="{cell}" '
                             f'height="{cell}" fill="{colour}"><title>{html.escape(tip)}'
                             "</title></rect>")
        text.append("".join(row))
    w, h = n2 * cell, n1 * cell
    width = max(w, LEGEND_PX) + 2
    legend = _legend(lo, hi, max(w, LEGEND_PX), h) if mags.size else ""
    svg = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{h + 40}" '
           f'viewBox="-1 -1 {width} {h + 40}" role="img" aria-label="{html.escape(q.name)}: '
           f'non-zero pattern"><rect x="-0.5" y="-0.5" width="{w + 1}" height="{h + 1}" '
           f'fill="#fff" stroke="#999"/>{"".join(rects)}{legend}</svg>')
    return Picture(svg, "\n".join(text), _facts(q, vals, nonzero, tiny, lo, hi))


def _cell(vals, i, j, nonzero, tiny, lo, hi) -> tuple[str, str, str]:
    """(text mark, SVG colour or "" for none, tooltip) of entry (i, j)."""
    where = f"({i + 1},{j + 1})"
    if not nonzero[i, j]:
        return "\u00b7", "", ""
    if vals is None:
        return "\u25a0", "#444444", where
    tip = f"{where} = {vals[i, j]:.4g}"
    if tiny[i, j]:
        return "~", TINY_COLOUR, tip
    dec = math.floor(math.log10(abs(vals[i, j])))
    return str(min(dec - lo, 9)), _colour((dec - lo) / (hi - lo) if hi > lo else 1.0), tip


def _legend(lo: int, hi: int, w: int, h: int) -> str:
    steps = max(hi - lo, 0) + 1
    bw = w / steps
    out = []
    for k in range(steps):
        colour = _colour(k / (steps - 1) if steps > 1 else 1.0)
        out.append(f'<rect x="{k * bw:.1f}" y="{h + 6}" width="{bw:.1f}" height="10" '
                   f'fill="{colour}"/>')
    out.append(f'<text x="0" y="{h + 30}" font-size="11">1e{lo}</text>')
    out.append(f'<text x="{w}" y="{h + 30}" font-size="11" '
               f'text-anchor="end">1e{hi}</text>')
    return "".join(out)


def _facts(q, vals, nonzero, tiny, lo: int, hi: int) -> str:
    n1, n2 = nonzero.shape
    facts = [f"{q.name}: {n1} \u00d7 {n2}, {int(nonzero.sum())} non-zeros"]
    if n1 == n2:
        sym_struct = bool((nonzero == nonzero.T).all())
        if vals is not None:
            scale = np.abs(vals).max() or 1.0
            sym_vals = bool(np.allclose(vals, vals.T, rtol=0, atol=1e-12 * scale))
            facts.append("symmetric" if sym_vals else
                         "not symmetric" + (" (symmetric pattern)" if sym_struct else ""))
        else:
            facts.append("symmetric pattern" if sym_struct else "unsymmetric pattern")
    shown = nonzero & ~tiny
    if vals is not None and shown.any():
        mags = np.abs(vals[shown])
        facts.append(f"|entries| from {mags.min():.3g} to {mags.max():.3g}"
                     + (f" {q.unit}" if q.unit else "") + " at the default parameters; "
                     f"colour (text: digit k) = decade 1e{lo}+k, up to 1e{hi}")
    if tiny.any():
        facts.append(f"{int(tiny.sum())} entries below {ROUNDOFF:g} times the largest "
                     "(round-off) in grey (text: ~)")
    elif vals is None:
        facts.append("values depend on variables without a start value: pattern only")
    return "; ".join(facts) + "."
