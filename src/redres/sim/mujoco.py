"""MuJoCo as the plant: an MJCF model simulated by MuJoCo, driven by redres' controllers.

The plant is MuJoCo's (Todorov, Erez, Tassa, "MuJoCo: A physics engine for model-based
control", IROS 2012): its integrator, its joint damping, armature and friction loss, its
actuators. The controller computes with redres' robot built from the same file
(:meth:`MujocoPlant.robot`); nothing of redres' dynamics is in the loop, so a run checks
the controller against a model it did not write.

Two ways to drive it:

* :func:`run_on_mujoco`: a kinematic :class:`~redres.control.Controller` whose command
  goes to the joints' position actuators, as to a robot's joint-position interface. Like
  the robot's own joint controller, the plant adds gravity compensation and the velocity
  feedforward of the command (the actuators of a Menagerie file are PD servos
  ``τ = k_p (u − q) − k_v q̇``, which would otherwise lag a moving command by
  ``k_v q̇ / k_p``: they get ``u = q_c + (k_v/k_p) q̇_c``); the controller integrates its
  own command (``q_c ← q_c + q̇ dt``), as a joint-position client of a real robot does.
* :func:`simulate_on_mujoco` (or :func:`redres.dynamics.simulate` with ``plant=``): a
  torque law whose joint torques MuJoCo applies (its actuators off).

Both record a :class:`~redres.control.RunLog` whose tracked frame's position and error
are MuJoCo's own kinematics of its state.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from .._validate import FloatArray, as_scalar, as_vector
from ..control import Controller, RunLog, analysis
from ..dynamics import simulate
from ..errors import InvalidParameterError, MissingDependencyError, SimulationError, install_hint
from ..robot import Robot
from ..robot.chain import log3
from ..tasks import FrameTask

if TYPE_CHECKING:
    from ..control import Trajectory
    from ..dynamics import Payload, TorqueLaw
    from ..resolution import Scheme
    from ..tasks import Task

if TYPE_CHECKING:
    pass


def _mujoco() -> Any:
    try:
        import mujoco
    except ImportError:
        raise MissingDependencyError(
            f"MuJoCo is not installed; install the mujoco extra: {install_hint('mujoco')}"
        ) from None
    return mujoco


class MujocoPlant:
    """An MJCF model simulated by MuJoCo, as a robot redres drives (module docstring).

    Args:
        path: the MJCF file (a MuJoCo Menagerie model, or any).
        frame: the site or body whose pose the runs track and measure (default: the last
            site of the file, else its last body).
        timestep: MuJoCo's integration step, s (default: the file's).

    Attributes:
        model: MuJoCo's ``MjModel`` (read it; the plant steps it), and ``data`` its
            ``MjData``.
        n: the number of joints (every hinge and slide joint of the file, in its order).
        joint_names: their names.
        frame: the site or body the runs track.
    """

    name = "mujoco"

    def __init__(
        self, path: str | Path, *, frame: str | None = None, timestep: float | None = None
    ) -> None:
        """The arguments are described in ``help(MujocoPlant)``."""
        mujoco = _mujoco()
        self.path = Path(path)
        if not self.path.is_file():
            raise InvalidParameterError(f"MJCF file not found: {self.path}")
        self.model = mujoco.MjModel.from_xml_path(str(self.path))
        self.data = mujoco.MjData(self.model)
        m = self.model
        kinds = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        joints = [j for j in range(m.njnt) if int(m.jnt_type[j]) in kinds]
        if len(joints) != m.njnt:
            raise InvalidParameterError(
                f"{self.path.name}: a free or ball joint; redres drives fixed-base arms of "
                "hinge and slide joints"
            )
        self.n = len(joints)
        self.joint_names = [m.joint(j).name for j in joints]
        self._qpos = np.array([m.jnt_qposadr[j] for j in joints])
        self._dof = np.array([m.jnt_dofadr[j] for j in joints])
        if timestep is not None:
            m.opt.timestep = as_scalar(timestep, "timestep", minimum=0.0, strict=True)
        self.frame, self._site = self._frame(frame)
        self._actuators: np.ndarray | None = None  # the position actuators, on first use
        self.name = f"mujoco:{self.path.stem}"

    def _frame(self, frame: str | None) -> tuple[str, bool]:
        mujoco, m = _mujoco(), self.model
        if frame is None:
            if m.nsite:
                return m.site(m.nsite - 1).name, True
            return m.body(m.nbody - 1).name, False
        if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, frame) >= 0:
            return frame, True
        if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, frame) >= 0:
            return frame, False
        names = [m.site(i).name for i in range(m.nsite)] + [m.body(i).name for i in range(m.nbody)]
        raise InvalidParameterError(f"no site or body {frame!r} in {self.path.name}: {names}")

    def robot(self) -> Robot:
        """redres' robot built from the same file (Pinocchio's MJCF parser), its tip the
        plant's :attr:`frame`, checked against MuJoCo (:meth:`check`)."""
        robot = Robot.from_mjcf(self.path, tip=self.frame)
        self.check(robot)
        return robot

    def check(self, robot: Robot, tolerance: float = 1e-9) -> None:
        """Refuse a ``robot`` that is not this plant's arm: other joints, or a pose of
        :attr:`frame` (the robot's tip) that differs from MuJoCo's forward kinematics by
        more than ``tolerance`` (m, and rad in each rotation entry) at the robot's neutral
        configuration and at eight seeded random ones. Every run here checks first."""
        if list(robot.joint_names) != self.joint_names:
            raise InvalidParameterError(
                f"{self.path.name}: the robot's joints {robot.joint_names} are not MuJoCo's "
                f"{self.joint_names}"
            )
        rng = np.random.default_rng(0)
        low, high = np.maximum(robot.q_min, -np.pi), np.minimum(robot.q_max, np.pi)
        for q in [robot.neutral(), *rng.uniform(low, high, (8, robot.n))]:
            gap = float(np.abs(robot.fk(q) - self.pose(q)).max())
            if not gap <= tolerance:
                raise InvalidParameterError(
                    f"{self.path.name}: the robot's {robot.tip} is {gap:.3g} from MuJoCo's "
                    f"{self.frame} at q = {np.round(q, 4)}: not the same arm"
                )

    # -- state ---------------------------------------------------------------------------

    def reset(self, q: FloatArray, qd: FloatArray | None = None) -> None:
        """Set the joint positions ``q`` (rad) and velocities ``qd`` (default 0), at rest
        otherwise, and compute MuJoCo's kinematics of them."""
        mujoco = _mujoco()
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self._qpos] = as_vector(q, "q", self.n)
        self.data.qvel[self._dof] = 0.0 if qd is None else as_vector(qd, "qd", self.n)
        mujoco.mj_forward(self.model, self.data)

    @property
    def q(self) -> FloatArray:
        """Joint positions, ``(n,)``, rad."""
        return np.array(self.data.qpos[self._qpos])

    @property
    def qd(self) -> FloatArray:
        """Joint velocities, ``(n,)``, rad/s."""
        return np.array(self.data.qvel[self._dof])

    def pose(self, q: FloatArray | None = None) -> FloatArray:
        """The 4x4 world pose of :attr:`frame` by MuJoCo's kinematics (at ``q``, default:
        the current state, which is left unchanged)."""
        mujoco, d = _mujoco(), self.data
        if q is not None:
            saved = d.qpos.copy()
            d.qpos[self._qpos] = q
            mujoco.mj_kinematics(self.model, d)
        i = self._index()
        T = np.eye(4)
        if self._site:
            T[:3, :3], T[:3, 3] = d.site_xmat[i].reshape(3, 3), d.site_xpos[i]
        else:
            T[:3, :3], T[:3, 3] = d.xmat[i].reshape(3, 3), d.xpos[i]
        if q is not None:
            d.qpos[:] = saved
            mujoco.mj_kinematics(self.model, d)
        return T

    def jacobian(self) -> FloatArray:
        """The world-aligned Jacobian ``[v; ω]`` of :attr:`frame` at its origin, ``(6, n)``,
        by MuJoCo (``mj_jacSite`` / ``mj_jacBody``) at the current state."""
        mujoco, m, d = _mujoco(), self.model, self.data
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        (mujoco.mj_jacSite if self._site else mujoco.mj_jacBody)(m, d, jacp, jacr, self._index())
        return np.vstack([jacp, jacr])[:, self._dof]

    def mass_matrix(self) -> FloatArray:
        """MuJoCo's joint-space inertia at the current state (``mj_fullM``, armature on its
        diagonal), ``(n, n)``."""
        mujoco, m = _mujoco(), self.model
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, self.data, full)
        return full[np.ix_(self._dof, self._dof)]

    def bias(self) -> FloatArray:
        """MuJoCo's ``qfrc_bias`` (Coriolis, centrifugal and gravity torques) at the
        current state, ``(n,)``."""
        return np.array(self.data.qfrc_bias[self._dof])

    def _index(self) -> int:
        mujoco, m = _mujoco(), self.model
        kind = mujoco.mjtObj.mjOBJ_SITE if self._site else mujoco.mjtObj.mjOBJ_BODY
        return int(mujoco.mj_name2id(m, kind, self.frame))

    def add_payload(self, payload: Payload) -> None:
        """Fix ``payload`` (:class:`redres.dynamics.Payload`, in the axes of :attr:`frame`)
        to the body that carries :attr:`frame`: its mass, centre of mass and inertia are
        summed into the body's (parallel-axis theorem), as MuJoCo then simulates it."""
        mujoco, m = _mujoco(), self.model
        if payload.frame not in (None, self.frame):
            raise InvalidParameterError(
                f"the plant carries loads at its frame {self.frame!r}; got {payload.frame!r}"
            )
        i = self._index()
        body = int(m.site_bodyid[i]) if self._site else i
        X = pin.SE3.Identity()
        if self._site:
            w, x, y, z = m.site_quat[i]
            X = pin.SE3(pin.Quaternion(w, x, y, z).matrix(), m.site_pos[i].copy())
        w, x, y, z = m.body_iquat[body]
        R = pin.Quaternion(w, x, y, z).matrix()
        own = pin.Inertia(float(m.body_mass[body]), m.body_ipos[body].copy(),
                          R @ np.diag(m.body_inertia[body]) @ R.T)  # fmt: skip
        total = own + X.act(payload.pinocchio_inertia())
        principal, axes = np.linalg.eigh(total.inertia)
        if np.linalg.det(axes) < 0:
            axes[:, 0] = -axes[:, 0]
        q = pin.Quaternion(axes)
        m.body_mass[body], m.body_ipos[body] = total.mass, total.lever
        m.body_iquat[body], m.body_inertia[body] = (q.w, q.x, q.y, q.z), principal
        mujoco.mj_setConst(m, self.data)

    # -- stepping ------------------------------------------------------------------------

    def substeps(self, dt: float) -> int:
        """MuJoCo steps per control period ``dt``, which must be a whole number of them."""
        ratio = dt / self.model.opt.timestep
        count = round(ratio)
        if count < 1 or abs(ratio - count) > 1e-9 * ratio:
            raise InvalidParameterError(
                f"the control period {dt} s is not a whole number of MuJoCo steps of "
                f"{self.model.opt.timestep} s; give MujocoPlant(timestep=...)"
            )
        return count

    def advance(self, tau: FloatArray, dt: float, substeps: int) -> tuple[FloatArray, FloatArray]:
        """Apply joint torques ``tau`` (N·m) for ``substeps`` MuJoCo steps with its
        actuators off (the :class:`redres.dynamics.simulate` plant protocol; ``dt`` must
        be MuJoCo's timestep). Returns ``(q, qd)``."""
        mujoco, m, d = _mujoco(), self.model, self.data
        if abs(dt - m.opt.timestep) > 1e-12 * dt:
            raise InvalidParameterError(
                f"simulate's dt = {dt} s must be MuJoCo's timestep {m.opt.timestep} s"
            )
        flags = m.opt.disableflags
        m.opt.disableflags = flags | mujoco.mjtDisableBit.mjDSBL_ACTUATION
        try:
            d.qfrc_applied[:] = 0.0
            d.qfrc_applied[self._dof] = tau
            for _ in range(substeps):
                mujoco.mj_step(m, d)
        finally:
            m.opt.disableflags = flags
            d.qfrc_applied[:] = 0.0
        return self.q, self.qd

    def follow(self, q_c: FloatArray, qd_c: FloatArray, substeps: int) -> None:
        """One control period of the joint-position interface: the position actuators
        (``τ = k_p (u − q) − k_v q̇`` within their force range) track ``q_c`` with the
        velocity feedforward of ``qd_c`` (``u = q_c + (k_v/k_p) q̇_c``, so that
        ``τ = k_p (q_c − q) + k_v (q̇_c − q̇)``), gravity compensated (module docstring)."""
        mujoco, m, d = _mujoco(), self.model, self.data
        actuators = self._position_actuators()
        kp, kv = m.actuator_gainprm[actuators, 0], -m.actuator_biasprm[actuators, 2]
        d.ctrl[actuators] = q_c + kv / kp * qd_c
        for _ in range(substeps):
            d.qfrc_applied[:] = 0.0
            d.qfrc_applied[self._dof] = self._gravity()
            mujoco.mj_step(m, d)
        d.qfrc_applied[:] = 0.0

    def _gravity(self) -> FloatArray:
        """Gravity torques at the current positions: MuJoCo's recursive Newton–Euler bias
        ``C(q, q̇) q̇ + g(q)`` at zero velocity (the state is left as it was)."""
        mujoco, m, d = _mujoco(), self.model, self.data
        saved = d.qvel.copy()
        d.qvel[:] = 0.0
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        out = np.zeros(m.nv)
        mujoco.mj_rne(m, d, 0, out)
        d.qvel[:] = saved
        return out[self._dof]

    def _position_actuators(self) -> np.ndarray:
        if self._actuators is not None:
            return self._actuators
        m = self.model
        by_joint = {int(m.actuator_trnid[a, 0]): a for a in range(m.nu)}
        joints = [self.model.joint(name).id for name in self.joint_names]
        missing = [self.joint_names[i] for i, j in enumerate(joints) if j not in by_joint]
        if missing:
            raise InvalidParameterError(
                f"{self.path.name}: joints {missing} have no actuator; a joint-position run "
                "needs a position actuator on every joint"
            )
        found = np.array([by_joint[j] for j in joints])
        kp, bias = m.actuator_gainprm[found, 0], m.actuator_biasprm[found, :3]
        if not (np.allclose(bias[:, 0], 0.0) and np.allclose(bias[:, 1], -kp) and np.all(kp > 0)):
            raise InvalidParameterError(
                f"{self.path.name}: the actuators are not position servos "
                "(gain k_p, bias [0, -k_p, -k_v])"
            )
        self._actuators = found
        return found


