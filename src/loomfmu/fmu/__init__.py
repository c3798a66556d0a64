"""The FMU archive: compile, document, zip.

Owns :func:`~.builder.build_fmu` (sources, gcc with strict flags, the
exported-symbol check, validation, the .fmu), the compile cache
(:mod:`.compile_cache`) and the FMU's own documentation page
(:mod:`.documentation`).

May import: :mod:`loomfmu.declare`, :mod:`loomfmu.registry`,
:mod:`loomfmu.export`, :mod:`loomfmu.verification`, :mod:`loomfmu.inspection`.
"""
