"""Export: a declared :class:`~loomfmu.declare.Model` as text an FMU is made of.

Owns the DAE form (explicit or implicit, unknowns, Jacobian sparsity,
:mod:`.dae`), the generated C (CasADi functions and the model's declaration
table, :mod:`.codegen`), the FMI 2.0/3.0 model descriptions and their model
structure (:mod:`.fmi_xml`, :mod:`.fmi_structure`) and the list of the C
runtime's files (:mod:`.runtime_files`).

May import: :mod:`loomfmu.declare`.  It never imports a mechanism's content.
"""
