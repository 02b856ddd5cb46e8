"""``write_report``: plots, 3D views and the page, written atomically."""

from __future__ import annotations

import os
import re
import shutil
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InvalidParameterError, ShapeError, describe_os_error, shown_path
from . import global_plan, html, plots, view3d
from ._deps import check_report_dependencies, require
from .table import table_html

if TYPE_CHECKING:
    from ..control import RunLog
    from ..objectives import Obstacle
    from ..robot import Robot
    from ..scenarios.planned import PlanComparison

#: A run of the report: ``(robot, log)``, or ``(robot, log, obstacles)`` to draw them.
Run = tuple["Robot", "RunLog"] | tuple["Robot", "RunLog", Sequence["Obstacle"]]

PAGE = "report.html"
#: The file that marks a folder as a redres report (a later report may replace its files).
MARKER = ".redres-report"
#: Prefix of the staging folders inside a report folder.
STAGING = ".redres-staging-"
_MARKER_TEXT = "This folder holds a report written by redres; a later report replaces its files.\n"


def _check_options(
    table: Sequence[Mapping[str, Any]] | None, frames: int, max_points: int
) -> list[Mapping[str, Any]] | None:
    if frames < 2:
        raise InvalidParameterError(f"frames must be at least 2; got {frames}")
    if max_points < 4:
        raise InvalidParameterError(f"max_points must be at least 4; got {max_points}")
    if table is None:
        return None
    rows = list(table)
    for i, row in enumerate(rows):
        if not isinstance(row, Mapping):
            raise InvalidParameterError(
                f"table[{i}] must be a mapping such as RunLog.summary(); got {type(row).__name__}"
            )
    return rows


def _check_runs(runs: Sequence[Run]) -> list[tuple[Robot, RunLog, tuple[Obstacle, ...]]]:
    from ..collision import OBSTACLE_TYPES

    pairs = []
    for i, pair in enumerate(runs):
        if not isinstance(pair, tuple) or len(pair) not in (2, 3):
            raise InvalidParameterError(
                f"runs[{i}] must be a (robot, log) pair or a (robot, log, obstacles) triple; "
                f"got {pair!r}"
            )
        robot, log = pair[0], pair[1]
        obstacles = tuple(pair[2]) if len(pair) == 3 else ()  # type: ignore[misc]
        for obs in obstacles:
            if not isinstance(obs, OBSTACLE_TYPES):
                raise InvalidParameterError(
                    f"runs[{i}]: obstacles must be SphereObstacle, CapsuleObstacle, BoxObstacle "
                    f"or PlaneObstacle; got {obs!r}"
                )
        pairs.append((robot, log, obstacles))
    if not pairs:
        raise InvalidParameterError("runs is empty: give at least one (robot, log) pair")
    for i, (robot, log, _) in enumerate(pairs):
        if log.steps < 1:
            raise InvalidParameterError(f"runs[{i}] ({log.robot} {log.scheme}) has no steps")
        if log.robot != robot.name:
            raise InvalidParameterError(
                f"runs[{i}]: the log was recorded on {log.robot!r} but is paired with robot "
                f"{robot.name!r}"
            )
        if log.q.shape != (log.steps, robot.n):
            raise ShapeError(
                f"runs[{i}]: log.q has shape {log.q.shape}; expected ({log.steps}, {robot.n}) "
                f"for {robot.name}"
            )
    return pairs


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "robot"


def _write_plots(
    staging: Path,
    pairs: Sequence[tuple[Robot, RunLog, Any]],
    colours: Mapping[str, str],
    max_points: int,
) -> list[html.RobotPlots]:
    by_robot: dict[str, tuple[Robot, list[RunLog]]] = {}
    for robot, log, _ in pairs:
        by_robot.setdefault(robot.name, (robot, []))[1].append(log)
    out = []
    for name, (robot, logs) in by_robot.items():
        pngs = plots.robot_figures(robot, logs, colours, max_points=max_points)
        files = {kind: f"{_slug(name)}-{kind.replace('_', '-')}.png" for kind in pngs}
        for kind, data in pngs.items():
            (staging / files[kind]).write_bytes(data)
        out.append(html.RobotPlots(name, pngs, files))
    return out


