"""What a new user tripped over in the first hour (issue 26, item 4), one test each.

* A joint with no placement line passed ``openimp check`` and failed later in terms of
  mobility: check and run now name the joint and the link(s) it is not placed on.
* A misspelt link or body name silently made a new one: a located warning (decks) or a
  logged one (Python) names both names.
"""

from __future__ import annotations

import logging
import subprocess
import sys

import pytest

import openimp
from helpers.decks import FOUR_LOOP, cpu_limit, line_of, run_deck, write
from openimp.imp.deck import load
from openimp.imp.interp import DeckError
from openimp.topology import misspelt_bodies, one_edit

FOUR = FOUR_LOOP
RUN = "DATA POSITION (A) = 0, 10, 3\nLIST POSITION (D)\nEXECUTE\nEND\n"
CLI = [sys.executable, "-m", "openimp.cli"]


def test_a_joint_with_no_placement_is_named(tmp_path) -> None:
    """No DATA ZPIN (C): check and run say that joint C is not placed on CPLR and ROCK,
    at its statement, with what to write; a placed deck says nothing of the kind."""
    text = FOUR.replace("DATA ZPIN (C) = 3,2,0; 4,2,0; 4,2,0\n", "") + RUN
    p = write(tmp_path, text)
    n = line_of(text, "ZPIN (CPLR, ROCK)")
    want = (f"{p}:{n}: warning: ZPIN joint C is not placed on link(s) CPLR, ROCK: no DATA "
            "statement gives its frame there")
    r = subprocess.run([*CLI, "check", str(p)], capture_output=True, text=True,
                       preexec_fn=cpu_limit)
    assert want in r.stderr and "DATA ZPIN (C) = ..." in r.stderr, r.stderr
    _runs, echo = run_deck(p)
    assert sum(want.split(" warning: ")[1] in ln for ln in echo) == 1, echo
    _runs, echo = run_deck(write(tmp_path, FOUR + RUN, "placed.imp"))
    assert not any("is not placed" in ln for ln in echo)


def test_one_data_link_leaves_the_other_side_unplaced(tmp_path) -> None:
    text = FOUR.replace("DATA ZPIN (C) = 3,2,0; 4,2,0; 4,2,0\n",
                        "DATA LINK (CPLR, C) = 3,2,0; 4,2,0; 3,3,0\n") + RUN
    """Only CPLR's side of joint C is placed: the frames cannot conform, the deck is
    refused, and the warning that explains why names ROCK."""
    with pytest.raises(DeckError) as info:
        load(write(tmp_path, text))
    said = [str(w) for w in info.value.warnings if "is not placed" in str(w)]
    assert len(said) == 1 and "on link(s) ROCK:" in said[0], said
    assert "do not conform" in str(info.value)


def test_a_misspelt_link_in_a_deck_is_warned_about(tmp_path) -> None:
    """COUPLER in joint B, COUPLR... in a deck names are significant to four characters,
    so the misspelling that makes a new link is within those: CPLR and CLPR differ by
    more than one letter, CPLR and CPLE by one; the warning is at the lonely link's
    joint and names the other's."""
    text = FOUR.replace("ZPIN (CPLR, ROCK) = C", "ZPIN (CPLE, ROCK) = C") + RUN
    p = write(tmp_path, text)
    r = subprocess.run([*CLI, "check", str(p)], capture_output=True, text=True,
                       preexec_fn=cpu_limit)
    nb, nc = line_of(text, "ZPIN (CRNK, CPLR)"), line_of(text, "ZPIN (CPLE, ROCK)")
    said = [ln for ln in r.stderr.splitlines() if "one letter from" in ln]
    assert len(said) == 1, r.stderr
    assert said[0].startswith(f"{p}:{nb}: warning: link CPLR is named in joint B only, and "
                              f"its name is one letter from link CPLE (joint C at {p}:{nc})")
    # numbered links are meant: no warning
    text = FOUR.replace("CPLR", "LNK1").replace("CRNK", "LNK2") + RUN
    _runs, echo = run_deck(write(tmp_path, text, "numbered.imp"))
    assert not any("one letter from" in ln for ln in echo)


