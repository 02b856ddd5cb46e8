"""Every number of an MJCF is read and checked before Pinocchio builds the model: its
parser fills a short or unreadable ``pos`` from uninitialised memory, takes a zero axis,
a zero quaternion, a negative mass or size (the reliability issue's reproductions)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.errors import MJCFError, ModelFileError, URDFError

ARM = """<mujoco model="two">
  <default><default class="arm"><joint damping="{damping}"/></default></default>
  <worldbody>
    <body name="b0">
      <joint name="j1" type="hinge" axis="{axis}" range="{range}"/>
      <geom type="capsule" size="0.05" fromto="0 0 0 0 0 0.3" mass="{mass}"/>
      <body name="b1" pos="{pos}" quat="{quat}" childclass="arm">
        <inertial pos="0 0 0.1" mass="1" diaginertia="{inertia}"/>
        <joint name="j2" type="hinge" axis="0 1 0" range="-90 90"/>
        <geom type="sphere" size="{size}"/>
        <site name="tip" pos="0 0 0.2"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

GOOD = dict(axis="0 0 1", range="-90 90", mass="1", pos="0 0 0.3", quat="1 0 0 0",
            size="0.05", inertia="0.01 0.01 0.01", damping="0.5")  # fmt: skip


def write(tmp_path: Path, **changes: str) -> Path:
    path = tmp_path / "arm.xml"
    path.write_text(ARM.format(**{**GOOD, **changes}))
    return path


def test_the_unchanged_arm_loads_and_matches_mujoco(tmp_path: Path) -> None:
    """The fixture is valid: MuJoCo's own kinematics agree, so each case below fails by
    the one attribute it changes."""
    mujoco = pytest.importorskip("mujoco", reason="the mujoco extra is not installed")
    path = write(tmp_path)
    robot = rr.Robot.from_mjcf(path, tip="tip")
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    q = np.array([0.3, -0.7])
    data.qpos[:] = q
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(robot.fk(q)[:3, 3], data.site_xpos[0], atol=1e-12)


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("pos", "0.3 0", r"<body name='b1' pos='0.3 0'>: needs 3 finite number"),
        ("pos", "a b c", r"<body name='b1' pos='a b c'>: needs 3 finite"),
        ("pos", "nan 0 0", r"pos='nan 0 0'>: needs 3 finite"),
        ("pos", "0 0 1e9", r"pos='0 0 1e9'>: must lie within"),
        ("range", "nan 1", r"<joint name='j1' range='nan 1'>: needs 2 finite"),
        ("range", "90 -90", r"range='90 -90'>: the low end is above the high end"),
        ("axis", "0 0 0", r"<joint name='j1' axis='0 0 0'>: is all zero, no direction"),
        ("mass", "-1", r"<geom mass='-1'>: must not be negative"),
        ("quat", "0 0 0 0", r"quat='0 0 0 0'>: is all zero, no rotation"),
        ("size", "-1", r"<geom size='-1'>: must not be negative"),
        ("inertia", "0.01 -0.01 0.01", r"<inertial diaginertia='0.01 -0.01 0.01'>: must not"),
        ("damping", "x", r"<joint damping='x'>: needs 1 finite"),  # in a default class
    ],
)
def test_malformed_numbers_are_refused_by_element_and_attribute(
    tmp_path: Path, key: str, value: str, message: str
) -> None:
    path = write(tmp_path, **{key: value})
    with pytest.raises(MJCFError, match=message) as caught:
        rr.Robot.from_mjcf(path, tip="tip")
    assert str(path) in str(caught.value)  # the file is named
    assert isinstance(caught.value, ModelFileError) and not isinstance(caught.value, URDFError)


def test_the_shared_checks_name_an_mjcf_error(tmp_path: Path) -> None:
    """The chain reduction is shared with URDF; its refusals of an MJCF are MJCF errors."""
    with pytest.raises(MJCFError, match="no frame named 'hand'"):
        rr.Robot.from_mjcf(write(tmp_path), tip="hand")
