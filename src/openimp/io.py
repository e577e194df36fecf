"""Result tables and their export: IMP-style listings, JSON, CSV and STORE files.

A :class:`Table` is what a request produces: the request that asked for it
(``LIST POSITION``), the item (``joint JT5``), column names with units and
rows of numbers in the units the listing prints (degrees where IMP prints
degrees).  :class:`Run` gathers the tables of one EXECUTE.  Writers produce
the JSON schema of DESIGN.md, one CSV file per table and IMP's STORE file;
files are written whole or not at all (:mod:`openimp.files`).
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from io import StringIO
from pathlib import Path
from typing import Any

import numpy as np

from openimp import files
from openimp.errors import OutputError


@dataclass
class Table:
    """One listed table: request, item, columns, units and rows."""

    request: str
    item: str
    columns: list[str]
    units: list[str]
    rows: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (NaN written as null)."""
        arr = np.asarray(self.rows, dtype=float)
        rows = arr.tolist()
        if not np.all(np.isfinite(arr)):
            rows = [[v if math.isfinite(v) else None for v in r] for r in rows]
        return {"request": self.request, "item": self.item, "columns": list(self.columns),
                "units": list(self.units), "rows": rows}


@dataclass
class Run:
    """The output of one EXECUTE: its title, mode, tables and messages."""

    title: str
    mode: str
    tables: list[Table] = field(default_factory=list)
    messages: list[str] = field(default_factory=list)
    #: set when the analysis stopped early (what was computed is still listed)
    failure: str = ""
    #: requests that could not be produced (analyses not built yet), one message each
    unsupported: list[str] = field(default_factory=list)
    #: set when the user interrupted the run (Ctrl-C); what was solved is kept
    interrupted: bool = False

    @property
    def ok(self) -> bool:
        """True when the run finished and produced every request."""
        return not self.failure and not self.unsupported

    def table(self, request: str, item: str) -> Table:
        """The table of a request (``'LIST POSITION'``) and item (``'joint A'``)."""
        for t in self.tables:
            if t.request == request and t.item == item:
                return t
        have = ", ".join(f"{t.request} / {t.item}" for t in self.tables) or "none"
        raise KeyError(f"no table {request} / {item} in run {self.title!r} (tables: {have})")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict of the run."""
        d: dict[str, Any] = {"title": self.title, "mode": self.mode,
                             "tables": [t.to_dict() for t in self.tables]}
        if self.messages:
            d["messages"] = list(self.messages)
        if self.failure:
            d["failure"] = self.failure
        if self.unsupported:
            d["unsupported"] = list(self.unsupported)
        if self.interrupted:
            d["interrupted"] = True
        return d


def atomic_write(path: str | os.PathLike[str], text: str | bytes) -> Path:
    """Write ``text`` to ``path`` whole or not at all (see :func:`openimp.files.atomic_write`).

    The file gets the permissions ``open()`` would give it (the umask
    applies); no temporary file is left behind.  Raises
    :class:`~openimp.errors.OutputError` naming ``path`` when it cannot be
    written.
    """
    return files.atomic_write(path, text)


def json_text(runs: Sequence[Run]) -> str:
    """The DESIGN.md JSON document of ``runs`` (full precision, NaN as null)."""
    doc = {"runs": [r.to_dict() for r in runs]}
    return json.dumps(doc, allow_nan=False) + "\n"


def write_json(path: str | os.PathLike[str], runs: Sequence[Run]) -> Path:
    """Write every run's tables in the DESIGN.md JSON schema, full precision."""
    return atomic_write(path, json_text(runs))