def test_a_misspelt_body_in_python_is_logged(caplog) -> None:
    """From Python the compile logs it (the ``openimp`` logger) and keeps it in
    ``System.warnings``; silenced by the logger's level."""
    m = openimp.Model("fourbar")
    m.add_joint("revolute", "A", "BASE", "CRANK", origin=(0, 0, 0), axis=(0, 0, 1))
    m.add_joint("revolute", "B", "CRANK", "COUPLER", origin=(1, 0, 0), axis=(0, 0, 1))
    m.add_joint("revolute", "C", "COUPLR", "ROCKER", origin=(3, 2, 0), axis=(0, 0, 1))
    m.add_joint("revolute", "D", "ROCKER", "BASE", origin=(4, 0, 0), axis=(0, 0, 1))
    with caplog.at_level(logging.WARNING, logger="openimp"):
        s = openimp.compile(m)
    said = [r.getMessage() for r in caplog.records if "misspelt" in r.getMessage()]
    assert len(said) == 1 and len(s.warnings) == 1
    assert "body 'COUPLER' appears only in joint 'B'" in said[0]
    assert "one letter from body 'COUPLR' (joint 'C')" in said[0]


@pytest.mark.parametrize(("a", "b", "near"), [
    ("COUPLER", "COUPLR", True), ("ROCKER", "ROCKET", True), ("CRANK", "CRANKS", True),
    ("LINK1", "LINK2", False), ("CRANK", "CRANK2", False), ("L1", "L2", False),
    ("ARM", "ARMS", True), ("BASE", "BASE", False), ("CRANK", "COUPLER", False),
])
def test_one_edit(a, b, near) -> None:
    assert one_edit(a, b) is near and one_edit(b, a) is near


def test_misspelt_bodies_need_a_lonely_body() -> None:
    """Two names one letter apart that are both in two joints are meant (a chain ROCKER,
    ROCKET): only a body in a single joint is suspected, each pair once."""
    chain = [("A", "BASE", "ROCKER"), ("B", "ROCKER", "ROCKET"), ("C", "ROCKET", "BASE")]
    assert misspelt_bodies(chain, "BASE") == []
    typo = [("A", "BASE", "CRANK"), ("B", "CRANK", "COUPLER"), ("C", "COUPLR", "ROCKER"),
            ("D", "ROCKER", "BASE")]
    assert misspelt_bodies(typo, "BASE") == [("COUPLER", "B", "COUPLR", ["C"])]


def test_an_incomplete_sweep_is_said(caplog) -> None:
    """The crank-rocker's rocker driven through a whole turn stops at its limit of
    travel: the sweep keeps the steps before it and logs a warning that says so
    (``warn=False`` does not)."""
    import numpy as np

    from helpers.models import fourbar

    system = openimp.compile(fourbar())
    angles = np.radians(np.arange(0.0, 361.0, 10.0))
    with caplog.at_level(logging.WARNING, logger="openimp"):
        res = openimp.sweep(system, {"D": angles})
    assert not res.complete and 0 < res.nsteps < angles.size
    said = [r.getMessage() for r in caplog.records if r.getMessage().startswith("sweep: ")]
    assert len(said) == 1, said
    assert f"keeps the {res.nsteps} of {angles.size} steps solved" in said[0], said
    assert said[0].startswith(f"sweep: {res.message}")
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="openimp"):
        openimp.sweep(system, {"D": angles}, warn=False)
    assert not [r for r in caplog.records if r.getMessage().startswith("sweep: ")]


def test_print_heading_says_its_units_and_no_round_off(tmp_path) -> None:
    """PRINT HEADING's table says its units (not in IMP's own listing format) and a
    rate that is round-off prints 0.000, never -0.000."""
    text = FOUR + "DATA POSITION (A) = 0, 10, 3\nPRINT HEADING\nEXECUTE\nEND\n"
    _runs, echo = run_deck(write(tmp_path, text))
    heads = [ln for ln in echo if ln.startswith("Joint Set by Position")]
    assert heads and all(h.endswith("[deg, rad/s, rad/s^2 or length, length/s, length/s^2]")
                         for h in heads)
    rows = [ln for ln in echo if ln.startswith("A 1 user")]
    assert len(rows) == 4 and not any("-0.000" in ln for ln in echo), rows
    imp = "REMARK OPENIMP LISTING = IMP\n" + text
    _runs, echo = run_deck(write(tmp_path, imp, "imp.imp"))
    assert "Joint Set by Position Velocity Acceleration" in echo


