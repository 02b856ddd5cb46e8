"""MuJoCo as an independent plant: redres' kinematics and dynamics of four MuJoCo Menagerie
arms equal MuJoCo's own; controllers computed with redres' model track on MuJoCo's
simulation; redres' own simulator includes the file's damping, armature and friction."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.dynamics import GravityCompensation, OperationalSpaceController, Payload, with_payload
from redres.models.mujoco_menagerie import SHIPPED
from redres.objectives import JointLimitObjective, PostureObjective
from redres.resolution import GradientProjectionScheme
from redres.tasks import FrameTask

mujoco = pytest.importorskip("mujoco", reason="the mujoco extra is not installed")
from redres.sim import MujocoPlant, run_on_mujoco, simulate_on_mujoco  # noqa: E402

MENAGERIE = SHIPPED
ARMS = ["panda", "fr3", "iiwa14", "xarm7"]


def _plant(name: str) -> MujocoPlant:
    return MujocoPlant(rr.models.menagerie_path(name, MENAGERIE), timestep=1e-3)


@pytest.mark.parametrize("name", ARMS)
def test_kinematics_and_dynamics_equal_mujocos(name: str, rng: np.random.Generator) -> None:
    """Every body's pose and the tracked site's Jacobian (``mj_kinematics``,
    ``mj_jacSite``) to 1e-12; the mass matrix (``mj_fullM``, armature included) and the
    bias forces (``qfrc_bias``) to 1e-11 of their size."""
    plant = _plant(name)
    robot = plant.robot()
    m, d = plant.model, plant.data
    for _ in range(10):
        q = robot.random_configuration(rng)
        qd = rng.uniform(-1.5, 1.5, robot.n)
        plant.reset(q, qd)
        for body in range(1, m.nbody):
            T = robot.fk(q, m.body(body).name)
            np.testing.assert_allclose(T[:3, 3], d.xpos[body], rtol=0, atol=1e-12)
            np.testing.assert_allclose(T[:3, :3], d.xmat[body].reshape(3, 3), rtol=0, atol=1e-12)
        np.testing.assert_allclose(robot.fk(q), plant.pose(), rtol=0, atol=1e-12)
        np.testing.assert_allclose(robot.jacobian(q), plant.jacobian(), rtol=0, atol=1e-12)
        M = robot.mass_matrix(q)
        np.testing.assert_allclose(M, plant.mass_matrix(), rtol=0, atol=1e-11 * np.abs(M).max())
        b = robot.bias(q, qd)
        np.testing.assert_allclose(b, plant.bias(), rtol=0, atol=1e-11 * np.abs(b).max())


def test_the_xarm7_base_is_where_mujoco_puts_it() -> None:
    """The xArm7's base body sits 0.12 m up (Pinocchio's parser alone drops it)."""
    robot = _plant("xarm7").robot()
    np.testing.assert_allclose(robot.fk(robot.neutral(), "link_base")[:3, 3], [0, 0, 0.12])


def _circle(robot: rr.Robot, q0: np.ndarray) -> rr.control.Circle:
    return rr.control.Circle(robot.fk(q0), 0.05, 4.0, ramp=0.5, normal=(1.0, 0.0, 0.0))


def test_the_controller_tracks_through_mujocos_position_actuators() -> None:
    """Gradient projection on the Panda, commands to MuJoCo's position servos: a 5 cm
    circle tracked within 1 mm, measured by MuJoCo's kinematics."""
    plant = _plant("panda")
    robot = plant.robot()
    q0 = robot.neutral()
    scheme = GradientProjectionScheme([JointLimitObjective()])
    log = run_on_mujoco(plant, FrameTask(), _circle(robot, q0), scheme, q0=q0, duration=2.0)
    assert log.position_error.max() < 1e-3
    commanded = log.extra["q_command"]
    assert np.abs(log.q[1:] - commanded[:-1]).max() < 1e-3  # the servos follow the commands


