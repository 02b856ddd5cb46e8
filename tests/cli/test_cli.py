"""The redres command line: robots, demo (quick), run with scenario validation."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

import redres as rr
from redres.cli import main

RUN_KEYS = ("robot", "scheme", "steps", "max_position_error_m", "rms_position_error_m",
            "min_joint_limit_margin_rad", "min_sigma", "peak_speed_ratio",
            "step_time_us_median")  # fmt: skip
STABLE_SCHEMES = {"pinv", "dls", "gradient_projection", "wln", "augmented", "priority", "osc",
                  "qp", "sns"}  # fmt: skip


def test_robots_table_lists_every_builtin(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    for name in rr.models.names():
        assert name in out
    assert "tcp" in out and "flange" in out


def test_robots_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    by_name = {r["name"]: r for r in records}
    assert by_name["panda"]["dof"] == 7 and by_name["panda"]["tip"] == "tcp"
    assert by_name["iiwa14"]["tau_max"][0] == 320.0


@pytest.fixture(scope="module")
def quick_demo(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    out = tmp_path_factory.mktemp("demo") / "report"
    proc = subprocess.run(
        [sys.executable, "-m", "redres", "demo", "--quick", "--json", "--out", str(out)],
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout), out


def test_demo_json_has_the_stable_keys(quick_demo: tuple[dict, Path]) -> None:
    payload, out = quick_demo
    assert set(payload) >= {"report", "runs"}
    assert {run["scheme"] for run in payload["runs"]} == STABLE_SCHEMES  # every one, no other
    for run in payload["runs"]:
        for key in RUN_KEYS:
            assert key in run, key
        assert run["steps"] == 500  # 5 % of 10 s at 1 kHz
    assert {run["robot"] for run in payload["runs"]} == {"panda", "iiwa14"}
    if payload["report"] is not None:
        assert Path(payload["report"]).is_file()
        assert Path(payload["report"]).parent == out


def test_demo_json_carries_the_seed_numbers(quick_demo: tuple[dict, Path]) -> None:
    examples = quick_demo[0]["examples"]
    assert examples[0]["qd_rad_s"] == [-3.59, 5.56, -0.41]
    assert examples[1]["qd_rad_s"] == [-2.76, 5.56, -2.84]
    assert examples[2]["qd_rad_s"] == [0.146, 0.107]
    assert examples[2]["achieved_x"] == [-0.293, 0.254, 0.254]
    assert examples[3]["qd_rad_s"] == [1.093, 0.8]
    assert examples[4]["qd_rad_s"] == [0.8, 0.4]
    assert examples[5]["task_residual"] < 1e-12


def test_run_list_and_builtin_name(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["run", "--list"]) == 0
    listing = capsys.readouterr().out
    assert "panda_joint_limit_circle" in listing and "iiwa_arm_angle_eight" in listing
    code = main(["run", "iiwa_arm_angle_eight", "--quick", "--quiet", "--out", str(tmp_path / "r")])
    assert code == 0
    table = capsys.readouterr().out
    assert "augmented" in table and "iiwa14" in table


def test_bad_usage_exits_2() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "redres", "fly"], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 2 and "invalid choice" in proc.stderr


def test_demo_ends_with_the_compiled_loop(quick_demo: tuple[dict, Path]) -> None:
    rows = {row["loop"]: row for row in quick_demo[0]["compiled_loop"]}
    assert "gradient projection (fused kernel)" in rows
    for row in rows.values():
        assert 0.0 < row["median_us"] < 1e4
        assert row["max_error_mm"] < 10.0  # the first 0.1 s of the circle, from rest
    # the fused step tracks like rr.run's gradient projection (0.0073 mm over the 10 s)
    assert rows["gradient projection (fused kernel)"]["max_error_mm"] < 0.02


def test_a_folder_of_the_users_is_refused_before_anything_runs(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """One line naming the folder and the way out, exit 2, at once (no run happens); with
    --force the report is added and the user's file kept."""
    (tmp_path / "report.html").write_text("mine")
    start = time.perf_counter()
    assert main(["run", "iiwa_arm_angle_eight", "--quick", "--quiet", "--out", str(tmp_path)]) == 2
    assert time.perf_counter() - start < 5.0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--force" in err and str(tmp_path) in err
    assert (tmp_path / "report.html").read_text() == "mine"
    assert (
        main(["run", "iiwa_arm_angle_eight", "--quick", "--quiet", "--out", str(tmp_path / "new")])
        == 0
    )
    args = ["run", "iiwa_arm_angle_eight", "--quick", "--quiet", "--force", "--out"]
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    assert main([*args, str(tmp_path / "other")]) == 0
    assert (tmp_path / "other" / "notes.txt").read_text() == "mine"


def test_plan_prints_the_schemes_against_the_optimum(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    out_dir = tmp_path / "report"
    args = ["plan", "panda_joint_limit_circle", "--duration", "0.5", "--out", str(out_dir)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "global plan (DP)" in out and "% of the optimum" in out and "wln" in out
    assert "wln: min margin" in out and "% of the optimum" in out
    page = (out_dir / "report.html").read_text(encoding="utf-8")
    assert "Against the global optimum" in page and "global-plan-panda_joint_limit_circle" in page
    assert (out_dir / "global-plan-panda_joint_limit_circle.png").stat().st_size > 1000
    assert main(["plan", "iiwa_arm_angle_eight", "--objective", "obstacle_clearance",
                 "--out", str(tmp_path / "other")]) == 2  # fmt: skip
    assert "no obstacles" in capsys.readouterr().err
