"""IMP-style listings (docs/imp-language.md §2.2-2.4): run banners, LIST tables, STORE files.

Built from the result containers (:class:`~openimp.results.Table`,
:class:`~openimp.results.Run`); printed numbers follow IMP's formats.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

from openimp.results import Run, Table


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


def format_listing(t: Table, units: bool = True) -> str:
    """IMP-style listing of a table: header, column titles, one row per step.

    Time prints as %.6f (a step number as an integer) and values as %.3f (IMP's
    LIST format, docs/imp-language.md §2.3); values IMP cannot determine print as ????.
    ``units``: the column titles carry their units (``Time (s)``); without them
    they are IMP's (``Time  JVar 1``).
    A frequency response (LIST DYNAMICS) prints every number with 6
    significant digits: its magnitudes span decades.
    """
    quantity = t.request.split(maxsplit=1)[-1].upper()
    head = f"Listing of {QUANTITY_WORDS.get(quantity, quantity.lower())} of {t.item}"
    if quantity == "FORCE":
        head = f"Listing of force in {t.item}"
    elif quantity == "DYNAMICS":
        head = f"Listing of the frequency response to {t.item}"
    titles = [f"{c}" + (f" ({u})" if u and units else "") for c, u in zip(t.columns, t.units)]
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
            elif quantity == "DYNAMICS":
                s = f"{v:.6g}"
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
    ``0.000002``, as IMP did (docs/imp-language.md §5).
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
