"""URDF loading: chains, locked branches, continuous joints, and clear errors."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.errors import ModelFileNotFoundError, URDFError
from redres.testing import assert_jacobian_close, frame_jacobian_fd

TWO_LINK = """<?xml version="1.0"?>
<robot name="two">
  <link name="base"/>
  <joint name="j1" type="{kind}">
    <parent link="base"/><child link="l1"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" velocity="2" effort="5"/>
  </joint>
  <link name="l1"><inertial><mass value="1"/><origin xyz="0.2 0 0"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="j2" type="revolute">
    <parent link="l1"/><child link="l2"/><origin xyz="0.4 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" velocity="3" effort="4"/>
  </joint>
  <link name="l2"><inertial><mass value="0.5"/><origin xyz="0.1 0 0"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
</robot>
"""


def write(tmp_path: Path, text: str, name: str = "robot.urdf") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_unbranched_chain_defaults_to_its_last_link(tmp_path: Path) -> None:
    robot = rr.Robot.from_urdf(write(tmp_path, TWO_LINK.format(kind="revolute")))
    assert robot.n == 2 and robot.tip == "l2" and robot.name == "two"
    assert np.allclose(robot.q_min, [-1, -2]) and np.allclose(robot.qd_max, [2, 3])
    assert np.allclose(robot.tau_max, [5, 4])


def test_continuous_joint_becomes_a_bounded_revolute_joint(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    path = write(tmp_path, TWO_LINK.format(kind="continuous"))
    robot = rr.Robot.from_urdf(path, continuous_limits=(-3.0, 3.0))
    reference = rr.Robot.from_urdf(write(tmp_path, TWO_LINK.format(kind="revolute"), "r.urdf"))
    assert robot.n == 2 and robot.q_min[0] == -3.0 and robot.q_max[0] == 3.0
    for _ in range(5):
        q = rng.uniform(-1, 1, 2)
        assert np.allclose(robot.fk(q), reference.fk(q), atol=1e-14)
        assert np.allclose(robot.mass_matrix(q), reference.mass_matrix(q), atol=1e-14)
        assert_jacobian_close(robot.jacobian(q), frame_jacobian_fd(robot, q), atol=1e-8)


def test_branches_are_locked_at_the_given_value(fixtures_dir: Path) -> None:
    path = fixtures_dir / "panda_description.urdf"
    open_hand = rr.Robot.from_urdf(path, tip="panda_hand", locked={"panda_finger_joint1": 0.04})
    closed = rr.Robot.from_urdf(path, tip="panda_hand")
    q = open_hand.neutral()
    finger_open = open_hand.fk(q, "panda_finger1")[:3, 3]
    finger_closed = closed.fk(q, "panda_finger1")[:3, 3]
    assert open_hand.n == 7
    assert np.linalg.norm(finger_open - finger_closed) == pytest.approx(0.04, abs=1e-12)


def test_a_branching_urdf_needs_a_tip(fixtures_dir: Path) -> None:
    with pytest.raises(URDFError, match="branches; pass tip=.*panda_hand"):
        rr.Robot.from_urdf(fixtures_dir / "panda_description.urdf")


def test_a_tip_on_a_finger_keeps_the_finger_joint(fixtures_dir: Path) -> None:
    robot = rr.Robot.from_urdf(fixtures_dir / "panda_description.urdf", tip="panda_finger1")
    assert robot.n == 8 and robot.joint_names[-1] == "panda_finger_joint1"


def test_missing_file(tmp_path: Path) -> None:
    missing = tmp_path / "nope.urdf"
    with pytest.raises(ModelFileNotFoundError, match="nope.urdf") as info:
        rr.Robot.from_urdf(missing)
    assert isinstance(info.value, FileNotFoundError)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("<robot name='x'><link name='a'>", "not well-formed XML"),
        ("<sdf version='1.6'/>", "root element is <sdf>, expected <robot>"),
        ("<robot name='x'/>", "has no <link>"),
        ("<robot name='x'><link name='a'/></robot>", "no movable joint"),
    ],
)
def test_malformed_urdf_names_the_file_and_the_problem(
    tmp_path: Path, text: str, message: str
) -> None:
    path = write(tmp_path, text, "broken.urdf")
    with pytest.raises(URDFError, match=message) as info:
        rr.Robot.from_urdf(path)
    assert "broken.urdf" in str(info.value) and isinstance(info.value, ValueError)


def test_unknown_tip_and_unknown_locked_joint(fixtures_dir: Path) -> None:
    path = fixtures_dir / "panda_description.urdf"
    with pytest.raises(URDFError, match="no frame named 'gripper'.*panda_hand"):
        rr.Robot.from_urdf(path, tip="gripper")
    with pytest.raises(URDFError, match="cannot lock unknown joint 'finger'"):
        rr.Robot.from_urdf(path, tip="panda_hand", locked={"finger": 0.0})


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            '<mass value="1"/>',
            '<mass value="-1"/>',
            r"link 'l1': <mass value='-1'> must be from 0 to 1e\+06 kg",
        ),
        ('<mass value="1"/>', '<mass value="nan"/>', r"link 'l1': <mass value='nan'> must be 1"),
        ('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>', r"joint 'j2': <axis xyz='0 0 0'> is no"),
        ('<axis xyz="0 1 0"/>', '<axis xyz="0 1"/>', r"joint 'j2': <axis xyz='0 1'> must be 3"),
        ('<axis xyz="0 1 0"/>', "<axis/>", r"joint 'j2': <axis> has no xyz"),
        ('upper="2"', 'upper="nan"', r"joint 'j2': <limit upper='nan'> must be 1 finite"),
        ('<origin xyz="0.4 0 0"/>', '<origin xyz="0.4 0 inf"/>', r"<origin xyz='0.4 0 inf'>"),
    ],
)
def test_physically_wrong_urdfs_are_refused_by_name(
    tmp_path: Path, old: str, new: str, message: str
) -> None:
    """Pinocchio builds these silently (issue 18, item 7)."""
    text = TWO_LINK.format(kind="revolute")
    assert old in text
    with pytest.raises(URDFError, match=message):
        rr.Robot.from_urdf(write(tmp_path, text.replace(old, new, 1)))


def long_chain(joints: int) -> str:
    body = ['<robot name="snake"><link name="l0"/>']
    for i in range(1, joints + 1):
        body.append(
            f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
            '<origin xyz="0 0 0.01"/><axis xyz="0 1 0"/>'
            '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'
            f'<link name="l{i}"/>'
        )
    return "".join(body) + "</robot>"


def test_chains_beyond_the_joint_limit_are_refused_before_building(tmp_path: Path) -> None:
    from redres.robot.dh import MAX_JOINTS

    assert rr.Robot.from_urdf(write(tmp_path, long_chain(MAX_JOINTS))).n == MAX_JOINTS
    with pytest.raises(URDFError, match=rf"2000 movable joints; .* at most {MAX_JOINTS}"):
        rr.Robot.from_urdf(write(tmp_path, long_chain(2000)))  # Pinocchio would need GBs
    links = [dict(a=0.01, alpha=0.0, d=0.0)] * (MAX_JOINTS + 1)
    with pytest.raises(rr.errors.DHParameterError, match=rf"101 DH records; .* {MAX_JOINTS}"):
        rr.Robot.from_dh(links)


def test_a_tip_at_the_root_says_so(tmp_path: Path) -> None:
    path = write(tmp_path, TWO_LINK.format(kind="revolute"))
    with pytest.raises(URDFError, match=r"no movable joint between the root and tip 'base'"):
        rr.Robot.from_urdf(path, tip="base")


def test_a_urdf_in_another_encoding_loads_as_its_utf8_twin(
    tmp_path: Path, fixtures_dir: Path, rng: np.random.Generator
) -> None:
    """An ISO-8859-1 URDF (declared in its header) with a non-ASCII robot name was a raw
    UnicodeDecodeError from Pinocchio's names; it is read as the same robot."""
    text = (fixtures_dir / "arm3.urdf").read_text(encoding="utf-8")
    assert text.startswith('<?xml version="1.0"?>') and '<robot name="arm3">' in text
    latin = text.replace('<?xml version="1.0"?>', '<?xml version="1.0" encoding="ISO-8859-1"?>')
    latin = latin.replace('<robot name="arm3">', '<robot name="bras-\xe9">')
    path = tmp_path / "bras.urdf"
    path.write_bytes(latin.encode("latin-1"))
    shutil.copytree(fixtures_dir / "meshes", tmp_path / "meshes")  # found beside the file
    robot = rr.Robot.from_urdf(path)
    reference = rr.Robot.from_urdf(fixtures_dir / "arm3.urdf")
    assert robot.name == "bras-\xe9"
    assert len(robot.capsules) == len(reference.capsules)
    q = reference.random_configuration(rng)
    np.testing.assert_array_equal(robot.fk(q), reference.fk(q))