def test_operational_space_control_on_mujoco_and_on_redres_agree() -> None:
    """OSC on MuJoCo's Panda and on redres' own simulator of the same file (damping and
    armature included): the same tracking, to a micrometre; with a 1.5 kg payload the law
    knows, within 1 mm after settling."""
    plant = _plant("panda")
    robot = plant.robot()
    q0 = robot.neutral()
    law = OperationalSpaceController(kp=400.0, objectives=[(PostureObjective(q0), 1.0)])
    circle = _circle(robot, q0)
    on_mujoco = simulate_on_mujoco(plant, law, circle, q0=q0, duration=2.0)
    on_redres = rr.dynamics.simulate(robot, law, circle, q0=q0, duration=2.0)
    settled = slice(500, None)
    assert on_mujoco.position_error[settled].max() < 5e-5
    np.testing.assert_allclose(on_mujoco.position_error, on_redres.position_error, atol=1e-6)
    load = Payload(1.5, com=(0.0, 0.0, 0.05), frame=plant.frame)
    plant.add_payload(load)
    loaded = simulate_on_mujoco(plant, law, circle, robot=with_payload(robot, load), q0=q0,
                                duration=2.0)  # fmt: skip
    assert loaded.position_error[settled].max() < 1e-3


def test_the_null_space_torque_leaves_the_task_acceleration_on_mujoco(
    rng: np.random.Generator,
) -> None:
    """The dynamically consistent null-space torque, applied by MuJoCo, changes the task
    acceleration by less than 1e-9 of what the same torque unprojected would."""
    plant = _plant("panda")
    robot = plant.robot()
    m, d = plant.model, plant.data
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ACTUATION
    for _ in range(10):
        q, qd = robot.random_configuration(rng, margin=0.2), rng.uniform(-1, 1, robot.n)
        J, M = robot.jacobian(q), robot.mass_matrix(q)
        tau0 = rng.standard_normal(robot.n) * 5.0
        out = rr.dynamics.operational_space_torque(J, M, robot.bias(q, qd), np.zeros(6), tau0)
        accelerations = []
        for tau in (out.tau - out.null, out.tau, out.tau - out.null + tau0):
            plant.reset(q, qd)
            d.qfrc_applied[:] = tau
            mujoco.mj_forward(m, d)
            accelerations.append(J @ d.qacc)
        change = np.linalg.norm(accelerations[1] - accelerations[0])
        unprojected = np.linalg.norm(accelerations[2] - accelerations[0])
        assert change <= 1e-9 * unprojected


@pytest.mark.parametrize("name", ["panda", "xarm7"])
def test_redres_simulator_has_the_files_damping(name: str) -> None:
    """Gravity compensated and spinning at 0.5 rad/s, each arm slows down by its joints'
    damping: redres' simulator and MuJoCo agree on the velocities after 0.3 s (to the
    difference of their integrators), and would not without the damping."""
    plant = _plant(name)
    robot = plant.robot()
    q0, qd0 = robot.neutral(), np.full(robot.n, 0.5)
    law = GravityCompensation()
    on_mujoco = simulate_on_mujoco(plant, law, q0=q0, qd0=qd0, duration=0.3)
    on_redres = rr.dynamics.simulate(robot, law, q0=q0, qd0=qd0, duration=0.3)
    gap = np.abs(on_mujoco.extra["final_qd"] - on_redres.extra["final_qd"]).max()
    slowed = np.abs(qd0 - on_mujoco.extra["final_qd"]).max()
    assert slowed > 0.05 and gap < 0.05 * slowed


def test_dry_friction_holds_a_joint_below_its_friction_torque() -> None:
    """The FR3's joints have friction losses of 0.25–1.14 N·m: a torque below one holds the
    joint still in both simulators, a torque above it turns the joint."""
    plant = _plant("fr3")
    robot = plant.robot().derived(name="fr3")
    q0 = robot.neutral()
    f = robot.model.friction[6]

    class Push(rr.dynamics.TorqueLaw):
        name = "push"

        def __init__(self, torque: float) -> None:
            self.torque = torque

        def step(self, robot, q, qd, sample=None):  # type: ignore[no-untyped-def]
            tau = robot.gravity(q)
            tau[6] += self.torque
            return rr.dynamics.ControlStep(tau)

    for scale, moves in ((0.5, False), (3.0, True)):
        law = Push(scale * f)
        for log in (simulate_on_mujoco(plant, law, q0=q0, duration=0.2),
                    rr.dynamics.simulate(robot, law, q0=q0, duration=0.2)):  # fmt: skip
            turned = abs(log.extra["final_q"][6] - q0[6])
            assert (turned > 1e-3) == moves, (scale, turned)