def _measure(plant: MujocoPlant, log: RunLog, targets: FloatArray) -> None:
    """The log's frame positions and tracking errors from MuJoCo's kinematics of its
    configurations against the target poses ``targets`` (K x 4 x 4)."""
    if not log.steps:
        return
    poses = np.array([plant.pose(q) for q in log.q])
    log.position[:], log.target[:] = poses[:, :3, 3], targets[:, :3, 3]
    log.position_error[:] = np.linalg.norm(log.target - log.position, axis=1)
    # |log(R_d Rᵀ)|, the frame task's orientation error, by redres' one SO(3) logarithm
    rotations = targets[:, :3, :3] @ poses[:, :3, :3].transpose(0, 2, 1)
    log.orientation_error[:] = np.linalg.norm(log3(rotations), axis=1)


def run_on_mujoco(
    plant: MujocoPlant,
    task: Task,
    trajectory: Trajectory | None,
    scheme: Scheme,
    *,
    robot: Robot | None = None,
    dt: float = 1e-3,
    duration: float | None = None,
    q0: Any = None,
    gain: float = 50.0,
    limit_velocity: bool = True,
    shaping: bool = False,
    label: str = "",
    progress: bool | None = None,
) -> RunLog:
    """Drive ``plant`` with a kinematic :class:`~redres.control.Controller` through its
    joint-position interface (module docstring) and record the run.

    Args:
        plant: the MuJoCo plant.
        task: as for :func:`redres.run`, and so are ``trajectory``, ``scheme``, ``dt``,
            ``duration``, ``gain``, ``limit_velocity``, ``shaping``, ``label`` and
            ``progress``.
        robot: the controller's model (default: :meth:`MujocoPlant.robot`).
        q0: start configuration (default: the robot's neutral one), the plant at rest.

    Returns:
        The :class:`~redres.control.RunLog`: ``q`` and ``qd`` the plant's measured state at
        the start of each step, the tracked frame's position and error by MuJoCo's
        kinematics; ``extra["q_command"]``, ``extra["qd_command"]`` the commands.
    """
    robot = plant.robot() if robot is None else robot
    plant.check(robot)
    controller = Controller(robot, task, scheme, gain=gain, dt=dt,
                            limit_velocity=limit_velocity, shaping=shaping)  # fmt: skip
    controller._eager_info()
    dt = controller.dt
    substeps = plant.substeps(dt)
    duration = analysis.run_duration(trajectory, duration)
    steps = analysis.run_steps(duration, dt)
    q_c = analysis.start_configuration(robot, q0)
    plant.reset(q_c)
    scheme.reset()
    log = RunLog.empty(robot.name, scheme.name, dt, steps, robot.n, label or plant.name)
    commands, rates = np.empty((steps, robot.n)), np.empty((steps, robot.n))
    targets = np.empty((steps, 4, 4))
    frame = task if isinstance(task, FrameTask) else None
    bar = analysis.progress_bar(steps, progress, f"{plant.name} {label or scheme.name}")
    try:
        for k in range(steps):
            t0 = time.perf_counter_ns()
            if trajectory is not None and frame is not None:
                sample = trajectory.sample(k * dt)
                frame.set_target(sample.pose, sample.twist, validate=False)
            log.q[k], log.qd[k] = plant.q, plant.qd
            q_c = controller.step(q_c)
            log.step_time_ns[k] = time.perf_counter_ns() - t0
            commands[k], rates[k] = q_c, controller.qd
            targets[k] = frame.target if frame is not None else plant.pose()
            info = controller.info
            log.sigma_min[k], log.damping[k], log.rank[k] = info.sigma_min, info.damping, info.rank
            plant.follow(q_c, rates[k], substeps)
            if not np.all(np.isfinite(plant.q)):
                raise SimulationError(f"step {k}: MuJoCo's state became non-finite")
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    log.speed_ratio[:] = np.max(np.abs(log.qd) / robot.qd_max, axis=1)
    log.extra.update(q_command=commands, qd_command=rates, plant=plant.name, final_q=plant.q)
    rows = frame.rows if frame is not None else list(range(6))
    analysis.analyse_run(robot, log, frame=frame.frame if frame else None, rows=rows)
    _measure(plant, log, targets)
    return log


