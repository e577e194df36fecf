"""Running a deck: its events in order, each EXECUTE through the runner of its mode,
tables, PRINT text, listings, pictures and the files the deck asks for.

:data:`SOLVERS` maps a mode to its runner, a function
``(prepared run, output times, start posture, notes, progress) -> Solution``
(kinematic, static and dynamic).  Everything else here (banners,
tables, listings, graphics, files) is the same for every mode.
"""

from __future__ import annotations

import os
import time as _time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from openimp._interrupt import held_interrupt
from openimp.errors import InputError, OutputError
from openimp.files import OutputFolder, printable, slug
from openimp.imp.interp import DEFAULT_TITLE, RunSpec, State, Where, build_model
from openimp.imp.listing import banner, format_listing, format_store, step_text
from openimp.imp.run import dynamic, kinematic, static, vibration
from openimp.imp.run.forces import safe_compute, wants_forces
from openimp.imp.run.prepare import (
    Prepared,
    needs,
    not_produced,
    plot_driver,
    stepped,
    time_grid,
    trailing_requests,
    validate,
)
from openimp.imp.run.quantities import (
    dynamic_tables,
    integration_lines,
    joint_frames,
    make_table,
    print_step,
    stop_at_value,
    value_resolver,
)
from openimp.imp.run.solution import Solution
from openimp.results import Run, Table

#: the runner of each mode: (prepared run, output times, start, notes, progress) -> Solution
SOLVERS: dict[str, Callable[..., Solution]] = {"kinematic": kinematic.solve,
                                                "static": static.solve,
                                                "dynamic": dynamic.solve}


@dataclass
class Context:
    """State carried from run to run: reference posture, time, output sinks.

    ``folder`` receives the files the deck asks for (STORE, PRINT ON, STORE
    INPUT, graphics); ``out_dir`` is set when graphics are rendered (--out).
    ``problems`` receives a message for every file that was refused or could
    not be written.  ``stopped`` ends the deck (END in a VALUE, Ctrl-C).
    """

    out_dir: Path | None
    echo: Callable[[str], None]
    notes: Callable[[str], None]
    progress: Callable[[int, int, int], None] | None
    deck_stem: str
    folder: OutputFolder
    problems: Callable[[str], None]
    ref_q: np.ndarray | None = None
    ref_names: tuple[str, ...] | None = None
    ref_sol: tuple[Prepared, Solution] | None = None
    time0: float = 0.0
    print_on: str | None = None
    print_files: dict[str, list[str]] = field(default_factory=dict)
    files: dict[str, str] = field(default_factory=dict)
    file_where: dict[str, Where] = field(default_factory=dict)
    draws: int = 0
    graphics_note: bool = False
    interactive_note: bool = False
    viz: Any = None
    viz_error: str | None = None
    stopped: bool = False

    def say(self, line: str) -> None:
        """Print a line (and copy it to the PRINT ON file), control characters escaped."""
        line = printable(line)
        self.echo(line)
        if self.print_on is not None:
            self.print_files.setdefault(self.print_on, []).append(line)

    def get_viz(self, where: Where) -> Any:
        """The viz module, or None (with a note located at ``where``) when it cannot be
        imported."""
        if self.viz is None and self.viz_error is None:
            try:
                from openimp import viz  # type: ignore[attr-defined]

                self.viz = viz
            except Exception as exc:
                self.viz_error = f"{type(exc).__name__}: {exc}"
                self.notes(f"{where[0]}:{where[1]}: graphics were not rendered: openimp.viz "
                           f"cannot be imported ({printable(self.viz_error, 200)})")
        return self.viz

    def picture(self, name: str, where: Where, render: Callable[[str], Any]) -> None:
        """Render a graphics file ``name`` in the output folder with ``render(path)``
        (refused names and write failures go to ``problems``)."""
        path = self.folder.target(name, where)
        if path is None:
            self.problems(self.folder.refused[-1])
            return
        try:
            render(str(path))
        except OutputError as exc:
            self.problems(f"{where[0]}:{where[1]}: {exc}")
            return
        self.folder.claim(path)


def singular_notes(sol: Solution, stepped: bool) -> list[str]:
    """One message per singular posture and driver switch of a solved run."""
    out = []
    grid = sol.times if sol.grid is None else sol.grid
    for r in sol.traj.singularities:
        k = min(r.step, len(grid) - 1)
        text = str(r)
        if sol.missing:  # the run went on past it (kinematic.solve)
            text = text.replace("the sweep stops there", "the positions beyond it that cannot "
                                "be reached are skipped")
        out.append(f"Singular posture {text}" + ("" if stepped or k < 0 else
                                                 f" (time near {grid[k]:.6g})"))
    for w in sol.traj.switches:
        out.append(f"Input switched: {w}")
    return out


