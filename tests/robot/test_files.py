"""Robots from the files users bring: MJCF, URDF text, tips that follow the link tree,
a neutral pose that is not a limit, and robots under tighter limits."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.errors import (
    InvalidParameterError,
    MJCFError,
    ModelFileNotFoundError,
    ShapeError,
    URDFError,
)
from redres.testing import assert_jacobian_close, frame_jacobian_fd


@pytest.fixture(scope="module")
def arms(fixtures_dir: Path) -> tuple[rr.Robot, rr.Robot]:
    return (rr.Robot.from_urdf(fixtures_dir / "arm3.urdf"),
            rr.Robot.from_mjcf(fixtures_dir / "arm3.xml"))  # fmt: skip


def test_mjcf_gives_the_urdf_arm(arms: tuple[rr.Robot, rr.Robot], rng: np.random.Generator) -> None:
    urdf, mjcf = arms
    assert urdf.n == mjcf.n == 3 and urdf.tip == mjcf.tip == "tool"
    assert mjcf.joint_names == ["j1", "j2", "j3"]
    np.testing.assert_allclose(mjcf.q_min, urdf.q_min)
    np.testing.assert_allclose(mjcf.q_max, urdf.q_max)
    for _ in range(10):
        q = urdf.random_configuration(rng)
        np.testing.assert_allclose(mjcf.fk(q), urdf.fk(q), atol=1e-12)
        for frame in ("l2", "l3", "tool"):
            np.testing.assert_allclose(mjcf.fk(q, frame), urdf.fk(q, frame), atol=1e-12)
        np.testing.assert_allclose(mjcf.jacobian(q), urdf.jacobian(q), atol=1e-12)
        np.testing.assert_allclose(mjcf.jacobian(q, reference="local"),
                                   urdf.jacobian(q, reference="local"), atol=1e-12)  # fmt: skip
        assert_jacobian_close(mjcf.jacobian(q), frame_jacobian_fd(mjcf, q), atol=1e-7)
        np.testing.assert_allclose(mjcf.mass_matrix(q), urdf.mass_matrix(q), atol=1e-10)


def test_mjcf_keyframe_home_is_the_neutral_pose(arms: tuple[rr.Robot, rr.Robot]) -> None:
    np.testing.assert_allclose(arms[1].neutral(), [0.3, 0.4, -0.8])
    assert np.all(np.isinf(arms[1].qd_max))  # MJCF has no velocity limits


def test_missing_and_malformed_mjcf(tmp_path: Path) -> None:
    with pytest.raises(ModelFileNotFoundError, match="MJCF file not found"):
        rr.Robot.from_mjcf(tmp_path / "nope.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<robot/>")
    with pytest.raises(MJCFError, match="expected <mujoco>") as caught:
        rr.Robot.from_mjcf(bad)
    assert not isinstance(caught.value, URDFError)  # an MJCF problem is named as one


def test_urdf_string_gives_the_file_robot(fixtures_dir: Path, rng: np.random.Generator) -> None:
    path = fixtures_dir / "arm3.urdf"
    text = path.read_text()
    robot = rr.Robot.from_urdf_string(text, mesh_dir=fixtures_dir)
    reference = rr.Robot.from_urdf(path)
    q = reference.random_configuration(rng)
    np.testing.assert_allclose(robot.fk(q), reference.fk(q), atol=1e-14)
    assert len(robot.capsules) == len(reference.capsules) == 3
    assert len(robot.visuals) == len(reference.visuals)


def test_urdf_text_given_as_a_path_says_what_to_do() -> None:
    text = "<robot name='x'>" + "<link name='a'/>" * 400 + "</robot>"
    with pytest.raises(URDFError, match="from_urdf_string"):
        rr.Robot.from_urdf(text)


KINOVA_LIKE = """<?xml version="1.0"?>
<robot name="kinova_like">
  <link name="base"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1" effort="1"/>
  </joint>
  <link name="l1"/>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="hand"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="1" effort="1"/>
  </joint>
  <link name="hand"/>
  <joint name="finger_left_joint" type="fixed"><parent link="hand"/><child link="finger_left"/>
    <origin xyz="0.02 0 0.1"/></joint>
  <link name="finger_left"/>
  <joint name="finger_right_joint" type="fixed"><parent link="hand"/><child link="finger_right"/>
    <origin xyz="-0.02 0 0.1"/></joint>
  <link name="finger_right"/>
