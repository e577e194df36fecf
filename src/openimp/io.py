"""Export of results: one JSON document of every run and one CSV file per table.

The JSON document, ``{"runs": [{"title", "mode", "tables": [{"request", "item",
"columns", "units", "rows"}, ...], ...}]}``, is described in docs/imp.md
("Requests and output"), the CSV files (``run<k>_<request>_<item>.csv``, a
header ``column [unit]``, undefined values ``nan``) there and in its "Quick start".

The tables (:class:`~openimp.results.Table`) and runs
(:class:`~openimp.results.Run`) are result containers; IMP-style listings and
STORE files are written by :mod:`openimp.imp.listing`.  Files are written
whole or not at all (:mod:`openimp.files`).
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Sequence
from io import StringIO
from pathlib import Path

import numpy as np

from openimp import files
from openimp.errors import OutputError
from openimp.results import Run, Table

__all__ = ["Run", "Table", "atomic_write", "csv_files", "json_text", "write_csv",
           "write_json"]


def atomic_write(path: str | os.PathLike[str], text: str | bytes) -> Path:
    """Write ``text`` to ``path`` whole or not at all (see :func:`openimp.files.atomic_write`).

    The file gets the permissions ``open()`` would give it (the umask
    applies); no temporary file is left behind.  Raises
    :class:`~openimp.errors.OutputError` naming ``path`` when it cannot be
    written.
    """
    return files.atomic_write(path, text)


def json_text(runs: Sequence[Run]) -> str:
    """The JSON document of ``runs`` (full precision, NaN as null; docs/imp.md,
    "Requests and output")."""
    doc = {"runs": [r.to_dict() for r in runs]}
    return json.dumps(doc, allow_nan=False) + "\n"


def write_json(path: str | os.PathLike[str], runs: Sequence[Run]) -> Path:
    """Write every run's tables as the JSON document of :func:`json_text`, full precision."""
    return atomic_write(path, json_text(runs))


def csv_files(runs: Sequence[Run]) -> list[tuple[str, str]]:
    """``(file name, CSV text)`` of every table (``run<k>_<request>_<item>.csv``)."""
    out: list[tuple[str, str]] = []
    names: set[str] = set()
    for k, run in enumerate(runs, start=1):
        for t in run.tables:
            stem = f"run{k}_{files.slug(t.request)}_{files.slug(t.item)}"
            name, n = f"{stem}.csv", 2
            while name in names:
                name, n = f"{stem}_{n}.csv", n + 1
            names.add(name)
            out.append((name, _csv_text(t)))
    return out


def _csv_text(t: Table) -> str:
    """One table as CSV: a header ``column [unit]``, then rows of full-precision numbers;
    an undefined value (any number that is not finite) is ``nan``, as it is ``null`` in
    JSON and ``????`` in a listing."""
    buf = StringIO()
    w = csv.writer(buf)
    w.writerow([f"{c} [{u}]" if u else c for c, u in zip(t.columns, t.units)])
    rows = np.asarray(t.rows, dtype=float)
    w.writerows([[repr(v) if math.isfinite(v) else "nan" for v in r] for r in rows.tolist()])
    return buf.getvalue()


def write_csv(directory: str | os.PathLike[str], runs: Sequence[Run]) -> list[Path]:
    """One CSV file per table (``run<k>_<request>_<item>.csv``); returns the paths.

    Every file that can be written is written; the first
    :class:`~openimp.errors.OutputError` is raised after the others.
    """
    out = Path(directory)
    paths: list[Path] = []
    first: OutputError | None = None
    for name, text in csv_files(runs):
        try:
            paths.append(atomic_write(out / name, text))
        except OutputError as exc:
            first = first or exc
    if first is not None:
        raise first
    return paths