def _ascii(text: str) -> str:
    """``text`` for a picture: printable ASCII, any other character as '?' (the fonts
    of the pictures need not have a glyph for it, and IMP titles are ASCII)."""
    return "".join(ch if " " <= ch <= "~" else "?" for ch in text)


def _title(state: State) -> str:
    return state.title or DEFAULT_TITLE


def execute_run(spec: RunSpec, ctx: Context) -> Run:
    """Carry out one EXECUTE (see the module docstring)."""
    state = spec.state
    run = Run(_title(state), spec.mode)
    when = _time.strftime("%m/%d/%Y at %H:%M:%S")
    for line in banner(printable(run.title), spec.mode.capitalize(), when).split("\n"):
        ctx.say(line)
    failure, unsupported = not_produced(spec)
    if failure is not None:
        run.failure = failure
        ctx.say(f"*** {run.failure} ***")
        return run
    prep = validate(spec)
    for m in prep.built.messages:
        run.messages.append(m)
        ctx.say(f"*** {m} ***")
    times, assumed = time_grid(state, ctx.time0)
    if assumed:
        run.messages.append(assumed)
        ctx.say(f"*** {assumed} ***")
    for text in unsupported:
        run.unsupported.append(text)
        ctx.say(f"*** {text} ***")
    start = None
    if ctx.ref_q is not None:
        if ctx.ref_names == prep.system.var_names:
            start = ctx.ref_q
        else:
            m = ("The model changed since EXECUTE HOLD; this run starts from the design "
                 "position.")
            run.messages.append(m)
            ctx.say(f"*** {m} ***")
    notes: list[str] = []
    prog = None
    if ctx.progress is not None:
        def prog(done: int, total: int, _i: int = spec.index) -> None:
            assert ctx.progress is not None
            ctx.progress(_i, done, total)
    sol = SOLVERS[spec.mode](prep, times, start, notes, prog)
    loc = f"{spec.where[0]}:{spec.where[1]}"

    def told() -> None:
        ctx.notes(f"{loc}: Ctrl-C: the {sol.n} output(s) solved are being listed and written; "
                  "Ctrl-C again abandons them")

    with held_interrupt(told) as held:  # what is solved is the user's: finish it
        _results(spec, ctx, prep, sol, notes, run)
    if held[0] and not run.interrupted:
        run.interrupted = True
        run.failure = (f"{loc}: EXECUTE: interrupted by the user (Ctrl-C) after its {sol.n} "
                       "output(s) were solved; they are listed and written")
        ctx.say(f"*** {run.failure} ***")
    return run


