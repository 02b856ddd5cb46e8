"""The comparison table of ``redres run`` and ``redres demo``: within 100 columns, long
scheme labels wrapped, headers stacked over their numbers."""

from __future__ import annotations

from redres.scenarios.runner import (
    COLUMNS,
    LABEL_WIDTH,
    aligned_table,
    column_table,
    format_table,
)


def _summary(label: str) -> dict[str, object]:
    return {
        "robot": "iiwa14", "label": label, "max_position_error_m": 0.0041980,
        "rms_position_error_m": 0.0004159, "min_joint_limit_margin_rad": -0.329,
        "min_sigma": 0.212, "min_obstacle_clearance_m": -0.107, "peak_speed_ratio": 0.85,
        "path_length_rad": 11.45, "step_time_us_median": 110.2,
    }  # fmt: skip


def test_the_demos_table_fits_100_columns_and_keeps_every_word() -> None:
    labels = ["pinv", "gradient projection: joint limits", "sns: saturation in the null space",
              "priority: path, then arm angle, then posture", "x" * 40]  # fmt: skip
    table = format_table([_summary(label) for label in labels])
    lines = table.splitlines()
    assert max(map(len, lines)) <= 100, table
    rule = next(i for i, line in enumerate(lines) if line.startswith("---"))
    assert rule == 3  # headers of up to three lines, bottom-aligned over the rule
    cells = [line[8 : 8 + LABEL_WIDTH].rstrip() for line in lines[rule + 1 :]]
    body = " ".join(" ".join(cells).split())
    for label in labels[:4]:  # every word of every label, in order, once wrapped
        assert " ".join(label.split()) in body, body
    i = cells.index("gradient projection:")  # broken after the colon
    assert cells[i + 1] == "  joint limits"
    assert len(format_table([_summary("pinv")]).splitlines()) == rule + 2  # short: one line
    # every column but the self-collision clearance (shown when a run measured it)
    assert len(COLUMNS) - 1 == len(lines[rule].split())


def test_a_collision_scenarios_table_fits_100_columns() -> None:
    """With the self-collision column too, the labels of panda_table_shelf fit."""
    labels = ["qp: collision constraint", "qp: joint limits only",
              "gradient projection: obstacle penalty"]  # fmt: skip
    rows = [{**_summary(label), "robot": "panda", "min_self_clearance_m": -0.0845}
            for label in labels]  # fmt: skip
    lines = format_table(rows).splitlines()
    assert max(map(len, lines)) <= 100
    rule = next(i for i, line in enumerate(lines) if line.startswith("---"))
    assert len(COLUMNS) == len(lines[rule].split())
    assert "-84.5" in lines[rule + 1]


def test_aligned_table_stacks_lines_of_headers_and_cells() -> None:
    table = aligned_table(["a\nb", "c"], [["1\n2", "3"], ["4", "5"]])
    assert table.splitlines() == ["a", "b  c", "-  -", "1  3", "2", "4  5"]


def test_column_table_writes_each_record_by_its_columns() -> None:
    records = [{"x": 1.5, "name": "a"}, {"x": -20.0, "name": "bc\nd"}]
    columns = [("name", lambda r: str(r["name"])), ("x\nunit", lambda r: f"{r['x']:.2f}")]
    by_hand = [["a", "1.50"], ["bc\nd", "-20.00"]]
    assert column_table(columns, records) == aligned_table(["name", "x\nunit"], by_hand)
    assert column_table(columns, iter(records)).splitlines()[3:] == [
        "a     1.50",
        "bc    -20.00",
        "d",
    ]
    assert column_table(columns, []) == aligned_table(["name", "x\nunit"], [])
