"""The self-contained report page: one HTML file, no network, no server.

Plots are PNG data URIs; plotly.js is inlined once; the 3D figures of every run are one
JSON document in the page, and a small script draws the run picked in a drop-down into a
single plotly graph (one WebGL context however many runs there are). The graph element
gets ``data-status="rendered"`` once plotly has drawn it (``"error"`` if it failed) and
``data-scene``, a JSON summary of what plotly holds (for the obstacles and the robot's
meshes and link capsules: name, shape, whether shown, vertex count and bounding box of the
coordinates it draws; the frame shown; how many animation frames move the meshes), which
automated checks can read; it is written again after each animation and each change of a
trace's visibility (a legend click). The robot's meshes are sent once, in their links'
coordinates, with each frame's link poses (``rigid``, one entry per moving mesh trace; an
entry moved by the poses of an earlier one gives its index as ``poses``): the script
poses them for every frame before plotly draws.
"""

from __future__ import annotations

import base64
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from html import escape
from typing import Any

from .plots import PLOT_TITLES

PLOTLY_CONFIG = {"displaylogo": False, "responsive": True}

CSS = """
:root { --fg: #1d1f23; --muted: #5f6570; --line: #dde0e5; --accent: #1f5fbf; }
* { box-sizing: border-box; }
body { margin: 0; color: var(--fg); background: #fff;
  font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", sans-serif; }
main { max-width: 1260px; margin: 0 auto; padding: 24px 28px 48px; }
header h1 { margin: 0 0 4px; font-size: 26px; letter-spacing: -0.01em; }
header .meta { color: var(--muted); font-size: 13px; margin: 0 0 12px; }
header p { margin: 6px 0; max-width: 900px; }
h2 { font-size: 19px; margin: 34px 0 10px; padding-bottom: 4px;
  border-bottom: 1px solid var(--line); }
table.summary { border-collapse: collapse; width: 100%; font-size: 13.5px; }
table.summary th, table.summary td { padding: 5px 9px; border-bottom: 1px solid var(--line);
  text-align: left; vertical-align: bottom; }
table.summary th { font-weight: 600; background: #f5f6f8; }
table.summary tbody tr:hover { background: #f0f5ff; }
.num { text-align: right !important; font-variant-numeric: tabular-nums; }
.unit { font-weight: 400; color: var(--muted); font-size: 12px; }
td.bad { color: #b3261e; font-weight: 600; }
td.missing { color: var(--muted); }
ul.warnings { margin: 10px 0 0; padding-left: 20px; color: #8a4b00; font-size: 13.5px; }
.picker { display: flex; gap: 10px; align-items: center; margin: 6px 0 4px; }
.picker select, .picker button { font: inherit; padding: 3px 8px; }
.picker button { border: 1px solid #b9bec7; background: #f5f6f8; border-radius: 4px;
  cursor: pointer; }
.picker button:hover { background: #e8ecf3; }
.hint { color: var(--muted); font-size: 13px; }
#arm-view { width: 100%; min-height: 680px; border: 1px solid var(--line); border-radius: 6px; }
.plots { display: grid; grid-template-columns: 1fr 1fr; gap: 14px; }
.plots figure { margin: 0; }
.plots figure.wide { grid-column: 1 / -1; }
.plots img { width: 100%; height: auto; border: 1px solid var(--line); border-radius: 4px; }
figcaption { color: var(--muted); font-size: 13px; }
footer { margin-top: 40px; color: var(--muted); font-size: 12.5px; }
"""

