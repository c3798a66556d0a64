"""Parameter studies on dask.distributed (``loomfmu sweep``).

    from loomfmu.sweep import Study, Figure, grid, run_study
    study = Study("heald_frame", cases=grid(b1=[0.008, 0.012], k_z=[3.0, 5.0]),
                  figures=[Figure("max_abs", "x2_out")], stop_time=0.42,
                  output_interval=1e-3, rtol=1e-8, atol=1e-11)
    result = run_study(study, out="map.csv", workers=2)

A study is a model of loomfmu.registry (built once into an FMU), a list of
cases (grid, lists, latin_hypercube), the figures recorded of each case
(Figure: a reduction of one output over time; Derived: a function of the
outputs) and the experiment. run_study runs it on an embedded LocalCluster
(or any scheduler), one task per case, each worker extracting the FMU once
and resetting one instance between cases; rows go to a CSV keyed by a case
hash, so a rerun resumes. run_serial is the plain loop it is checked
against. The seeds' studies: loomfmu.machines.studies.

May import: declare, progress, registry, export, verification, fmu.  A generic
layer: it never imports a mechanism's content.
"""
from loomfmu.sweep.figures import REDUCTIONS, Derived, Figure, parse_figure
from loomfmu.sweep.run import StudyResult, fmu_blob, run_serial, run_study
from loomfmu.sweep.space import grid, latin_hypercube, lists
from loomfmu.sweep.study import Study, case_key
from loomfmu.sweep.worker import STATUSES

__all__ = ["Derived", "Figure", "REDUCTIONS", "STATUSES", "Study", "StudyResult", "case_key",
           "fmu_blob", "grid", "latin_hypercube", "lists", "parse_figure", "run_serial",
           "run_study"]
