"""Pictures of a mechanism: DRAW, ANIMATE, AXES and PLOT of IMP (chapter 8).

A :class:`Scene` holds what IMP would draw: the polylines of each visible
link at every output step (global coordinates), their SHOW colours, the local
frames of the joints named by AXES, the view (``DATA VIEW``) and the eye
distance (``DATA DRAW``).  From it:

* :func:`draw_png` draws one step to a PNG file (DRAW);
* :func:`animate_gif` draws every step to an animated GIF (ANIMATE);
* :func:`animate_html` writes one self-contained HTML page (no network) with
  the projected polylines of every step, a play/pause button and a time slider;
* :func:`bode_png` draws a frequency-response table as a Bode plot;
* :func:`plot_png` plots the columns of a result :class:`~openimp.results.Table`
  against one of its columns, the first (time or step) by default (PLOT).

Screen coordinates are x to the right and y up.  The standard views map global
X, Y, Z on the screen as the table of docs/imp-language.md §8.7 says (FRONT: X
right, Y up, Z out of the screen; TOP: X right, Y out, Z down; ISOMETRIC: X
down-right, Y up, Z down-left ...).  A view may also be given as ``(eye,
up)``: the eye position and an up vector in global coordinates, looking at the
centre of the scene.
Pictures keep an equal aspect ratio; animations use one fixed frame (the
bounding box over all steps) so the picture does not jump.  IMP drew on a black
screen; these pictures are drawn on white, so IMP's WHITE (the default colour)
is drawn as a dark grey line.  IMP's rule that ``SHOW BLACK`` is the same as
ERASE belongs to the caller: a link given BLACK here is drawn black.

Everything is rendered with matplotlib's Agg canvas (no display, no pyplot
state) and every file is written whole or not at all (to a temporary name in
the same directory, then renamed).
"""

from __future__ import annotations

import html
import json
import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import FancyArrowPatch

from openimp.errors import InputError
from openimp.files import atomic_write_with

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

    from openimp.results import Table

__all__ = [
    "AXIS_COLORS",
    "COLORS",
    "VIEWS",
    "Scene",
    "animate_gif",
    "animate_html",
    "bode_png",
    "color_hex",
    "draw_png",
    "plot_png",
    "project",
    "view_rotation",
]

PathLike = str | os.PathLike[str]

#: IMP colour name -> RGB hex used on the white background.
COLORS: dict[str, str] = {
    "BLACK": "#000000",
    "RED": "#d62728",
    "ORANGE": "#ff7f0e",
    "YELLOW": "#c9a800",  # dark yellow: pure yellow vanishes on white
    "GREEN": "#2ca02c",
    "CYAN": "#00a5b5",
    "AQUA": "#00a5b5",
    "BLUE": "#1f4fd0",
    "MAGENTA": "#c000c0",
    "VIOLET": "#c000c0",
    "WHITE": "#404040",  # IMP's default white line on black, drawn dark grey on white
}

#: colours of the u, v, w arrows drawn for AXES.
AXIS_COLORS: tuple[str, str, str] = ("#e00000", "#00a000", "#0000e0")

_R = np.array
#: Rows are the global directions of screen right, screen up and out of the screen.
VIEWS: dict[str, np.ndarray] = {
    "FRONT": _R([[1.0, 0, 0], [0, 1, 0], [0, 0, 1]]),
    "BACK": _R([[-1.0, 0, 0], [0, 1, 0], [0, 0, -1]]),
    "TOP": _R([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
    "BOTTOM": _R([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]),
    "LEFT": _R([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]]),
    "RIGHT": _R([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]),
    "ISOMETRIC": _R(
        [
            [1 / math.sqrt(2), 0, -1 / math.sqrt(2)],
            [-1 / math.sqrt(6), 2 / math.sqrt(6), -1 / math.sqrt(6)],
            [1 / math.sqrt(3), 1 / math.sqrt(3), 1 / math.sqrt(3)],
        ]
    ),
}
del _R

_LINE_WIDTH = 2.5
_FIG_SIZE = (8.0, 6.0)  # inches
_PNG_DPI = 100  # 800 x 600 pixels
_GIF_DPI = 80  # 640 x 480 pixels


@dataclass
class Scene:
    """What to draw: link polylines at every step, colours, view and joint frames.

    ``links`` maps a link name to its polylines, each an array of shape
    ``(steps, npts, 3)`` in global coordinates (NaN breaks a line).  ``colors``
    maps link names to IMP colour names (BLACK RED ORANGE YELLOW GREEN CYAN/AQUA
    BLUE MAGENTA/VIOLET WHITE, abbreviations to four letters allowed); links
    not named are WHITE and an unknown colour is WHITE, as in IMP.  ``view`` is
    a standard view name or ``(eye_xyz, up_xyz)``.  ``axes`` holds
    ``(joint name, frames of shape (steps, 4, 4), length)``: the u, v, w axes of
    each frame are drawn as red, green and blue arrows of that length (0 hides
    them).  ``times`` (shape ``(steps,)``) labels the steps; ``perspective`` is
    the eye distance of DATA DRAW (0 = orthographic).
    """

    links: dict[str, list[np.ndarray]]
    colors: dict[str, str] = field(default_factory=dict)
    view: str | tuple[Any, Any] = "FRONT"
    axes: list[tuple[str, np.ndarray, float]] = field(default_factory=list)
    times: np.ndarray | None = None
    title: str = ""
    perspective: float = 0.0


# --------------------------------------------------------------------------- colours


def color_hex(name: str | None) -> str:
    """RGB hex of an IMP colour name; unknown or missing names give WHITE (as IMP)."""
    key = (name or "").strip().upper()
    if len(key) >= 3:
        for full, hx in COLORS.items():
            if full == key or (len(key) >= 4 and full.startswith(key)):
                return hx
    return COLORS["WHITE"]


# --------------------------------------------------------------------------- projection


def _vec3(v: Any, what: str) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"view: {what} must be three numbers, got {v!r}") from exc
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InputError(f"view: {what} must be three finite numbers x,y,z, got {v!r}")
    return a


