"""A sweep as one self-contained HTML page (``redres sweep ... --html``).

The page is the run report's (:mod:`redres.report.page`: its styles, plotly.js inlined,
no network). A capability or redundancy map is a 3D view with horizontal slices; a
base placement its best bases and a floor plot (:mod:`.sweep_placement`); scheme
statistics their table and plots (:mod:`.sweep_statistics`).

A capability map is drawn as its tested voxels' centres coloured by the reachability
index (Zacharias et al. 2007, percent); a redundancy map as its poses' positions
coloured by the width of the arm angles reachable there (rad, the mean over the poses
sharing a position, e.g. a voxel's orientations). A slider shows the whole map or one
horizontal slab of it (each distinct height of a voxel grid; 20 equal slabs of heights
otherwise).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..sweeps.folder import SweepFolderError
from ..sweeps.results import load
from .page import Section, figure_html, render_document, write_page
from .scene3d import xyz

__all__ = ["KINDS", "map_figure", "write_html"]

#: The kinds a page is written for.
KINDS = ("capability", "redundancy_map", "base_placement", "scheme_statistics")

_SLABS = 20  # slabs of a map whose heights are not a grid's


def _points(out: str | Path) -> tuple[np.ndarray, np.ndarray, str, float, str]:
    """Positions ``(P, 3)``, values ``(P,)``, the colour bar's title and top, the title."""
    data = load(out)
    if data.kind == "capability":
        from ..sweeps.kinds.capability import load_map

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
        from ..sweeps.kinds.redundancy import load_redundancy_map

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


_MAP_INTRO = {
    "capability": "Each tested voxel's centre, coloured by its reachability index (Zacharias "
    "et al. 2007): the share of its orientations reachable within the joint limits, percent.",
    "redundancy_map": "Each pose's position, coloured by the width of the arm angles "
    "reachable there within the joint limits (rad; the mean over the poses sharing a "
    "position). Shimizu et al. 2008's closed form on S-R-S arms, self-motion tracing "
    "elsewhere.",
}


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
            **xyz(positions[rows], 5),
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
        "margin": {"l": 0, "r": 0, "t": 40, "b": 70},  # room for the slider
        "showlegend": False,
    }  # fmt: skip
    return {"data": data, "layout": layout}


def write_html(out: str | Path, path: str | Path) -> Path:
    """Write the page of the sweep in folder ``out`` to ``path`` (atomically); returns
    ``path``.

    Raises:
        MissingDependencyError: plotly or matplotlib (the ``report`` extra) is missing.
        SweepFolderError: ``out`` holds no sweep, or one of a kind without a page (the
            :data:`KINDS` have one).
    """
    from .._version import __version__

    data = load(out)
    if data.kind in ("capability", "redundancy_map"):
        figure = map_figure(out)
        section = Section("Map", _MAP_INTRO[data.kind], figure_html("map", figure))
        meta = figure["layout"]["title"]["text"]
    elif data.kind == "base_placement":
        from .sweep_placement import placement_section

        section, meta = placement_section(out), f"{len(data['count'])} candidate bases"
    elif data.kind == "scheme_statistics":
        from .sweep_statistics import statistics_section

        section = statistics_section(out)
        meta = f"{len(data['shape'])} paths x {len(data.meta['labels'])} schemes"
    else:
        raise SweepFolderError(f"{out} holds a {data.kind} sweep; pages are written for "
                               f"{', '.join(KINDS)}")  # fmt: skip
    title = f"{data.kind.replace('_', ' ')} sweep {data.name}"
    page = render_document(title=title, meta=meta, sections=[section], version=__version__)
    return write_page(path, page)