def _build(
    staging: Path,
    pairs: Sequence[tuple[Robot, RunLog, tuple[Obstacle, ...]]],
    rows: list[Mapping[str, Any]] | None,
    title: str,
    description: str,
    frames: int,
    max_points: int,
    comparisons: Sequence[PlanComparison] = (),
) -> None:
    """Write every file of the report into ``staging``."""
    from .._version import __version__
    from ..scenarios.runner import summarise

    colours = plots.palette([plots.run_name(log) for _, log, _ in pairs])
    robot_plots = _write_plots(staging, pairs, colours, max_points)
    against_plan, pngs = global_plan.comparison_section(comparisons, colours)
    for name, data in pngs.items():
        (staging / name).write_bytes(data)
    views = []
    for robot, log, obstacles in pairs:
        anim = view3d.arm_animation(robot, log, frames=frames, obstacles=obstacles)
        figure = view3d.animation_figure(anim, colours[plots.run_name(log)])
        views.append((robot.name, anim.label, figure))
    page = html.render_page(
        title=title,
        description=description,
        table=table_html(rows if rows is not None else [summarise(r, log) for r, log, _ in pairs]),
        views=views,
        plots=robot_plots,
        plotly_js=require("plotly.offline").get_plotlyjs(),
        version=__version__,
        against_plan=against_plan,
    )
    (staging / PAGE).write_text(page, encoding="utf-8")


def check_out_dir(out_dir: str | os.PathLike[str], *, force: bool = False) -> Path:
    """The report folder, resolved, if writing a report into it cannot replace a user's
    files: it does not exist yet, is empty, or holds an earlier redres report (the
    :data:`MARKER` file); ``force=True`` writes into any folder (files of other names are
    kept, files named like the report's are replaced).

    Raises:
        InvalidParameterError: an empty name (it would write into the current folder), a
            path that is a file or lies under one, a folder that cannot be written (read-only,
            ``/proc``, a name too long), a folder named ``report.html`` inside it, or a
            folder holding other files without ``force``.
    """
    if not str(out_dir).strip():
        raise InvalidParameterError(
            "the report folder is empty; give one (--out FOLDER), e.g. redres-report"
        )
    target = Path(out_dir).resolve()
    if target.exists() and not target.is_dir():
        raise InvalidParameterError(
            f"the report folder {shown_path(target)} is a file, not a directory; choose a "
            "folder (--out)"
        )
    _check_writable(target)
    if (target / PAGE).is_dir() or (target / MARKER).is_dir():
        raise InvalidParameterError(
            f"{shown_path(target / PAGE)} is a folder, where the report's page goes; rename "
            "or remove it, or choose another folder (--out)"
        )
    if target.is_dir() and not force and not _holds_report(target):
        theirs = sorted(p.name for p in target.iterdir() if not p.name.startswith(STAGING))
        if theirs:
            shown = ", ".join(theirs[:3]) + (", ..." if len(theirs) > 3 else "")
            raise InvalidParameterError(
                f"{str(target)!r} holds files that are not a redres report ({shown}); "
                f"write into a new or empty folder, or pass force=True (--force) to add the "
                f"report's files to it"
            )
    return target


def _check_writable(target: Path) -> None:
    """Create and remove a staging folder where the report will go (``target``, else its
    nearest existing parent), so that a folder that cannot be written is refused before
    anything runs.

    Raises:
        InvalidParameterError: one line naming the folder, the reason and the fix.
    """
    parent = target
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise InvalidParameterError(
            f"cannot create the report folder {shown_path(target)}: {shown_path(parent)} is "
            "a file; choose another folder (--out)"
        )
    try:
        os.rmdir(tempfile.mkdtemp(prefix=STAGING, dir=parent))
    except OSError as exc:
        exc.filename = str(target)
        raise InvalidParameterError(
            f"cannot write the report folder: {describe_os_error(exc)} (--out)"
        ) from None