def test_a_menagerie_checkout_gives_robots_with_the_vendors_limits(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The shipped copies are laid out like a Menagerie checkout and serve without one:
    the FR3 comes with Franka's published limits (MJCF files have none), the iiwa14 with
    the file's; unknown names and a missing file are refused with the fix."""
    fr3 = rr.models.menagerie("fr3", MENAGERIE)
    np.testing.assert_array_equal(fr3.qddd_max, rr.models.franka.FR3.qddd_max)
    np.testing.assert_array_equal(fr3.qd_max, rr.models.franka.FR3.qd_max)
    monkeypatch.setenv("MUJOCO_MENAGERIE", str(MENAGERIE))
    assert rr.models.menagerie("iiwa14").n == 7
    path = rr.models.menagerie_path("ufactory_xarm7/xarm7_nohand.xml")
    assert path == MENAGERIE / "ufactory_xarm7" / "xarm7_nohand.xml"
    with pytest.raises(rr.errors.RobotNotFoundError, match="known: panda, fr3"):
        rr.models.menagerie("ur5")
    with pytest.raises(rr.errors.ModelFileNotFoundError, match="kinova_gen3/gen3.xml"):
        rr.models.menagerie("gen3")  # not in this checkout
    monkeypatch.delenv("MUJOCO_MENAGERIE")
    assert rr.models.menagerie_path("fr3") == MENAGERIE / "franka_fr3" / "fr3.xml"
    with pytest.raises(rr.errors.ModelFileNotFoundError, match="MUJOCO_MENAGERIE to a clone"):
        rr.models.menagerie("gen3")


def test_a_run_refuses_a_robot_that_is_not_the_plants_arm() -> None:
    """Every run compares the controller's robot with MuJoCo's forward kinematics first:
    another arm, or the same file's arm with another tip, is refused with the gap."""
    plant = _plant("panda")
    scheme = GradientProjectionScheme([JointLimitObjective()])
    for robot, message in ((rr.models.panda(), "joints"),
                           (plant.robot().derived(tip="link7"), "from MuJoCo's")):  # fmt: skip
        with pytest.raises(rr.errors.InvalidParameterError, match=message):
            run_on_mujoco(plant, FrameTask(), None, scheme, robot=robot, duration=0.01)


def test_a_payload_in_mujoco_is_the_payload_in_redres(rng: np.random.Generator) -> None:
    """``add_payload`` sums the load into the body's mass, centre of mass and inertia in
    MuJoCo's model: its mass matrix and bias forces then equal redres' ``with_payload``
    robot's (Pinocchio), to 1e-11 of their size."""
    plant = _plant("panda")
    robot = plant.robot()
    load = Payload(1.5, com=(0.01, -0.02, 0.05), inertia=np.diag([0.004, 0.003, 0.002]),
                   frame=plant.frame)  # fmt: skip
    plant.add_payload(load)
    loaded = with_payload(robot, load)
    for _ in range(5):
        q, qd = robot.random_configuration(rng), rng.uniform(-1.0, 1.0, robot.n)
        plant.reset(q, qd)
        M, b = loaded.mass_matrix(q), loaded.bias(q, qd)
        np.testing.assert_allclose(plant.mass_matrix(), M, rtol=0, atol=1e-11 * np.abs(M).max())
        np.testing.assert_allclose(plant.bias(), b, rtol=0, atol=1e-11 * np.abs(b).max())
    assert np.abs(loaded.mass_matrix(q) - robot.mass_matrix(q)).max() > 1e-3  # it weighs