def _results(spec: RunSpec, ctx: Context, prep: Prepared, sol: Solution, notes: list[str],
             run: Run) -> None:
    """The solution of one EXECUTE made into its tables, printout, listings, graphics and
    held reference (into ``run`` and through ``ctx``)."""
    state = spec.state
    run.missing = list(sol.missing or [])
    bodies, points = needs(prep, sol.n)
    sol.traj.prefetch(bodies, points)  # one pass over the steps for every table
    for text in singular_notes(sol, stepped(state)):
        notes.append(text)
    if not (sol.stop or sol.interrupted) and sol.n:
        sol = stop_at_value(prep, sol, notes)
    items = prep.items
    force_failure = ""
    if sol.n and wants_forces(prep):
        laws = prep.built.dyn.laws
        if laws is not None:
            laws.resolve_at = (lambda k, s=sol: value_resolver(prep, s, k, s.times[k], None, k,
                                                          notes))
        sol.forces, force_failure = safe_compute(prep, sol, notes)
        if sol.forces is None:
            items = [it for it in items if it.request.quantity != "FORCE"]
    # tables
    tables: dict[tuple[str, str, str], Table] = {}
    for it in items:
        if it.kind in vibration.KINDS:
            continue
        t = make_table(prep, sol, it, notes)
        tables[(it.request.family, it.request.quantity, t.item)] = t
        run.tables.append(t)
        run.tables.extend(dynamic_tables(sol, it))  # dynamic HEADING: energy, integration
    vib = vibration.analyse(prep, sol, [it for it in items if it.kind in vibration.KINDS],
                            notes)
    run.tables.extend(vib.tables)
    # PRINT output per position
    print_items = [it for it in items if it.request.family == "PRINT" and it.kind != "dynamics"]
    if print_items:
        for k in range(sol.n):
            ctx.say(f"step = {step_text(sol.times[k])}" if stepped(state)
                    else f"time = {sol.times[k]:.6f}")
            for line in print_step(prep, sol, k, tables, print_items):
                ctx.say(line)
            for line in vib.steps.get(k, []):
                ctx.say(line)
        if any(it.kind == "heading" for it in print_items):
            for line in integration_lines(sol):
                ctx.say(line)
    for note in notes:
        run.messages.append(note)
        ctx.say(f"*** {note} ***")
    if sol.stop:
        run.messages.append(sol.stop)
        ctx.say(f"*** {sol.stop} ***")
        ctx.stopped = ctx.stopped or sol.end
    if sol.message:
        run.failure = f"{spec.where[0]}:{spec.where[1]}: EXECUTE: {sol.message}"
    elif force_failure:
        run.failure = force_failure
    run.interrupted = sol.interrupted
    for text in vib.problems:
        run.unsupported.append(text)
        ctx.say(f"*** {text} ***")
    if vib.after:  # PRINT DYNAMICS, for the last position of the run
        ctx.say("")
        for line in vib.after:
            ctx.say(line)
    # listings
    for t in run.tables:
        if t.request.startswith("LIST"):
            ctx.say("")
            for line in format_listing(t, units=not spec.state.imp_listing).split("\n"):
                ctx.say(line)
    if run.failure:
        ctx.say("")
        ctx.say(f"*** {run.failure} ***")
    if not run.interrupted:
        _graphics(prep, sol, run, ctx)
    if spec.hold and sol.n > 0:
        ctx.ref_q = sol.q[-1].copy()
        ctx.ref_names = prep.system.var_names
        ctx.ref_sol = (prep, sol)
        ctx.time0 = float(sol.times[-1])
        m = "The current position is set as reference."
        run.messages.append(m)
        ctx.say(f"*** {m} ***")


def _scene(prep: Prepared, sol: Solution, steps: slice, title: str) -> Any:
    from openimp.viz import Scene  # type: ignore[import-not-found]

    st = prep.spec.state
    g = st.graphics
    model = prep.built.model
    links: dict[str, list[np.ndarray]] = {}
    colors: dict[str, str] = {}
    for link, pts in st.polylines:
        pts = [p for p in pts if p in model.points]
        if len(pts) < 2 or link not in model.body_frames:
            continue
        if link in g.erased or ("*" in g.erased and link not in g.colors):
            continue
        poly = np.stack([sol.traj.point(p)[steps] for p in pts], axis=1)
        links.setdefault(link, []).append(poly)
        colors[link] = g.colors.get(link, g.all_color or "WHITE")
    axes = []
    for j in model.joints:
        length = g.axes.get(j, g.axes_all)
        if length:
            axes.append((j, joint_frames(prep, sol, j)[steps], float(length)))
    view = g.view
    times = None if stepped(st) else np.asarray(sol.times[steps])  # None: "step k / n"
    return Scene(links=links, colors=colors, view=view, axes=axes, times=times,
                 title=_ascii(title))


def _graphics(prep: Prepared, sol: Solution, run: Run, ctx: Context) -> None:
    st = prep.spec.state
    g = st.graphics
    plots = [t for t in run.tables if t.request.startswith("PLOT")]
    wants = g.animate or plots
    if not wants:
        return
    if not _can_render(ctx, prep.spec.where):
        return
    _interactive_note(st, ctx)
    viz = ctx.get_viz(prep.spec.where)
    if viz is None or sol.n == 0:
        return
    k = prep.spec.index
    where = prep.spec.where
    try:
        if g.animate:
            scene = _scene(prep, sol, slice(None), run.title)
            ctx.picture(f"run{k}_animation.gif", where, lambda p: viz.animate_gif(scene, p))
            ctx.picture(f"run{k}_animation.html", where, lambda p: viz.animate_html(scene, p))
        for t in plots:
            name = f"run{k}_plot_{slug(t.request.split()[-1])}_{slug(t.item)}.png"
            x = 1 if plot_driver(prep) is not None else 0
            if t.request == "PLOT DYNAMICS":  # a Bode plot against the frequency
                ctx.picture(name, where, lambda p, t=t: viz.bode_png(t, p))
            else:
                ctx.picture(name, where, lambda p, t=t, x=x: viz.plot_png(t, p, x=x))
    except Exception as exc:
        ctx.notes(f"{where[0]}:{where[1]}: run {k}: graphics failed ({type(exc).__name__}: "
                  f"{printable(str(exc), 200)}); the numeric results are not affected")


