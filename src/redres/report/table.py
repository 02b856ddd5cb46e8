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
    optional: bool = False  # shown only when a row has it


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
    Column(
        "min_obstacle_clearance_m",
        "min obstacle clearance",
        "mm",
        _mm,
        "smallest distance between the link capsules and any obstacle over the run; "
        "negative: they overlapped",
        optional=True,
    ),
    Column(
        "min_self_clearance_m",
        "min self clearance",
        "mm",
        _mm,
        "smallest distance between two link capsules the collision constraint pairs over the "
        "run; negative: the arm went into itself",
        optional=True,
    ),
    Column(
        "collision_binding_steps",
        "collision-bound steps",
        "",
        lambda v: f"{int(v):,}",
        "steps where a collision row bound the velocity (the task yielded there)",
        optional=True,
    ),
    Column("path_length_rad", "path length", "rad", lambda v: f"{v:.2f}", "Σ ‖Δq‖ over the run"),
    Column("step_time_us_median", "median step time", "µs", lambda v: f"{v:.1f}"),
)


def _cell(column: Column, row: Mapping[str, Any]) -> str:
    value = row.get(column.key)
    if value is None:
        return '<td class="num missing">–</td>'
    css = "num"
    if column.key in ("min_joint_limit_margin_rad", "min_obstacle_clearance_m",
                      "min_self_clearance_m") and value < 0:  # fmt: skip
        css += " bad"
    return f'<td class="{css}">{escape(column.fmt(float(value)))}</td>'


def table_html(rows: Sequence[Mapping[str, Any]]) -> str:
    """An HTML ``<table>`` of the summaries (columns :data:`COLUMNS`, an optional one only
    when a row has it), escaped, followed by a list of the runs' warnings.

    Args:
        rows: :meth:`RunLog.summary` dicts (``robot``, ``label`` or ``scheme`` and the
            metric keys; a missing metric shows as a dash).
    """
    columns = [c for c in COLUMNS if not c.optional or any(c.key in r for r in rows)]
    head = ["<th>robot</th>", "<th>scheme</th>"]
    for c in columns:
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
        cells += [_cell(c, row) for c in columns]
        body.append("<tr>" + "".join(cells) + "</tr>")
    return (
        '<table class="summary"><thead><tr>'
        + "".join(head)
        + "</tr></thead><tbody>\n"
        + "\n".join(body)
        + "\n</tbody></table>"
        + _warnings_html(rows)
    )


def _warnings_html(rows: Sequence[Mapping[str, Any]]) -> str:
    """The runs' warnings (``summary["warnings"]``) as a list under the table."""
    items = [
        f"<li><b>{escape(str(r.get('robot', '')))} · "
        f"{escape(str(r.get('label') or r.get('scheme', '')))}</b>: "
        f"{escape(str(w.get('message', '')))}</li>"
        for r in rows
        for w in r.get("warnings", ()) or ()
        if isinstance(w, Mapping)
    ]
    return f'<ul class="warnings">{"".join(items)}</ul>' if items else ""
