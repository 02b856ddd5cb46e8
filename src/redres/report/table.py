"""The comparison table: one row per run, from :meth:`RunLog.summary` dicts."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from html import escape
from typing import Any


@dataclass(frozen=True)
class Column:
    """A table column: summary ``key``, header, unit and number format."""

    key: str
    header: str
    unit: str
    fmt: Callable[[float], str]
    hint: str = ""


def _mm(value: float) -> str:
    return f"{1e3 * value:.3g}"


COLUMNS: tuple[Column, ...] = (
    Column("steps", "steps", "", lambda v: f"{int(v):,}"),
    Column("max_position_error_m", "max position error", "mm", _mm),
    Column("rms_position_error_m", "RMS position error", "mm", _mm),
    Column(
        "min_joint_limit_margin_rad",
        "min joint-limit margin",
        "rad",
        lambda v: f"{v:+.3f}",
        "negative: a joint went past its limit",
    ),
    Column(
        "min_sigma",
        "min σ",
        "",
        lambda v: f"{v:.3g}",
        "smallest singular value of the task Jacobian",
    ),
    Column(
        "peak_speed_ratio",
        "peak speed ratio",
        "",
        lambda v: f"{v:.2f}",
        "max |q̇ᵢ| / q̇_max,i; 1 means the command was scaled to the velocity limits",
    ),
    Column("path_length_rad", "path length", "rad", lambda v: f"{v:.2f}", "Σ ‖Δq‖ over the run"),
    Column("step_time_us_median", "median step time", "µs", lambda v: f"{v:.1f}"),
)


def _cell(column: Column, row: Mapping[str, Any]) -> str:
    value = row.get(column.key)
    if value is None:
        return '<td class="num missing">–</td>'
    css = "num"
    if column.key == "min_joint_limit_margin_rad" and value < 0:
        css += " bad"
    return f'<td class="{css}">{escape(column.fmt(float(value)))}</td>'


def table_html(rows: Sequence[Mapping[str, Any]]) -> str:
    """An HTML ``<table>`` of the summaries (columns :data:`COLUMNS`), escaped.

    Args:
        rows: :meth:`RunLog.summary` dicts (``robot``, ``label`` or ``scheme`` and the
            metric keys; a missing metric shows as a dash).
    """
    head = ["<th>robot</th>", "<th>scheme</th>"]
    for c in COLUMNS:
        unit = f"<br><span class=unit>{escape(c.unit)}</span>" if c.unit else ""
        title = f' title="{escape(c.hint)}"' if c.hint else ""
        head.append(f'<th class="num"{title}>{escape(c.header)}{unit}</th>')
    body = []
    for row in rows:
        label = str(row.get("label") or row.get("scheme", ""))
        scheme = str(row.get("scheme", ""))
        name_title = f' title="scheme {escape(scheme)}"' if scheme and scheme != label else ""
        cells = [
            f"<td>{escape(str(row.get('robot', '')))}</td>",
            f"<td{name_title}>{escape(label)}</td>",
        ]
        cells += [_cell(c, row) for c in COLUMNS]
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (
        '<table class="summary"><thead><tr>'
        + "".join(head)
        + "</tr></thead><tbody>\n"
        + "\n".join(body)
        + "\n</tbody></table>"
    )
