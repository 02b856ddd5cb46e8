"""Built-in models: the registry, published figures, and the Panda from DH against the
Panda described joint by joint in a URDF written from Franka's description."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.errors import MissingDependencyError, RobotNotFoundError, install_hint


def test_names_and_load() -> None:
    assert rr.models.names() == ["iiwa14", "panda", "planar2", "planar3", "srs7"]
    for name in rr.models.names():
        robot = rr.models.load(name)
        assert robot.name == name
        assert robot.within_limits(robot.neutral())


def test_unknown_robot_lists_the_names() -> None:
    with pytest.raises(RobotNotFoundError, match="unknown robot 'ur5'.*iiwa14, panda"):
        rr.models.load("ur5")


def test_panda_published_figures() -> None:
    robot = rr.models.panda()
    assert robot.n == 7
    assert robot.q_max[3] == pytest.approx(-0.0698) and robot.q_min[5] == pytest.approx(-0.0175)
    assert np.allclose(robot.tau_max, [87, 87, 87, 87, 12, 12, 12])
    assert np.allclose(robot.qd_max, [2.175] * 4 + [2.61] * 3)
    assert np.allclose(robot.qdd_max, [15, 7.5, 10, 12.5, 15, 20, 20])
    # All joints at zero: flange at x = 0.088 m, z = 0.333 + 0.316 + 0.384 − 0.107 m.
    T = robot.fk(np.zeros(7), "flange")
    assert np.allclose(T[:3, 3], [0.088, 0.0, 0.333 + 0.316 + 0.384 - 0.107], atol=1e-12)
    assert np.allclose(T[:3, 2], [0.0, 0.0, -1.0], atol=1e-12)  # flange z points down
    T_tcp = robot.fk(np.zeros(7), "tcp")
    assert np.allclose(T_tcp[:3, 3], T[:3, 3] - [0.0, 0.0, 0.1034], atol=1e-12)


def test_iiwa14_published_figures() -> None:
    robot = rr.models.iiwa14()
    deg = np.pi / 180
    assert np.allclose(robot.q_max, np.array([170, 120, 170, 120, 170, 120, 175]) * deg)
    assert np.allclose(robot.qd_max, np.array([85, 85, 100, 75, 130, 135, 135]) * deg)
    assert np.allclose(robot.tau_max, [320, 320, 176, 176, 110, 40, 40])
    q = np.zeros(7)
    assert np.allclose(robot.fk(q)[:3, 3], [0, 0, 0.36 + 0.42 + 0.40 + 0.126], atol=1e-5)
    for frame, height in (("shoulder", 0.36), ("elbow", 0.78), ("wrist", 1.18)):
        assert np.allclose(robot.fk(q, frame)[:3, 3], [0, 0, height], atol=1e-5)


@pytest.mark.parametrize("name", ["iiwa14", "srs7"])
def test_srs_arms_have_spherical_shoulder_and_wrist(name: str, rng: np.random.Generator) -> None:
    """Joints 1–3 leave the shoulder point fixed, joints 5–7 leave the wrist point fixed
    relative to the elbow: the S-R-S structure of seed 000 section 2.1."""
    robot = rr.models.load(name)
    q = robot.random_configuration(rng)
    for frame, joints in (("shoulder", [0, 1, 2]), ("wrist", [4, 5, 6])):
        J = robot.jacobian(q, frame)
        assert np.allclose(J[:3, joints], 0.0, atol=1e-12), frame
    J_elbow = robot.jacobian(q, "elbow")
    assert np.allclose(J_elbow[:3, 3], 0.0, atol=1e-12)  # the elbow joint turns about itself


def test_panda_from_dh_matches_the_urdf_description(
    fixtures_dir: Path, rng: np.random.Generator
) -> None:
    dh = rr.models.panda(hand=True)
    urdf = rr.Robot.from_urdf(
        fixtures_dir / "panda_description.urdf",
        tip="panda_hand_tcp",
        locked={"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04},
    )
    assert urdf.n == 7
    assert np.allclose(urdf.q_min, dh.q_min) and np.allclose(urdf.q_max, dh.q_max)
    assert np.allclose(urdf.qd_max, dh.qd_max) and np.allclose(urdf.tau_max, dh.tau_max)
    pairs = [(f"link{i}", f"panda_link{i}") for i in range(1, 8)]
    pairs += [("flange", "panda_link8"), ("hand", "panda_hand"), ("tcp", "panda_hand_tcp")]
    for _ in range(10):
        q = dh.random_configuration(rng)
        for a, b in pairs:
            assert np.allclose(dh.fk(q, a), urdf.fk(q, b), atol=1e-12), a
            for reference in ("world", "local"):
                assert np.allclose(
                    dh.jacobian(q, a, reference), urdf.jacobian(q, b, reference), atol=1e-12
                )
        assert np.allclose(dh.mass_matrix(q), urdf.mass_matrix(q), atol=1e-12)
        assert np.allclose(dh.gravity(q), urdf.gravity(q), atol=1e-10)


def test_panda_without_hand_is_lighter() -> None:
    q = rr.models.panda().neutral()
    with_hand = rr.models.panda(hand=True).gravity(q)
    without = rr.models.panda(hand=False).gravity(q)
    assert abs(with_hand[1]) > abs(without[1])


def test_example_robot_data_missing_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    from importlib import metadata

    def not_installed(name: str) -> None:
        raise metadata.PackageNotFoundError(name)

    monkeypatch.setattr(metadata, "distribution", not_installed)
    with pytest.raises(MissingDependencyError, match=re.escape(install_hint("robots"))):
        rr.models.example_robot("panda")


def test_example_robot_data_loads_a_urdf_by_name() -> None:
    pytest.importorskip("cmeel")
    try:
        names = rr.models.example_robot_names()
    except MissingDependencyError:
        pytest.skip("the robots extra (example-robot-data) is not installed")
    assert "panda" in names
    robot = rr.models.example_robot("panda", tip="panda_hand")
    assert robot.n == 7
    reference = rr.models.panda()
    q = reference.neutral()
    assert np.allclose(robot.fk(q)[:3, 3], reference.fk(q, "hand")[:3, 3], atol=1e-6)
    with pytest.raises(RobotNotFoundError, match="no URDF named"):
        rr.models.example_robot("no_such_robot")
