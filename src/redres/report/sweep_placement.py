"""The report view of a base-placement sweep: the best bases and a floor plot.

The table lists the best candidates of :func:`redres.sweeps.kinds.placement.ranking` (task
poses reached, then the mean reachability index of their voxels). The floor plot shows,
at each candidate floor position, its best yaw's (by the same order) poses reached and
score (Zacharias et al. 2008's reachability score, percent) as two heatmaps, the best
base marked.
"""

from __future__ import annotations

import math
from html import escape
from pathlib import Path
from typing import Any

import numpy as np

from ..sweeps.kinds.placement import ranking
from ..sweeps.results import load
from .page import Section, figure_html

__all__ = ["floor_figure", "placement_section", "ranking_table_html"]


def ranking_table_html(out: str | Path, top: int = 10) -> str:
    """The ``top`` best bases of the base-placement sweep in ``out`` as a table."""
    r = ranking(out)
    poses = int(load(out)["reachable"].shape[1])
    rows = []
    for k in range(min(top, len(r["count"]))):
        x, y, yaw = r["bases"][k]
        cells = [str(k + 1), f"{x:+.3f}", f"{y:+.3f}", f"{math.degrees(yaw):.1f}",
                 f"{int(r['count'][k])} / {poses}", f"{r['score'][k]:.1f}"]  # fmt: skip
        rows.append("<tr>" + "".join(f'<td class="num">{escape(c)}</td>' for c in cells) + "</tr>")
    columns = (("rank", ""), ("x", "m"), ("y", "m"), ("yaw", "deg"),
               ("task poses reached", ""), ("score", "%"))  # fmt: skip
    head = "".join(
        f'<th class="num">{escape(h)}<br><span class=unit>{escape(u)}</span></th>'
        for h, u in columns
    )
    return (f'<table class="summary"><thead><tr>{head}</tr></thead><tbody>'
            + "\n".join(rows) + "</tbody></table>")  # fmt: skip


def _floor(out: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Floor axes ``xs (X,)``, ``ys (Y,)``; per position the best yaw's count, score and
    yaw ``(Y, X)`` (rows: y)."""
    data = load(out)
    bases, count, score = data.tables["bases"], data["count"], data["score"]
    xs, ix = np.unique(np.round(bases[:, 0], 9), return_inverse=True)
    ys, iy = np.unique(np.round(bases[:, 1], 9), return_inverse=True)
    best_count = np.full((len(ys), len(xs)), -1.0)
    best_score = np.zeros((len(ys), len(xs)))
    best_yaw = np.zeros((len(ys), len(xs)))
    for b in np.lexsort((score, count)):  # worst first: the best yaw is written last
        j, i = iy.reshape(-1)[b], ix.reshape(-1)[b]
        best_count[j, i], best_score[j, i], best_yaw[j, i] = count[b], score[b], bases[b, 2]
    return xs, ys, best_count, best_score, best_yaw


def floor_figure(out: str | Path) -> dict[str, Any]:
    """The floor plot (plotly figure of plain dicts) of the base-placement sweep in
    ``out``: trace 0 the poses reached, trace 1 the score (%), trace 2 the best base."""
    xs, ys, count, score, yaw = _floor(out)
    poses = int(load(out)["reachable"].shape[1])
    best = ranking(out)["bases"][0]
    text = [[f"best yaw {math.degrees(a):.0f} deg" for a in row] for row in yaw]

    def heat(z: np.ndarray, name: str, top: float, axis: str, bar_x: float) -> dict[str, Any]:
        return {
            "type": "heatmap", "name": name, "x": xs.tolist(), "y": ys.tolist(),
            "z": np.round(z, 3).tolist(), "zmin": 0.0, "zmax": top, "text": text,
            "colorscale": "Viridis", "xaxis": f"x{axis}", "yaxis": f"y{axis}",
            "colorbar": {"title": {"text": name}, "x": bar_x, "len": 0.9},
            "hovertemplate": "(%{x}, %{y}) m: %{z}, %{text}<extra></extra>",
        }  # fmt: skip

    marker = {"type": "scatter", "mode": "markers", "name": "best base", "x": [float(best[0])],
              "y": [float(best[1])], "xaxis": "x", "yaxis": "y",
              "marker": {"symbol": "x", "size": 12, "color": "#d62728"}}  # fmt: skip
    axis = {"title": {"text": "x (m)"}}
    layout = {
        "title": {"text": "best yaw at each floor position"},
        "xaxis": {**axis, "domain": [0.0, 0.4]}, "yaxis": {"title": {"text": "y (m)"},
                                                         "scaleanchor": "x"},
        "xaxis2": {**axis, "domain": [0.55, 0.95], "anchor": "y2"}, "yaxis2": {"anchor": "x2",
                                                              "scaleanchor": "x2"},
        "margin": {"l": 50, "r": 20, "t": 50, "b": 40}, "showlegend": False,
    }  # fmt: skip
    data = [heat(count, f"poses reached (of {poses})", float(poses), "", 0.42),
            heat(score, "score (%)", 100.0, "2", 0.97), marker]  # fmt: skip
    return {"data": data, "layout": layout}


def placement_section(out: str | Path) -> Section:
    """The section of the page for the base-placement sweep in ``out``."""
    intro = (
        "Candidate bases ranked by the task poses their capability map reaches, then by "
        "the mean reachability index of those poses' voxels (the score, %). The floor plot "
        "shows each floor position's best yaw; the cross marks the best base."
    )
    body = ranking_table_html(out) + figure_html("floor", floor_figure(out), flat=True)
    return Section("Base placement", intro, body)
