"""The declaration's CasADi expressions in readable form: SymPy, LaTeX, MathML.

CasADi prints an SX expression as a chain of ``@1=...`` temporaries and has
no LaTeX printer; no maintained CasADi-to-SymPy bridge exists.  This package
reads an expression through CasADi's function instruction interface and
rebuilds it in SymPy, one instruction at a time (:mod:`.convert`, the op
table :data:`OPS`), names shared subexpressions once (:mod:`.listing`), prints
the model's variable names as a machine designer writes them (:mod:`.names`)
and prints LaTeX and MathML (:mod:`.printing`); the derivation's named
quantities, matrices included, go through :mod:`.quantity_forms`.

Symbols keep the model's own names (``sympy.Symbol.name`` is the variable's
name, e.g. ``"der(phi)"`` or ``"n3.vax"``) and print the way a machine
designer writes them: ``der(phi)`` as :math:`\\dot{\\phi}`, ``alpha1`` as
:math:`\\alpha_1`, ``T_min`` as :math:`T_{\\mathrm{min}}`, ``n3.vx`` as
:math:`v_{x,\\mathrm{n3}}`, ``delay(u)`` as :math:`u^{\\mathrm{del}}`.

The front door::

    from loomfmu import load_model
    from loomfmu.inspection import readable
    m = load_model("backrest")
    readable.equations(m)        # [(lhs, rhs), ...] as SymPy, lhs - rhs = 0
    readable.outputs(m)          # [(y, expr), ...]
    readable.quantities(m)       # [(Quantity, SymPy expr or Matrix), ...]
    lst = readable.listing(m)    # shared subexpressions named once (sympy.cse)
    print(readable.latex(m))     # one LaTeX line per definition / equation
    html = readable.mathml(m)    # one <math display="block"> per line

:func:`to_sympy` converts any SX expression (e.g. an event indicator).
"""
from loomfmu.inspection.readable.convert import OPS, symbols, to_sympy, to_sympy_matrix
from loomfmu.inspection.readable.listing import (
                             Listing,
                             delays,
                             equations,
                             events,
                             listing,
                             mode_rules,
                             outputs,
)
from loomfmu.inspection.readable.names import Shared, Var, latex_name
from loomfmu.inspection.readable.printing import latex, mathml, mathml_body, mathml_line, to_latex
from loomfmu.inspection.readable.quantity_forms import (
                             ENTRY_VOCABULARY,
                             QuantitySymbol,
                             entry_symbol,
                             entry_symbols,
                             quantities,
                             quantities_written,
                             quantity,
                             symbol_mathml,
                             written_with_quantities,
)

__all__ = ["OPS", "ENTRY_VOCABULARY", "Var", "Shared", "Listing", "QuantitySymbol",
           "latex_name", "to_sympy", "to_sympy_matrix", "symbols", "equations", "outputs",
           "events", "mode_rules", "delays", "listing", "quantities", "quantity",
           "quantities_written", "entry_symbol", "entry_symbols", "symbol_mathml",
           "written_with_quantities", "latex", "mathml", "mathml_line", "mathml_body",
           "to_latex"]
