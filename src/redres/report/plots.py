"""Matplotlib figures comparing the runs of one robot (Agg, no display needed).

Each function draws one figure for one robot, one curve per run, in the colours the
report gives the runs; long series are thinned by :func:`~redres.report.series.
envelope_indices` so single-step spikes still show. Figures are built on
``matplotlib.figure.Figure`` directly, never through ``pyplot``, so no global state or
display backend is touched.
"""

from __future__ import annotations

import io
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray
from ._deps import require
from .series import envelope_indices

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..control import RunLog
    from ..robot import Robot

DPI = 100
LIMIT_SHADE = "#f4c7c3"
PLOT_TITLES = {
    "joints": "Joint positions against their limits",
    "position_error": "Task position error",
    "sigma_min": "Smallest singular value of the task Jacobian",
    "objectives": "Secondary objectives",
}


def run_name(log: RunLog) -> str:
    """The name of a run in legends and tables: its label, else its scheme."""
    return log.label or log.scheme


def palette(names: Sequence[str]) -> dict[str, str]:
    """A colour (``#rrggbb``) per distinct name, in order of first appearance (tab10)."""
    colors = require("matplotlib.colors")
    cmap = require("matplotlib").colormaps["tab10"]
    return {name: colors.to_hex(cmap(i % 10)) for i, name in enumerate(dict.fromkeys(names))}


#: Legend text: inches per character at 9 pt (a generous mean), and per entry's handle.
_CHAR_IN, _ENTRY_IN = 0.068, 0.55