def _holds_report(folder: Path) -> bool:
    """Whether ``folder`` holds a report redres wrote: the marker, or (reports written
    before the marker existed) a page whose head names redres as its generator."""
    if (folder / MARKER).exists():
        return True
    try:
        with (folder / PAGE).open("rb") as page:
            return b'<meta name="generator" content="redres ' in page.read(4096)
    except OSError:
        return False


def _clean_stale_staging(target: Path) -> None:
    """Remove staging folders that killed runs left in ``target`` (older than an hour: a
    report is staged for seconds, so a running writer's folder is never that old)."""
    now = time.time()
    for stale in target.glob(STAGING + "*"):
        try:
            if stale.is_dir() and now - stale.stat().st_mtime > 3600.0:
                shutil.rmtree(stale, ignore_errors=True)
        except OSError:  # gone meanwhile
            pass


def write_report(
    out_dir: str | os.PathLike[str],
    runs: Sequence[Run],
    *,
    title: str,
    description: str = "",
    table: Sequence[Mapping[str, Any]] | None = None,
    frames: int = 80,
    max_points: int = 2000,
    force: bool = False,
    comparisons: Sequence[PlanComparison] = (),
) -> Path:
    """Write a report of several runs: PNG plots per robot and one self-contained page.

    Everything is built in a staging folder inside ``out_dir`` and moved into place only
    when complete (one rename per file, the page last), so a failure leaves ``out_dir`` as
    it was. A user's own files are never replaced: ``out_dir`` must be new, empty, or an
    earlier redres report (:func:`check_out_dir`), unless ``force``.

    Args:
        out_dir: directory to write (created if needed; other files in it are kept).
        force: write into a folder that holds other files too.
        runs: ``(robot, log)`` pairs, any mix of robots and schemes, or ``(robot, log,
            obstacles)`` triples whose 3D view also draws the obstacles (spheres, points,
            capsules) and the closest arm–obstacle pair; a run is named by ``log.label``
            (else ``log.scheme``).
        title: page title.
        description: plain-text introduction (blank lines separate paragraphs).
        table: summary rows for the comparison table (``RunLog.summary()`` dicts; default:
            :func:`redres.scenarios.runner.summarise` of each run).
        frames: animation frames per run in the 3D view (≥ 2).
        max_points: at most this many samples per plotted curve (≥ 4).
        comparisons: the runs against the global plan of their path
            (:func:`redres.scenarios.planned.compare_with_plan`): a section "Against the
            global optimum" with a sentence, a table row and a bar per scheme.

    Returns:
        Path of ``report.html`` in ``out_dir``.

    Raises:
        MissingDependencyError: matplotlib or plotly is missing (the ``report`` extra).
        InvalidParameterError: no runs, a log without steps or paired with another robot,
            ``out_dir`` is a file or holds files that are not a report (without
            ``force``), a table row that is not a mapping, ``frames < 2`` or
            ``max_points < 4``.
        ShapeError: a log's joint positions do not match its robot.
    """
    check_report_dependencies()
    pairs = _check_runs(runs)
    rows = _check_options(table, frames, max_points)
    target = check_out_dir(out_dir, force=force)
    created = not target.exists()
    target.mkdir(parents=True, exist_ok=True)
    _clean_stale_staging(target)
    staging = Path(tempfile.mkdtemp(prefix=STAGING, dir=target))
    try:
        _build(staging, pairs, rows, title, description, frames, max_points, comparisons)
        (staging / MARKER).write_text(_MARKER_TEXT, encoding="utf-8")
        in_the_way = [target / p.name for p in staging.iterdir() if (target / p.name).is_dir()]
        if in_the_way:
            raise InvalidParameterError(
                f"{shown_path(in_the_way[0])} is a folder, where a file of the report goes; "
                "rename or remove it, or choose another folder (--out)"
            )
        for path in sorted(staging.iterdir(), key=lambda p: (p.name == PAGE, p.name)):
            os.replace(path, target / path.name)  # one rename per file, the page last
        created = False
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        if created:  # a failed first report leaves no folder behind
            shutil.rmtree(target, ignore_errors=True)
    return target / PAGE
