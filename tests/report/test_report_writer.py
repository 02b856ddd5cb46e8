"""write_report: the files, a single self-contained page, atomic writes, bad input."""

from __future__ import annotations

import base64
import json
import os
import re
import sys
import time
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.errors import InvalidParameterError, MissingDependencyError, install_hint
from redres.report import arm_frames, write_report
from redres.report import html as report_html
from redres.report import plots as report_plots

from .conftest import Runs


class _Page(HTMLParser):
    """Collects what a page loads and its embedded JSON."""

    def __init__(self) -> None:
        super().__init__()
        self.loads: list[tuple[str, str, str]] = []  # (tag, attribute, value)
        self.scripts: dict[str, str] = {}
        self._script: str | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = {k: v or "" for k, v in attrs}
        for attr in ("src", "href", "data"):
            if attr in values:
                self.loads.append((tag, attr, values[attr]))
        if tag == "script":
            self._script = values.get("id", "")
            self.scripts.setdefault(self._script, "")

    def handle_endtag(self, tag: str) -> None:
        if tag == "script":
            self._script = None

    def handle_data(self, data: str) -> None:
        if self._script is not None:
            self.scripts[self._script] += data


def _parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


@pytest.fixture(scope="module")
def report(runs: Runs, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("report") / "out"
    return write_report(
        out, runs, title="Test <report>", description="First.\n\nSecond & last.", frames=25
    )


def test_files_are_written(report: Path) -> None:
    assert report.name == "report.html" and report.is_file()
    names = sorted(p.name for p in report.parent.iterdir())
    expected = """report.html panda-joints.png panda-position-error.png panda-sigma-min.png
        panda-objectives.png iiwa14-joints.png iiwa14-position-error.png iiwa14-sigma-min.png
        .redres-report"""  # the marker: a later report may write here again
    assert names == sorted(expected.split())  # no staging folder left
    assert not [p for p in report.parent.parent.iterdir() if p.name.startswith(".")]


def test_page_is_one_self_contained_file(report: Path) -> None:
    page = _parse(report)
    images = [v for tag, _, v in page.loads if tag == "img"]
    assert len(images) == 7  # every PNG is embedded
    for src in images:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1]).startswith(b"\x89PNG")
    others = [(tag, attr, v) for tag, attr, v in page.loads if tag != "img"]
    assert others == []  # no <script src>, <link href>, iframes, ...
    text = report.read_text(encoding="utf-8")
    assert "Plotly" in page.scripts[""]  # plotly.js is inlined ...
    assert text.count("plotly.js v") == 1  # ... once
    assert "<title>Test &lt;report&gt;</title>" in text
    assert "<p>First.</p><p>Second &amp; last.</p>" in text


def test_table_lists_every_run(report: Path, runs: Runs) -> None:
    text = report.read_text(encoding="utf-8")
    table = text.split('<table class="summary">', 1)[1].split("</table>", 1)[0]
    assert table.count("<tr>") == len(runs) + 1  # header + one row per run
    for robot, log in runs:
        row = f"<td>{robot.name}</td><td[^>]*>{re.escape(log.label or log.scheme)}</td>"
        assert re.search(row, table)


def test_embedded_3d_data(report: Path, runs: Runs) -> None:
    page = _parse(report)
    figures = json.loads(page.scripts["redres-runs"])
    assert len(figures) == len(runs)
    for figure, (robot, log) in zip(figures, runs):
        assert len(figure["frames"]) == 25
        assert robot.name in figure["layout"]["title"]["text"]
        k = len(arm_frames(robot))
        for frame in figure["frames"]:
            arm = frame["data"][0]
            assert len(arm["x"]) == len(arm["y"]) == len(arm["z"]) == k
        last = figure["frames"][-1]["data"][0]
        tip = np.array([last["x"][-1], last["y"][-1], last["z"][-1]])
        np.testing.assert_allclose(tip, robot.fk(log.q[-1])[:3, 3], atol=1e-5)
    options = report.read_text(encoding="utf-8").count("<option ")
    assert options == len(runs)


def test_given_table_rows_replace_the_summaries(runs: Runs, tmp_path: Path) -> None:
    rows = [dict(runs[0][1].summary(), label="only row")]
    path = write_report(tmp_path / "r", runs[:1], title="t", table=rows, frames=2)
    text = path.read_text(encoding="utf-8")
    assert re.search("<td[^>]*>only row</td>", text) and text.count("<tr>") == 2


