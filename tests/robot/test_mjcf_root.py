"""A jointless base body under ``<worldbody>`` keeps its placement (Pinocchio's MJCF parser
drops it): forward kinematics equal MuJoCo's own for every way MJCF writes an
orientation."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import redres as rr

mujoco = pytest.importorskip("mujoco", reason="the mujoco extra is not installed")

ARM = """<mujoco model="base_arm">
  {compiler}
  <worldbody>
    <body name="base" pos="0.1 -0.2 0.12" {orientation}>
      <body name="mount" pos="0.05 0 0.02" quat="0.9238795 0 0 0.3826834">
        <body name="l1" pos="0 0 0.1">
          <inertial mass="1" pos="0 0 0.1" diaginertia="0.01 0.01 0.01"/>
          <joint name="j1" axis="0 0 1" range="-2 2"/>
          <body name="l2" pos="0.3 0 0">
            <inertial mass="1" pos="0.1 0 0" diaginertia="0.01 0.01 0.01"/>
            <joint name="j2" axis="0 1 0" range="-2 2"/>
            <site name="tip" pos="0.2 0.01 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

ORIENTATIONS = [
    ("", ""),
    ("", 'quat="0.9 0.1 -0.3 0.2"'),
    ("", 'axisangle="1 2 3 40"'),
    ("", 'euler="10 -20 30"'),
    ('<compiler angle="radian" eulerseq="ZYX"/>', 'euler="0.2 -0.4 0.6"'),
    ('<compiler angle="radian" eulerseq="xzy"/>', 'euler="0.2 -0.4 0.6"'),
    ("", 'xyaxes="0 1 0 -1 0.2 0"'),
    ("", 'zaxis="0.3 -0.2 1"'),
]


@pytest.mark.parametrize(("compiler", "orientation"), ORIENTATIONS)
def test_a_fixed_base_body_keeps_its_placement(
    tmp_path: Path, compiler: str, orientation: str, rng: np.random.Generator
) -> None:
    path = tmp_path / "arm.xml"
    path.write_text(ARM.format(compiler=compiler, orientation=orientation))
    robot = rr.Robot.from_mjcf(path, tip="tip")
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    for _ in range(5):
        q = rng.uniform(-2.0, 2.0, 2)
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for name in ("base", "mount", "l1", "l2"):
            body = model.body(name).id
            T = robot.fk(q, name)
            np.testing.assert_allclose(T[:3, 3], data.xpos[body], rtol=0, atol=1e-12)
            np.testing.assert_allclose(T[:3, :3], data.xmat[body].reshape(3, 3), atol=1e-12)
        np.testing.assert_allclose(robot.fk(q)[:3, 3], data.site_xpos[0], rtol=0, atol=1e-12)


def test_a_branching_file_names_its_sites_as_tips(tmp_path: Path) -> None:
    """Two fingers make the tree branch: the error lists the links and the sites (an MJCF's
    TCP is usually a site), and a site given as tip is taken."""
    arm = ARM.format(compiler="", orientation="").replace(
        '<site name="tip" pos="0.2 0.01 0"/>',
        '<site name="tip" pos="0.2 0.01 0"/>'
        '<body name="left" pos="0.25 0.02 0"><joint name="f1" axis="0 1 0" range="0 0.04"/>'
        '<inertial mass="0.1" pos="0 0 0" diaginertia="1e-4 1e-4 1e-4"/></body>'
        '<body name="right" pos="0.25 -0.02 0"><joint name="f2" axis="0 1 0" range="0 0.04"/>'
        '<inertial mass="0.1" pos="0 0 0" diaginertia="1e-4 1e-4 1e-4"/></body>',
    )
    path = tmp_path / "hand.xml"
    path.write_text(arm)
    with pytest.raises(rr.errors.MJCFError, match=r"branches; pass tip= one of its links: .*"
                       r"left, right; or of its sites: tip"):  # fmt: skip
        rr.Robot.from_mjcf(path)
    assert rr.Robot.from_mjcf(path, tip="tip").tip == "tip"
