"""A self-contained page of sections and plotly figures (the sweeps' report views).

The same page as the run report's (:mod:`.html`): its stylesheet, plotly.js inlined once,
figures as JSON documents in the page, PNG plots as data URIs, written atomically; but
its body is a list of sections, each figure drawn into its own element. Every figure
element gets ``data-status="rendered"`` once plotly has drawn it (``"error"`` if it
failed) and ``data-scene``, a JSON summary of what plotly holds (per trace: name, type,
``points`` (markers or heatmap cells), the range of its colour values and the colour
scale's ``cmin``, ``cmax``), which automated checks can read.
"""

from __future__ import annotations

import base64
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from html import escape
from pathlib import Path
from typing import Any

from ..sweeps.store import write_atomic
from ._deps import require
from .html import CSS, PLOTLY_CONFIG, script_json

__all__ = ["Section", "figure_html", "png_html", "render_document", "write_page"]

FIGURE_CSS = """
.redres-figure { width: 100%; min-height: 620px; border: 1px solid var(--line);
  border-radius: 6px; }
.redres-figure.flat { min-height: 460px; }
figure.png { margin: 14px 0 0; }
figure.png img { width: 100%; height: auto; border: 1px solid var(--line); border-radius: 4px; }
"""

FIGURE_SCRIPT = """
(function () {
  var config = JSON.parse(document.getElementById("redres-plotly-config").textContent);
  function values(c, out) {  // the numbers of a (nested) array
    if (Array.isArray(c)) { c.forEach(function (x) { values(x, out); }); }
    else if (typeof c === "number" && isFinite(c)) { out.push(c); }
    return out;
  }
  function summary(t) {
    var colour = t.type === "heatmap" ? t.z : (t.marker || {}).color;
    var v = values(colour, []);
    var scale = t.type === "heatmap" ? t : (t.marker || {});
    return {name: t.name, type: t.type,
            points: t.type === "heatmap" ? v.length : (t.x || []).length,
            min: v.length ? Math.min.apply(null, v) : null,
            max: v.length ? Math.max.apply(null, v) : null,
            cmin: scale.cmin === undefined ? (t.zmin === undefined ? null : t.zmin) : scale.cmin,
            cmax: scale.cmax === undefined ? (t.zmax === undefined ? null : t.zmax) : scale.cmax};
  }
  document.querySelectorAll("div.redres-figure").forEach(function (view) {
    view.dataset.status = "rendering";
    var fig = JSON.parse(document.getElementById(view.dataset.figure).textContent);
    Plotly.newPlot(view, fig.data, fig.layout, config)
      .then(function () {
        view.dataset.scene = JSON.stringify({traces: view.data.map(summary)});
        view.dataset.status = "rendered";
      })
      .catch(function (err) { view.dataset.status = "error"; console.error(err); });
  });
})();
"""


@dataclass(frozen=True)
class Section:
    """One section of the page: a heading, plain-text introduction (escaped) and HTML
    built by :func:`figure_html`, :func:`png_html` or a table (already escaped)."""

    title: str
    intro: str
    body: str


def figure_html(element_id: str, figure: Mapping[str, Any], *, flat: bool = False) -> str:
    """A plotly figure (plain JSON-ready dicts) as its element and JSON document.

    Args:
        element_id: the element's id (letters, digits, ``-``); the JSON is
            ``{element_id}-figure``.
        figure: ``{"data": [...], "layout": {...}}``.
        flat: a 2D figure (a lower element than a 3D scene's).
    """
    css = "redres-figure flat" if flat else "redres-figure"
    return (
        f'<div id="{escape(element_id)}" class="{css}" data-figure="{escape(element_id)}-figure" '
        f'data-status="pending"></div><script type="application/json" '
        f'id="{escape(element_id)}-figure">{script_json(figure)}</script>'
    )


def png_html(png: bytes, alt: str, caption: str) -> str:
    """A PNG plot as a data URI with its caption."""
    data = base64.b64encode(png).decode("ascii")
    return (
        f'<figure class="png"><img alt="{escape(alt)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{escape(caption)}</figcaption></figure>"
    )


def render_document(*, title: str, meta: str, sections: Sequence[Section], version: str) -> str:
    """The whole page as one string: the run report's stylesheet and plotly.js (the
    ``report`` extra), the sections, and the script that draws every figure element.

    Raises:
        MissingDependencyError: plotly is not installed.
    """
    inline_js = require("plotly.offline").get_plotlyjs().replace("</script", "<\\/script")
    body = "".join(
        f"<section><h2>{escape(s.title)}</h2>"
        + "".join(f"<p>{escape(p.strip())}</p>" for p in s.intro.split("\n\n") if p.strip())
        + f"{s.body}</section>"
        for s in sections
    )
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="redres {escape(version)}">
<title>{escape(title)}</title><style>{CSS}{FIGURE_CSS}</style>
<script>{inline_js}</script>
</head><body><main>
<header><h1>{escape(title)}</h1>
<p class="meta">redres {escape(version)} · {escape(meta)} · one self-contained file, works
offline</p></header>
{body}
<footer>Made with redres {escape(version)}. Plots: matplotlib; figures: plotly.js (MIT).
</footer></main>
<script type="application/json" id="redres-plotly-config">{script_json(PLOTLY_CONFIG)}</script>
<script>{FIGURE_SCRIPT}</script>
</body></html>
"""


def write_page(path: str | os.PathLike[str], text: str) -> Path:
    """Write ``text`` to ``path`` atomically (a temporary file beside it, renamed);
    returns ``path``."""
    target = Path(path)
    write_atomic(target, text.encode("utf-8"))
    return target
