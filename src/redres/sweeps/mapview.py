"""A map as one self-contained HTML page: a 3D view with horizontal slices.

A capability map is drawn as its tested voxels' centres coloured by the reachability
index (Zacharias et al. 2007, percent); a redundancy map as its poses' positions
coloured by the width of the arm angles reachable there (rad, the mean over the poses
sharing a position, e.g. a voxel's orientations). A slider shows the whole map or one
horizontal slab of it (each distinct height of a voxel grid; 20 equal slabs of heights
otherwise). plotly.js is inlined (the ``report`` extra), so the page needs no network.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from html import escape
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MissingDependencyError
from .folder import SweepFolderError
from .results import load

__all__ = ["map_figure", "write_html"]

_SLABS = 20  # slabs of a map whose heights are not a grid's


def _points(out: str | Path) -> tuple[np.ndarray, np.ndarray, str, float, str]:
    """Positions ``(P, 3)``, values ``(P,)``, the colour bar's title and top, the title."""
    data = load(out)
    if data.kind == "capability":
        from .capability import load_map

        cap = load_map(out)
        return (
            cap.centres,
            cap.reachability_index,
            "reachability index (%)",
            100.0,
            (
                f"capability map {data.name}: {len(cap.centres)} voxels, "
                f"{cap.rotations.shape[0]} orientations each"
            ),
        )
    if data.kind == "redundancy_map":
        from .redundancy import load_redundancy_map

        red = load_redundancy_map(out)
        positions, inverse = np.unique(red.pose[:, :3, 3], axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        total = np.bincount(inverse, weights=red.total_width, minlength=len(positions))
        mean = total / np.maximum(np.bincount(inverse, minlength=len(positions)), 1)
        return (
            positions,
            mean,
            "reachable arm-angle width (rad)",
            2.0 * math.pi,
            (
                f"redundancy map {data.name} ({red.method}): {len(red.pose)} poses at "
                f"{len(positions)} positions"
            ),
        )
    raise SweepFolderError(f"{out} holds a {data.kind} sweep; maps drawn: capability, "
                           "redundancy_map")  # fmt: skip


def _slabs(z: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Slab index of each height and the slabs' labels (m)."""
    levels = np.unique(np.round(z, 9))
    if 0 < len(levels) <= 60:
        return np.searchsorted(levels, np.round(z, 9)), [f"z = {v:.3f} m" for v in levels]
    edges = np.linspace(z.min(), z.max(), _SLABS + 1) if len(z) else np.zeros(_SLABS + 1)
    index = np.clip(np.searchsorted(edges, z, side="right") - 1, 0, _SLABS - 1)
    return index, [f"z in [{edges[k]:.3f}, {edges[k + 1]:.3f}] m" for k in range(_SLABS)]


def map_figure(out: str | Path) -> dict[str, Any]:
    """The plotly figure (plain JSON-ready dicts) of the map in sweep folder ``out``.

    Trace 0 is the whole map; trace ``k + 1`` slab ``k``, shown alone by the slider.

    Raises:
        SweepFolderError: ``out`` holds no capability or redundancy map.
    """
    positions, values, bar, top, title = _points(out)
    slab, labels = _slabs(positions[:, 2])

    def trace(rows: np.ndarray, name: str, visible: bool) -> dict[str, Any]:
        return {
            "type": "scatter3d", "mode": "markers", "name": name, "visible": visible,
            "x": np.round(positions[rows, 0], 5).tolist(),
            "y": np.round(positions[rows, 1], 5).tolist(),
            "z": np.round(positions[rows, 2], 5).tolist(),
            "marker": {"size": 3, "color": np.round(values[rows], 4).tolist(),
                       "colorscale": "Viridis", "cmin": 0.0, "cmax": top,
                       "colorbar": {"title": {"text": bar}}},
            "hovertemplate": "(%{x}, %{y}, %{z}) m: %{marker.color}<extra></extra>",
        }  # fmt: skip

    every = np.arange(len(positions))
    data = [trace(every, "all", True)]
    data += [trace(np.flatnonzero(slab == k), label, False) for k, label in enumerate(labels)]
    steps = []
    for k, label in enumerate(["all", *labels]):
        visible = [i == k for i in range(len(data))]
        steps.append({"label": label, "method": "restyle", "args": [{"visible": visible}]})
    layout = {
        "title": {"text": title},
        "scene": {"aspectmode": "data", "xaxis": {"title": {"text": "x (m)"}},
                  "yaxis": {"title": {"text": "y (m)"}}, "zaxis": {"title": {"text": "z (m)"}}},
        "sliders": [{"active": 0, "steps": steps, "currentvalue": {"prefix": "slice: "}}],
        "margin": {"l": 0, "r": 0, "t": 40, "b": 0},
        "showlegend": False,
    }  # fmt: skip
    return {"data": data, "layout": layout}


def write_html(out: str | Path, path: str | Path) -> Path:
    """Write the page of the map in sweep folder ``out`` to ``path`` (atomically);
    returns ``path``.

    Raises:
        MissingDependencyError: plotly (the ``report`` extra) is not installed.
        SweepFolderError: ``out`` holds no capability or redundancy map.
    """
    try:
        from plotly.offline import get_plotlyjs
    except ImportError:
        raise MissingDependencyError(
            "a map's HTML view inlines plotly.js; install it: pip install 'redres[report]'"
        ) from None
    figure = map_figure(out)
    title = figure["layout"]["title"]["text"]
    payload = json.dumps(figure, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    page = (
        f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{escape(title)}'
        f'</title></head><body style="margin:0;font-family:system-ui,sans-serif">'
        f'<script>{get_plotlyjs()}</script><div id="map" style="width:100%;height:96vh">'
        f'</div><script id="figure" type="application/json">{payload}</script><script>'
        "const f=JSON.parse(document.getElementById('figure').textContent);"
        "Plotly.newPlot('map',f.data,f.layout,{displaylogo:false,responsive:true});"
        "</script></body></html>\n"
    )
    target = Path(path)
    handle, temporary = tempfile.mkstemp(dir=target.parent, prefix=".map-", suffix=".html")
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as f:
            f.write(page)
        os.replace(temporary, target)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return target