def _can_render(ctx: Context, where: Where) -> bool:
    """True with --out; otherwise say once that graphics were accepted but not rendered."""
    if ctx.out_dir is not None:
        return True
    if not ctx.graphics_note:
        ctx.graphics_note = True
        ctx.notes(f"{where[0]}:{where[1]}: graphics statements (DRAW, ANIMATE, PLOT ...) were "
                  "accepted but not rendered: give --out DIR to write plots and animations")
    return False


def _interactive_note(state: State, ctx: Context) -> None:
    if state.graphics.interactive and not ctx.interactive_note:
        ctx.interactive_note = True
        w = state.graphics.interactive[0]
        ctx.notes(f"{w[0]}:{w[1]}: interactive view statements (DEVICE, ZOOM, SLIDE, TURN, "
                  "STORE/RECALL VIEW, DATA DRAW, SHOW LOOP) have no effect on the files "
                  "written with --out")


def _draw(state: State, where: tuple[str, int], ctx: Context) -> None:
    if not _can_render(ctx, where):
        return
    _interactive_note(state, ctx)
    viz = ctx.get_viz(where)
    if viz is None:
        return
    ctx.draws += 1
    try:
        if ctx.ref_sol is not None:
            prep, sol = ctx.ref_sol
            prep = Prepared(RunSpec(prep.spec.index, state, where, False, prep.spec.statement,
                                    "kinematic"), prep.built, prep.system, prep.drivers, [], [])
            scene = _scene(prep, sol, slice(sol.n - 1, sol.n), _title(state))
        else:
            scene = _design_scene(state, where)
        if scene is None:
            return
        ctx.picture(f"draw{ctx.draws}.png", where, lambda p: viz.draw_png(scene, 0, p))
    except InputError as exc:
        ctx.notes(f"{where[0]}:{where[1]}: DRAW: the model cannot be drawn yet "
                  f"({printable(str(exc), 200)})")
    except Exception as exc:
        ctx.notes(f"{where[0]}:{where[1]}: DRAW failed ({type(exc).__name__}: "
                  f"{printable(str(exc), 200)})")


def _design_scene(state: State, where: tuple[str, int]) -> Any:
    """A one-step scene of the model at its design (modeling) posture."""
    from openimp.viz import Scene  # type: ignore[import-not-found]

    built = build_model(state, where)
    model = built.model
    g = state.graphics
    links: dict[str, list[np.ndarray]] = {}
    colors: dict[str, str] = {}
    for link, pts in state.polylines:
        pts = [p for p in pts if p in model.points]
        if len(pts) < 2 or link in g.erased or ("*" in g.erased and link not in g.colors):
            continue
        poly = np.stack([model.points[p].xyz for p in pts])[None]
        links.setdefault(link, []).append(poly)
        colors[link] = g.colors.get(link, g.all_color or "WHITE")
    axes = []
    for j, (_, jd, L1, _) in built.joints.items():
        length = g.axes.get(j, g.axes_all)
        if length:
            F = state.links[jd.link1].frame @ L1
            axes.append((j, F[None], float(length)))
    return Scene(links=links, colors=colors, view=g.view, axes=axes, times=np.zeros(1),
                 title=_ascii(_title(state)))


