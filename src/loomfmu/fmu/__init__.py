"""The FMU archive: compile, document, zip.

Owns :func:`~.builder.build_fmu` (sources, gcc with strict flags, the
exported-symbol check, validation, the .fmu), the platforms it builds
binaries for (:mod:`.platforms`), the driver that runs those binaries
natively and under emulators (:mod:`.platform_run`, ``platform_driver.c``),
the compile cache (:mod:`.compile_cache`), the FMU's own documentation
page (:mod:`.documentation`) and the reference result it carries under
FMI-LS-REF, with its check (:mod:`.reference_results`).

May import: :mod:`loomfmu.declare`, :mod:`loomfmu.models` (a model module's
docstring, for the page), :mod:`loomfmu.registry`, :mod:`loomfmu.fidelity`,
:mod:`loomfmu.export`, :mod:`loomfmu.verification`, :mod:`loomfmu.inspection`.
"""
