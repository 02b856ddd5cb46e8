"""The report's section "Against the global optimum": each scheme's value of an objective
next to the optimum that dynamic programming finds on the same path
(:func:`redres.scenarios.planned.compare_with_plan`; Ferrentino, Salvioli & Chiacchio,
Robotics 10(1):42, 2021): a sentence and a table row per scheme, and one bar chart of the
values with the optimum drawn across them.
"""

from __future__ import annotations

import base64
import math
from collections.abc import Mapping, Sequence
from html import escape
from typing import TYPE_CHECKING

from ._deps import require
from .plots import DPI, png_bytes

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..scenarios.planned import PlanComparison

__all__ = ["comparison_figure", "comparison_section"]

#: Bar colour of a scheme whose value is below 0 (a limit passed, an obstacle touched).
_BELOW = "#c0392b"


def comparison_figure(found: PlanComparison, colours: Mapping[str, str]) -> Figure:
    """Horizontal bars: each scheme's value of the objective (in the runs' colours), the
    optimum as a dashed line, each bar labelled with its share of the optimum."""
    from ..scenarios.planned import COMPARED

    figure_module = require("matplotlib.figure")
    rows = found.rows
    height = 1.1 + 0.34 * max(len(rows), 1)
    fig: Figure = figure_module.Figure(figsize=(9.0, height), dpi=DPI)
    ax = fig.add_axes((0.36, 0.55 / height, 0.56, 1 - 1.05 / height))
    names = [r.scheme for r in rows]
    values = [r.value if math.isfinite(r.value) else 0.0 for r in rows]
    colour = [colours.get(n, "#777777") if v >= 0 else _BELOW for n, v in zip(names, values)]
    ax.barh(range(len(rows)), values, color=colour, height=0.65)
    ax.set_yticks(range(len(rows)), names, fontsize=8)
    ax.invert_yaxis()
    ax.axvline(0.0, color="#444444", lw=0.8)
    measure = COMPARED[found.objective][0]
    if math.isfinite(found.optimum):
        ax.axvline(found.optimum, color="black", ls="--", lw=1.2)
        for i, r in enumerate(rows):
            if math.isfinite(r.percent):
                ax.annotate(f"{r.percent:.0f} %", (values[i], i), xytext=(3, 0), fontsize=7,
                            textcoords="offset points", va="center")  # fmt: skip
        title = f"{found.scenario}: {measure} against the global optimum {found.optimum:.3f}"
    else:
        title = f"{found.scenario}: {measure} (no admissible path for the global plan)"
    ax.set_xlabel(f"{measure} ({found.unit}); dashed: the optimum (dynamic programming)")
    fig.suptitle(f"{title} {found.unit}", fontsize=10, y=1 - 0.1 / height, va="top")
    return fig


def comparison_section(
    comparisons: Sequence[PlanComparison], colours: Mapping[str, str]
) -> tuple[str, dict[str, bytes]]:
    """The section's HTML (escaped) and its PNG files ``{name: bytes}`` (one per
    scenario); empty without comparisons."""
    if not comparisons:
        return "", {}
    from ..scenarios.planned import COMPARED

    parts, files = [], {}
    for found in comparisons:
        png = png_bytes(comparison_figure(found, colours))
        name = f"global-plan-{_slug(found.scenario)}.png"
        files[name] = png
        stats = found.plan.stats
        measure = COMPARED[found.objective][0]
        head = (
            f"<h3>{escape(found.scenario)}</h3><p>Global plan: {escape(measure)} "
            f"{found.optimum:.4f} {escape(found.unit)} over {stats.nodes:,} grid nodes "
            f"({stats.feasible_nodes:,} feasible, {stats.components} component(s) from start "
            f"to end; {escape(found.plan.parameter)} at {found.plan.grid.shape[1]} values, "
            f"dt {found.plan.dt:g} s).</p>"
        )
        items = "".join(f"<li>{escape(line)}</li>" for line in found.lines())
        body = "".join(
            f"<tr><td>{escape(r.scheme)}</td><td>{r.value:+.4f}</td><td>{r.percent:.1f}</td></tr>"
            for r in found.rows
        )
        table = (
            f'<table class="summary plan-comparison"><thead><tr><th>scheme</th>'
            f"<th>{escape(measure)} ({escape(found.unit)})</th><th>% of the optimum</th>"
            f"</tr></thead><tbody><tr><td>global plan (DP)</td><td>{found.optimum:+.4f}</td>"
            f"<td>100.0</td></tr>{body}</tbody></table>"
        )
        data = base64.b64encode(png).decode("ascii")
        figure = (
            f'<figure class="wide"><img alt="{escape(found.scenario)}: the schemes against '
            f'the global optimum" src="data:image/png;base64,{data}"><figcaption>'
            f"{escape(measure)} of each scheme against the optimum · {escape(name)}"
            f"</figcaption></figure>"
        )
        parts.append(f"{head}<ul>{items}</ul>{table}{figure}")
    intro = (
        "<p>Each scheme is local: it picks the joint velocity from the present state. The "
        "global plan is the best joint path along the same tool path from the same start, "
        "found by dynamic programming over the self-motion (Ferrentino, Salvioli &amp; "
        "Chiacchio, Robotics 10(1):42, 2021). It is optimal over its grid: a scheme can pass "
        "it only by what the grid leaves out, or by leaving the path.</p>"
    )
    return (
        f'<section id="global-plan"><h2>Against the global optimum</h2>{intro}'
        f"{''.join(parts)}</section>",
        files,
    )


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name).strip("._") or "plan"