@contextmanager
def _warnings_as_notes(ctx: Context, where: Where, messages: list[str] | None = None
                       ) -> Iterator[None]:
    """Turn the Python warnings raised inside the block (numpy overflow, matplotlib)
    into one located note each, so none reaches the terminal raw."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        finally:
            seen: set[str] = set()
            for w in caught:
                text = f"{w.category.__name__}: {printable(str(w.message), 120)}"
                if text in seen:
                    continue
                seen.add(text)
                note = (f"{where[0]}:{where[1]}: a computation gave a warning ({text}, in "
                        f"{os.path.basename(w.filename)}:{w.lineno})")
                if issubclass(w.category, RuntimeWarning):
                    note += ("; values that are not finite are listed as ????: check the sizes "
                             "of the input numbers")
                ctx.notes(note)
                if messages is not None:
                    messages.append(note)


def _one_run(spec: RunSpec, ctx: Context) -> Run:
    """One EXECUTE; its input errors and unexpected failures become the run's failure,
    Ctrl-C an interrupted run."""
    loc = f"{spec.where[0]}:{spec.where[1]}"
    messages: list[str] = []
    try:
        with _warnings_as_notes(ctx, spec.where, messages):
            run = execute_run(spec, ctx)
    except KeyboardInterrupt:
        run = Run(_title(spec.state), spec.mode, interrupted=True)
        run.failure = f"{loc}: EXECUTE: interrupted by the user (Ctrl-C) before its results"
    except InputError as exc:  # found only now (e.g. a file changed meanwhile)
        run = Run(_title(spec.state), spec.mode)
        run.failure = (str(exc) if exc.where is not None else f"{loc}: EXECUTE: {exc}")
    except Exception as exc:  # one run's bug must not lose the others
        run = Run(_title(spec.state), spec.mode)
        run.failure = (f"{loc}: EXECUTE failed unexpectedly ({type(exc).__name__}: "
                       f"{printable(str(exc), 200)}); please report it")
    else:
        run.messages.extend(messages)
        ctx.stopped = ctx.stopped or run.interrupted
        return run
    ctx.say(f"*** {run.failure} ***")
    if run.interrupted:
        ctx.stopped = True
    return run


def _event(kind: str, payload: Any, ctx: Context, runs: list[Run]) -> None:
    """Carry out one event of the deck (see :class:`~openimp.imp.interp.Interpreter`)."""
    if kind == "text":
        ctx.say(payload)
    elif kind == "run":
        runs.append(_one_run(payload, ctx))
    elif kind == "draw":
        with _warnings_as_notes(ctx, payload[1]):
            _draw(payload[0], payload[1], ctx)
    elif kind == "reset":
        ctx.time0 = 0.0
    elif kind == "print_on":
        if payload is None:
            ctx.print_on = None
        else:
            ctx.print_on = payload[0]
            ctx.file_where.setdefault(payload[0], payload[1])
    elif kind == "store_input":
        name, lines, where = payload
        ctx.files[name] = "\n".join([*lines, "RETURN"]) + "\n"
        ctx.file_where[name] = where


def _write_files(ctx: Context, runs: list[Run], deck_path: str) -> None:
    """Write the STORE, PRINT ON and STORE INPUT files into the output folder."""
    store = format_store(runs)
    if store:
        ctx.files[f"{ctx.deck_stem}_store.txt"] = store
    for name, lines in ctx.print_files.items():
        ctx.files[name] = "\n".join(lines) + "\n"
    for name, text in ctx.files.items():
        where = ctx.file_where.get(name, (deck_path, 0))
        try:
            if ctx.folder.write(name, text, where) is None:
                ctx.problems(ctx.folder.refused[-1])
        except OutputError as exc:
            loc = f"{where[0]}:{where[1]}: " if where[1] > 0 else f"{where[0]}: "
            ctx.problems(f"{loc}{exc}")


def run_deck(deck: Any, out_dir: str | os.PathLike[str] | None = None,
             echo: Callable[[str], None] | None = None,
             progress: Callable[[int, int, int], None] | None = None,
             notes: Callable[[str], None] | None = None,
             overwrite: bool = False,
             problems: Callable[[str], None] | None = None) -> list[Run]:
    """Carry out the events of a deck in order; see :meth:`Deck.run`.

    Files go to ``out_dir`` or, without it, to the deck's folder; a file the
    run did not create is replaced only with ``overwrite``.  ``problems``
    receives one message per file refused or not written (default: ``notes``).
    Ctrl-C, or END evaluated in a VALUE, ends the deck after the current run;
    the files of what was run are still written.
    """
    out = Path(out_dir) if out_dir is not None else None
    base = out if out is not None else (Path(deck.path).parent or Path("."))
    if out is not None:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"the output folder {printable(str(out), 80)} cannot be created "
                              f"({exc.strerror or type(exc).__name__})", str(out)) from None
    say_note = notes or (lambda s: None)
    ctx = Context(out, echo or (lambda s: None), say_note, progress, Path(deck.path).stem,
                  OutputFolder(base, overwrite), problems or say_note)
    runs: list[Run] = []
    for kind, payload in deck.events:
        if ctx.stopped:
            break
        _event(kind, payload, ctx, runs)
    for text in trailing_requests(deck):
        ctx.notes(text)
    with held_interrupt(lambda: ctx.notes("Ctrl-C: the deck's files of what was run are being "
                                          "written; Ctrl-C again abandons them")) as held:
        _write_files(ctx, runs, deck.path)
    if held[0] and runs and not runs[-1].interrupted:
        runs[-1].interrupted = True
        runs[-1].failure = runs[-1].failure or "interrupted by the user (Ctrl-C) while its files "\
            "were written; they are written whole"
    return runs
