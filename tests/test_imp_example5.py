"""The IMP manual's chapter 9 example 5 (a double-toggle bench clamp, ``clamp.dat``),
run unchanged with the manual's session: a solid-model deck that shapes, frames
and gives points to each link (SHAPE, DATA LINK, POINT) before any joint names
it, as IMP-2000 allowed.

Independent check: the clamp is three four-bar-like loops in a chain, so each
link's angle follows from the one before by a circle intersection; solved here
with Newton's method and continuation in plain numpy, the path of the clamping
point F0 agrees with openimp's table, all 16 rows.
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers.decks import MANUAL_DECKS, manual_session

#: the manual's session; its .geo files are not in the manual: any closed solid serves
SESSION = ("RECALL INPUT = clamp.dat\nDATA POSITION A = 0 30 2\nANIMATE\nEXECUTE\n"
           "DATA POSITION A = 0 4 15\nLIST POSITION F0\nEXECUTE\nEND\n")
SOLIDS = ("AD", "BD", "AC", "BC", "CE", "EF", "EG", "GH")

#: pin centres at the drawing (DATA ZPIN; C = CC and E = EE share a centre; H's
#: "6.2,3.8.0" reads as 6.2, 3.8, 0) and F0 (DATA POINT F0 LINK in LKGH's frame: origin
#: (6.1, 2.84), u along X)
PIN = {k: np.array(v) for k, v in {
    "D": (-2.5, 4.0), "A": (-0.5, 2.0), "B": (-0.5, 4.0), "C": (-0.5, 6.0), "E": (4.60, 5.44),
    "F": (3.25, 3.91), "G": (5.9, 6.95), "H": (6.2, 3.8)}.items()}
F0 = np.array([6.1 - 4.0, 2.84 - 2.75])


def _rot(v: np.ndarray, a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def _newton(g, x: float) -> float:
    for _ in range(60):
        h = 1e-7
        step = g(x) / ((g(x + h) - g(x - h)) / (2 * h))
        x -= step
        if abs(step) < 1e-15:
            break
    assert abs(g(x)) < 1e-12
    return x


def clamp_f0(theta_deg: np.ndarray) -> np.ndarray:
    """F0 (n, 2) for crank angles of A (degrees), by continuation from the drawing."""
    P = PIN
    out = []
    phi = psi = chi = 0.0  # LKBD about D; LKCE and LKEG absolute turns

    def dist(p: np.ndarray, q: np.ndarray) -> float:
        return float(np.sum((p - q) ** 2))

    for th in np.radians(np.linspace(0.0, theta_deg[-1], 40 * len(theta_deg) - 39)):
        C = P["A"] + _rot(P["C"] - P["A"], th)  # LKAC about A
        phi = _newton(lambda f, C=C: dist(P["D"] + _rot(P["B"] - P["D"], f), C)
                      - dist(P["B"], P["C"]), phi)
        F = P["D"] + _rot(P["F"] - P["D"], phi)
        H = P["D"] + _rot(P["H"] - P["D"], phi)
        psi = _newton(lambda f, C=C, F=F: dist(C + _rot(P["E"] - P["C"], f), F)
                      - dist(P["E"], P["F"]), psi)
        E = C + _rot(P["E"] - P["C"], psi)
        chi = _newton(lambda f, E=E, H=H: dist(E + _rot(P["G"] - P["E"], f), H)
                      - dist(P["G"], P["H"]), chi)
        G = E + _rot(P["G"] - P["E"], chi)
        d0, d = P["H"] - P["G"], H - G
        om = np.arctan2(d[1], d[0]) - np.arctan2(d0[1], d0[0])  # LKGH's turn
        out.append(G + _rot(F0 - P["G"], om))
    return np.array(out)[::40]


@pytest.fixture(scope="module")
def example5(tmp_path_factory):
    hexa = MANUAL_DECKS.parent / "imp-solids-example-hex.geo"
    return manual_session(tmp_path_factory.mktemp("ex5"), "clamp.dat", SESSION,
                          {f"BAR{s}.geo": hexa for s in SOLIDS})


def test_clamp_deck_runs_unchanged(example5) -> None:
    """Both EXECUTEs run; the only messages about the solids say that their mass is not
    computed (solid files are integrated by the contact issue)."""
    runs, echo = example5
    assert len(runs) == 2 and all(r.ok for r in runs), [r.failure for r in runs]
    assert all(r.mode == "kinematic" for r in runs)
    notes = [ln for ln in echo if "warning" in ln]
    assert len(notes) == 8 and all("mass properties of solid" in m for m in notes), notes
    assert not any("not defined" in ln for ln in echo)


def test_clamp_f0_path_against_the_loop_solution(example5) -> None:
    """LIST POSITION F0 over A = 0, 4, ..., 60 deg: 16 rows, each where the three loops
    put it to 1e-9."""
    runs, _ = example5
    rows = runs[1].table("LIST POSITION", "point F0").rows
    assert rows.shape == (16, 4)
    expect = clamp_f0(4.0 * np.arange(16))
    np.testing.assert_allclose(rows[:, 1:3], expect, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rows[:, 3], 0.0, atol=1e-12)
    np.testing.assert_allclose(rows[0, 1:3], [2.1, 0.09], atol=1e-12)  # the drawing