def test_stiffness_and_modes_in_the_coordinates_the_user_names() -> None:
    """A four-bar with a mass on its coupler, gravity and a torsion spring on the crank,
    at its equilibrium: the elimination may choose any FGC; in the crank's angle
    (``in_coordinates(["A"])``) K is d2V/dA2 of the potential energy computed here from
    the sweep's postures (central differences, 1e-5 relative), M is 2 T / A'^2 of the
    kinetic energy at a unit crank rate, and the frequency is unchanged."""
    import numpy as np

    from helpers.models import fourbar

    m = fourbar()
    mass, g, k, free = 3.0, 9.81, 40.0, 0.2
    m.add_point("G", "COUPLER", (2.0, 1.2, 0.0))
    m.add_mass("COUPLER", mass, (2.0, 1.2, 0.0))
    m.set_gravity((0.0, -g, 0.0))
    m.set_joint_spring("A", k, free)
    system = openimp.compile(m)
    eq = openimp.equilibrium(system)
    assert eq.converged
    lin = openimp.linearize(system, eq.q)
    crank = lin.in_coordinates(["A"])
    assert crank.coords == ["A.theta"] and not crank.specified[0]
    a0 = eq.q[system.var_index("A")]

    def energy(a: np.ndarray) -> np.ndarray:  # potential along crank angles a
        tr = openimp.sweep(system, {"A": a}, q=eq.q)
        assert tr.complete
        return mass * g * tr.point("G")[:, 1] + 0.5 * k * (a - free) ** 2

    h = 1e-3
    V = energy(a0 + h * np.array([-2.0, -1.0, 0.0, 1.0, 2.0]))
    d2 = (-V[0] + 16 * V[1] - 30 * V[2] + 16 * V[3] - V[4]) / (12 * h * h)
    assert crank.K[0, 0] == pytest.approx(d2, rel=1e-5)
    tr = openimp.sweep(system, {"A": [a0]}, rates={"A": [1.0]}, q=eq.q)
    v = tr.point_velocity("G")[0]
    assert crank.M[0, 0] == pytest.approx(mass * float(v @ v), rel=1e-9)
    w_lin = openimp.modes(lin).frequency[0]
    assert openimp.modes(crank).frequency[0] == pytest.approx(w_lin, rel=1e-9)
    assert w_lin == pytest.approx(np.sqrt(d2 / (mass * float(v @ v))), rel=1e-5)
    with pytest.raises(openimp.InputError, match="one coordinate per FGC"):
        lin.in_coordinates(["A", "B"])


def test_to_table_prints_as_a_table() -> None:
    """Every to_table() is still a dict of columns (pandas.DataFrame takes it) and prints
    as an aligned table: a header, one line per row, long tables cut in the middle."""
    import numpy as np

    from openimp.results import SHOW_ROWS, Columns

    t = Columns({"mode": np.arange(1, 3), "kind": ["oscillation", "overdamped"],
                 "frequency": np.array([2.712461, np.nan]), "unstable": np.array([False, True])})
    lines = str(t).splitlines()
    assert lines[0].split() == ["mode", "kind", "frequency", "unstable"]
    assert lines[1].split() == ["1", "oscillation", "2.71246", "False"]
    assert lines[2].split() == ["2", "overdamped", "nan", "True"]
    assert len({len(x) for x in lines}) == 1 and repr(t) == str(t)
    long = Columns({"step": np.arange(100)})
    out = str(long).splitlines()
    assert len(out) == 1 + SHOW_ROWS + 1 + 1 and out[-1] == "(100 rows)"
    assert [x.strip() for x in out].count("...") == 1
    assert isinstance(long, dict) and list(long) == ["step"]