</robot>
"""


def test_fixed_fingers_make_the_link_tree_branch_so_the_tip_is_asked_for() -> None:
    with pytest.raises(URDFError, match=r"links fixed after joint 'j2' branch .*pass tip="):
        rr.Robot.from_urdf_string(KINOVA_LIKE)
    robot = rr.Robot.from_urdf_string(KINOVA_LIKE, tip="hand")
    assert robot.tip == "hand" and robot.n == 2
    one_finger = KINOVA_LIKE.replace(
        KINOVA_LIKE[KINOVA_LIKE.index('  <joint name="finger_right_joint"'):
                    KINOVA_LIKE.index("</robot>")], "")  # fmt: skip
    assert rr.Robot.from_urdf_string(one_finger).tip == "finger_left"  # unbranched: the end


def test_file_robots_start_mid_range_not_on_a_limit(fixtures_dir: Path) -> None:
    robot = rr.Robot.from_urdf(fixtures_dir / "panda_description.urdf", tip="panda_hand")
    np.testing.assert_allclose(robot.neutral(), 0.5 * (robot.q_min + robot.q_max))
    assert np.all(robot.joint_limit_margin(robot.neutral()) > 0.3)
    zero = np.clip(np.zeros(robot.n), robot.q_min, robot.q_max)  # the old default
    assert robot.joint_limit_margin(zero).min() == pytest.approx(0.0, abs=1e-12)
    sigma = np.linalg.svd(robot.jacobian(robot.neutral()), compute_uv=False)[-1]
    sigma_zero = np.linalg.svd(robot.jacobian(zero), compute_uv=False)[-1]
    assert sigma > 3 * sigma_zero  # σ_min 0.149 against 0.041 at the stretched pose


def test_with_limits_returns_a_tighter_robot() -> None:
    panda = rr.models.panda()
    slow = panda.with_limits(qd_max=0.5 * panda.qd_max, qdd_max=3.0)
    np.testing.assert_allclose(slow.qd_max, 0.5 * panda.qd_max)
    np.testing.assert_allclose(slow.qdd_max, 3.0)
    np.testing.assert_allclose(panda.qd_max, rr.models.panda().qd_max)  # unchanged
    assert slow.capsules == panda.capsules and slow.tip == panda.tip
    q = panda.random_configuration(1)
    np.testing.assert_allclose(slow.fk(q), panda.fk(q), atol=0)
    with pytest.raises(InvalidParameterError, match="cannot raise"):
        panda.with_limits(qd_max=2 * panda.qd_max)
    with pytest.raises(InvalidParameterError, match="positive"):
        panda.with_limits(tau_max=0.0)
    with pytest.raises(ShapeError):
        panda.with_limits(qd_max=[1.0, 2.0])


@pytest.mark.parametrize(
    ("loader", "fixture", "keyword", "suggested"),
    [
        ("from_urdf", "arm3.urdf", "capsuls", "capsules"),
        ("from_mjcf", "arm3.xml", "lockd", "locked"),
        ("from_urdf_string", "arm3.urdf", "mesh_dri", "mesh_dir"),
    ],
)
def test_a_misspelt_loader_option_names_the_nearest_one(
    fixtures_dir: Path, loader: str, fixture: str, keyword: str, suggested: str
) -> None:
    path = fixtures_dir / fixture
    source = path.read_text() if loader == "from_urdf_string" else path
    with pytest.raises(rr.errors.UnknownParameterError, match=f"did you mean '{suggested}'"):
        getattr(rr.Robot, loader)(source, **{keyword: 1})
    robot = getattr(rr.Robot, loader)(source, name="renamed", capsules=False)
    assert robot.name == "renamed" and not robot.capsules


@pytest.mark.parametrize(
    ("options", "error", "message"),
    [
        ({"tip": 5}, InvalidParameterError, "tip must be a frame name"),
        ({"locked": 5}, InvalidParameterError, "locked must map joint names to positions"),
        ({"locked": {"j1": "a"}}, InvalidParameterError, r"locked\['j1'\] must be a number"),
        ({"continuous_limits": "ab"}, ShapeError, "continuous_limits must be a pair"),
        ({"continuous_limits": (1,)}, InvalidParameterError, "two finite numbers low < high"),
        ({"continuous_limits": (1, -1)}, InvalidParameterError, "two finite numbers low < high"),
        ({"capsules": "no"}, InvalidParameterError, "capsules must be True or False"),
        ({"name": 3}, InvalidParameterError, "name must be a string"),
    ],
)
def test_loader_options_are_checked_by_name(
    fixtures_dir: Path, options: dict, error: type, message: str
) -> None:
    """Each of these was a raw TypeError, a C++ signature mismatch, or silently accepted."""
    with pytest.raises(error, match=message):
        rr.Robot.from_urdf(fixtures_dir / "arm3.urdf", **options)


@pytest.mark.parametrize(
    ("value", "error"),
    [("abc", ShapeError), (1 + 2j, InvalidParameterError), ({}, ShapeError),
     (10**400, ShapeError), ([[1, 2], [3]], ShapeError), ([1.0, 2.0], ShapeError)],
)  # fmt: skip
def test_with_limits_refuses_what_is_not_a_limit(value: object, error: type) -> None:
    with pytest.raises(error, match="qd_max"):
        rr.models.panda().with_limits(qd_max=value)


def test_with_limits_names_an_unknown_keyword() -> None:
    with pytest.raises(rr.errors.UnknownParameterError, match="'qd_mx'.*qd_max"):
        rr.models.panda().with_limits(qd_mx=1.0)