SCRIPT = """
(function () {
  var runs = JSON.parse(document.getElementById("redres-runs").textContent);
  var shared = JSON.parse(document.getElementById("redres-meshes").textContent);
  var config = JSON.parse(document.getElementById("redres-plotly-config").textContent);
  var view = document.getElementById("arm-view");
  var select = document.getElementById("run-select");
  var current = 0, frame = "0", bound = false;
  function quiet() {}  // an interrupted animation rejects its promise: expected
  function pause() {
    return Plotly.animate(view, [null], {mode: "immediate", transition: {duration: 0},
                                         frame: {duration: 0, redraw: false}}).catch(quiet);
  }
  function play() {  // from the frame after the one shown, or from the start at the end
    var names = runs[current].frames.map(function (f) { return f.name; });
    var at = names.indexOf(frame);
    var rest = at >= 0 && at < names.length - 1 ? names.slice(at + 1) : names;
    Plotly.animate(view, rest, {mode: "immediate", transition: {duration: 0},
                                frame: {duration: runs[current].play.frame_ms, redraw: true}})
      .catch(quiet);
  }
  function expand(fig) {  // move the robot's meshes: frame f's link poses on local vertices
    if (fig.expanded) { return; }
    (fig.rigid || []).forEach(function (r) { pose(fig, r); });
    fig.expanded = true;
  }
  function pose(fig, r) {  // one moving mesh trace (an entry of fig.rigid), every frame
    if (r.mesh !== undefined) {  // a mesh several runs share: written once in the page
      var m = shared[r.mesh], t = fig.data[r.trace];
      ["x", "y", "z"].forEach(function (c) { r[c] = m[c]; });
      ["i", "j", "k", "facecolor"].forEach(function (c) { if (m[c]) { t[c] = m[c]; } });
    }
    var scale = Math.pow(10, r.decimals);
    var poses = typeof r.poses === "number" ? fig.rigid[r.poses].poses : r.poses;
    fig.frames.forEach(function (fr, f) {
      var x = r.x.slice(), y = r.y.slice(), z = r.z.slice();
      r.parts.forEach(function (p) {
        if (p[2] < 0) { return; }
        var T = poses[f][p[2]];  // rows of [R | t]
        for (var v = p[0]; v < p[0] + p[1]; v++) {
          var a = r.x[v], b = r.y[v], c = r.z[v];
          x[v] = Math.round((T[0] * a + T[1] * b + T[2] * c + T[3]) * scale) / scale;
          y[v] = Math.round((T[4] * a + T[5] * b + T[6] * c + T[7]) * scale) / scale;
          z[v] = Math.round((T[8] * a + T[9] * b + T[10] * c + T[11]) * scale) / scale;
        }
      });
      fr.data.push({type: "mesh3d", x: x, y: y, z: z});
      fr.traces.push(r.trace);
    });
  }
  function drawn() {  // what the scene holds, for automated checks (data-scene)
    return view.data.filter(function (t) { return t.meta && t.meta.kind; })
      .map(function (t) {
        var box = ["x", "y", "z"].map(function (c) {
          return [Math.min.apply(null, t[c]), Math.max.apply(null, t[c])];
        });
        return {name: t.name, kind: t.meta.kind, shape: t.meta.shape, type: t.type,
                visible: t.visible === undefined ? true : t.visible, vertices: t.x.length,
                min: box.map(function (b) { return b[0]; }),
                max: box.map(function (b) { return b[1]; })};
      });
  }
  function describe() {  // data-scene: the summary of the scene as drawn now
    var fig = runs[current], rigid = fig.rigid || [];
    var moving = fig.frames.filter(function (fr) {  // frames that move every mesh trace
      return rigid.length && rigid.every(function (r) { return fr.traces.indexOf(r.trace) >= 0; });
    }).length;
    view.dataset.scene = JSON.stringify({drawn: drawn(), traces: view.data.length,
                                         frames: fig.frames.length, moving: moving,
                                         frame: frame});
  }
  function show(i) {
    var fig = runs[i];
    current = i; frame = "0";
    view.dataset.status = "rendering";
    if (view.data) { pause(); }
    expand(fig);
    Plotly.react(view, {data: fig.data, layout: fig.layout, frames: fig.frames, config: config})
      .then(function () {
        if (!bound) {
          view.on("plotly_animatingframe", function (e) { frame = e.name; });
          view.on("plotly_animated", describe);
          view.on("plotly_restyle", describe);  // a legend click shows or hides a trace
          bound = true;
        }
        describe();
        view.dataset.status = "rendered"; view.dataset.run = String(i);
      })
      .catch(function (err) { view.dataset.status = "error"; console.error(err); });
  }
  select.addEventListener("change", function () { show(Number(select.value)); });
  document.getElementById("play").addEventListener("click", play);
  document.getElementById("pause").addEventListener("click", pause);
  var match = /^#run-(\\d+)$/.exec(window.location.hash);
  var first = match && Number(match[1]) < runs.length ? Number(match[1]) : 0;
  select.value = String(first);
  show(first);
})();
"""


@dataclass(frozen=True)
class RobotPlots:
    """The PNG plots of one robot, keyed by kind (see :data:`~redres.report.plots.PLOT_TITLES`)."""

    robot: str
    pngs: Mapping[str, bytes]
    files: Mapping[str, str]


