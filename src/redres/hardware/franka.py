"""Drive a Franka arm (FR3 or Panda) at 1 kHz over libfranka, or its model (a dry run).

:func:`run_on_franka` connects to the robot's control interface through ``pylibfranka``
(Franka's Python bindings of libfranka; the ``franka`` extra), reads the measured state,
and runs one redres controller in the robot's own 1 kHz loop:

* ``mode="velocity"``: a :class:`~redres.control.Controller` step on the measured ``q``,
  its shaped joint velocity as the command;
* ``mode="position"``: the controller integrates its own command ``q_c`` (started at the
  robot's commanded position), as a joint-position client does;
* ``mode="torque"``: a torque law (:class:`~redres.dynamics.OperationalSpaceController`,
  ...) on the measured state; the command is its torque less gravity (the robot
  compensates gravity itself), limited to the torque rate the robot accepts (1000 N·m/s).

Command shaping (:mod:`redres.control.shaping`) is always on, started from the robot's
last commanded velocity and acceleration. Time is the robot's (``readOnce``'s elapsed
duration), so the trajectory runs in robot time whatever the load of the client machine.

After a missed cycle the client follows the robot's command history
(:class:`redres.hardware.continuation.Continuation`). At the end the command ramps to
rest within the limits and the motion is finished (the robot holds; its brakes are its
own business). When the robot stops the motion itself — a lost connection, a limit, a
reflex — :class:`~redres.errors.RobotStoppedError` names its reason and carries the run
log up to that cycle.

``address=None`` is a dry run: the same loop against redres' model (the command is the
motion, torques through :class:`~redres.dynamics.simulate`'s plant), to try a scenario
before a robot.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .. import _compile
from .._validate import FloatArray
from ..control import Controller, RunLog, analysis
from ..control.shaping import MARGIN, CommandShaper
from ..dynamics import Payload, TorqueLaw, with_payload
from ..dynamics.simulate import RigidBodyPlant
from ..errors import (
    InvalidParameterError,
    MissingDependencyError,
    RobotStoppedError,
    install_hint,
)
from ..models import menagerie, panda
from ..resolution import Scheme
from ..tasks import FrameTask
from .continuation import DT, Continuation, State

if TYPE_CHECKING:
    from ..control import Trajectory
    from ..robot import Robot
    from ..tasks import Task

Mode = Literal["velocity", "position", "torque"]
#: The torque rate the Franka arms accept, N·m/s (``franka::kMaxTorqueRate``).
TORQUE_RATE = 1000.0
#: Fraction of the velocity, acceleration and jerk limits the commands keep in hand: room
#: for the robot's state being single precision on the wire
#: (:class:`~redres.hardware.continuation.Continuation`).
SHAPING_MARGIN = 0.05
#: The kernel groups a robot loop may call.
WARM_GROUPS = ("linalg", "derivatives", "chain", "controller", "shaping", "dynamics", "hard limits")


def franka_robot(arm: str = "fr3", *, hand: bool = False) -> Robot:
    """redres' model of a Franka arm with Franka's published limits: ``"fr3"`` (the MuJoCo
    Menagerie's FR3 shipped with redres) or ``"panda"`` (the built-in Panda).

    ``hand=False``: the tip is the flange (``attachment_site`` of the FR3, turned −45° about
    z like the hand's mount; ``flange`` of the Panda), nothing attached. ``hand=True``: the
    Franka Hand's mass is on the flange and the tip is its ``tcp``, 0.1034 m along the
    hand's z (Franka's robot description; configure the same end effector in Desk).
    """
    if arm == "panda":
        robot = panda(hand=hand)
        return robot if hand else robot.derived(tip="flange")
    if arm != "fr3":
        raise InvalidParameterError(f"arm must be 'fr3' or 'panda'; got {arm!r}")
    robot = menagerie("fr3", tip="attachment_site")
    if not hand:
        return robot
    from ..models.panda import HAND_COM, HAND_INERTIA, HAND_MASS, TCP_D, inertia_matrix

    robot.add_frame("tcp", "attachment_site", _along_z(TCP_D))
    load = Payload(HAND_MASS, com=HAND_COM, inertia=inertia_matrix(*HAND_INERTIA),
                   frame="attachment_site")  # fmt: skip
    return with_payload(robot, load, name="fr3+hand").derived(tip="tcp")


def _along_z(d: float) -> FloatArray:
    T = np.eye(4)
    T[2, 3] = d
    return T


class _Libfranka:
    """The robot through pylibfranka (one motion)."""

    def __init__(self, address: str) -> None:
        try:
            import pylibfranka as pf
        except ImportError:
            raise MissingDependencyError(
                "pylibfranka is not installed (Python 3.10-3.12); install the franka extra: "
                + install_hint("franka")
            ) from None
        self.pf = pf
        try:
            self.robot = pf.Robot(address, pf.RealtimeConfig.kIgnore)
        except Exception as exc:  # NetworkException and the like: say where
            raise RobotStoppedError(f"cannot connect to the robot at {address}: {exc}") from None
        if self.robot.read_once().robot_mode == pf.RobotMode.Reflex:
            self.robot.automatic_error_recovery()  # after an earlier motion's reflex
        self.active: Any = None

    def peek(self) -> State:
        return State(self.robot.read_once(), 0.0)

    def start(self, mode: Mode) -> State:
        pf, robot = self.pf, self.robot
        impedance = pf.ControllerMode.JointImpedance
        starts = {"velocity": lambda: robot.start_joint_velocity_control(impedance),
                  "position": lambda: robot.start_joint_position_control(impedance),
                  "torque": robot.start_torque_control}  # fmt: skip
        self.active = starts[mode]()
        self.kind = {"velocity": pf.JointVelocities, "position": pf.JointPositions,
                     "torque": pf.Torques}[mode]  # fmt: skip
        raw, _ = self.active.readOnce()
        return State(raw, 0.0)

    def read(self) -> State:
        raw, duration = self.active.readOnce()
        return State(raw, duration.to_sec())

    def write(self, command: FloatArray, finished: bool = False) -> None:
        out = self.kind(command.tolist())
        out.motion_finished = finished
        self.active.writeOnce(out)


class _Model:
    """A dry run: redres' model as the robot (the command is the motion; torques through
    :class:`~redres.dynamics.simulate.RigidBodyPlant`, gravity added back as the robot
    would)."""

    def __init__(self, robot: Robot, q0: FloatArray) -> None:
        self.robot = robot
        n = robot.n
        self.q, self.dq = q0.copy(), np.zeros(n)
        self.q_d, self.dq_d, self.ddq_d = q0.copy(), np.zeros(n), np.zeros(n)
        self.mode: Mode = "velocity"
        self.plant = RigidBodyPlant(robot)

    #: Every command arrives (a libfranka state's success rate).
    control_command_success_rate = 1.0

    def _state(self, elapsed: float) -> State:
        return State(self, elapsed)  # the model has the state's fields

    def peek(self) -> State:
        return self._state(0.0)

    def start(self, mode: Mode) -> State:
        self.mode = mode
        self.plant.reset(self.q, self.dq)
        return self._state(0.0)

    def read(self) -> State:
        return self._state(DT)

    def write(self, command: FloatArray, finished: bool = False) -> None:
        if self.mode == "velocity":
            velocity = command
        elif self.mode == "position":
            velocity = (command - self.q_d) / DT
        else:
            tau = command + self.robot.gravity(self.q)
            self.q, self.dq = self.plant.advance(tau, DT, 1)
            return
        self.ddq_d = (velocity - self.dq_d) / DT
        self.dq_d = velocity.copy()
        self.q_d = self.q_d + velocity * DT
        self.q, self.dq = self.q_d.copy(), velocity.copy()


def run_on_franka(
    address: str | None,
    task: Task | None,
    trajectory: Trajectory | Callable[[FloatArray], Trajectory] | None,
    law: Scheme | TorqueLaw,
    *,
    mode: Mode = "velocity",
    arm: str = "fr3",
    hand: bool = False,
    robot: Robot | None = None,
    duration: float | None = None,
    gain: float = 50.0,
    q0: Any = None,
    label: str = "",
    progress: bool | None = None,
) -> RunLog:
    """Run one controller on a Franka arm at 1 kHz (module docstring) and record it.

    Args:
        address: the robot's (or simulator's) address; None: a dry run on the model.
        task: the controller's task (a :class:`~redres.tasks.FrameTask` follows
            ``trajectory``); None for a torque law.
        trajectory: the reference, or a function of the measured start pose that makes it
            (``lambda T0: Circle(T0, 0.05, 4.0, ramp=0.5)``: the robot starts where it is).
        law: a redres scheme (velocity and position modes) or a torque law (torque mode).
        mode: ``"velocity"``, ``"position"`` or ``"torque"``.
        arm: ``"fr3"`` or ``"panda"``, ``hand`` whether the Franka Hand is on
            (:func:`franka_robot`); ``robot`` overrides both.
        duration: s of motion before the stop (default: the trajectory's).
        gain: the CLIK gain (velocity and position modes), 1/s.
        q0: the dry run's start, inside the limits (default: the robot's neutral
            configuration); a robot starts where it is.
        label, progress: as for :func:`redres.run`.

    Returns:
        The :class:`~redres.control.RunLog`, one row per robot cycle of the motion:
        measured ``q``, ``dq`` (as ``qd``), the tracked frame's position by redres' forward
        kinematics of the measured ``q``; ``extra``, for every cycle, the stop to rest
        included (``motion_cycles`` of them are the motion): ``command`` (what was sent),
        ``success_rate``,
        ``robot_time``, ``compute_us`` (from the state read to the command ready: task,
        controller or law, shaping), ``write_us`` (sending it), ``lost_cycles``.

    Raises:
        RobotStoppedError: the robot stopped the motion (its reason named; ``.log`` kept),
            or cannot be reached.
        MissingDependencyError: pylibfranka is not installed.
    """
    if mode not in ("velocity", "position", "torque"):
        raise InvalidParameterError(f"mode must be velocity, position or torque; got {mode!r}")
    torque = mode == "torque"
    if torque != isinstance(law, TorqueLaw):
        raise InvalidParameterError(
            "torque mode runs a torque law; velocity and position modes a redres scheme"
        )
    robot = franka_robot(arm, hand=hand) if robot is None else robot
    backend: Any = _Model(robot, analysis.start_configuration(robot, q0))
    if address is not None:
        backend = _Libfranka(address)
    first = backend.peek()  # the state before the motion: where the robot is
    frame = task if isinstance(task, FrameTask) else None
    if frame is None and isinstance(law, TorqueLaw) and law.task_frame() is not None:
        name, rows_ = law.task_frame()  # type: ignore[misc]
        frame = FrameTask(name, rows=rows_)  # only to measure: the law has its own
    # Position mode continues the robot's commanded position; the others start where it is.
    q_start = first.q_d if mode == "position" else first.q
    path = trajectory(robot.fk(q_start)) if callable(trajectory) else trajectory
    duration = analysis.run_duration(path, duration)
    shaper = CommandShaper.for_robot(robot, DT, margin=SHAPING_MARGIN)
    controller = None
    # Nothing compiles in the robot's loop: the kernels are cached (or compiled) first,
    # and one step at the start configuration loads every entry point the loop takes.
    _compile.warm(WARM_GROUPS, quiet=True)
    if not torque:
        assert task is not None and isinstance(law, Scheme)
        controller = Controller(robot, task, law, gain=gain, dt=DT, shaping=shaper)
        if frame is not None and path is not None:
            frame.set_target(path.sample(0.0).pose, validate=False)
        controller.step(q_start)
    else:
        assert isinstance(law, TorqueLaw)
        law.step(robot, first.q, first.dq, path.sample(0.0) if path is not None else None)
    law.reset()
    state = backend.start(mode)
    shaper.reset(state.dq_d, state.ddq_d)
    steps = analysis.run_steps(duration, DT)
    rows = steps + int(2.0 / DT)  # room for the stop
    log = RunLog.empty(robot.name, law.name, DT, rows, robot.n, label or f"franka {mode}")
    success, robot_time = np.ones(rows), np.zeros(rows)
    compute, writing, lost = np.zeros(rows), np.zeros(rows), np.zeros(rows, dtype=np.int64)
    record = {"command": np.zeros((rows, robot.n)), "write_us": writing}
    q_c, tau_prev = state.q_d.copy(), np.zeros(robot.n)
    rate = TORQUE_RATE * (1.0 - MARGIN) * DT
    follow = Continuation(mode == "position", shaper)
    t, k, tick, stopping, moving, unlogged = 0.0, 0, 0, False, 0, 0
    bar = analysis.progress_bar(steps, progress, f"franka {mode} {label or law.name}")
    collecting = gc.isenabled()
    gc.disable()  # a collection inside a 1 ms cycle can take several: none until the stop
    try:
        while True:
            if k:  # the first cycle's state is the one that started the motion
                state = backend.read()
            t0 = time.perf_counter_ns()
            t += state.elapsed
            cycles = round(state.elapsed / DT)
            tick, missed = tick + cycles, max(cycles - 1, 0) + unlogged
            action, planned, unlogged = "step", q_c, 0
            if not torque:  # where the robot's history is (Continuation)
                action, planned = follow.plan(state, tick, q_c)
            if action == "skip":
                unlogged = missed + 1  # counted with the next row's lost cycles
                continue
            stopping = stopping or t >= duration
            moving = moving if stopping else k + 1
            if isinstance(law, TorqueLaw):
                command = _torque(law, robot, state, path, t, tau_prev, rate, stopping)
                tau_prev, done = command, stopping
            elif action == "hold":  # the zero-jerk continuation of the robot's history
                command, done = planned, False
                q_c = planned if mode == "position" else q_c + planned * DT
            else:
                assert controller is not None
                q_c = planned
                if stopping:
                    qd = shaper(np.zeros(robot.n))
                    done = bool(np.abs(qd).max() < 1e-9 and np.abs(shaper.qdd).max() < 1e-6)
                else:
                    if frame is not None and path is not None:
                        sample = path.sample(t)
                        frame.set_target(sample.pose, sample.twist, validate=False)
                    controller.step(state.q if mode == "velocity" else q_c)
                    qd, done = controller.qd, False
                q_c = q_c + qd * DT
                command = qd if mode == "velocity" else q_c
            t1 = time.perf_counter_ns()
            backend.write(command, finished=done)
            follow.wrote(tick, q_c)
            compute[k], writing[k] = (t1 - t0) / 1e3, (time.perf_counter_ns() - t1) / 1e3
            log.q[k], log.qd[k], record["command"][k] = state.q, state.dq, command
            success[k], robot_time[k], lost[k] = state.success, t, missed
            if frame is not None and path is not None:
                log.target[k] = path.sample(min(t, duration)).pose[:3, 3]
            k += 1
            if bar is not None and k <= steps:
                bar.update(1)
            if done or k == rows:
                break
    except RobotStoppedError:
        raise
    except Exception as exc:  # libfranka's ControlException: the robot's own reason
        _finish(log, k, moving, robot, frame, success, robot_time, compute, lost, record)
        raise RobotStoppedError(f"the robot stopped the motion at {t:.3f} s: {exc}", log) from exc
    finally:
        if collecting:
            gc.enable()
        if bar is not None:
            bar.close()
    _finish(log, k, moving, robot, frame, success, robot_time, compute, lost, record)
    return log


def _torque(
    law: TorqueLaw,
    robot: Robot,
    state: State,
    path: Trajectory | None,
    t: float,
    previous: FloatArray,
    rate: float,
    stopping: bool,
) -> FloatArray:
    """The torque command of a cycle: the law's torque less gravity, within the torque
    rate and the torque limits (the last command held once stopping)."""
    if stopping:
        return previous
    sample = path.sample(t) if path is not None else None
    wanted = np.asarray(law.step(robot, state.q, state.dq, sample).tau) - robot.gravity(state.q)
    wanted = np.clip(wanted, -robot.tau_max, robot.tau_max)
    return previous + np.clip(wanted - previous, -rate, rate)


def _finish(
    log: RunLog,
    k: int,
    moving: int,
    robot: Robot,
    frame: FrameTask | None,
    success: FloatArray,
    robot_time: FloatArray,
    compute: FloatArray,
    lost: Any,
    record: dict[str, FloatArray],
) -> None:
    """Cut the log to the ``moving`` cycles of the motion (``extra`` keeps all ``k``, the
    stop included) and fill the measures."""
    extras = {"command": record["command"][:k], "success_rate": success[:k],
              "robot_time": robot_time[:k], "compute_us": compute[:k],
              "write_us": record["write_us"][:k], "lost_cycles": lost[:k],
              "motion_cycles": moving}  # fmt: skip
    k = moving
    for name in ("q", "qd", "position", "target", "position_error", "orientation_error",
                 "sigma_min", "damping", "rank", "speed_ratio", "scaled", "joint_limit_margin",
                 "manipulability", "step_time_ns"):  # fmt: skip
        setattr(log, name, getattr(log, name)[:k])
    log.t = log.t[:k]
    log.step_time_ns[:] = compute[:k] * 1e3
    for j, q in enumerate(log.q):
        log.position[j] = robot.fk(q)[:3, 3]
    if frame is not None:
        log.position_error[:] = np.linalg.norm(log.target - log.position, axis=1)
    log.speed_ratio[:] = np.max(np.abs(log.qd) / robot.qd_max, axis=1) if k else 0.0
    log.extra.update(extras)
    if k:
        analysis.analyse_run(robot, log, frame=frame.frame if frame else None,
                             rows=frame.rows if frame else list(range(6)))  # fmt: skip