def legend_grid(labels: Sequence[str], width: float) -> tuple[int, int]:
    """Columns and rows of a legend of ``labels`` that fits ``width`` inches."""
    if not labels:
        return 1, 0
    column = _ENTRY_IN + _CHAR_IN * max(len(label) for label in labels)
    ncols = int(max(1, min(len(labels), (width - 0.4) // column)))
    return ncols, -(-len(labels) // ncols)


def _figure(
    width: float,
    panels: int,
    max_cols: int,
    *,
    row_height: float,
    left: float,
    legend: Sequence[str] = (),
) -> tuple[Figure, Any]:
    """A figure of ``panels`` axes in rows of at most ``max_cols`` (the unused ones of the
    last row hidden), with a fixed layout, margins in inches: room for the title and the
    legend of ``legend`` (as many rows as it needs) on top, tick labels left and below. (A
    fixed layout draws ~2.5x faster than the constrained one, which dominates the report's
    run time.)"""
    figure_module = require("matplotlib.figure")
    ncols = min(max_cols, panels)
    nrows = -(-panels // ncols)
    top, bottom = 0.65 + 0.2 * max(legend_grid(legend, width)[1], 1), 0.5
    height = top + bottom + row_height * nrows
    fig: Figure = figure_module.Figure(figsize=(width, height), dpi=DPI)
    axes = fig.subplots(nrows, ncols, sharex=True, squeeze=False)
    fig.subplots_adjust(
        left=left / width,
        right=1 - 0.2 / width,
        top=1 - top / height,
        bottom=bottom / height,
        hspace=0.45 if nrows > 1 else 0.2,
        wspace=0.22,
    )
    for ax in axes.reshape(-1)[panels:]:
        ax.set_visible(False)
    return fig, axes.reshape(-1)


def _curve(
    ax: Axes,
    log: RunLog,
    y: FloatArray,
    colours: Mapping[str, str],
    max_points: int,
    *,
    positive: bool = False,
) -> None:
    """One run's curve ``y(log.t)``, thinned, in the run's colour and named after it."""
    idx = envelope_indices(y, max_points)
    values = y[idx]
    if positive:  # log axes: leave out exact zeros instead of drawing them at -inf
        values = np.where(values > 0, values, np.nan)
    marker = "o" if idx.size < 3 else None  # a one-step run is a point, not a line
    name = run_name(log)
    # Earlier runs wider, so that a later run drawn over an identical one leaves it visible.
    order = list(colours)
    rank, count = order.index(name), len(order)
    width = 1.2 + 2.0 * (count - 1 - rank) / max(count - 1, 1)
    ax.plot(log.t[idx], values, color=colours[name], lw=width, label=name, marker=marker, ms=3)


def _title(fig: Figure, text: str, handles: Sequence[Any], labels: Sequence[str]) -> None:
    height = fig.get_figheight()
    fig.suptitle(text, fontsize=11, y=1 - 0.08 / height, va="top")
    fig.legend(
        handles,
        labels,
        loc="upper center",
        bbox_to_anchor=(0.5, 1 - 0.34 / height),
        ncols=legend_grid(labels, fig.get_figwidth())[0],
        frameon=False,
        fontsize=9,
        handlelength=1.6,
        columnspacing=1.2,
        borderaxespad=0.0,
    )


def joints_figure(
    robot: Robot, logs: Sequence[RunLog], colours: Mapping[str, str], max_points: int = 2000
) -> Figure:
    """One panel per joint: ``q_i(t)`` of every run, limits dashed, outside shaded.

    Args:
        robot: gives ``q_min``, ``q_max`` (rad or m) and the joint names.
        logs: runs of this robot, each with ``q`` of shape ``(K, n)``.
        colours: colour of each run name.
        max_points: at most this many samples per curve.
    """
    n = robot.n
    legend = list(dict.fromkeys(run_name(log) for log in logs))
    fig, axes = _figure(12.0, n, 4, row_height=1.9, left=0.55, legend=legend)
    for j, ax in enumerate(axes[:n]):
        for log in logs:
            _curve(ax, log, log.q[:, j], colours, max_points)
        _draw_limits(ax, float(robot.q_min[j]), float(robot.q_max[j]))
        ax.set_title(f"{j + 1}: {robot.joint_names[j]}", fontsize=9)
        ax.tick_params(which="both", labelsize=8)
        ax.grid(alpha=0.3)
    for ax in axes[-min(4, n) :]:  # the bottom row
        ax.set_xlabel("t (s)", fontsize=9)
    _title(
        fig, f"{robot.name}: joint positions (rad) and limits", *axes[0].get_legend_handles_labels()
    )
    return fig


def _draw_limits(ax: Axes, low: float, high: float) -> None:
    y0, y1 = ax.get_ylim()
    bounds = [v for v in (low, high) if np.isfinite(v)]
    lo, hi = min([y0, *bounds]), max([y1, *bounds])
    pad = 0.06 * (hi - lo) if hi > lo else 0.1
    lo, hi = lo - pad, hi + pad
    for value in bounds:
        ax.axhline(value, color="0.25", lw=0.9, ls="--")
    if np.isfinite(high):
        ax.axhspan(high, hi, color=LIMIT_SHADE, lw=0, zorder=0)
    if np.isfinite(low):
        ax.axhspan(lo, low, color=LIMIT_SHADE, lw=0, zorder=0)
    ax.set_ylim(lo, hi)


#: The one-panel time series: kind -> (the plotted values of a run, title, y label).
_SERIES: dict[str, tuple[Callable[[RunLog], FloatArray], str, str]] = {
    "position_error": (
        lambda log: 1e3 * log.position_error,
        "task position error",
        "‖p_d − p‖ (mm)",
    ),
    "sigma_min": (lambda log: log.sigma_min, "smallest singular value σ_min", "σ_min of J"),
}


def _time_series_figure(
    kind: str, robot_name: str, logs: Sequence[RunLog], colours: Mapping[str, str], max_points: int
) -> Figure:
    series, title, ylabel = _SERIES[kind]
    legend = list(dict.fromkeys(run_name(log) for log in logs))
    fig, (ax,) = _figure(6.0, 1, 1, row_height=2.45, left=0.75, legend=legend)
    for log in logs:
        _curve(ax, log, series(log), colours, max_points, positive=True)
    _log_axis(ax)
    ax.set_xlabel("t (s)", fontsize=9)
    ax.set_ylabel(ylabel, fontsize=9)
    ax.tick_params(which="both", labelsize=8)
    ax.grid(alpha=0.3, which="both")
    _title(fig, f"{robot_name}: {title}", *ax.get_legend_handles_labels())
    return fig


def _log_axis(ax: Axes) -> None:
    """Log scale with short plain labels (``0.006``, ``1e-05``); minor ticks labelled only
    when the axis spans less than about a decade and a half."""
    ticker = require("matplotlib.ticker")
    ax.set_yscale("log")
    plain = ticker.FuncFormatter(lambda value, _: f"{value:.3g}")
    ax.yaxis.set_major_formatter(plain)
    low, high = ax.get_ylim()
    few_decades = low > 0 and np.log10(high / low) < 1.5
    ax.yaxis.set_minor_formatter(plain if few_decades else ticker.NullFormatter())


def position_error_figure(
    robot_name: str, logs: Sequence[RunLog], colours: Mapping[str, str], max_points: int = 2000
) -> Figure:
    """``‖p_d − p‖`` over time, mm, log scale (exact zeros are left out)."""
    return _time_series_figure("position_error", robot_name, logs, colours, max_points)


def sigma_min_figure(
    robot_name: str, logs: Sequence[RunLog], colours: Mapping[str, str], max_points: int = 2000
) -> Figure:
    """Smallest singular value of the task Jacobian over time, log scale."""
    return _time_series_figure("sigma_min", robot_name, logs, colours, max_points)


def objectives_figure(
    robot_name: str, logs: Sequence[RunLog], colours: Mapping[str, str], max_points: int = 2000
) -> Figure | None:
    """One panel per logged objective (costs ``D(q)``), each run that logged it a curve;
    ``None`` when no run logged any."""
    names = list(dict.fromkeys(name for log in logs for name in log.objectives))
    if not names:
        return None
    legend = list(dict.fromkeys(run_name(log) for log in logs if log.objectives))
    fig, axes = _figure(12.0, len(names), 3, row_height=2.3, left=0.6, legend=legend)
    for ax, name in zip(axes, names):
        for log in logs:
            if name in log.objectives:
                values = np.asarray(log.objectives[name], dtype=float)
                _curve(ax, log, values, colours, max_points)
        ax.set_title(name.replace("_", " "), fontsize=9)
        ax.set_xlabel("t (s)", fontsize=9)
        ax.tick_params(which="both", labelsize=8)
        ax.grid(alpha=0.3)
    handles: dict[str, Any] = {}
    for ax in axes[: len(names)]:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, handle)
    title = f"{robot_name}: secondary objectives (costs, lower is better)"
    _title(fig, title, list(handles.values()), list(handles))
    return fig


def png_bytes(fig: Figure) -> bytes:
    """The figure as PNG bytes."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def robot_figures(
    robot: Robot, logs: Sequence[RunLog], colours: Mapping[str, str], *, max_points: int = 2000
) -> dict[str, bytes]:
    """Every figure of one robot as PNG bytes, keyed by kind (see :data:`PLOT_TITLES`);
    ``objectives`` is absent when no run logged an objective."""
    figures = {
        "joints": joints_figure(robot, logs, colours, max_points),
        "position_error": position_error_figure(robot.name, logs, colours, max_points),
        "sigma_min": sigma_min_figure(robot.name, logs, colours, max_points),
        "objectives": objectives_figure(robot.name, logs, colours, max_points),
    }
    return {kind: png_bytes(fig) for kind, fig in figures.items() if fig is not None}
