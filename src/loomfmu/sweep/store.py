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


_TEXT_COLUMNS = ("key", "message", "worker", "status")


def _typed(cols: list[str], fields: list[str]) -> dict:
    row = {k: (v if k in _TEXT_COLUMNS else _value(v)) for k, v in zip(cols, fields)}
    row.update({k: None for k in cols[len(fields):]})   # a line cut short
    return row


def read_rows(path: Path) -> list[dict]:
    """The rows of a results file (missing file: none), values typed back:
    ints, floats (bit for bit), booleans, text; a line cut short has None in
    its missing columns, a line with more fields than the header keeps the
    header's columns."""
    return [row for _, row, _ in read_lines(path)]


def read_lines(path: Path) -> list[tuple[int, dict, str | None]]:
    """Each row of a results file with its line number and what is wrong with
    its shape (None: nothing): fewer or more fields than the header."""
    path = Path(path)
    if not path.exists():
        return []
    out = []
    with path.open(newline="") as f:
        reader = csv.reader(f)
        cols = next(reader, None)
        if cols is None:
            return []
        for fields in reader:
            if not fields:
                continue
            problem = None
            if len(fields) != len(cols):
                problem = (f"{len(fields)} fields, the header has {len(cols)}"
                           + (" (a line cut short)" if len(fields) < len(cols) else ""))
            out.append((reader.line_num, _typed(cols, fields[:len(cols)]), problem))
    return out


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