def view_rotation(view: str | tuple[Any, Any] | Sequence[Any],
                  centre: Any = (0.0, 0.0, 0.0)) -> np.ndarray:
    """3x3 matrix whose rows are screen right, screen up and out of the screen.

    ``view`` is FRONT, BACK, TOP, BOTTOM, LEFT, RIGHT or ISOMETRIC (any case,
    four-letter abbreviations allowed) or ``(eye, up)`` in global coordinates;
    the eye then looks at ``centre``.  Raises :class:`InputError` for an
    unknown name, an eye at the centre or an up vector parallel to the line of
    sight.
    """
    if isinstance(view, str):
        key = view.strip().upper()
        for name, rot in VIEWS.items():
            if key == name or (len(key) >= 4 and name.startswith(key)):
                return rot.copy()
        raise InputError(
            f"unknown view {view!r}: use FRONT, BACK, TOP, BOTTOM, LEFT, RIGHT, ISOMETRIC "
            "or (eye_xyz, up_xyz)"
        )
    try:
        eye_raw, up_raw = view
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"view must be a standard view name or (eye_xyz, up_xyz), got {view!r}"
        ) from exc
    eye = _vec3(eye_raw, "eye position")
    up = _vec3(up_raw, "up vector")
    c = _vec3(centre, "centre")
    out = eye - c
    n_out = float(np.linalg.norm(out))
    if n_out == 0.0:
        raise InputError("view: the eye position is at the centre of the scene; move the eye")
    out /= n_out
    right = np.cross(up, out)
    n_right = float(np.linalg.norm(right))
    if n_right <= 1e-9 * max(float(np.linalg.norm(up)), 1e-300):
        raise InputError(
            "view: the up vector is parallel to the line of sight (or zero); "
            "give an up vector across the view direction"
        )
    right /= n_right
    return np.vstack([right, np.cross(out, right), out])


