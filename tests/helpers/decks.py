"""IMP decks written and run by the tests."""

from __future__ import annotations

import resource
from pathlib import Path

from openimp.imp.deck import load

#: CPU seconds a deck run in a subprocess may take, compile included (cold on 2 cores:
#: minutes): a run that loops fails, a busy machine does not
CPU_LIMIT = 900

#: a four-bar with four-letter link names (crank 1, coupler sqrt 8, rocker sqrt 5, ground
#: 4): the tests' smallest closed loop, eight lines
FOUR_LOOP = """ZPIN (BASE, CRNK) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
ZPIN (CRNK, CPLR) = B
DATA ZPIN (B) = 1,0,0; 2,0,0; 2,0,0
ZPIN (CPLR, ROCK) = C
DATA ZPIN (C) = 3,2,0; 4,2,0; 4,2,0
ZPIN (ROCK, BASE) = D
DATA ZPIN (D) = 4,0,0; 5,0,0; 5,0,0
"""

#: examples/fourbar.imp's four-bar (BASE, CRANK, COUPLER, ROCKER), its joints only
FOURBAR_JOINTS = """ZPIN (BASE, CRANK) = A
ZPIN (CRANK, COUPLER) = B
ZPIN (COUPLER, ROCKER) = C
ZPIN (ROCKER, BASE) = D
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
DATA ZPIN (B) = 1,0,0; 2,0,0; 3,3,0
DATA ZPIN (C) = 3,3,0; 5,6,0; 4,0,0
DATA ZPIN (D) = 4,0,0; 3,3,0; 5,0,0
"""

#: the fuzz findings' pendulum (issue 30): 2 (mass units) at 0.25 m, 1/6 kg m^2 about the
#: pin; its dynamic part is added by the tests
PENDULUM_HEAD = """\
UNIT (MASS) = 1
ZPIN (BASE, ARM) = A
DATA ZPIN (A) = 0,0,0; 1,0,0; 1,0,0
DATA MASS (ARM, A) = 2; 0.25, 0, 0
DATA INERTIA (ARM, A) = 0, 0.1666667, 0.1666667, 0, 0, 0
DATA GRAVITY = 0, -9.80665, 0
"""


def cpu_limit() -> None:
    """``preexec_fn`` of a subprocess: at most CPU_LIMIT seconds of CPU."""
    resource.setrlimit(resource.RLIMIT_CPU, (CPU_LIMIT, CPU_LIMIT))


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


#: the manual's chapter 9 decks (shared/reference/imp-manual-decks), beside the checkout
MANUAL_DECKS = Path(__file__).resolve().parents[3] / "shared" / "reference" / "imp-manual-decks"


def manual_session(folder: Path, deck: str, session: str,
                   extra: dict[str, Path] | None = None):
    """Run the manual's ``deck`` with its ``session`` from ``folder`` (the deck and the
    ``extra`` files copied there by name); (runs, echo).  Skips without shared/."""
    import shutil

    import pytest

    src = MANUAL_DECKS / deck
    if not src.exists():
        pytest.skip("shared/reference is not beside the checkout")
    shutil.copy(src, folder / deck)
    for name, path in (extra or {}).items():
        shutil.copy(path, folder / name)
    return run_deck(write(folder, session, "session.imp"))