def _slug(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", s).strip("_").lower() or "table"


def csv_files(runs: Sequence[Run]) -> list[tuple[str, str]]:
    """``(file name, CSV text)`` of every table (``run<k>_<request>_<item>.csv``)."""
    out: list[tuple[str, str]] = []
    names: set[str] = set()
    for k, run in enumerate(runs, start=1):
        for t in run.tables:
            stem = f"run{k}_{_slug(t.request)}_{_slug(t.item)}"
            name, n = f"{stem}.csv", 2
            while name in names:
                name, n = f"{stem}_{n}.csv", n + 1
            names.add(name)
            out.append((name, _csv_text(t)))
    return out


def _csv_text(t: Table) -> str:
    """One table as CSV: a header ``column [unit]``, then rows of full-precision numbers."""
    buf = StringIO()
    w = csv.writer(buf)
    w.writerow([f"{c} [{u}]" if u else c for c, u in zip(t.columns, t.units)])
    rows = np.asarray(t.rows, dtype=float)
    w.writerows([[repr(v) for v in r] for r in rows.tolist()])
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


def banner(title: str, mode: str, when: str) -> str:
    """IMP's run banner: a 72-column box with the title, mode and date."""
    width = 72
    lines = ["*" * width]
    for text in ("", title, "", f"{mode} Mode", f"on {when}", ""):
        lines.append("*" + text.center(width - 2) + "*")
    lines.append("*" * width)
    return "\n".join(lines)


#: how a request's quantity is named in listing headers
QUANTITY_WORDS = {"POSITION": "position", "VELOCITY": "velocity", "ACCEL": "acceleration",
                  "VALUE": "value", "HEADING": "generalized coordinates"}


def format_listing(t: Table) -> str:
    """IMP-style listing of a table: header, column titles, one row per step.

    Time prints as %.6f (a step number as an integer) and values as %.3f (IMP's
    LIST format, reference 2.3); values IMP cannot determine print as ????.
    """
    quantity = t.request.split(maxsplit=1)[-1].upper()
    head = f"Listing of {QUANTITY_WORDS.get(quantity, quantity.lower())} of {t.item}"
    if quantity == "FORCE":
        head = f"Listing of force in {t.item}"
    titles = [f"{c}" + (f" ({u})" if u else "") for c, u in zip(t.columns, t.units)]
    widths = [max(12, len(s) + 2) for s in titles]
    lines = [head, "".join(s.rjust(w) for s, w in zip(titles, widths))]
    for r in t.rows:
        cells = []
        for j, v in enumerate(r):
            if not math.isfinite(v):
                s = "????"
            elif j == 0 and t.columns[0] == "Step":
                s = step_text(v)
            elif j == 0 and t.columns[0].lower() in ("time", "step"):
                s = f"{v:.6f}"
            else:
                s = f"{v:.3f}"
                if s == "-0.000":
                    s = "0.000"
            cells.append(s.rjust(widths[j]))
        lines.append("".join(cells))
    return "\n".join(lines)


def step_text(v: float) -> str:
    """A step number as listings print it: an integer (``%.6f`` if it is not one)."""
    return f"{v:.0f}" if v == round(v) else f"{v:.6f}"


def format_store(runs: Sequence[Run]) -> str:
    """IMP's STORE file: every STORE table of every run, one line per row.

    Each table starts with ``# <request> <item>`` and a column line; rows hold
    full-precision numbers (``%.10g``); undetermined values are written as
    ``0.000002``, as IMP did (reference §5).
    """
    lines: list[str] = []
    for k, run in enumerate(runs, start=1):
        for t in run.tables:
            if not t.request.upper().startswith("STORE"):
                continue
            lines.append(f"# run {k}: {run.title}")
            lines.append(f"# {t.request} {t.item}")
            lines.append("# " + " ".join(f"{c} [{u}]" if u else c
                                         for c, u in zip(t.columns, t.units)))
            for r in t.rows:
                lines.append(" ".join(f"{v:.10g}" if math.isfinite(v) else "0.000002"
                                      for v in r))
    return "\n".join(lines) + ("\n" if lines else "")


def format_run(run: Run, when: str) -> str:
    """The whole listing of a run: banner, messages, every table."""
    parts = [banner(run.title, run.mode, when)]
    parts.extend(f"*** {m} ***" for m in run.messages)
    for t in run.tables:
        parts.append("")
        parts.append(format_listing(t))
    if run.failure:
        parts.append("")
        parts.append(f"*** {run.failure} ***")
    return "\n".join(parts) + "\n"


def tables_from_columns(request: str, item: str, names: Iterable[str], units: Iterable[str],
                        cols: Iterable[np.ndarray]) -> Table:
    """A table from parallel column arrays."""
    arr = np.column_stack([np.asarray(c, dtype=float) for c in cols])
    return Table(request, item, list(names), list(units), arr)
