"""Tests of openimp.viz: pictures, animations, views and plots.

The HTML animation is opened in headless Chromium (Debian's ``chromium``
package: ``apt-get update && apt-get install -y chromium``); those tests are
skipped with that reason when ``/usr/bin/chromium`` is missing.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from helpers.decks import cpu_limit
from openimp.errors import InputError
from openimp.results import Table
from openimp.viz import (
    COLORS,
    Scene,
    animate_gif,
    animate_html,
    color_hex,
    draw_png,
    plot_png,
    project,
    view_rotation,
)
from openimp.viz import _plot_figure as plot_figure

CHROMIUM = Path("/usr/bin/chromium")


def _rgb(hx: str) -> np.ndarray:
    return np.array([int(hx[i:i + 2], 16) for i in (1, 3, 5)])


def _count_color(path: Path, hx: str, tol: int = 12) -> int:
    """Pixels of ``path`` within ``tol`` of colour ``hx``."""
    a = np.asarray(Image.open(path).convert("RGB")).astype(int)
    return int(np.sum(np.all(np.abs(a - _rgb(hx)) <= tol, axis=-1)))


def _crank_scene(steps: int = 12, **kw: object) -> Scene:
    """A crank turning 0..90 deg about Z, a coupler and a fixed frame link."""
    th = np.linspace(0.0, math.pi / 2, steps)
    crank = np.zeros((steps, 2, 3))
    crank[:, 1, 0] = 2.0 * np.cos(th)
    crank[:, 1, 1] = 2.0 * np.sin(th)
    coupler = np.zeros((steps, 2, 3))
    coupler[:, 0] = crank[:, 1]
    coupler[:, 1] = [5.0, 2.0, 0.0]
    frame = np.broadcast_to(np.array([[0.0, 0, 0], [5, 0, 0], [5, 2, 0]]), (steps, 3, 3))
    frames = np.tile(np.eye(4), (steps, 1, 1))
    frames[:, :3, 3] = crank[:, 1]
    args: dict[str, object] = dict(
        links={"CRANK": [crank], "COUPLER": [coupler], "FRAME": [frame.copy()]},
        colors={"CRANK": "RED", "COUPLER": "BLUE"},
        axes=[("J2", frames, 0.6)],
        times=np.linspace(0.0, 0.5, steps),
        title="Crank test",
    )
    args.update(kw)
    return Scene(**args)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- views

E = np.eye(3)
S2, S6 = 1 / math.sqrt(2), 1 / math.sqrt(6)
#: screen (x right, y up) of global X, Y, Z for each view of reference 8.7
EXPECTED = {
    "FRONT": [(1, 0), (0, 1), (0, 0)],
    "BACK": [(-1, 0), (0, 1), (0, 0)],
    "TOP": [(1, 0), (0, 0), (0, -1)],
    "BOTTOM": [(1, 0), (0, 0), (0, 1)],
    "LEFT": [(0, 0), (0, 1), (-1, 0)],
    "RIGHT": [(0, 0), (0, 1), (1, 0)],
    "ISOMETRIC": [(S2, -S6), (0, 2 * S6), (-S2, -S6)],
}
#: screen-out component (+1 out of screen, -1 into) of X, Y, Z
DEPTH = {
    "FRONT": (0, 0, 1), "BACK": (0, 0, -1), "TOP": (0, 1, 0), "BOTTOM": (0, -1, 0),
    "LEFT": (1, 0, 0), "RIGHT": (-1, 0, 0),
}


@pytest.mark.parametrize("view", list(EXPECTED))
def test_standard_view_projection(view: str) -> None:
    np.testing.assert_allclose(project(E, view), np.array(EXPECTED[view], float), atol=1e-12)
    p = np.array([1.5, -2.0, 3.0])
    want = 1.5 * np.array(EXPECTED[view][0]) - 2.0 * np.array(EXPECTED[view][1]) \
        + 3.0 * np.array(EXPECTED[view][2])
    np.testing.assert_allclose(project(p, view), want, atol=1e-12)
    rot = view_rotation(view)
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rot) == pytest.approx(1.0)  # right-handed screen frame
    if view in DEPTH:
        np.testing.assert_allclose(rot[2], DEPTH[view], atol=1e-12)


def test_isometric_directions_and_abbreviations() -> None:
    x, y, z = project(E, "isom")
    assert x[0] > 0 > x[1]  # X down-right
    assert y[0] == pytest.approx(0) and y[1] > 0  # Y up
    assert z[0] < 0 and z[1] < 0  # Z down-left
    assert x[1] == pytest.approx(z[1])
    np.testing.assert_allclose(project(E, "Fron"), project(E, "FRONT"))


@pytest.mark.parametrize(
    ("eye", "up", "std"),
    [((0, 0, 10), (0, 1, 0), "FRONT"), ((0, 0, -7), (0, 3, 0), "BACK"),
     ((0, 10, 0), (0, 0, -1), "TOP"), ((0, -4, 0), (0, 0, 1), "BOTTOM"),
     ((10, 0, 0), (0, 1, 0), "LEFT"), ((-2, 0, 0), (0, 1, 0), "RIGHT"),
     ((5, 5, 5), (0, 1, 0), "ISOMETRIC"), ((0, 0, 10), (0, 1, 0.9), "FRONT")],
)
def test_eye_up_view_matches_standard(eye: tuple, up: tuple, std: str) -> None:
    np.testing.assert_allclose(view_rotation((eye, up)), view_rotation(std), atol=1e-12)


def test_eye_up_view_errors() -> None:
    with pytest.raises(InputError, match="parallel"):
        view_rotation(((0, 0, 10), (0, 0, 2)))
    with pytest.raises(InputError, match="eye position is at the centre"):
        view_rotation(((1, 2, 3), (0, 1, 0)), centre=(1, 2, 3))
    with pytest.raises(InputError, match="three"):
        view_rotation(((0, 0), (0, 1, 0)))


def test_eye_up_view_looks_at_centre() -> None:
    c = np.array([1.0, 2.0, 3.0])
    rot = view_rotation(((1.0, 2.0, 13.0), (0, 1, 0)), centre=c)
    np.testing.assert_allclose(rot, np.eye(3), atol=1e-12)


def test_perspective_scales_about_centre() -> None:
    c = np.array([0.0, 0.0, 0.0])
    d = 10.0
    pts = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 5.0], [1.0, 1.0, -10.0], [1.0, 1.0, 12.0]])
    s = project(pts, "FRONT", perspective=d, centre=c)
    np.testing.assert_allclose(s[0], [1, 1])  # on the centre plane: unchanged
    np.testing.assert_allclose(s[1], [2, 2])  # halfway to the eye: twice as large
    np.testing.assert_allclose(s[2], [0.5, 0.5])  # as far behind: half
    assert np.all(np.isnan(s[3]))  # behind the eye
    np.testing.assert_allclose(project(pts[:3], "FRONT", 0.0), pts[:3, :2])


# --------------------------------------------------------------------------- bad input


def _bad_scenes() -> list[tuple[str, Scene]]:
    good = _crank_scene(4)
    crank = good.links["CRANK"][0]
    return [
        ("empty", Scene(links={})),
        ("empty", Scene(links={"A": []})),
        ("shape", Scene(links={"A": [crank[0]]})),
        ("shape", Scene(links={"A": [np.zeros((4, 2, 2))]})),
        ("no points", Scene(links={"A": [np.zeros((4, 0, 3))]})),
        ("steps", Scene(links={"A": [crank], "B": [np.zeros((5, 2, 3))]})),
        ("unknown view", Scene(links={"A": [crank]}, view="SIDEWAYS")),
        ("zero up", Scene(links={"A": [crank]}, view=((0, 0, 10), (0, 0, 0)))),
        ("eye", Scene(links={"A": [crank]}, view=((1, 1), (0, 1, 0)))),
        ("times", Scene(links={"A": [crank]}, times=np.zeros(3))),
        ("axes", Scene(links={"A": [crank]}, axes=[("J1", np.zeros((4, 3, 4)), 1.0)])),
        ("steps", Scene(links={"A": [crank]}, axes=[("J1", np.zeros((5, 4, 4)), 1.0)])),
        ("length", Scene(links={"A": [crank]}, axes=[("J1", np.zeros((4, 4, 4)), -1.0)])),
        ("perspective", Scene(links={"A": [crank]}, perspective=-2.0)),
        ("finite", Scene(links={"A": [np.full((4, 2, 3), np.nan)]})),
    ]


@pytest.mark.parametrize(("what", "scene"), _bad_scenes(), ids=lambda v: v
                         if isinstance(v, str) else "")
def test_bad_scene_raises_input_error(what: str, scene: Scene, tmp_path: Path) -> None:
    for fn in (lambda: draw_png(scene, 0, tmp_path / "a.png"),
               lambda: animate_gif(scene, tmp_path / "a.gif"),
               lambda: animate_html(scene, tmp_path / "a.html")):
        with pytest.raises(InputError):
            fn()
    assert list(tmp_path.iterdir()) == []


def test_unknown_view_message() -> None:
    with pytest.raises(InputError, match=r"unknown view 'SIDEWAYS'.*FRONT"):
        project(E, "SIDEWAYS")


def test_step_out_of_range(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="out of range"):
        draw_png(_crank_scene(4), 4, tmp_path / "a.png")


def test_colour_names() -> None:
    assert color_hex("RED") == COLORS["RED"]
    assert color_hex("viol") == color_hex("MAGENTA")
    assert color_hex("AQUA") == color_hex("cyan")
    assert color_hex("BLAC") == "#000000"
    assert color_hex("PINK") == COLORS["WHITE"]  # unknown becomes WHITE, as in IMP
    assert color_hex(None) == COLORS["WHITE"]
    assert COLORS["WHITE"] != "#ffffff"  # visible on the white background


# --------------------------------------------------------------------------- PNG and GIF


def test_draw_png_has_link_colours(tmp_path: Path) -> None:
    out = draw_png(_crank_scene(), -1, tmp_path / "sub" / "draw.png")
    assert out == tmp_path / "sub" / "draw.png"
    assert out.stat().st_size > 1000
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert Image.open(out).size == (800, 600)
    assert _count_color(out, COLORS["RED"]) > 50  # CRANK
    assert _count_color(out, COLORS["BLUE"]) > 50  # COUPLER
    assert _count_color(out, COLORS["WHITE"]) > 50  # FRAME, default colour
    assert _count_color(out, "#00a000", tol=30) > 10  # v axis arrow of J2
    assert [p.name for p in (tmp_path / "sub").iterdir()] == ["draw.png"]  # no temp left


def test_draw_png_last_step_differs(tmp_path: Path) -> None:
    sc = _crank_scene(view="TOP", perspective=30.0)
    a = np.asarray(Image.open(draw_png(sc, 0, tmp_path / "a.png")).convert("L"))
    b = np.asarray(Image.open(draw_png(sc, -1, tmp_path / "b.png")).convert("L"))
    assert np.count_nonzero(a != b) > 100


def test_failed_write_leaves_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.figure import Figure

    out = tmp_path / "a.png"
    out.write_bytes(b"old")

    def boom(*args: object, **kw: object) -> None:
        Path(args[1]).write_bytes(b"half")  # type: ignore[arg-type]
        raise RuntimeError("disk full")

    monkeypatch.setattr(Figure, "savefig", boom)
    with pytest.raises(RuntimeError, match="disk full"):
        draw_png(_crank_scene(), 0, out)
    assert out.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["a.png"]


def test_gif_frame_count(tmp_path: Path) -> None:
    out = animate_gif(_crank_scene(10), tmp_path / "a.gif", fps=10)
    im = Image.open(out)
    assert im.format == "GIF"
    assert im.n_frames == 10
    assert im.info["duration"] == 100
    first = np.asarray(im.convert("RGB")).astype(int)
    im.seek(9)
    last = np.asarray(im.convert("RGB")).astype(int)
    assert np.count_nonzero(np.any(first != last, axis=-1)) > 100
    assert np.sum(np.all(np.abs(last - _rgb(COLORS["RED"])) <= 12, axis=-1)) > 30


def test_gif_subsamples_beyond_max_frames(tmp_path: Path) -> None:
    out = animate_gif(_crank_scene(25), tmp_path / "a.gif", max_frames=6)
    assert Image.open(out).n_frames == 6


# --------------------------------------------------------------------------- plots


def _table() -> Table:
    t = np.linspace(0.0, 1.0, 21)
    rows = np.column_stack([t, 90.0 * t, np.sin(t), 10.0 * t])
    return Table("LIST POSITION", "joint J1", ["Time", "JVar 1", "X", "JVar 2"],
                 ["s", "deg", "m", "deg"], rows)


def test_plot_png_labels(tmp_path: Path) -> None:
    table = _table()
    fig = plot_figure(table, ["JVar 1"])
    ax = fig.axes[0]
    assert ax.get_xlabel() == "Time (s)"
    assert ax.get_ylabel() == "JVar 1 (deg)"
    assert ax.get_title() == "LIST POSITION joint J1"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["JVar 1 (deg)"]
    np.testing.assert_allclose(ax.lines[0].get_xydata(), table.rows[:, :2])

    fig = plot_figure(table, None)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["JVar 1 (deg)", "X (m)", "JVar 2 (deg)"]
    assert plot_figure(table, [1, 3]).axes[0].get_ylabel() == "Value (deg)"

    out = plot_png(table, tmp_path / "plot.png")
    assert out.stat().st_size > 1000
    assert Image.open(out).size == (800, 600)


def test_plot_png_abscissa(tmp_path: Path) -> None:
    """``x`` picks the abscissa; by default it is left out of the ordinates."""
    table = _table()
    ax = plot_figure(table, None, "JVar 1").axes[0]
    assert ax.get_xlabel() == "JVar 1 (deg)"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["X (m)", "JVar 2 (deg)"]
    np.testing.assert_allclose(ax.lines[1].get_xydata(), table.rows[:, [1, 3]])
    assert plot_figure(table, ["X"], 3).axes[0].get_xlabel() == "JVar 2 (deg)"
    with pytest.raises(InputError):
        plot_png(table, tmp_path / "p.png", x="Nope")


@pytest.mark.parametrize("columns", [["Nope"], [7], []])
def test_plot_png_bad_columns(columns: list, tmp_path: Path) -> None:
    with pytest.raises(InputError):
        plot_png(_table(), tmp_path / "p.png", columns)
    assert list(tmp_path.iterdir()) == []


def test_plot_png_bad_table(tmp_path: Path) -> None:
    empty = Table("LIST POSITION", "joint J1", ["Time", "JVar 1"], ["s", "deg"],
                  np.zeros((0, 2)))
    with pytest.raises(InputError, match="no rows"):
        plot_png(empty, tmp_path / "p.png")
    wrong = Table("LIST POSITION", "joint J1", ["Time", "JVar 1"], ["s", "deg"],
                  np.zeros((3, 3)))
    with pytest.raises(InputError, match="shape"):
        plot_png(wrong, tmp_path / "p.png")


# --------------------------------------------------------------------------- HTML


def _page_data(path: Path) -> dict:
    text = path.read_text(encoding="utf-8")
    m = re.search(r'<script type="application/json" id="scene-data">(.*?)</script>', text, re.S)
    assert m is not None
    return json.loads(m.group(1))


def test_html_is_self_contained(tmp_path: Path) -> None:
    sc = _crank_scene(8, title="Crank </script><b>&")
    out = animate_html(sc, tmp_path / "a.html")
    text = out.read_text(encoding="utf-8")
    assert "http://" not in text and "https://" not in text and "//cdn" not in text
    assert "<link" not in text and " src=" not in text
    assert "<canvas" in text and 'type="range"' in text and 'id="play"' in text
    assert "<b>" not in text  # title escaped
    data = _page_data(out)
    assert data["steps"] == 8
    assert data["title"] == "Crank </script><b>&"
    assert data["times"] == pytest.approx(list(np.linspace(0, 0.5, 8)))
    crank = data["links"][0]
    assert crank["name"] == "CRANK" and crank["color"] == COLORS["RED"]
    assert len(crank["polylines"][0]) == 8 and len(crank["polylines"][0][0]) == 4
    assert crank["polylines"][0][-1][2:] == pytest.approx([0.0, 2.0], abs=1e-5)
    x0, x1, y0, y1 = data["bbox"]  # one frame over all steps
    assert x0 < 0.0 and x1 > 5.0 and y0 < 0.0 and y1 > 2.0
    assert len(data["axes"][0]["arrows"][0]) == 8


def _chromium(url: str, tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    profile = tmp_path / f"profile{len(list(tmp_path.glob('profile*')))}"
    cmd = [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
           "--no-first-run", "--disable-background-networking", "--disable-component-update",
           "--disable-sync", "--hide-scrollbars", f"--user-data-dir={profile}",
           "--window-size=800,600", *args, url]
    return subprocess.run(cmd, capture_output=True, text=True, check=False,
                          preexec_fn=cpu_limit)


needs_chromium = pytest.mark.skipif(
    not CHROMIUM.exists(),
    reason="headless browser test needs Debian's chromium: "
           "apt-get update && apt-get install -y chromium",
)


@needs_chromium
def test_html_in_chromium_first_and_last_step(tmp_path: Path) -> None:
    page = animate_html(_crank_scene(12), tmp_path / "anim.html")
    url = page.resolve().as_uri()
    shots = []
    for frag in ("first", "last"):
        dom = _chromium(f"{url}#step={frag}", tmp_path, "--dump-dom").stdout
        assert "<canvas" in dom, dom[:500]
        assert 'data-error="1"' not in dom and "ERROR:" not in dom.split("<script")[0], dom
        m = re.search(r'<output id="status"[^>]*>', dom)
        assert m is not None
        assert 'data-state="ok"' in m.group(0)
        assert f'data-step="{0 if frag == "first" else 11}"' in m.group(0)
        assert 'data-segments="7"' in m.group(0)  # 1 + 1 + 2 link segments + 3 arrows

        shot = tmp_path / f"{frag}.png"
        r = _chromium(f"{url}#step={frag}", tmp_path, f"--screenshot={shot}")
        assert shot.exists(), r.stderr[-2000:]
        a = np.asarray(Image.open(shot).convert("RGB")).astype(int)
        assert a.shape[:2] == (600, 800)
        canvas = a[60:]  # below the control bar
        assert np.count_nonzero(np.any(canvas < 235, axis=-1)) > 500  # a picture, not blank
        # the links in their SHOW colours (at the first step the frame covers the crank)
        for name in ("BLUE", "WHITE") if frag == "first" else ("RED", "BLUE", "WHITE"):
            px = np.all(np.abs(canvas - _rgb(COLORS[name])) <= 12, axis=-1)
            assert np.count_nonzero(px) > 50, name
        shots.append(canvas)
    assert np.count_nonzero(np.any(shots[0] != shots[1], axis=-1)) > 500


@needs_chromium
def test_html_js_errors_are_surfaced(tmp_path: Path) -> None:
    page = animate_html(_crank_scene(4), tmp_path / "anim.html")
    text = page.read_text(encoding="utf-8")
    bad = tmp_path / "bad.html"
    bad.write_text(text.replace('"steps":4', '"steps":'), encoding="utf-8")
    dom = _chromium(bad.resolve().as_uri(), tmp_path, "--dump-dom").stdout
    assert 'data-error="1"' in dom
    assert re.search(r"<title>ERROR: .*JSON", dom)
