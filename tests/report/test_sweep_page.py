"""The sweeps' HTML pages: what they hold against the sweeps' own arrays, and the pages
opened in headless Chromium (no console errors; what plotly draws is the map: as many
voxels, the colour range of the reachability index). How Chromium runs:
``tests/_chromium.py``; its tests are skipped where Debian's chromium is not installed.
"""

from __future__ import annotations

import json
import math
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from _chromium import CHROMIUM, console_problems, dump_dom
from sweeps.helpers import write_spec
from sweeps.kinds.test_schemes import SCENARIO
from sweeps.kinds.test_schemes import SPEC as STATS_SPEC

from redres import sweeps
from redres.errors import RedresError
from redres.report.sweep_page import write_html
from redres.report.sweep_placement import floor_figure
from redres.sweeps.kinds.placement import ranking
from redres.sweeps.kinds.schemes import summary

chromium = pytest.mark.skipif(not CHROMIUM.exists(), reason="needs chromium at /usr/bin/chromium")

REDUNDANCY = """
kind = "redundancy_map"
seed = 3
shard_size = 15
small_shards = true
[robot]
model = "iiwa14"
[redundancy_map]
poses = 30
"""


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """One small sweep of each kind with a page, and each page written."""
    root = tmp_path_factory.mktemp("pages")
    sweeps.run(write_spec(root, name="cap.toml"), root / "cap", workers=1, progress=False)
    (root / "red.toml").write_text(REDUNDANCY)
    sweeps.run(root / "red.toml", root / "red", workers=1, progress=False)
    m = sweeps.load_map(root / "cap")
    poses = []
    for v in range(0, len(m.index), 2):  # a reachable pose of every other voxel
        o = np.flatnonzero(m.reachable[v])
        if len(o):
            q = pin.Quaternion(m.rotations[o[0]]).coeffs()
            poses.append([*m.centres[v].tolist(), *q.tolist()])
    (root / "place.toml").write_text(f"""
kind = "base_placement"
shard_size = 200
small_shards = true
[robot]
model = "panda"
[base_placement]
map = "cap"
x = [-0.2, 0.2, 0.1]
y = [-0.1, 0.2, 0.1]
yaws = 4
poses = {json.dumps(poses)}
""")
    sweeps.run(root / "place.toml", root / "place", workers=1, progress=False)
    (root / "two.toml").write_text(SCENARIO)
    (root / "stats.toml").write_text(STATS_SPEC)
    sweeps.run(root / "stats.toml", root / "stats", workers=1, progress=False)
    for name in ("cap", "red", "place", "stats"):
        write_html(root / name, root / f"{name}.html")
    return {name: root / name for name in ("cap", "red", "place", "stats")}


class _Elements(HTMLParser):
    """Attributes of the elements with an id, and the text of table cells."""

    def __init__(self) -> None:
        super().__init__()
        self.by_id: dict[str, dict[str, str]] = {}
        self.rows: list[list[str]] = []
        self.tags: list[str] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = {k: v or "" for k, v in attrs}
        self.tags.append(tag)
        if "id" in values:
            self.by_id[values["id"]] = values
        if tag == "tr":
            self.rows.append([])
        if tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            self.rows[-1].append("".join(self._cell))
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def _parse(text: str) -> _Elements:
    parser = _Elements()
    parser.feed(text)
    return parser


def _figure(page: Path, element: str) -> dict:  # type: ignore[type-arg]
    found = re.search(rf'id="{element}-figure">(.*?)</script>', page.read_text(), re.S)
    assert found is not None
    return json.loads(found.group(1))  # type: ignore[no-any-return]


def test_placement_page_lists_the_ranking(folders: dict[str, Path]) -> None:
    r = ranking(folders["place"])
    rows = _parse(folders["place"].with_suffix(".html").read_text()).rows
    body = [row for row in rows if row and row[0].isdigit()]
    assert len(body) == min(10, len(r["count"]))
    for k, row in enumerate(body):
        x, y, yaw = r["bases"][k]
        assert [float(row[1]), float(row[2]), float(row[3])] == pytest.approx(
            [x, y, math.degrees(yaw)], abs=1e-3
        )
        assert int(row[4].split("/")[0]) == r["count"][k]
        assert float(row[5]) == pytest.approx(r["score"][k], abs=0.05)


def test_floor_plot_is_the_best_yaw_of_each_position(folders: dict[str, Path]) -> None:
    data = sweeps.load(folders["place"])
    bases, count = data.tables["bases"], data["count"]
    figure = floor_figure(folders["place"])
    reached, score, best = figure["data"]
    assert np.shape(reached["z"]) == (len(reached["y"]), len(reached["x"])) == (4, 5)
    for j, y in enumerate(reached["y"]):
        for i, x in enumerate(reached["x"]):
            here = np.isclose(bases[:, 0], x) & np.isclose(bases[:, 1], y)
            assert here.sum() == 4  # the yaws
            assert reached["z"][j][i] == count[here].max()
    top = ranking(folders["place"])["bases"][0]
    assert (best["x"][0], best["y"][0]) == pytest.approx((top[0], top[1]))
    assert score["zmax"] == 100.0 and reached["zmax"] == data["reachable"].shape[1]


