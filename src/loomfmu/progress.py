"""Progress of long work: a tqdm bar on a terminal, plain lines in logs.

Every command that can run longer than a few seconds (builds, references,
benchmarks, design searches, calibrations) reports through :class:`Progress`::

    with Progress(total=len(models), desc="build") as bar:
        for name in models:
            bar.stage(f"{name}: compiling")
            ...
            bar.advance(f"{name}: done")

On a terminal (stderr is a TTY) it draws a tqdm bar whose postfix is the
current stage; elsewhere (CI logs, pipes) it prints one plain line per stage,
``build [2/8] drive: compiling (14 s)``, so a log reads top to bottom. The
environment variable ``LOOMFMU_PROGRESS`` forces ``bar``, ``plain`` or ``off``.
"""
from __future__ import annotations

import os
import sys
import time
from typing import TextIO

MODES = ("bar", "plain", "off")


def _mode(stream: TextIO) -> str:
    forced = os.environ.get("LOOMFMU_PROGRESS", "").strip().lower()
    if forced:
        if forced not in MODES:
            raise ValueError(f"LOOMFMU_PROGRESS = {forced!r}; allowed: {list(MODES)}")
        return forced
    isatty = getattr(stream, "isatty", None)
    return "bar" if isatty is not None and isatty() else "plain"


class Progress:
    """How far a piece of work of ``total`` units is, and what it does now.

    total: number of units (>= 0); desc: a short name printed before each line.
    """

    def __init__(self, total: int, desc: str, *, stream: TextIO | None = None):
        if not isinstance(total, int) or total < 0:
            raise ValueError(f"total = {total!r}; allowed: an integer >= 0")
        self.total, self.desc, self.done = total, desc, 0
        self.stream = stream if stream is not None else sys.stderr
        self.mode = _mode(self.stream)
        self.t0 = time.perf_counter()
        self._bar = None
        if self.mode == "bar":
            from tqdm import tqdm
            self._bar = tqdm(total=total, desc=desc, file=self.stream, leave=True,
                             bar_format="{desc} {bar} {n_fmt}/{total_fmt} "
                                        "[{elapsed}<{remaining}] {postfix}")

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _line(self, text: str) -> None:
        if self.mode == "plain":
            elapsed = time.perf_counter() - self.t0
            print(f"{self.desc} [{self.done}/{self.total}] {text} ({elapsed:.0f} s)",
                  file=self.stream, flush=True)

    def stage(self, text: str) -> None:
        """Say what is being done now (does not advance)."""
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=True)
        self._line(text)

    def advance(self, text: str = "", n: int = 1) -> None:
        """``n`` more units are done; ``text`` says which."""
        self.done += n
        if self._bar is not None:
            self._bar.update(n)
            if text:
                self._bar.set_postfix_str(text, refresh=True)
        elif text:
            self._line(text)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
