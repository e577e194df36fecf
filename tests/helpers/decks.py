"""IMP decks written and run by the tests."""

from __future__ import annotations

from pathlib import Path

from openimp.imp.deck import load


def run_deck(path: Path):
    deck = load(path)
    echo: list[str] = []
    runs = deck.run(echo=echo.append)
    return runs, echo


def write(tmp_path: Path, text: str, name: str = "deck.imp") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def line_of(text: str, start: str) -> int:
    """1-based number of the first line of ``text`` that starts with ``start``."""
    for i, ln in enumerate(text.splitlines(), start=1):
        if ln.startswith(start):
            return i
    raise AssertionError(start)