def test_statistics_page_tabulates_the_summary(folders: dict[str, Path]) -> None:
    rows = summary(folders["stats"])
    data = sweeps.load(folders["stats"])
    for s, row in enumerate(rows):  # the summary against the stored arrays
        assert row["success_pct"] == pytest.approx(100 * data["success"][:, s].mean())
        assert row["rms_error_max_m"] == data["rms_error"][:, s].max()
        assert row["step_us_median"] == np.median(data["step_us"][:, s])
    parsed = _parse(folders["stats"].with_suffix(".html").read_text())
    table = {row[0]: row for row in parsed.rows if row and row[0] in ("pinv", "joint limits")}
    assert set(table) == {"pinv", "joint limits"}
    for row in rows:
        cells = table[row["scheme"]]
        assert int(cells[1]) == row["paths"] == 5
        assert float(cells[2]) == pytest.approx(row["success_pct"], abs=0.05)
        assert float(cells[6]) == pytest.approx(1e3 * row["rms_error_max_m"], rel=1e-2)
    assert parsed.tags.count("img") == 1  # the plots


def test_a_folder_that_is_no_sweep_is_refused(tmp_path: Path) -> None:
    with pytest.raises(RedresError, match="not a sweep folder"):
        write_html(tmp_path, tmp_path / "x.html")
    assert not (tmp_path / "x.html").exists()


def test_an_ik_dataset_has_no_page(tmp_path: Path) -> None:
    from sweeps.kinds.test_ikdata import SPEC as DATASET

    (tmp_path / "ik.toml").write_text(DATASET.replace("poses = 50", "poses = 4"))
    sweeps.run(tmp_path / "ik.toml", tmp_path / "ik", workers=1, progress=False)
    with pytest.raises(RedresError, match="holds a ik_dataset sweep; pages are written for"):
        write_html(tmp_path / "ik", tmp_path / "ik.html")
    assert not (tmp_path / "ik.html").exists()


def _open(page: Path, profile: Path) -> _Elements:
    proc = dump_dom(page.as_uri(), profile)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert console_problems(proc.stderr) == []
    return _parse(proc.stdout)


@chromium
def test_capability_map_renders_its_voxels(folders: dict[str, Path], tmp_path: Path) -> None:
    dom = _open(folders["cap"].with_suffix(".html"), tmp_path / "profile")
    view = dom.by_id["map"]
    assert view["data-status"] == "rendered"
    assert "canvas" in dom.tags  # the WebGL scene
    traces = json.loads(view["data-scene"])["traces"]
    m = sweeps.load_map(folders["cap"])
    index = np.round(m.reachability_index, 4)
    whole, slices = traces[0], traces[1:]
    assert whole["type"] == "scatter3d" and whole["points"] == len(m.centres)
    assert (whole["min"], whole["max"]) == pytest.approx((index.min(), index.max()))
    assert (whole["cmin"], whole["cmax"]) == (0.0, 100.0)
    assert len(slices) == len(np.unique(m.centres[:, 2]))
    assert sum(t["points"] for t in slices) == len(m.centres)


@chromium
def test_redundancy_map_renders_its_widths(folders: dict[str, Path], tmp_path: Path) -> None:
    dom = _open(folders["red"].with_suffix(".html"), tmp_path / "profile")
    view = dom.by_id["map"]
    assert view["data-status"] == "rendered"
    whole = json.loads(view["data-scene"])["traces"][0]
    m = sweeps.load_redundancy_map(folders["red"])
    width = np.round(m.total_width, 4)  # random poses: one per position
    assert whole["points"] == len(m.pose) == 30
    assert (whole["min"], whole["max"]) == pytest.approx((width.min(), width.max()))
    assert whole["cmax"] == pytest.approx(2 * np.pi)


@chromium
def test_placement_and_statistics_pages_render(folders: dict[str, Path], tmp_path: Path) -> None:
    dom = _open(folders["place"].with_suffix(".html"), tmp_path / "p1")
    floor = dom.by_id["floor"]
    assert floor["data-status"] == "rendered"
    reached, score, best = json.loads(floor["data-scene"])["traces"]
    count = ranking(folders["place"])["count"]
    assert reached["type"] == "heatmap" and reached["points"] == 4 * 5
    assert reached["max"] == count[0]
    assert 0.0 <= score["min"] <= score["max"] <= 100.0 and best["points"] == 1
    dom = _open(folders["stats"].with_suffix(".html"), tmp_path / "p2")
    assert "img" in dom.tags
    assert {row[0] for row in dom.rows if row} >= {"pinv", "joint limits"}