def test_failure_while_plotting_leaves_no_directory(
    runs: Runs, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(*args: object, **kwargs: object) -> None:
        raise RuntimeError("plotting failed")

    monkeypatch.setattr(report_plots, "sigma_min_figure", broken)
    with pytest.raises(RuntimeError, match="plotting failed"):
        write_report(tmp_path / "out", runs, title="t", frames=2)
    assert list(tmp_path.iterdir()) == []  # neither the report nor its staging directory


def test_failure_after_the_plots_keeps_the_previous_report(
    runs: Runs, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    write_report(out, runs[2:], title="first", frames=2, force=True)  # notes.txt is kept
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def broken(**kwargs: object) -> str:
        raise RuntimeError("page failed")

    monkeypatch.setattr(report_html, "render_page", broken)
    with pytest.raises(RuntimeError, match="page failed"):
        write_report(out, runs[:1], title="second", frames=2)  # would add panda plots
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert (out / "notes.txt").read_text() == "mine"


def test_missing_extra_is_named(
    runs: Runs, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "plotly.offline", None)  # import fails
    with pytest.raises(MissingDependencyError, match=re.escape(install_hint("report"))) as info:
        write_report(tmp_path / "out", runs, title="t")
    assert isinstance(info.value, ImportError) and "plotly" in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_bad_input(runs: Runs, tmp_path: Path) -> None:
    with pytest.raises(InvalidParameterError, match="empty"):
        write_report(tmp_path / "a", [], title="t")
    log = runs[0][1]
    with pytest.raises(InvalidParameterError, match=r"runs\[0\].*'panda'.*'iiwa14'"):
        write_report(tmp_path / "b", [(rr.models.iiwa14(), log)], title="t")
    with pytest.raises(InvalidParameterError, match="pair"):
        write_report(tmp_path / "c", [log], title="t")  # type: ignore[list-item]
    with pytest.raises(InvalidParameterError, match="frames"):
        write_report(tmp_path / "d", runs, title="t", frames=1)
    with pytest.raises(InvalidParameterError, match="max_points"):
        write_report(tmp_path / "d", runs, title="t", max_points=3)
    with pytest.raises(InvalidParameterError, match=r"table\[0\]"):
        write_report(tmp_path / "d", runs, title="t", table=[("panda", 1)])  # type: ignore[list-item]
    (tmp_path / "file").write_text("x")
    with pytest.raises(InvalidParameterError, match="not a directory"):
        write_report(tmp_path / "file", runs, title="t")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_a_users_files_are_never_replaced(runs: Runs, tmp_path: Path) -> None:
    """A folder holding files redres did not write is refused (their names in the
    message), with or without a file named like the report's; force=True adds the report
    and keeps the user's other files; a folder holding a report is written again."""
    for name in ("report.html", "panda-joints.png", "notes.txt"):
        out = tmp_path / name.replace(".", "_")
        out.mkdir()
        (out / name).write_text("mine")
        with pytest.raises(InvalidParameterError, match=re.escape(name)):
            write_report(out, runs[2:], title="t", frames=2)
        assert [p.name for p in out.iterdir()] == [name]  # untouched, no staging left
        assert (out / name).read_text() == "mine"
    forced = tmp_path / "notes_txt"
    write_report(forced, runs[2:], title="t", frames=2, force=True)
    assert (forced / "notes.txt").read_text() == "mine" and (forced / "report.html").exists()
    again = write_report(forced, runs[2:], title="again", frames=2)  # now marked: no force
    assert "again" in again.read_text(encoding="utf-8")
    with pytest.raises(InvalidParameterError, match="report folder is empty"):
        write_report("", runs[2:], title="t", frames=2)


def test_a_report_written_before_the_marker_is_recognised(runs: Runs, tmp_path: Path) -> None:
    out = tmp_path / "old"
    write_report(out, runs[2:], title="t", frames=2)
    (out / ".redres-report").unlink()  # as written by an earlier version
    write_report(out, runs[2:], title="t", frames=2)


def test_staging_left_by_a_killed_run_is_removed(runs: Runs, tmp_path: Path) -> None:
    """Staging happens inside the report folder; one older than an hour is a killed run's
    and goes at the next report, a fresh one (another writer at work) stays."""
    out = tmp_path / "out"
    write_report(out, runs[2:], title="t", frames=2)
    stale, fresh = out / ".redres-staging-old", out / ".redres-staging-new"
    for folder in (stale, fresh):
        folder.mkdir()
        (folder / "report.html").write_text("half")
    os.utime(stale, (time.time() - 7200, time.time() - 7200))
    write_report(out, runs[2:], title="t", frames=2)
    assert not stale.exists() and fresh.exists()
