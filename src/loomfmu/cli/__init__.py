"""The ``loomfmu`` command: the one front door.

Owns the parser and the commands build, list, simulate and verify
(:mod:`.dispatch`, :mod:`.commands`), ``loomfmu scene`` (:mod:`.scene`) and
``loomfmu sweep`` (:mod:`.sweep`); the mechanism packages and bench bring
their own subcommands, which :mod:`.dispatch` hands the rest of the line to.

May import: every layer.
"""
from loomfmu.cli.dispatch import main

__all__ = ["main"]
