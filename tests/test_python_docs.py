"""docs/python.md runs as written, and its results are right.

Every ```python block of the page is executed in order in one namespace, in
a temporary directory; then the coupler point's path and speed are checked
against the four-bar's closed form (plain numpy: B on the crank circle, C the
intersection of the circles about B and D on the branch of the drawing, P
fixed in the coupler), and the pictures the page promises are checked as
files.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from helpers.docs import blocks, squash

DOC = Path(__file__).parent.parent / "docs" / "python.md"

#: positions are solved to 1e-10 internal units: 1e-9 in model lengths
TOL = 1e-9


def coupler_point(theta: np.ndarray) -> np.ndarray:
    """(steps, 3) path of P: crank 1, coupler 3, rocker 2.5, frame 3.2 (the page's)."""
    D = np.array([3.2, 0.0])
    B0 = np.array([1.0, 0.0])
    L = np.linalg.norm(D - B0)
    x = (9.0 - 6.25 + L * L) / (2 * L)
    C0 = B0 + np.array([x, np.sqrt(9.0 - x * x)])
    P0 = (B0 + C0) / 2 + np.array([0.0, 0.5])
    u0 = (C0 - B0) / 3.0
    a, b = (P0 - B0) @ u0, (P0 - B0) @ np.array([-u0[1], u0[0]])  # P in the coupler
    out, prev = [], C0
    for th in theta:
        B = np.array([np.cos(th), np.sin(th)])
        d = np.linalg.norm(D - B)
        s = (9.0 - 6.25 + d * d) / (2 * d)
        h = np.sqrt(9.0 - s * s)
        e = (D - B) / d
        cands = [B + s * e + sgn * h * np.array([-e[1], e[0]]) for sgn in (1.0, -1.0)]
        C = min(cands, key=lambda c: np.linalg.norm(c - prev))  # the branch goes on
        prev = C
        u = (C - B) / 3.0
        out.append([*(B + a * u + b * np.array([-u[1], u[0]])), 0.0])
    return np.array(out)


def test_python_docs_run_and_are_right(tmp_path, monkeypatch) -> None:
    code = blocks(DOC.read_text())
    assert len(code) == 5, "docs/python.md: describe, sweep, plot, animate, vocabulary"
    monkeypatch.chdir(tmp_path)
    ns: dict = {"__name__": "docs_python"}
    for block in code:
        exec(compile(block, str(DOC), "exec"), ns)

    crank, path, speed = ns["crank"], ns["path"], ns["speed"]
    assert len(crank) == 181
    exact = coupler_point(crank)
    assert np.max(np.abs(path - exact)) < TOL
    # speed of P at 2 pi rad/s: 5-point central differences of the closed form
    h = 1e-4
    d = (-coupler_point(crank + 2 * h) + 8 * coupler_point(crank + h)
         - 8 * coupler_point(crank - h) + coupler_point(crank - 2 * h)) / (12 * h)
    np.testing.assert_allclose(speed, 2 * np.pi * np.linalg.norm(d, axis=1), rtol=0,
                               atol=1e-7)

    from PIL import Image

    assert Image.open(tmp_path / "coupler_curve.png").size == (1000, 400)
    assert Image.open(tmp_path / "fourbar_step45.png").format == "PNG"
    gif = Image.open(tmp_path / "fourbar.gif")
    assert gif.format == "GIF" and getattr(gif, "n_frames", 1) > 10
    page = (tmp_path / "fourbar.html").read_text()
    data = json.loads(re.search(r'<script type="application/json" id="scene-data">(.*?)'
                                r"</script>", page, flags=re.S).group(1))
    assert data["steps"] == 181
    assert data["times"][90] == pytest.approx(0.5)
    # the vocabulary block: a start posture as a mapping reaches the closed form
    np.testing.assert_allclose(ns["half"].point("P"), exact[:46], rtol=0, atol=TOL)


#: every analysis of the Python API: the vocabulary table has a row for each
ANALYSES = ["sweep", "forces", "forces_of", "equilibrium", "equilibria", "linearize",
            "modes", "modes_along", "simulate"]


def test_one_vocabulary_table_lists_every_analysis() -> None:
    """One table (section "One vocabulary") with a row naming each analysis, and the
    decided names in it: q, state=, specified=, force_rtol, max_iter, force_error."""
    import openimp

    text = DOC.read_text()
    section = text[text.index("## 7. One vocabulary"):]
    rows = [r for r in section.splitlines() if r.startswith("| `")]
    named = {n for r in rows for n in re.findall(r"`(\w+)", r.split("|")[1])}
    assert named == set(ANALYSES), named ^ set(ANALYSES)
    assert all(callable(getattr(openimp, n)) for n in ANALYSES)
    head = squash(section.split("| analysis |")[1].splitlines()[0])
    assert "start" in head and "`specified=`" in head and "progress(done, total)" in head
    for word in ("`force_rtol`", "`max_iter`", "`force_error`", "`state=`",
                 "`start` -> `q`", "`rtol` -> `force_rtol`", "`max_steps` -> `max_iter`"):
        assert word in section, word
