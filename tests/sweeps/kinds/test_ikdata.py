"""IK datasets: every stored solution is an IK solution of its pose (Pinocchio FK), the
solutions of a pose are distinct, and the pose is the FK of its configuration."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres import sweeps
from redres.sweeps.kinds.ikdata import distinct

SPEC = """
kind = "ik_dataset"
seed = 4
shard_size = 20
small_shards = true
[robot]
model = "iiwa14"
[solver]
tol_position = 1e-6
tol_orientation = 1e-5
[ik_dataset]
poses = 50
solutions = 4
attempts = 12
"""


def test_dataset(tmp_path: Path) -> None:
    (tmp_path / "ik.toml").write_text(SPEC)
    report = sweeps.run(tmp_path / "ik.toml", tmp_path / "out", workers=1, progress=False)
    assert report.shards == 3 and report.queries == 50
    data = sweeps.load(tmp_path / "out")
    robot = rr.models.iiwa14()
    count, solutions = data["count"], data["solutions"]
    assert (count >= 1).mean() > 0.9 and (count >= 2).any()
    assert (data["attempts"] >= 1).all() and (data["attempts"] <= 12).all()
    for i in range(50):
        np.testing.assert_allclose(robot.fk(data["q_true"][i]), data["pose"][i], atol=1e-12)
        for s in range(count[i]):
            q = solutions[i, s]
            assert robot.within_limits(q)
            T = robot.fk(q)
            assert np.linalg.norm(T[:3, 3] - data["pose"][i][:3, 3]) <= 1e-6
            assert np.linalg.norm(pin.log3(data["pose"][i][:3, :3].T @ T[:3, :3])) <= 1e-5 + 1e-9
            for t in range(s):
                assert np.abs(solutions[i, t] - q).max() > 1e-3
        assert np.isnan(solutions[i, count[i] :]).all()


def test_distinct() -> None:
    a, b = np.zeros(3), np.ones(3)
    solutions = np.array([[a, a + 1e-4, b, np.full(3, np.nan)], [b, a, b + 2e-3, a]])
    out, kept = distinct(solutions, np.array([3, 4]), 1e-3)
    assert kept.tolist() == [2, 3]
    np.testing.assert_array_equal(out[0, :2], [a, b])
    np.testing.assert_array_equal(out[1, :3], [b, a, b + 2e-3])
    assert np.isnan(out[0, 2:]).all() and np.isnan(out[1, 3]).all()


def test_training_rows_pair_each_solution_with_its_pose(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`redres sweep ... --rows`: one row per (pose, distinct solution), the pose as
    position and a unit quaternion (w first, w >= 0); oracle: Pinocchio's FK of the row's
    q gives the row's pose; the .npz and .csv hold the same numbers."""
    from redres.cli import main
    from redres.sweeps.kinds.ikdata import export_rows, training_rows

    (tmp_path / "ik.toml").write_text(SPEC)
    out, npz, csv = tmp_path / "out", tmp_path / "rows.npz", tmp_path / "rows.csv"
    args = ["sweep", str(tmp_path / "ik.toml"), "--out", str(out), "--workers", "1"]
    assert main([*args, "--quiet", "--rows", str(npz)]) == 0
    assert f"training rows: {npz}" in capsys.readouterr().out
    data = sweeps.load(out)
    rows = np.load(npz)
    assert len(rows["q"]) == int(data["count"].sum()) and rows["pose"].shape[1] == 7
    assert list(rows["columns"]) == ["x", "y", "z", "qw", "qx", "qy", "qz",
                                     *(f"q{j}" for j in range(1, 8))]  # fmt: skip
    robot = rr.models.iiwa14()
    for pose, q, i in zip(rows["pose"], rows["q"], rows["pose_index"]):
        T = robot.fk(q)
        assert np.linalg.norm(T[:3, 3] - pose[:3]) <= 1e-6  # the solver's tolerance
        w, x, y, z = pose[3:]
        assert w >= 0 and abs(w * w + x * x + y * y + z * z - 1) < 1e-12
        R = pin.Quaternion(w, x, y, z).matrix()
        np.testing.assert_allclose(R, data["pose"][i][:3, :3], atol=1e-12)
        assert np.linalg.norm(pin.log3(R.T @ T[:3, :3])) <= 1e-5 + 1e-9
    export_rows(out, csv)
    table = np.loadtxt(csv, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, :7], rows["pose"])  # 17 digits: exact
    np.testing.assert_array_equal(table[:, 7:14], rows["q"])
    np.testing.assert_array_equal(table[:, 14], rows["pose_index"])
    true = training_rows(out, which="true")
    np.testing.assert_array_equal(true.q, data["q_true"])
    np.testing.assert_array_equal(true.pose_index, np.arange(50))
    assert main([*args, "--rows", str(tmp_path / "rows.h5")]) == 2
    assert "--rows writes .npz or .csv" in capsys.readouterr().err


def test_training_rows_refuse_another_kind_and_skip_unfinished_shards(tmp_path: Path) -> None:
    from redres.errors import InvalidParameterError
    from redres.sweeps.folder import MANIFEST
    from redres.sweeps.kinds.ikdata import training_rows

    from ..helpers import write_spec

    (tmp_path / "ik.toml").write_text(SPEC)
    sweeps.run(tmp_path / "ik.toml", tmp_path / "out", workers=1, progress=False)
    (tmp_path / "out" / MANIFEST / "000001.json").unlink()  # shard 1 (poses 20-39) unfinished
    rows = training_rows(tmp_path / "out", which="true")
    assert rows.pose_index.tolist() == [*range(20), *range(40, 50)]
    spec = write_spec(tmp_path)
    sweeps.run(spec, tmp_path / "map", workers=1, progress=False)
    with pytest.raises(InvalidParameterError, match="holds a capability sweep"):
        training_rows(tmp_path / "map")


def test_distinct_counts_do_not_exceed_the_solution_set_at_a_loose_tolerance(
    tmp_path: Path,
) -> None:
    """An iiwa14 with joint A3 fixed is a 6-joint arm with a spherical shoulder and wrist:
    at most 2 x 2 x 2 = 8 solutions per pose. Accepted at 1e-4 m and counted without
    refinement, 12 "distinct" ones came back on this spec; refined first, never above 8."""
    urdf = Path(rr.models.__file__).parent / "data" / "iiwa14.urdf"
    text = urdf.read_text().replace(
        'name="joint_a3" type="revolute"', 'name="joint_a3" type="fixed"'
    )
    assert 'name="joint_a3" type="fixed"' in text
    (tmp_path / "iiwa6.urdf").write_text(text)
    spec = SPEC.replace('model = "iiwa14"', 'urdf = "iiwa6.urdf"').replace("1e-6", "1e-4")
    spec = spec.replace("1e-5", "1e-3").replace("solutions = 4", "solutions = 12")
    spec = spec.replace("attempts = 12", "attempts = 48").replace("poses = 50", "poses = 60")
    (tmp_path / "ik.toml").write_text(spec)
    sweeps.run(tmp_path / "ik.toml", tmp_path / "out", workers=1, progress=False)
    data = sweeps.load(tmp_path / "out")
    robot = rr.Robot.from_urdf(tmp_path / "iiwa6.urdf")
    assert robot.n == 6
    count = data["count"]
    assert count.max() <= 8 and (count >= 4).any()
    for i in range(len(count)):
        for s in range(count[i]):
            T = robot.fk(data["solutions"][i, s])
            assert np.linalg.norm(T[:3, 3] - data["pose"][i][:3, 3]) <= 1e-4