def simulate_on_mujoco(
    plant: MujocoPlant,
    law: TorqueLaw,
    trajectory: Trajectory | None = None,
    *,
    robot: Robot | None = None,
    dt: float = 1e-3,
    duration: float | None = None,
    q0: Any = None,
    qd0: Any = None,
    limit_torque: bool = True,
    label: str = "",
    progress: bool | None = None,
) -> RunLog:
    """Simulate the torque law ``law`` on ``plant``: :func:`redres.dynamics.simulate` with
    MuJoCo integrating the state (control period ``dt``, a whole number of MuJoCo steps),
    the law computing with ``robot`` (default: :meth:`MujocoPlant.robot`; a robot
    without a load the plant carries, :meth:`MujocoPlant.add_payload`). The log's tracked
    frame's position and error are MuJoCo's kinematics of the plant's states."""
    robot = plant.robot() if robot is None else robot
    plant.check(robot)
    substeps = plant.substeps(as_scalar(dt, "dt", minimum=0.0, strict=True))
    log = simulate(robot, law, trajectory, dt=plant.model.opt.timestep, substeps=substeps,
                   duration=duration, q0=q0, qd0=qd0, limit_torque=limit_torque, plant=plant,
                   label=label or plant.name, progress=progress)  # fmt: skip
    if trajectory is not None:
        targets = np.array([trajectory.sample(t).pose for t in log.t])
        _measure(plant, log, targets)
    return log
