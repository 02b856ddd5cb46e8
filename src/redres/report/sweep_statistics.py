"""The report view of a scheme-statistics sweep: its table and plots.

Per scheme (:func:`redres.sweeps.kinds.schemes.summary`): success rate, share of paths with a
joint-limit violation, RMS tracking error, share of paths with singular steps and time per
control step. The table uses the run report's styles; the plots are one matplotlib
figure (PNG, the run report's palette): bars of the three shares, the distribution of
the paths' RMS tracking errors (box per scheme, log scale, mm) and of their median step
times (µs).
"""

from __future__ import annotations

from html import escape
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..sweeps.kinds.schemes import summary
from ..sweeps.results import load
from ._deps import require
from .page import Section, png_html
from .plots import DPI, palette, png_bytes

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["statistics_figure", "statistics_section", "statistics_table_html"]

#: The table's columns: summary key, header, unit, format.
_COLUMNS = (
    ("success_pct", "success", "%", "{:.1f}"),
    ("violating_pct", "paths with a limit violation", "%", "{:.1f}"),
    ("violation_steps", "violating steps per path", "", "{:.1f}"),
    ("rms_error_median_m", "RMS tracking error (median)", "mm", "{:.3g}"),
    ("rms_error_max_m", "RMS tracking error (worst)", "mm", "{:.3g}"),
    ("singular_pct", "paths with singular steps", "%", "{:.1f}"),
    ("step_us_median", "time per step (median)", "µs", "{:.1f}"),
)


def statistics_table_html(rows: list[dict[str, Any]]) -> str:
    """The :func:`~redres.sweeps.kinds.schemes.summary` rows as the report's table (escaped)."""
    head = "<th>scheme</th><th class=num>paths</th>" + "".join(
        f'<th class="num">{escape(h)}<br><span class=unit>{escape(u)}</span></th>'
        for _, h, u, _ in _COLUMNS
    )
    body = []
    for r in rows:
        cells = [f"<td>{escape(r['scheme'])}</td>", f'<td class="num">{r["paths"]}</td>']
        for key, _, unit, fmt in _COLUMNS:
            value = 1e3 * r[key] if unit == "mm" else r[key]
            bad = " bad" if key == "violating_pct" and value > 0 else ""
            cells.append(f'<td class="num{bad}">{escape(fmt.format(value))}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (f'<table class="summary"><thead><tr>{head}</tr></thead><tbody>'
            + "\n".join(body) + "</tbody></table>")  # fmt: skip


def statistics_figure(out: str | Path) -> Figure:
    """The plots of the scheme-statistics sweep in ``out`` (module docstring)."""
    data, rows = load(out), summary(out)
    labels = [r["scheme"] for r in rows]
    colours = palette(labels)
    fig: Figure = require("matplotlib.figure").Figure(figsize=(12.0, 6.4), dpi=DPI)
    axes = fig.subplots(2, 3).reshape(-1)
    fig.subplots_adjust(left=0.07, right=0.98, top=0.9, bottom=0.2, hspace=0.75, wspace=0.3)
    x = np.arange(len(labels))
    bars = (("success_pct", "success (%)"), ("violating_pct", "paths with a limit violation (%)"),
            ("singular_pct", "paths with singular steps (%)"))  # fmt: skip
    for ax, (key, title) in zip(axes[:3], bars):
        ax.bar(x, [r[key] for r in rows], color=[colours[n] for n in labels])
        ax.set_ylim(0, 105)
        ax.set_title(title, fontsize=10)
    boxes = (("rms_error", 1e3, "RMS tracking error per path (mm)", True),
             ("step_us", 1.0, "time per step, median of a path (µs)", False))  # fmt: skip
    for ax, (field, scale, title, log) in zip(axes[3:5], boxes):
        values = [scale * data[field][:, s] for s in range(len(labels))]
        values = [v[np.isfinite(v) & ((v > 0) if log else True)] for v in values]
        ax.boxplot([v if v.size else np.array([np.nan]) for v in values], positions=x,
                   widths=0.6)  # fmt: skip
        if log and any(v.size for v in values):
            ax.set_yscale("log")
        ax.set_title(title, fontsize=10)
    for ax in axes[:5]:
        ax.set_xticks(x, labels, rotation=30, ha="right", fontsize=8)
        ax.tick_params(axis="y", labelsize=8)
        ax.grid(alpha=0.3, axis="y")
    axes[5].set_visible(False)
    fig.suptitle(f"scheme statistics {data.name}: {len(data['shape'])} random paths", fontsize=11)
    return fig


def statistics_section(out: str | Path) -> Section:
    """The section of the page for the scheme-statistics sweep in ``out``."""
    data, rows = load(out), summary(out)
    circles = int((data["shape"] == 0).sum())
    intro = (
        f"{len(data['shape'])} random paths ({circles} circles, "
        f"{len(data['shape']) - circles} lines) run by each scheme of the scenario. "
        "Success: the run finished with its largest position error within the spec's "
        "success_tol; a limit violation: a step with a joint beyond its position limit; "
        "singular: a step whose task Jacobian's smallest singular value was below "
        "singular_sigma."
    )
    png = png_bytes(statistics_figure(out))
    caption = ("per scheme: shares of the paths, and the distributions of tracking error "
               "and step time (boxes: quartiles)")  # fmt: skip
    plots = png_html(png, "scheme statistics plots", caption)
    return Section("Scheme statistics", intro, statistics_table_html(rows) + plots)