def project(points: Any, view: str | tuple[Any, Any] = "FRONT", perspective: float = 0.0,
            centre: Any = None) -> np.ndarray:
    """Screen coordinates ``(..., 2)`` (x right, y up) of global points ``(..., 3)``.

    Orthographic (``perspective`` 0): screen x, y are the components of the
    point along screen right and screen up.  With an eye distance ``d`` > 0 the
    eye sits at ``centre + d * out`` and a point at depth ``z`` in front of the
    centre is scaled about the centre by ``d / (d - z)``; points at or behind
    the eye give NaN.  ``centre`` defaults to the origin.
    """
    p = np.asarray(points, dtype=float)
    if p.ndim == 0 or p.shape[-1] != 3:
        raise InputError(f"points to project must have shape (..., 3), got {p.shape}")
    c = np.zeros(3) if centre is None else _vec3(centre, "centre")
    rot = view_rotation(view, c)
    d = float(perspective)
    if not math.isfinite(d) or d < 0.0:
        raise InputError(f"perspective (DATA DRAW eye distance) must be >= 0, got {perspective!r}")
    if d == 0.0:
        return p @ rot[:2].T
    rel = (p - c) @ rot.T
    c2 = c @ rot[:2].T
    denom = d - rel[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(denom > 1e-9 * d, d / denom, np.nan)
    return c2 + rel[..., :2] * scale[..., None]


# --------------------------------------------------------------------------- preparation


@dataclass
class _Item:
    """One projected link: name, colour and its 2-D polylines ``(steps, npts, 2)``."""

    name: str
    color: str
    lines: list[np.ndarray]


@dataclass
class _Axis:
    """One projected joint frame: origin and u, v, w tips, shape ``(steps, 4, 2)``."""

    name: str
    pts: np.ndarray


@dataclass
class _Prepared:
    """A validated scene in screen coordinates with its fixed frame."""

    steps: int
    items: list[_Item]
    axes: list[_Axis]
    times: np.ndarray | None
    title: str
    bbox: tuple[float, float, float, float]  # xmin, xmax, ymin, ymax over all steps

    def label(self, k: int) -> str:
        """Text shown for step ``k``: the time if given, else the step number."""
        if self.times is not None:
            return f"t = {self.times[k]:.6g} s"
        return f"step {k + 1} / {self.steps}"


def _bbox(arrays: list[np.ndarray]) -> tuple[float, float, float, float] | None:
    xs = [a[..., 0].ravel() for a in arrays]
    ys = [a[..., 1].ravel() for a in arrays]
    if not xs:
        return None
    x = np.concatenate(xs)
    y = np.concatenate(ys)
    ok = np.isfinite(x) & np.isfinite(y)
    if not np.any(ok):
        return None
    return float(x[ok].min()), float(x[ok].max()), float(y[ok].min()), float(y[ok].max())


def _padded(b: tuple[float, float, float, float], pad: float = 0.06
            ) -> tuple[float, float, float, float]:
    """Bounding box grown by ``pad`` of its size, never of zero width or height."""
    x0, x1, y0, y1 = b
    w, h = x1 - x0, y1 - y0
    size = max(w, h)
    if size <= 0.0:
        size = max(abs(x0), abs(x1), abs(y0), abs(y1), 1.0) * 0.1
    w, h = max(w, size * 0.05), max(h, size * 0.05)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    hw, hh = 0.5 * w * (1 + 2 * pad), 0.5 * h * (1 + 2 * pad)
    return cx - hw, cx + hw, cy - hh, cy + hh


def _prepare(scene: Scene) -> _Prepared:
    """Validate ``scene`` and project it; raises :class:`InputError` on bad input."""
    if not isinstance(scene, Scene):
        raise InputError(f"expected a Scene, got {type(scene).__name__}")
    if not isinstance(scene.links, dict):
        raise InputError("Scene.links must be a dict of link name -> list of polylines")
    steps: int | None = None
    steps_from = ""

    def check_steps(n: int, what: str) -> None:
        nonlocal steps, steps_from
        if n < 1:
            raise InputError(f"{what} has no steps")
        if steps is None:
            steps, steps_from = n, what
        elif n != steps:
            raise InputError(f"{what} has {n} steps but {steps_from} has {steps}; "
                             "every array of a scene must cover the same steps")

    polylines: list[tuple[str, str, list[np.ndarray]]] = []
    allpts: list[np.ndarray] = []
    for name, lines in scene.links.items():
        if isinstance(lines, np.ndarray):
            raise InputError(f"link {name}: give a list of polylines, each (steps, npts, 3), "
                             "not a bare array")
        arrs: list[np.ndarray] = []
        for j, line in enumerate(lines):
            try:
                a = np.asarray(line, dtype=float)
            except (TypeError, ValueError) as exc:
                raise InputError(f"link {name}, polyline {j + 1}: not an array of numbers"
                                 ) from exc
            if a.ndim != 3 or a.shape[2] != 3:
                raise InputError(f"link {name}, polyline {j + 1}: shape {a.shape}; "
                                 "expected (steps, npts, 3) global coordinates")
            if a.shape[1] < 1:
                raise InputError(f"link {name}, polyline {j + 1}: has no points")
            check_steps(a.shape[0], f"link {name}, polyline {j + 1}")
            arrs.append(a)
            allpts.append(a.reshape(-1, 3))
        polylines.append((str(name), color_hex(scene.colors.get(name)), arrs))

    frames: list[tuple[str, np.ndarray, float]] = []
    for entry in scene.axes:
        try:
            jname, fr, length = entry
        except (TypeError, ValueError) as exc:
            raise InputError("Scene.axes entries must be (joint name, frames (steps,4,4), "
                             "length)") from exc
        try:
            f = np.asarray(fr, dtype=float)
            ln = float(length)
        except (TypeError, ValueError) as exc:
            raise InputError(f"axes of joint {jname}: frames and length must be numbers"
                             ) from exc
        if f.ndim != 3 or f.shape[1:] != (4, 4):
            raise InputError(f"axes of joint {jname}: frames have shape {f.shape}; "
                             "expected (steps, 4, 4)")
        if not math.isfinite(ln) or ln < 0.0:
            raise InputError(f"axes of joint {jname}: length must be >= 0 (0 hides them), "
                             f"got {length!r}")
        check_steps(f.shape[0], f"axes of joint {jname}")
        if ln == 0.0:
            continue
        origin = f[:, :3, 3]
        tips = origin[:, None, :] + ln * np.swapaxes(f[:, :3, :3], 1, 2)  # rows u, v, w
        frames.append((str(jname), np.concatenate([origin[:, None, :], tips], axis=1), ln))
        allpts.append(frames[-1][1].reshape(-1, 3))

    if steps is None or not allpts:
        raise InputError("empty scene: no link polylines and no joint axes to draw")
    cat = np.concatenate(allpts)
    fin = np.all(np.isfinite(cat), axis=1)
    if not np.any(fin):
        raise InputError("scene has no finite coordinates to draw")
    centre = 0.5 * (cat[fin].min(axis=0) + cat[fin].max(axis=0))

    times: np.ndarray | None = None
    if scene.times is not None:
        try:
            times = np.asarray(scene.times, dtype=float)
        except (TypeError, ValueError) as exc:
            raise InputError("Scene.times must be numbers") from exc
        if times.shape != (steps,):
            raise InputError(f"Scene.times has shape {times.shape}; expected ({steps},), "
                             "one time per step")

    def proj(a: np.ndarray) -> np.ndarray:
        return project(a, scene.view, scene.perspective, centre)

    items = [_Item(n, c, [proj(a) for a in arrs]) for n, c, arrs in polylines]
    axes = [_Axis(n, proj(p)) for n, p, _ in frames]
    every = [ln for it in items for ln in it.lines] + [ax.pts for ax in axes]
    box = _bbox(every)
    if box is None:
        raise InputError("scene has no visible point in front of the eye; "
                         "increase the DATA DRAW eye distance")
    return _Prepared(steps, items, axes, times, str(scene.title), box)


# --------------------------------------------------------------------------- files


def _atomic(path: PathLike, write: Callable[[str], None]) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it over
    ``path`` (:func:`openimp.files.atomic_write_with`: open()'s permissions, no
    temporary file left behind)."""
    return atomic_write_with(path, write)


# --------------------------------------------------------------------------- matplotlib


class _Picture:
    """A matplotlib figure of a prepared scene whose lines are updated per step."""

    def __init__(self, prep: _Prepared, bbox: tuple[float, float, float, float],
                 dpi: int) -> None:
        self.prep = prep
        self.fig = Figure(figsize=_FIG_SIZE, dpi=dpi, facecolor="white")
        FigureCanvasAgg(self.fig)
        rect = (0.02, 0.02, 0.96, 0.90)
        ax: Axes = self.fig.add_axes(rect)
        ax.set_facecolor("white")
        ax.set_axis_off()
        # grow the frame to the shape of the axes box: equal aspect, nothing clipped
        box_ratio = (rect[2] * _FIG_SIZE[0]) / (rect[3] * _FIG_SIZE[1])
        x0, x1, y0, y1 = bbox
        cx, cy, w, h = 0.5 * (x0 + x1), 0.5 * (y0 + y1), x1 - x0, y1 - y0
        if w / h < box_ratio:
            w = h * box_ratio
        else:
            h = w / box_ratio
        ax.set_xlim(cx - 0.5 * w, cx + 0.5 * w)
        ax.set_ylim(cy - 0.5 * h, cy + 0.5 * h)
        ax.set_aspect("equal", adjustable="box")
        ax.set_autoscale_on(False)
        self.ax = ax
        if prep.title:
            self.fig.suptitle(prep.title, fontsize=13, y=0.985)
        self.label: Text = self.fig.text(0.02, 0.935, "", fontsize=10, family="monospace")
        self.lines: list[tuple[Line2D, np.ndarray]] = []
        for it in prep.items:
            for a in it.lines:
                (ln,) = ax.plot([], [], color=it.color, lw=_LINE_WIDTH,
                                solid_capstyle="round", solid_joinstyle="round")
                self.lines.append((ln, a))
        self.arrows: list[tuple[FancyArrowPatch, np.ndarray, int]] = []
        for axis in prep.axes:
            for k in range(3):
                arrow = FancyArrowPatch((0, 0), (0, 0), arrowstyle="-|>", mutation_scale=12,
                                        color=AXIS_COLORS[k], lw=1.6, shrinkA=0, shrinkB=0)
                ax.add_patch(arrow)
                self.arrows.append((arrow, axis.pts, k))

    def show(self, k: int) -> None:
        """Put step ``k`` on the figure."""
        for ln, a in self.lines:
            ln.set_data(a[k, :, 0], a[k, :, 1])
        for arrow, pts, j in self.arrows:
            o, t = pts[k, 0], pts[k, j + 1]
            ok = bool(np.all(np.isfinite(o)) and np.all(np.isfinite(t)))
            arrow.set_visible(ok)
            if ok:
                arrow.set_positions((float(o[0]), float(o[1])), (float(t[0]), float(t[1])))
        self.label.set_text(self.prep.label(k))


def _step_index(step: int, steps: int) -> int:
    try:
        k = int(step)
    except (TypeError, ValueError) as exc:
        raise InputError(f"step must be an integer, got {step!r}") from exc
    if k != step or not -steps <= k < steps:
        raise InputError(f"step {step!r} is out of range: the scene has {steps} steps "
                         f"(0 to {steps - 1}, or negative from the end)")
    return k % steps


def draw_png(scene: Scene, step: int, path: PathLike) -> Path:
    """Draw the links (and joint axes) at step ``step`` to a PNG file (IMP's DRAW).

    ``step`` counts from 0; negative values count from the end.  The picture is
    framed on that step's bounding box with an equal aspect ratio.
    """
    prep = _prepare(scene)
    k = _step_index(step, prep.steps)
    at_k = [ln[k] for it in prep.items for ln in it.lines] + [ax.pts[k] for ax in prep.axes]
    box = _bbox(at_k) or prep.bbox
    pic = _Picture(prep, _padded(box), _PNG_DPI)
    pic.show(k)
    return _atomic(path, lambda tmp: pic.fig.savefig(tmp, format="png", dpi=_PNG_DPI,
                                                     facecolor="white"))


def _frame_indices(steps: int, max_frames: int) -> np.ndarray:
    if steps <= max_frames:
        return np.arange(steps)
    return np.unique(np.round(np.linspace(0, steps - 1, max_frames)).astype(int))


def _gif_palette(colors: Sequence[str]) -> Any:
    """A Pillow palette image: white, and each colour blended with white in 16 shades.

    The drawn colours are in it exactly, and anti-aliased edges map to a shade
    of their own colour; quantizing to one fixed palette is fast and keeps the
    colours steady from frame to frame.
    """
    from matplotlib.colors import to_rgb
    from PIL import Image

    entries: list[tuple[int, int, int]] = [(255, 255, 255)]
    for c in dict.fromkeys(colors):
        rgb = np.array(to_rgb(c)) * 255.0
        for alpha in np.linspace(1.0, 1.0 / 16, 16):
            r, g, b = (alpha * rgb + (1.0 - alpha) * 255.0).tolist()
            e = (round(r), round(g), round(b))
            if e not in entries:
                entries.append(e)
    entries = entries[:256]
    flat = [v for e in entries for v in e]
    flat += flat[-3:] * (256 - len(entries))
    pal = Image.new("P", (1, 1))
    pal.putpalette(flat)
    return pal


def animate_gif(scene: Scene, path: PathLike, fps: int = 20, max_frames: int = 400) -> Path:
    """Animated GIF of every step (IMP's ANIMATE) in one fixed frame.

    Beyond ``max_frames`` steps, ``max_frames`` evenly spaced steps are drawn
    (first and last included).  Written with matplotlib's Pillow writer, each
    frame mapped to one fixed palette of the scene's colours.  (Pillow merges a
    frame identical to the one before it into a longer frame; the time label
    normally makes every frame differ.)
    """
    from matplotlib.animation import PillowWriter
    from PIL import Image

    prep = _prepare(scene)
    if not (isinstance(fps, int | float) and math.isfinite(fps) and fps > 0):
        raise InputError(f"fps must be > 0, got {fps!r}")
    if not isinstance(max_frames, int) or max_frames < 1:
        raise InputError(f"max_frames must be a positive integer, got {max_frames!r}")
    pic = _Picture(prep, _padded(prep.bbox), _GIF_DPI)
    idx = _frame_indices(prep.steps, max_frames)
    palette = _gif_palette(["#000000", *(it.color for it in prep.items), *AXIS_COLORS])

    class _Writer(PillowWriter):
        def grab_frame(self, **savefig_kwargs: Any) -> None:
            self.fig.canvas.draw()
            rgba = np.asarray(self.fig.canvas.buffer_rgba())  # type: ignore[attr-defined]
            im = Image.fromarray(np.ascontiguousarray(rgba[..., :3]))
            self._frames.append(im.quantize(palette=palette, dither=Image.Dither.NONE))

    def write(tmp: str) -> None:
        writer = _Writer(fps=fps)
        with writer.saving(pic.fig, tmp, _GIF_DPI):
            for k in idx:
                pic.show(int(k))
                writer.grab_frame()

    return _atomic(path, write)


# --------------------------------------------------------------------------- HTML


def _flat(a: np.ndarray, digits: int) -> list[float | None]:
    """Flat ``[x0, y0, x1, y1, ...]`` rounded, NaN as null."""
    out: list[float | None] = []
    for v in np.round(a.reshape(-1), digits).tolist():
        out.append(v if math.isfinite(v) else None)
    return out


_HTML = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>__TITLE__</title>
<style>
  html, body { margin: 0; height: 100%; background: #fff; color: #111;
               font-family: system-ui, sans-serif; }
  body { display: flex; flex-direction: column; }
  #bar { display: flex; align-items: center; gap: 10px; padding: 6px 10px;
         border-bottom: 1px solid #ddd; flex: 0 0 auto; }
  #bar h1 { font-size: 15px; margin: 0 8px 0 0; font-weight: 600; white-space: nowrap; }
  #slider { flex: 1 1 auto; min-width: 80px; }
  #time { font-family: monospace; min-width: 14ch; }
  #wrap { flex: 1 1 auto; position: relative; min-height: 100px; }
  #view { position: absolute; inset: 0; width: 100%; height: 100%; display: block; }
  #error { color: #b00; background: #fee; margin: 0; padding: 6px 10px; white-space: pre-wrap; }
</style>
</head>
<body>
<pre id="error" hidden></pre>
<script>
window.__errors = [];
function __report(msg) {
  window.__errors.push(String(msg));
  document.title = "ERROR: " + msg;
  document.documentElement.setAttribute("data-error", "1");
  var e = document.getElementById("error");
  if (e) { e.hidden = false; e.textContent += "ERROR: " + msg + "\\n"; }
}
window.addEventListener("error", function (ev) {
  __report((ev.message || "error") + " (line " + ev.lineno + ":" + ev.colno + ")");
});
window.addEventListener("unhandledrejection", function (ev) { __report(ev.reason); });
</script>
<div id="bar">
  <h1>__TITLE__</h1>
  <button id="play" type="button">Play</button>
  <input id="slider" type="range" min="0" max="0" step="1" value="0" aria-label="step">
  <span id="time"></span>
</div>
<div id="wrap"><canvas id="view"></canvas></div>
<output id="status" hidden data-state="loading"></output>
<script type="application/json" id="scene-data">__DATA__</script>
<script>
(function () {
  "use strict";
  var data = JSON.parse(document.getElementById("scene-data").textContent);
  var n = data.steps;
  var canvas = document.getElementById("view");
  var slider = document.getElementById("slider");
  var button = document.getElementById("play");
  var label = document.getElementById("time");
  var status = document.getElementById("status");
  var axisColors = data.axisColors;
  var step = 0, playing = false, timer = null;
  slider.max = String(n - 1);

  function labelFor(k) {
    if (data.times) {
      var t = data.times[k];
      return "t = " + (t === null ? "?" : String(Number(t.toPrecision(6)))) + " s";
    }
    return "step " + (k + 1) + " / " + n;
  }

  function draw() {
    var dpr = window.devicePixelRatio || 1;
    var w = canvas.clientWidth || 300, h = canvas.clientHeight || 150;
    canvas.width = Math.round(w * dpr);
    canvas.height = Math.round(h * dpr);
    var ctx = canvas.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.fillStyle = "#ffffff";
    ctx.fillRect(0, 0, w, h);
    var b = data.bbox, pad = 12;
    var s = Math.min((w - 2 * pad) / (b[1] - b[0]), (h - 2 * pad) / (b[3] - b[2]));
    var ox = (w - s * (b[1] - b[0])) / 2, oy = (h - s * (b[3] - b[2])) / 2;
    function X(x) { return ox + (x - b[0]) * s; }
    function Y(y) { return h - oy - (y - b[2]) * s; }
    var segments = 0;
    ctx.lineCap = "round";
    ctx.lineJoin = "round";
    ctx.lineWidth = 2.5;
    data.links.forEach(function (link) {
      ctx.strokeStyle = link.color;
      link.polylines.forEach(function (pl) {
        var c = pl[step];
        ctx.beginPath();
        var pen = false;
        for (var i = 0; i + 1 < c.length; i += 2) {
          if (c[i] === null || c[i + 1] === null) { pen = false; continue; }
          if (pen) { ctx.lineTo(X(c[i]), Y(c[i + 1])); segments++; }
          else { ctx.moveTo(X(c[i]), Y(c[i + 1])); pen = true; }
        }
        ctx.stroke();
      });
    });
    ctx.lineWidth = 1.6;
    data.axes.forEach(function (axis) {
      var c = axis.arrows[step];
      for (var j = 0; j < 3; j++) {
        var x0 = c[0], y0 = c[1], x1 = c[2 + 2 * j], y1 = c[3 + 2 * j];
        if (x0 === null || y0 === null || x1 === null || y1 === null) { continue; }
        var ax = X(x0), ay = Y(y0), bx = X(x1), by = Y(y1);
        var dx = bx - ax, dy = by - ay, len = Math.hypot(dx, dy);
        ctx.strokeStyle = axisColors[j];
        ctx.fillStyle = axisColors[j];
        ctx.beginPath(); ctx.moveTo(ax, ay); ctx.lineTo(bx, by); ctx.stroke();
        if (len > 1) {
          var hl = Math.min(10, 0.4 * len), ux = dx / len, uy = dy / len;
          ctx.beginPath();
          ctx.moveTo(bx, by);
          ctx.lineTo(bx - hl * ux - 0.4 * hl * uy, by - hl * uy + 0.4 * hl * ux);
          ctx.lineTo(bx - hl * ux + 0.4 * hl * uy, by - hl * uy - 0.4 * hl * ux);
          ctx.closePath(); ctx.fill();
        }
        segments++;
      }
    });
    slider.value = String(step);
    label.textContent = labelFor(step);
    status.setAttribute("data-step", String(step));
    status.setAttribute("data-segments", String(segments));
    status.setAttribute("data-state", "ok");
    status.textContent = "drawn step " + step;
  }

  function show(k) { step = Math.max(0, Math.min(n - 1, k)); draw(); }
  function tick() { show(step + 1 < n ? step + 1 : 0); }
  function play() {
    if (n < 2) { return; }
    playing = true; button.textContent = "Pause";
    if (timer === null) { timer = setInterval(tick, 1000 / data.fps); }
  }
  function pause() {
    playing = false; button.textContent = "Play";
    if (timer !== null) { clearInterval(timer); timer = null; }
  }
  button.addEventListener("click", function () { if (playing) { pause(); } else { play(); } });
  slider.addEventListener("input", function () { pause(); show(parseInt(slider.value, 10)); });
  window.addEventListener("resize", draw);

  // #step=first|last|N (or ?step=...) shows that step, paused; otherwise the page plays.
  var params = new URLSearchParams(
    (window.location.hash || "").replace(/^#/, "") + "&" +
    (window.location.search || "").replace(/^\\?/, ""));
  var want = params.get("step");
  if (want === null) {
    show(0);
    if (params.get("play") !== "0") { play(); }
  } else {
    var k = want === "last" ? n - 1 : want === "first" ? 0 : parseInt(want, 10);
    if (isNaN(k)) { throw new Error("bad step in URL: " + want); }
    show(k < 0 ? n + k : k);
  }
})();
</script>
</body>
</html>
"""


def animate_html(scene: Scene, path: PathLike) -> Path:
    """One self-contained HTML page animating every step (no network needed).

    The page embeds the projected 2-D polylines of every step as JSON and draws
    them on a ``<canvas>`` in a fixed frame (the bounding box over all steps),
    with a play/pause button, a time slider and a label showing the time.  It
    plays on opening; the URL fragment ``#step=N`` (or ``first``/``last``, or a
    negative N from the end) shows one step, paused.  A JavaScript error is
    shown on the page, put in the title as ``ERROR: ...`` and flags
    ``<html data-error="1">``; after drawing, ``<output id="status">`` carries
    ``data-state="ok"`` and ``data-step``.
    """
    prep = _prepare(scene)
    box = _padded(prep.bbox, pad=0.03)
    size = max(box[1] - box[0], box[3] - box[2])
    digits = max(0, 6 - math.floor(math.log10(size))) if size > 0 else 6
    data: dict[str, Any] = {
        "title": prep.title,
        "steps": prep.steps,
        "fps": 20,
        "times": None if prep.times is None else [float(t) for t in prep.times],
        "bbox": [float(v) for v in box],
        "axisColors": list(AXIS_COLORS),
        "links": [
            {"name": it.name, "color": it.color,
             "polylines": [[_flat(a[k], digits) for k in range(prep.steps)] for a in it.lines]}
            for it in prep.items
        ],
        "axes": [
            {"name": ax.name, "arrows": [_flat(ax.pts[k], digits) for k in range(prep.steps)]}
            for ax in prep.axes
        ],
    }
    if data["times"] is not None and not all(math.isfinite(t) for t in data["times"]):
        data["times"] = [t if math.isfinite(t) else None for t in data["times"]]
    blob = json.dumps(data, separators=(",", ":"), allow_nan=False)
    blob = blob.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    title = html.escape(prep.title or "openimp animation")
    subst = {"__TITLE__": title, "__DATA__": blob}
    text = re.sub("__TITLE__|__DATA__", lambda m: subst[m.group(0)], _HTML)

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)

    return _atomic(path, write)


# --------------------------------------------------------------------------- plots


def _col_label(name: str, unit: str) -> str:
    return f"{name} ({unit})" if unit else name


def plot_png(table: Table, path: PathLike, columns: Sequence[str | int] | None = None,
             x: str | int = 0) -> Path:
    """Plot table columns against one of its columns to a PNG (IMP's PLOT).

    ``x`` names the abscissa (a column name or index; default the first column,
    the time or the step); ``columns`` are the ordinates, names or indices
    (default: every column but the first and the abscissa).  Axis labels carry
    the units ("Time (s)", "JVar 1 (deg)"); the title is the request and item
    of the table.
    """
    fig = _plot_figure(table, columns, x)
    return _atomic(path, lambda tmp: fig.savefig(tmp, format="png", dpi=_PNG_DPI))


def bode_png(table: Table, path: PathLike) -> Path:
    """A Bode plot of a frequency-response table (IMP's PLOT DYNAMICS) to a PNG.

    ``table``: the frequency (rad/s) first, then magnitude and phase (degrees)
    of every output in pairs (:meth:`openimp.FrequencyResponse.to_table`'s
    order; ``units`` label the magnitudes).  Magnitudes on log-log axes above,
    phases on semi-log axes below, one line per output; written atomically.
    """
    rows = np.asarray(table.rows, dtype=float)
    if rows.ndim != 2 or rows.shape[1] < 3 or rows.shape[1] % 2 != 1:
        raise InputError(f"table {table.request} {table.item}: a Bode plot needs the "
                         "frequency and (magnitude, phase) pairs")
    w = rows[:, 0]
    fig = Figure(figsize=_FIG_SIZE, dpi=_PNG_DPI, facecolor="white")
    FigureCanvasAgg(fig)
    top, bottom = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2)
    for j in range(1, rows.shape[1], 2):
        label = table.columns[j].strip("|")
        mag = np.where(rows[:, j] > 0, rows[:, j], np.nan)
        top.loglog(w, mag, lw=1.6, label=f"{label} ({table.units[j]})")
        bottom.semilogx(w, rows[:, j + 1], lw=1.6, label=label)
    top.set_ylabel("Magnitude")
    bottom.set_ylabel("Phase (deg)")
    bottom.set_xlabel("Frequency (rad/s)")
    for ax in (top, bottom):
        ax.grid(True, which="both", alpha=0.3)
    top.legend(fontsize=8)
    top.set_title(f"{table.request} {table.item}".encode("ascii", "replace").decode())
    fig.tight_layout()
    return _atomic(path, lambda tmp: fig.savefig(tmp, format="png", dpi=_PNG_DPI))


