"""Benchmarks (scripts, never timed tests).

    loomfmu bench charts [--quick] [--models heald_frame drive ...]
    loomfmu bench speed [--model heald_frame] [--repeats 5]
    loomfmu bench friction
    loomfmu bench limit [--models heald_frame drive ...] [--solvers dopri5 rodas4]

``charts``: work-precision and failure charts for every model in
:data:`loomfmu.bench.scenes.BENCH` (docs/results/bench/); ``speed`` and
``friction``: the first two benchmarks (docs/results/speed.json, docs/results/friction.json);
``limit``: each model at C level against its method's limit
(docs/results/limit.json, docs/guides/limit.md). ``loomfmu bench COMMAND --help``: a
command's options and their defaults.

May import: every layer but the command line; the benchmark scripts in
benchmarks/ import it.
"""
from loomfmu.bench.classic import friction, speed, time_at_error  # noqa: F401
from loomfmu.bench.cli import main  # noqa: F401