def script_json(value: Any) -> str:
    """JSON safe inside a ``<script>`` element (no ``</`` sequence can close it)."""
    return json.dumps(value, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")


_MESH_KEYS = ("i", "j", "k", "facecolor")


def share_meshes(figures: Sequence[Mapping[str, Any]]) -> tuple[list[Any], list[Any]]:
    """Write each robot mesh once: the triangles and local vertices that several runs'
    figures repeat (each entry of ``rigid``, one per moving mesh trace) move to a shared
    list, and each entry keeps an index to it (``mesh``); the page puts them back before
    drawing (:data:`SCRIPT`). The figures given are not changed."""
    shared: list[Any] = []
    index: dict[str, int] = {}
    out = []
    for fig in figures:
        data, rigid = list(fig["data"]), []
        for spec in fig.get("rigid", []):
            trace = data[spec["trace"]]
            mesh = {c: spec[c] for c in ("x", "y", "z")}
            mesh.update({c: trace[c] for c in _MESH_KEYS if c in trace})
            key = json.dumps(mesh, separators=(",", ":"))
            if key not in index:
                index[key] = len(shared)
                shared.append(mesh)
            # frame 0's world vertices stay with the run (they differ); the rest is shared
            data[spec["trace"]] = {k: v for k, v in trace.items() if k not in _MESH_KEYS}
            slim = {k: v for k, v in spec.items() if k not in ("x", "y", "z")}
            rigid.append({**slim, "mesh": index[key]})
        out.append({**fig, "data": data, "rigid": rigid} if rigid else fig)
    return shared, out


def _arm_section(views: Sequence[tuple[str, str, Mapping[str, Any]]]) -> str:
    options: dict[str, list[str]] = {}
    for i, (robot, label, _) in enumerate(views):
        options.setdefault(robot, []).append(f'<option value="{i}">{escape(label)}</option>')
    groups = "".join(
        f'<optgroup label="{escape(robot)}">{"".join(opts)}</optgroup>'
        for robot, opts in options.items()
    )
    return f"""<section id="motion"><h2>Arm motion</h2>
<div class="picker"><label for="run-select">Run</label>
<select id="run-select">{groups}</select>
<button id="play" type="button">▶ Play</button><button id="pause" type="button">❚❚ Pause</button>
<span class="hint">Play, or drag the time slider; drag the scene to turn it, scroll to zoom.
Links to one run: <code>report.html#run-N</code>.</span></div>
<div id="arm-view" data-status="pending"></div>
<noscript><p>The 3D view needs JavaScript.</p></noscript></section>"""


def _plot_section(plots: RobotPlots) -> str:
    figures = []
    for kind, title in PLOT_TITLES.items():
        if kind not in plots.pngs:
            continue
        data = base64.b64encode(plots.pngs[kind]).decode("ascii")
        wide = ' class="wide"' if kind in ("joints", "objectives") else ""
        figures.append(
            f'<figure{wide}><img alt="{escape(plots.robot)}: {escape(title)}" '
            f'src="data:image/png;base64,{data}"><figcaption>{escape(title)} · '
            f"{escape(plots.files[kind])}</figcaption></figure>"
        )
    if "objectives" not in plots.pngs:
        figures.append('<p class="hint">No run of this robot logged a secondary objective.</p>')
    return (
        f'<section class="robot"><h2>{escape(plots.robot)}</h2>'
        f'<div class="plots">{"".join(figures)}</div></section>'
    )


def _paragraphs(text: str) -> str:
    blocks = [b.strip() for b in text.split("\n\n") if b.strip()]
    return "".join(f"<p>{escape(b)}</p>" for b in blocks)


def render_page(
    *,
    title: str,
    description: str,
    table: str,
    views: Sequence[tuple[str, str, Mapping[str, Any]]],
    plots: Sequence[RobotPlots],
    plotly_js: str,
    version: str,
    against_plan: str = "",
) -> str:
    """The whole page as one string.

    Args:
        title, description: page heading and plain-text introduction (blank lines separate
            paragraphs); both are escaped.
        table: the summary table's HTML (already escaped, see :func:`table_html`).
        views: ``(robot, run label, plotly figure dict)`` for each run's 3D view.
        plots: the PNG plots of each robot.
        plotly_js: the plotly.js bundle, inlined once.
        version: redres version, shown in the header.
        against_plan: the section comparing the runs with the global plan (HTML,
            escaped; :func:`redres.report.global_plan.comparison_section`), or empty.
    """
    sections = "".join(_plot_section(p) for p in plots)
    shared, figures_list = share_meshes([fig for _, _, fig in views])
    figures = script_json(figures_list)
    inline_js = plotly_js.replace("</script", "<\\/script")  # cannot close its element
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="redres {escape(version)}">
<title>{escape(title)}</title><style>{CSS}</style>
<script>{inline_js}</script>
</head><body><main>
<header><h1>{escape(title)}</h1>
<p class="meta">redres {escape(version)} · {len(views)} runs ·
one self-contained file, works offline</p>
{_paragraphs(description)}</header>
<section id="summary"><h2>Summary</h2>{table}</section>
{against_plan}
{_arm_section(views)}
{sections}
<footer>Made with redres {escape(version)}. Plots: matplotlib; 3D view: plotly.js (MIT).
</footer></main>
<script type="application/json" id="redres-runs">{figures}</script>
<script type="application/json" id="redres-meshes">{script_json(shared)}</script>
<script type="application/json" id="redres-plotly-config">{script_json(PLOTLY_CONFIG)}</script>
<script>{SCRIPT}</script>
</body></html>
"""
