"""Inspection: the derivation of a model as a reader sees it.

Owns ``loomfmu.inspect`` (:mod:`.core`: named quantities evaluated, the
Jacobian's sparsity, the printed equations), the derivation reports in
HTML/MathML, Markdown and LaTeX (``loomfmu inspect``: :mod:`.report`,
:mod:`.derivation`, :mod:`.document`), readable formulas from CasADi
expressions through SymPy (:mod:`.readable`) and the generated model pages
(``loomfmu docs``: :mod:`.model_pages`).

May import: :mod:`loomfmu.declare`, :mod:`loomfmu.registry`,
:mod:`loomfmu.fidelity`, :mod:`loomfmu.export`.
"""