def _column_index(table: Table, c: Any) -> int:
    """The index of column ``c`` (a name or an index) of ``table``."""
    cols = list(table.columns)
    if isinstance(c, str):
        if c not in cols:
            raise InputError(f"table {table.request} {table.item}: no column {c!r}; "
                             f"columns are {', '.join(cols)}")
        return cols.index(c)
    if isinstance(c, int | np.integer) and -len(cols) <= int(c) < len(cols):
        return int(c) % len(cols)
    raise InputError(f"table {table.request} {table.item}: bad column {c!r}")


def _plot_figure(table: Table, columns: Sequence[str | int] | None,
                 x: str | int = 0) -> Figure:
    """The matplotlib figure of :func:`plot_png` (validated; not yet saved)."""
    cols = list(table.columns)
    units = list(table.units) + [""] * max(0, len(cols) - len(table.units))
    try:
        rows = np.asarray(table.rows, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"table {table.request} {table.item}: rows are not numbers") from exc
    if len(cols) < 2:
        raise InputError(f"table {table.request} {table.item}: needs at least two columns "
                         "to plot (x and y)")
    if rows.ndim != 2 or rows.shape[1] != len(cols):
        raise InputError(f"table {table.request} {table.item}: rows have shape {rows.shape}; "
                         f"expected (n, {len(cols)})")
    if rows.shape[0] == 0:
        raise InputError(f"table {table.request} {table.item}: has no rows to plot")
    ix = _column_index(table, x)
    if columns is None:
        chosen = [j for j in range(1, len(cols)) if j != ix]
    else:
        if isinstance(columns, str | int):
            columns = [columns]
        chosen = [_column_index(table, c) for c in columns]
    if not chosen:
        raise InputError(f"table {table.request} {table.item}: no columns chosen to plot")

    fig = Figure(figsize=_FIG_SIZE, dpi=_PNG_DPI, facecolor="white")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    for j in chosen:
        ax.plot(rows[:, ix], rows[:, j], lw=1.6, label=_col_label(cols[j], units[j]),
                marker="o" if rows.shape[0] == 1 else None)
    ax.set_xlabel(_col_label(cols[ix], units[ix]))
    if len(chosen) == 1:
        ax.set_ylabel(_col_label(cols[chosen[0]], units[chosen[0]]))
    else:
        common = {units[j] for j in chosen}
        ax.set_ylabel(f"Value ({common.pop()})" if len(common) == 1 and "" not in common
                      else "Value")
    ax.legend(loc="best")
    ax.grid(True, alpha=0.3)
    ax.set_title(f"{table.request} {table.item}".strip())
    fig.tight_layout()
    return fig
