"""The comparison table: every run, the promised columns and units, escaped text."""

from __future__ import annotations

import re
from html import unescape

import pytest

from redres.report.table import COLUMNS, table_html

from .conftest import Runs


def _rows(html: str) -> list[list[str]]:
    body = html.split("<tbody>", 1)[1]
    return [
        [unescape(re.sub(r"<[^>]+>", "", c)) for c in re.findall(r"<td[^>]*>(.*?)</td>", r)]
        for r in re.findall(r"<tr>(.*?)</tr>", body)
    ]


def test_one_row_per_run_with_values_in_table_units(runs: Runs) -> None:
    summaries = [log.summary() for _, log in runs]
    rows = _rows(table_html(summaries))
    assert len(rows) == len(runs)
    keys = [c.key for c in COLUMNS if not c.optional]  # no run here logged obstacles
    for row, summary in zip(rows, summaries):
        assert row[0] == summary["robot"] and row[1] == summary["label"]
        values = dict(zip(keys, row[2:]))
        assert int(values["steps"].replace(",", "")) == summary["steps"]
        for key in ("max_position_error_m", "rms_position_error_m"):  # shown in mm
            assert float(values[key]) == pytest.approx(1e3 * summary[key], rel=5e-3)
        assert float(values["min_joint_limit_margin_rad"]) == pytest.approx(
            summary["min_joint_limit_margin_rad"], abs=5e-4
        )
        assert float(values["step_time_us_median"]) == pytest.approx(
            summary["step_time_us_median"], abs=0.05
        )


def test_headers_name_the_columns_and_units() -> None:
    html = table_html([])
    headers = (
        "robot, scheme, max position error, RMS position error, min joint-limit margin, min σ, "
        "peak speed ratio, path length, median step time, mm, rad, µs"
    )
    for header in headers.split(", "):
        assert header in html


def test_violations_are_flagged_missing_values_dashed_text_escaped() -> None:
    row = {
        "robot": "panda",
        "scheme": "pinv",
        "label": "<b>mine</b>",
        "steps": 10,
        "min_joint_limit_margin_rad": -0.2,
    }
    html = table_html([row])
    assert "<b>" not in html and "&lt;b&gt;mine&lt;/b&gt;" in html
    assert 'class="num bad">-0.200<' in html
    shown = [c for c in COLUMNS if not c.optional]
    assert html.count("missing") == len(shown) - 2  # all but steps and margin
    assert 'title="scheme pinv"' in html
