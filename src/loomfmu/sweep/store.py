"""The results table of a study: one CSV row per finished case.

Rows are appended (and flushed) as cases finish, so an interrupted study
keeps every finished case; at the end the file is rewritten ordered by case
index. Floats are written with repr, so reading them back gives the same
bits. A Parquet copy is written next to it when pyarrow is installed.
"""
from __future__ import annotations

import csv
import os
from pathlib import Path

FIXED_COLUMNS = ("index", "key")
TAIL_COLUMNS = ("status", "message")
TIMING_COLUMNS = ("wall_s", "worker")


def columns(case_names: list[str], figure_names: list[str]) -> list[str]:
    return [*FIXED_COLUMNS, *case_names, *TAIL_COLUMNS, *figure_names, *TIMING_COLUMNS]


def _text(value) -> str:
    if isinstance(value, float):
        return repr(value)
    return "" if value is None else str(value)


def _value(text: str | None):
    if text is None:  # a line cut short
        return None
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def read_rows(path: Path) -> list[dict]:
    """The rows of a results file (missing file: none), values typed back:
    ints, floats (bit for bit), booleans, text."""
    path = Path(path)
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return [{k: (v if k in ("key", "message", "worker", "status") else _value(v))
                 for k, v in r.items()} for r in csv.DictReader(f)]


def header_of(path: Path) -> list[str] | None:
    path = Path(path)
    if not path.exists() or path.stat().st_size == 0:
        return None
    with path.open(newline="") as f:
        return next(csv.reader(f), None)


class Appender:
    """Appends rows to ``path`` (writing the header first if the file is new)."""

    def __init__(self, path: Path, cols: list[str]):
        self.path, self.cols = Path(path), cols
        self.path.parent.mkdir(parents=True, exist_ok=True)
        new = header_of(self.path) is None
        self._f = self.path.open("a", newline="")
        self._w = csv.writer(self._f)
        if new:
            self._w.writerow(cols)
            self._f.flush()

    def add(self, row: dict) -> None:
        self._w.writerow([_text(row.get(c)) for c in self.cols])
        self._f.flush()  # a killed study keeps its rows (no fsync: 10+ ms a row)

    def close(self) -> None:
        self._f.close()


def write_rows(path: Path, cols: list[str], rows: list[dict]) -> None:
    """Write ``rows`` (ordered by index) atomically, plus Parquet if possible."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    with tmp.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for row in sorted(rows, key=lambda r: r["index"]):
            w.writerow([_text(row.get(c)) for c in cols])
    os.replace(tmp, path)
    _parquet(path.with_suffix(".parquet"), cols, rows)


def _parquet(path: Path, cols: list[str], rows: list[dict]) -> None:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # optional: CSV is the table
        return
    data = {c: [r.get(c) for r in sorted(rows, key=lambda r: r["index"])] for c in cols}
    pq.write_table(pa.table(data), path)
