"""An MJCF robot carries the limits its file gives: the torque limits of the actuators
that drive its joints (through default classes and gears, capped by a joint's
``actuatorfrcrange``), and ``continuous_limits`` for a hinge without a range. Oracle:
MuJoCo's own compiled model of the same file."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.models import menagerie_path

mujoco = pytest.importorskip("mujoco", reason="the mujoco extra is not installed")

ARM = """<mujoco model="actuated_arm">
  <compiler angle="radian"/>
  <default>
    <joint damping="1"/>
    <general forcerange="-100 100"/>
    <default class="big">
      <general gear="3"/>
      <default class="big_capped">
        <joint actuatorfrcrange="-70 70"/>
      </default>
    </default>
    <default class="small">
      <motor forcerange="-12 12"/>
    </default>
  </default>
  <worldbody>
    <body name="l1" pos="0 0 0.1">
      <inertial pos="0 0 0.1" mass="1" diaginertia="0.01 0.01 0.01"/>
      <joint name="j1" axis="0 0 1"/>
      <body name="l2" pos="0 0 0.3" childclass="big_capped">
        <inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
        <joint name="j2" axis="0 1 0" range="-1.5 1.5"/>
        <body name="l3" pos="0.3 0 0">
          <inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
          <joint name="j3" axis="0 1 0" range="-2 2" class="small"/>
          <body name="l4" pos="0.3 0 0">
            <inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
            <joint name="j4" axis="0 0 1" range="-2 2" class="small"/>
            <site name="tool" pos="0.1 0 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general name="a1" joint="j1" class="big"/>
    <general name="a2" joint="j2" class="big"/>
    <motor name="a3" joint="j3" class="small" gear="-2"/>
    <motor name="a3b" joint="j3" class="small"/>
    <motor name="a4" joint="j4" class="small" forcelimited="false"/>
  </actuator>
</mujoco>
"""


def _mujoco_limits(path: Path, names: list[str]) -> np.ndarray:
    """Each named joint's torque limit as MuJoCo compiles the file: the sum of
    ``|gear| · max|forcerange|`` over the force-limited actuators on it, capped by the
    joint's force-limited ``actuatorfrcrange``."""
    model = mujoco.MjModel.from_xml_path(str(path))
    out = []
    for name in names:
        j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        total, driven = 0.0, False
        for a in range(model.nu):
            if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and (
                model.actuator_trnid[a, 0] == j and model.actuator_forcelimited[a]
            ):
                total += abs(model.actuator_gear[a, 0]) * np.abs(model.actuator_forcerange[a]).max()
                driven = True
        limit = total if driven else math.inf
        if model.jnt_actfrclimited[j]:
            limit = min(limit, np.abs(model.jnt_actfrcrange[j]).max())
        out.append(limit)
    return np.array(out)


def test_torque_limits_through_classes_gears_and_caps_equal_mujocos(tmp_path: Path) -> None:
    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    robot = rr.Robot.from_mjcf(path, tip="tool", capsules=False)
    names = ["j1", "j2", "j3", "j4"]
    expected = _mujoco_limits(path, names)
    np.testing.assert_array_equal(robot.tau_max, expected)
    # the cases this file builds, spelled out: gear 3 x 100; capped at 70; 2 x 12 + 12; none
    np.testing.assert_array_equal(expected, [300.0, 70.0, 36.0, math.inf])


def test_a_hinge_without_a_range_takes_continuous_limits(tmp_path: Path) -> None:
    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    model = mujoco.MjModel.from_xml_path(str(path))
    assert not model.jnt_limited[0]  # MuJoCo: joint j1 is unlimited
    robot = rr.Robot.from_mjcf(path, tip="tool", capsules=False)
    assert (robot.q_min[0], robot.q_max[0]) == (-math.pi, math.pi)
    np.testing.assert_array_equal(robot.q_min[1:], model.jnt_range[1:, 0])
    wide = rr.Robot.from_mjcf(path, tip="tool", capsules=False, continuous_limits=(-6.0, 6.0))
    assert (wide.q_min[0], wide.q_max[0]) == (-6.0, 6.0)
    assert wide.within_limits(wide.random_configuration(np.random.default_rng(0)))


@pytest.mark.parametrize("arm", ["panda", "fr3", "iiwa14", "xarm7", "arm3_menagerie.xml"])
def test_menagerie_arms_carry_their_files_torque_limits(arm: str, fixtures_dir: Path) -> None:
    path = fixtures_dir / arm if arm.endswith(".xml") else menagerie_path(arm)
    robot = rr.Robot.from_mjcf(path, capsules=False)
    names = [str(robot.model.names[j]) for j in range(1, robot.model.njoints)]
    np.testing.assert_array_equal(robot.tau_max, _mujoco_limits(path, names))


def test_a_bad_forcerange_is_named(tmp_path: Path) -> None:
    path = tmp_path / "arm.xml"
    path.write_text(ARM.replace('<motor name="a3" joint="j3" class="small" gear="-2"/>',
                                '<motor name="a3" joint="j3" forcerange="-5"/>'))  # fmt: skip
    with pytest.raises(rr.errors.MJCFError, match=r"actuator on joint 'j3' forcerange"):
        rr.Robot.from_mjcf(path, tip="tool", capsules=False)
