"""Forward-dynamics simulation of a torque law on any :class:`~redres.Robot`.

Each control step ``k`` (period ``h = substeps · dt``, time ``t = k h``):

1. the trajectory gives the reference sample; the law gives ``τ`` from ``(q, q̇)``,
   computed with the *controller's* model (the nominal robot, which need not know the
   payload);
2. ``τ`` is clipped to ``±tau_max`` (the step is flagged when it saturates);
3. the plant — the robot, with the payload if any — is integrated ``substeps`` times by
   semi-implicit (symplectic) Euler with ``q̈ = ABA(q, q̇, τ − d ∘ q̇)`` (Pinocchio; the
   model's armature is in its mass matrix, ``d`` its joint damping, and its joints' dry
   friction, as an MJCF file gives them: :class:`RigidBodyPlant`)::

       q̇ ← q̇ + dt q̈;   q ← q + dt q̇

   which keeps the energy error bounded over long runs (Hairer, Lubich & Wanner,
   *Geometric Numerical Integration*, 2006, §VI.3), unlike explicit Euler.

The result is a :class:`~redres.control.RunLog` like the kinematic loop's, with the
dynamic quantities in ``log.extra`` (``tau``, ``tau_command``, ``tau_null``,
``torque_ratio``, ``task_disturbance``, energies); :func:`dynamics_summary` adds them to
the summary. A non-finite torque or state stops the run with a
:class:`~redres.errors.SimulationError` naming the step.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any, Protocol, cast

import numpy as np
import pinocchio as pin

from .._validate import FloatArray, as_scalar, as_vector
from ..control.analysis import (
    analyse_run,
    progress_bar,
    run_duration,
    run_steps,
    start_configuration,
)
from ..control.log import RunLog
from ..errors import InvalidParameterError, ShapeError, SimulationError
from .base import ControlStep, TorqueLaw
from .payload import Payload, with_payload

if TYPE_CHECKING:
    from ..control import Trajectory
    from ..robot import Robot


class Plant(Protocol):
    """What :func:`simulate` integrates: a robot's state under joint torques.

    :class:`RigidBodyPlant` is redres' own; :class:`redres.sim.MujocoPlant` is MuJoCo's.
    """

    name: str

    def reset(self, q: FloatArray, qd: FloatArray) -> None:
        """Start from ``q`` (rad) and ``qd`` (rad/s), at rest otherwise."""

    def advance(self, tau: FloatArray, dt: float, substeps: int) -> tuple[FloatArray, FloatArray]:
        """Apply the joint torques ``tau`` (N·m) for ``substeps`` steps of ``dt`` s;
        returns the new ``(q, qd)``."""


class RigidBodyPlant:
    """redres' plant: ``q̈ = ABA(q, q̇, τ − d ∘ q̇)`` of ``robot`` (Pinocchio; its armature
    in the mass matrix, ``d`` its joint damping, N·m·s/rad) integrated by semi-implicit
    Euler (module docstring), with the dry friction ``f`` of its joints (N·m; an MJCF's
    ``frictionloss``): after each velocity update, joint torques ``|λᵢ| ≤ fᵢ`` that stop
    a joint when they can and oppose its motion at ``fᵢ`` when they cannot, found by
    projected Gauss–Seidel on the velocity-level complementarity problem with
    ``A = dt M⁻¹`` (Stewart and Trinkle's time stepping, IJNME 39, 1996)."""

    #: Gauss–Seidel sweeps of the friction problem per step.
    SWEEPS = 20

    def __init__(self, robot: Robot) -> None:
        self.robot, self.name = robot, robot.name
        self.damping = np.array(robot.model.damping, dtype=float)
        self.friction = np.array(robot.model.friction, dtype=float)
        self.q, self.qd = robot.neutral(), np.zeros(robot.n)

    def reset(self, q: FloatArray, qd: FloatArray) -> None:
        self.q, self.qd = q.copy(), qd.copy()

    def advance(self, tau: FloatArray, dt: float, substeps: int) -> tuple[FloatArray, FloatArray]:
        q, qd = self.q, self.qd
        dry = bool(np.any(self.friction > 0.0))
        for _ in range(substeps):
            qdd = self.robot.forward_dynamics(q, qd, tau - self.damping * qd)
            qd = qd + dt * qdd
            if dry:
                qd = self._dry_friction(q, qd, dt)
            q = q + dt * qd
        self.q, self.qd = q, qd
        return q, qd

    def _dry_friction(self, q: FloatArray, v: FloatArray, dt: float) -> FloatArray:
        """``v + A λ`` with ``λ`` the friction torques of the step (class docstring)."""
        A = dt * np.linalg.inv(self.robot.mass_matrix(q))
        f = self.friction
        lam = np.zeros_like(v)
        for _ in range(self.SWEEPS):
            for i in np.flatnonzero(f > 0.0):
                r = v[i] + A[i] @ lam  # joint i's velocity with the torques so far
                lam[i] = min(max(lam[i] - r / A[i, i], -f[i]), f[i])
        return v + A @ lam


class _Recorder:
    """Per-step arrays of one run (filled inside the loop, no allocation per step)."""

    def __init__(self, steps: int, n: int, tau_max: FloatArray) -> None:
        self.tau_max = tau_max
        self.q = np.empty((steps, n))
        self.qd = np.empty((steps, n))
        self.tau = np.empty((steps, n))
        self.tau_cmd = np.empty((steps, n))
        self.tau_null = np.zeros((steps, n))
        self.error = np.zeros((steps, 6))
        self.position = np.full((steps, 3), np.nan)
        self.target = np.zeros((steps, 3))
        self.sigma = np.zeros(steps)
        self.damping = np.zeros(steps)
        self.rank = np.full(steps, -1.0)
        self.saturated = np.zeros((steps, n), dtype=bool)
        self.step_ns = np.empty(steps)

    def record(
        self, k: int, q: FloatArray, qd: FloatArray, out: ControlStep, tau: FloatArray
    ) -> None:
        self.q[k], self.qd[k], self.tau_cmd[k], self.tau[k] = q, qd, out.tau, tau
        self.saturated[k] = np.abs(out.tau) > self.tau_max
        if out.tau_null is not None:
            self.tau_null[k] = out.tau_null
        if out.error is not None:
            self.error[k] = out.error
        if out.pose is not None:
            self.position[k] = out.pose[:3, 3]
        if out.target is not None:
            self.target[k] = out.target[:3, 3]
        if out.info is not None:
            info = out.info
            self.sigma[k], self.damping[k], self.rank[k] = info.sigma_min, info.damping, info.rank


def simulate(
    robot: Robot,
    law: TorqueLaw,
    trajectory: Trajectory | None = None,
    *,
    dt: float = 1e-3,
    duration: float | None = None,
    q0: Any = None,
    qd0: Any = None,
    payload: Payload | None = None,
    controller_robot: Robot | None = None,
    limit_torque: bool = True,
    substeps: int = 1,
    plant: Plant | None = None,
    label: str = "",
    progress: bool | None = None,
) -> RunLog:
    """Simulate ``law`` driving ``robot`` (module docstring) and record the run.

    Args:
        robot: the robot (the plant, before any payload).
        law: the torque law, e.g. :class:`~redres.dynamics.OperationalSpaceController`.
        trajectory: reference handed to the law each control step (``None``: none).
        dt: integration step, s (> 0).
        duration: s (default: the trajectory's duration).
        q0, qd0: initial state (default ``robot.neutral()`` at rest), rad and rad/s.
        payload: a load fixed to the plant (the law's model does not know it).
        controller_robot: the model the law computes with (default: ``robot``).
        limit_torque: clip torques to ``±robot.tau_max``.
        substeps: integration steps per control step (control period ``substeps·dt``).
        plant: what integrates the state (default: :class:`RigidBodyPlant` of ``robot``
            with the ``payload``); e.g. :class:`redres.sim.MujocoPlant`, MuJoCo's model of
            the same arm (which then carries the payload itself).
        label: name of the run in tables.
        progress: show a progress bar (default: long runs on a terminal).

    Returns:
        The :class:`~redres.control.RunLog`; one row per control step, state at its start.

    Raises:
        InvalidParameterError: bad ``dt``, ``duration``, ``substeps`` or ``law``.
        NonFiniteError, ShapeError: bad ``q0`` or ``qd0``, or a ``controller_robot`` with
            another number of joints.
        JointLimitError: ``q0`` outside the joint limits.
        SimulationError: a non-finite torque or state (the message names the step).
    """
    if not isinstance(law, TorqueLaw):
        raise InvalidParameterError(f"law must be a TorqueLaw; got {law!r}")
    dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
    if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
        raise InvalidParameterError(f"substeps must be an integer >= 1; got {substeps!r}")
    duration = run_duration(trajectory, duration)
    model = robot if payload is None else with_payload(robot, payload)
    engine = RigidBodyPlant(model) if plant is None else plant
    ctrl = robot if controller_robot is None else controller_robot
    if ctrl.n != robot.n:
        raise ShapeError(
            f"controller_robot has {ctrl.n} joints but the robot has {robot.n}; give a "
            "model of the same arm"
        )
    q = start_configuration(robot, q0)
    qd = np.zeros(robot.n) if qd0 is None else as_vector(qd0, "qd0", robot.n).copy()
    h = dt * substeps
    steps = run_steps(max(duration, h / 2), h)  # at least one step
    tau_max = model.tau_max if limit_torque else np.full(robot.n, np.inf)
    rec = _Recorder(steps, robot.n, tau_max)
    law.reset()
    engine.reset(q, qd)
    bar = progress_bar(steps, progress, f"{robot.name} {label or law.name}")
    clock = time.perf_counter_ns
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            for k in range(steps):
                sample = trajectory.sample(k * h) if trajectory is not None else None
                t0 = clock()
                out = law.step(ctrl, q, qd, sample)
                rec.step_ns[k] = clock() - t0
                tau = _checked_torque(out, robot.n, k, k * h, law.name)
                tau = np.clip(tau, -tau_max, tau_max)
                rec.record(k, q, qd, out, tau)
                q, qd = engine.advance(tau, dt, substeps)
                if not math.isfinite(float(q.sum() + qd.sum())):
                    raise SimulationError(
                        f"step {k} (t = {k * h:.4f} s): the state became non-finite "
                        f"(max |tau| = {np.abs(tau).max():.3g} N m); lower the gains "
                        "or dt, or limit the torques"
                    )
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    log = _make_log(robot, law, rec, h, label)
    log.extra.update(
        final_q=q, final_qd=qd, sim_dt=dt, substeps=substeps, payload=payload, plant=engine.name
    )
    _analyse(model, law, log, q, qd)
    return log


def _checked_torque(out: Any, n: int, k: int, t: float, name: str) -> FloatArray:
    if not isinstance(out, ControlStep):
        raise InvalidParameterError(f"the {name} law must return a ControlStep; got {out!r}")
    tau = np.asarray(out.tau, dtype=float)
    if tau.shape != (n,):
        raise SimulationError(
            f"step {k} (t = {t:.4f} s): the {name} law returned torques "
            f"of shape {tau.shape}; expected ({n},)"
        )
    if not np.all(np.isfinite(tau)):
        raise SimulationError(
            f"step {k} (t = {t:.4f} s): the {name} law returned a non-finite torque {tau}"
        )
    return tau


def _make_log(robot: Robot, law: TorqueLaw, rec: _Recorder, h: float, label: str) -> RunLog:
    steps = rec.q.shape[0]
    log = RunLog(
        robot=robot.name,
        scheme=law.name,
        dt=h,
        t=np.arange(steps, dtype=np.float64) * h,
        q=rec.q,
        qd=rec.qd,
        position=rec.position,
        target=rec.target,
        position_error=np.linalg.norm(rec.error[:, :3], axis=1),
        orientation_error=np.linalg.norm(rec.error[:, 3:], axis=1),
        sigma_min=rec.sigma.copy(),
        damping=rec.damping,
        rank=rec.rank,
        speed_ratio=np.max(np.abs(rec.qd) / robot.qd_max, axis=1),
        scaled=cast(FloatArray, rec.saturated.any(axis=1)),
        joint_limit_margin=np.zeros(steps),
        manipulability=np.zeros(steps),
        step_time_ns=rec.step_ns,
        label=label,
    )
    tau_max = robot.tau_max
    ratio = np.where(np.isfinite(tau_max), np.abs(rec.tau_cmd) / tau_max, 0.0)
    log.extra.update(
        tau=rec.tau,
        tau_command=rec.tau_cmd,
        tau_null=rec.tau_null,
        saturated=rec.saturated,
        torque_ratio=ratio.max(axis=1),
        inverse_sigma_min=rec.sigma,
        task_error=rec.error,
    )
    return log


def _energy(plant: Robot, q: FloatArray, qd: FloatArray, M: FloatArray) -> tuple[float, float]:
    """Kinetic ``½ q̇ᵀ M q̇`` and potential energy, J."""
    return 0.5 * float(qd @ M @ qd), float(pin.computePotentialEnergy(plant.model, plant.data, q))


def _analyse(
    plant: Robot, law: TorqueLaw, log: RunLog, q_end: FloatArray, qd_end: FloatArray
) -> None:
    """Post-run measures on the plant (not timed): limit margins, σ_min and
    manipulability of the task Jacobian, energies, the task acceleration caused by the
    null-space torque ``‖J M⁻¹ τ_null‖``, objective values."""
    frame, rows = law.task_frame() or (None, list(range(6)))
    null_law = getattr(law, "null_law", None)
    objectives = [obj for obj, _ in null_law.objectives] if null_law is not None else []
    sigma = analyse_run(plant, log, frame=frame, rows=rows, objectives=objectives)
    steps = log.steps
    kinetic, potential, disturbance = np.empty(steps), np.empty(steps), np.zeros(steps)
    tau_null = log.extra["tau_null"]
    fid = plant.frame_id(frame)
    for k, (q, qd) in enumerate(zip(log.q, log.qd)):
        if log.rank[k] < 0:
            log.rank[k] = int(np.sum(sigma[k] > 1e-10 * sigma[k][0]))
        placement, J6 = plant.placement_jacobian(q, fid)
        if np.isnan(log.position[k, 0]):
            log.position[k] = placement.translation
        M = plant.mass_matrix(q)
        kinetic[k], potential[k] = _energy(plant, q, qd, M)
        if tau_null[k].any():
            disturbance[k] = float(np.linalg.norm(J6[rows] @ np.linalg.solve(M, tau_null[k])))
    final = _energy(plant, q_end, qd_end, plant.mass_matrix(q_end))
    log.extra.update(
        kinetic_energy=kinetic,
        potential_energy=potential,
        energy=kinetic + potential,
        final_energy=sum(final),
        task_disturbance=disturbance,
    )


def dynamics_summary(log: RunLog) -> dict[str, Any]:
    """``log.summary()`` plus the dynamic metrics of a :func:`simulate` run.

    Added keys: ``max_torque_ratio`` (``max |τ_cmd| / τ_max``), ``saturated_steps``,
    ``max_task_disturbance`` and ``rms_task_disturbance`` (``‖J M⁻¹ τ_null‖``, m/s² and
    rad/s² together), ``energy_drift_rel`` (``(E_end − E_0) / |E_0|``) and
    ``max_energy_deviation_rel`` (largest ``|E_k − E_0| / |E_0|``).
    """
    out = log.summary()
    extra = log.extra
    dist = extra["task_disturbance"]
    energy = np.append(extra["energy"], extra["final_energy"])
    scale = abs(float(energy[0])) or 1.0
    out.update(
        max_torque_ratio=float(extra["torque_ratio"].max()),
        saturated_steps=int(log.scaled.sum()),
        max_task_disturbance=float(dist.max()),
        rms_task_disturbance=float(np.sqrt(np.mean(dist**2))),
        energy_drift_rel=float((energy[-1] - energy[0]) / scale),
        max_energy_deviation_rel=float(np.abs(energy - energy[0]).max() / scale),
    )
    return out
