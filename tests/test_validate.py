"""The shared input checks: complex values are refused by name, not made real (issue 18,
item 10); huge integers and ragged lists are one clear error."""

from __future__ import annotations

import inspect
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import redres as rr
from redres._validate import as_gains, as_matrix, as_scalar, as_vector
from redres.errors import InvalidParameterError, NonFiniteError, RedresError, ShapeError
from redres.objectives import JointLimitObjective


def test_complex_values_are_refused_by_name() -> None:
    with pytest.raises(InvalidParameterError, match=r"q must be real; got a complex array"):
        as_vector(np.zeros(3) + 0.5j, "q", 3)
    with pytest.raises(InvalidParameterError, match=r"J must be real"):
        as_matrix([[1.0, 2j]], "J")
    with pytest.raises(InvalidParameterError, match=r"damping must be a real number"):
        as_scalar(np.complex128(0.1), "damping")


def _complex_calls() -> dict[str, tuple[Callable[[], Any], str]]:
    """Every public array entry point, called with one argument complex: ``label ->
    (call, the argument's name in the error)``."""
    from redres import batch, control, dynamics, objectives, resolution, tasks

    robot = rr.models.panda()
    q, c = robot.neutral(), 0.5j
    J, M, P = robot.jacobian(q), robot.mass_matrix(q), robot.fk(q)
    z6, z7, lim = np.zeros(6), np.zeros(7), resolution.JointLimits.from_robot(robot)
    schemes = {
        "PseudoInverseScheme": resolution.PseudoInverseScheme(),
        "GradientProjectionScheme": resolution.GradientProjectionScheme([JointLimitObjective()]),
        "WeightedLeastNormScheme": resolution.WeightedLeastNormScheme(),
        "AugmentedJacobianScheme": resolution.AugmentedJacobianScheme(),
        "PriorityScheme": resolution.PriorityScheme([tasks.PostureTask()]),
        "SNSScheme": resolution.SNSScheme(1e-3),
        "QPScheme": resolution.QPScheme(1e-3),
    }
    calls: dict[str, tuple[Callable[[], Any], str]] = {}
    for method in ("fk", "jacobian", "kinematics", "jacobian_derivatives", "mass_matrix",
                   "gravity", "joint_limit_margin", "within_limits"):  # fmt: skip
        calls[f"Robot.{method}"] = (lambda m=method: getattr(robot, m)(q + c), "q")
    calls |= {
        "Robot.point_jacobians": (lambda: robot.point_jacobians(q + c, ["tcp"]), "q"),
        "Robot.jacobian_dot": (lambda: robot.jacobian_dot(q, q + c), "qd"),
        "Robot.bias": (lambda: robot.bias(q, q + c), "qd"),
        "Robot.inverse_dynamics": (lambda: robot.inverse_dynamics(q, q, q + c), "qdd"),
        "Robot.forward_dynamics": (lambda: robot.forward_dynamics(q, q, q + c), "tau"),
        "Robot.within_limits tol": (lambda: robot.within_limits(q, tol=0.1 + 1j), "tol"),
        "Robot.add_frame": (lambda: robot.add_frame("x", "tcp", np.eye(4) + c), "frame 'x'"),
        "rr.ik target": (lambda: rr.ik(robot, P + c), "target"),
        "rr.ik q0": (lambda: rr.ik(robot, P, q0=q + c), "q0"),
        "rr.ik q_preferred": (lambda: rr.ik(robot, P, q_preferred=q + c), "q_preferred"),
    }
    # rr.linalg: every public function (checked against __all__ below)
    L = rr.linalg
    calls |= {
        "pinv": (lambda: L.pinv(J + c), "J"),
        "right_pinv": (lambda: L.right_pinv(J + c), "J"),
        "left_pinv": (lambda: L.left_pinv(J.T + c), "J"),
        "square_inverse": (lambda: L.square_inverse(np.eye(3) + c), "J"),
        "generalized_inverse": (lambda: L.generalized_inverse(J + c), "J"),
        "damped_pinv": (lambda: L.damped_pinv(J + c, 0.1), "J"),
        "damped_pinv damping": (lambda: L.damped_pinv(J, 0.1 + 0j), "damping"),
        "adaptive_damped_pinv": (lambda: L.adaptive_damped_pinv(J + c, 0.1, 0.05), "J"),
        "weighted_pinv": (lambda: L.weighted_pinv(J + c, np.eye(7)), "J"),
        "weighted_pinv W": (lambda: L.weighted_pinv(J, np.eye(7) + c), "W"),
        "task_space_inertia": (lambda: L.task_space_inertia(J + c, M), "J"),
        "task_space_inertia M": (lambda: L.task_space_inertia(J, M + c), "M"),
        "dynamically_consistent_pinv": (lambda: L.dynamically_consistent_pinv(J + c, M), "J"),
        "dynamically_consistent_pinv M": (lambda: L.dynamically_consistent_pinv(J, M + c), "M"),
        "dynamically_consistent_projector": (
            lambda: L.dynamically_consistent_projector(J + c, M),
            "J",
        ),
        "nullspace_projector": (lambda: L.nullspace_projector(J + c), "J"),
        "nullspace_basis": (lambda: L.nullspace_basis(J + c), "J"),
        "is_moore_penrose": (lambda: L.is_moore_penrose(J + c, np.linalg.pinv(J)), "J"),
        "moore_penrose_residuals": (
            lambda: L.moore_penrose_residuals(J + c, np.linalg.pinv(J)),
            "J",
        ),
        "manipulability": (lambda: L.manipulability(J + c), "J"),
        "manipulability_gradient": (
            lambda: L.manipulability_gradient(J, np.zeros((7, 6, 7)) + c),
            "dJ_dq",
        ),
        "singular_values": (lambda: L.singular_values(J + c), "J"),
        "sigma_min": (lambda: L.sigma_min(J + c), "J"),
        "condition_number": (lambda: L.condition_number(J + c), "J"),
        "rate_step": (lambda: L.rate_step(J + c, z6), "J"),
        "rate_step xd": (lambda: L.rate_step(J, z6 + c), "xd"),
        "rate_step grad": (lambda: L.rate_step(J, z6, z7 + c), "grad"),
        "rate_step weights": (lambda: L.rate_step(J, z6, weights=np.ones(7) + c), "weights"),
        "adaptive_damping": (lambda: L.adaptive_damping(0.01 + 1j, 0.1, 0.05), "sigma_min"),
    }
    for label, scheme in schemes.items():
        calls[f"{label}.step q"] = (lambda s=scheme: s.step(robot, q + c, J, z6), "q")
        calls[f"{label}.step J"] = (lambda s=scheme: s.step(robot, q, J + c, z6), "J")
        calls[f"{label}.step xd"] = (lambda s=scheme: s.step(robot, q, J, z6 + c), "xd")
    calls |= {
        "SNSScheme qd_max": (lambda: resolution.SNSScheme(1e-3, qd_max=np.ones(7) + c), "qd_max"),
        "QPScheme qdd_max": (lambda: resolution.QPScheme(1e-3, qdd_max=20 + 1j), "qdd_max"),
        "WeightedLeastNormScheme c": (
            lambda: resolution.WeightedLeastNormScheme(c=np.ones(7) + c),
            "c",
        ),
        "JointLimits.from_robot": (
            lambda: resolution.JointLimits.from_robot(robot, qd_max=np.ones(7) + c),
            "qd_max",
        ),
        "braking_velocity distance": (
            lambda: resolution.braking_velocity(z7 + c, 1e-3, 1.0),
            "distance",
        ),
        "braking_velocity qdd_max": (
            lambda: resolution.braking_velocity(z7, 1e-3, z7 + 1 + c),
            "qdd_max",
        ),
        "velocity_bounds q": (lambda: resolution.velocity_bounds(lim, q + c, None, 1e-3), "q"),
        "velocity_bounds qd_prev": (
            lambda: resolution.velocity_bounds(lim, q, z7 + c, 1e-3),
            "qd_prev",
        ),
        "step_violation qd": (lambda: resolution.step_violation(lim, q, z7 + c, None, 1e-3), "qd"),
        "largest_scale J": (lambda: resolution.largest_scale(J + c, z6, z7 - 1, z7 + 1), "J"),
        "largest_scale lower": (
            lambda: resolution.largest_scale(J, z6, z7 - 1 + c, z7 + 1),
            "lower",
        ),
        "joint_limit_gradient q": (
            lambda: resolution.joint_limit_gradient(q + c, robot.q_min, robot.q_max, 1.0),
            "q",
        ),
        "joint_limit_gradient c": (
            lambda: resolution.joint_limit_gradient(q, robot.q_min, robot.q_max, 1.0 + 1j),
            "c",
        ),
        "wrap_angle": (lambda: tasks.wrap_angle(np.ones(3) + c), "angle"),
        "arm_angle_from_points": (
            lambda: tasks.arm_angle_from_points(np.ones(3) + c, z6[:3], z6[:3] + 1, z6[:3]),
            "shoulder",
        ),
        "ArmAngleTask.set_target": (lambda: tasks.ArmAngleTask().set_target(0.1 + 1j), "phi"),
        "ArmAngleTask target": (lambda: tasks.ArmAngleTask(target=0.1 + 1j), "target"),
        "ArmAngleTask reference": (
            lambda: tasks.ArmAngleTask(reference=np.ones(3) + c),
            "reference",
        ),
        "LookAtTask.set_target": (lambda: tasks.LookAtTask().set_target(np.ones(3) + c), "point"),
        "PostureTask q_ref": (lambda: tasks.PostureTask(q_ref=q + c), "q_ref"),
        "Line end": (lambda: control.Line(P, P[:3, 3] + c, 1.0), "end"),
        "Line start_pose": (lambda: control.Line(P + c, P[:3, 3], 1.0), "start"),
        "Circle start_pose": (lambda: control.Circle(P + c, 0.1, 1.0), "start"),
        "Circle normal": (lambda: control.Circle(P, 0.1, 1.0, normal=np.ones(3) + c), "normal"),
        "Circle radius": (lambda: control.Circle(P, 0.1 + 1j, 1.0), "radius"),
        "FigureEight start_pose": (lambda: control.FigureEight(P + c, 0.1, 0.1, 1.0), "start"),
        "Hold pose": (lambda: control.Hold(P + c, 1.0), "pose"),
        "MinimumJerk end_pose": (lambda: control.MinimumJerk(P, P + c, 1.0), "end"),
        "Payload com": (lambda: dynamics.Payload(1.0, com=np.zeros(3) + c), "com"),
        "Payload inertia": (lambda: dynamics.Payload(1.0, inertia=np.eye(3) + c), "inertia"),
        "Payload mass": (lambda: dynamics.Payload(1.0 + 1j), "mass"),
        "operational_space_torque J": (
            lambda: dynamics.operational_space_torque(J + c, M, z7, z6),
            "J",
        ),
        "operational_space_torque M": (
            lambda: dynamics.operational_space_torque(J, M + c, z7, z6),
            "M",
        ),
        "operational_space_torque bias": (
            lambda: dynamics.operational_space_torque(J, M, z7 + c, z6),
            "bias",
        ),
        "operational_space_torque command": (
            lambda: dynamics.operational_space_torque(J, M, z7, z6 + c),
            "command",
        ),
        "operational_space_torque tau0": (
            lambda: dynamics.operational_space_torque(J, M, z7, z6, z7 + c),
            "tau0",
        ),
        "resolve_acceleration J": (lambda: dynamics.resolve_acceleration(J + c, M, z6, z6), "J"),
        "resolve_acceleration M": (lambda: dynamics.resolve_acceleration(J, M + c, z6, z6), "M"),
        "resolve_acceleration xdd": (
            lambda: dynamics.resolve_acceleration(J, M, z6 + c, z6),
            "xdd",
        ),
        "resolve_acceleration jdot_qd": (
            lambda: dynamics.resolve_acceleration(J, M, z6, z6 + c),
            "jdot_qd",
        ),
        "resolve_acceleration qdd0": (
            lambda: dynamics.resolve_acceleration(J, M, z6, z6, z7 + c),
            "qdd0",
        ),
        "task_disturbance tau": (lambda: dynamics.task_disturbance(J, M, z7 + c), "tau"),
        "payload_spatial_inertia q": (
            lambda: dynamics.payload_spatial_inertia(robot, q + c, dynamics.Payload(1.0)),
            "q",
        ),
        "OperationalSpaceController kp": (
            lambda: dynamics.OperationalSpaceController(kp=400 + 1j),
            "kp",
        ),
        "AccelerationController kp": (
            lambda: dynamics.AccelerationController(kp=np.full(6, 400.0) + c),
            "kp",
        ),
        "batch.fk": (lambda: batch.fk(robot, q[None] + c), "q"),
        "batch.jacobian": (lambda: batch.jacobian(robot, q[None] + c), "q"),
        "batch.ik targets": (lambda: batch.ik(robot, P[None] + c), "targets"),
        "batch.ik q0": (lambda: batch.ik(robot, P[None], q0=q + c), "q0"),
        "batch.rate_step q": (lambda: batch.rate_step(robot, q[None] + c, z6[None]), "q"),
        "batch.rate_step xd": (lambda: batch.rate_step(robot, q[None], z6[None] + c), "xd"),
        "batch.rate_step grad": (
            lambda: batch.rate_step(robot, q[None], z6[None], z7[None] + c),
            "grad",
        ),
        "batch.rate_step weights": (
            lambda: batch.rate_step(robot, q[None], z6[None], weights=np.ones(7) + c),
            "weights",
        ),
        "SphereObstacle center": (
            lambda: objectives.SphereObstacle(np.zeros(3) + c, 0.1),
            "center",
        ),
        "CapsuleObstacle a": (
            lambda: objectives.CapsuleObstacle(np.zeros(3) + c, np.ones(3), 0.1),
            "a",
        ),
        "PointObstacle": (lambda: objectives.PointObstacle(np.zeros(3) + c), "point"),
        "PostureObjective q_ref": (lambda: objectives.PostureObjective(q_ref=q + c), "q_ref"),
        "PostureObjective weights": (
            lambda: objectives.PostureObjective(weights=np.ones(7) + c),
            "weights",
        ),
        "JointLimitObjective.cost": (lambda: JointLimitObjective().cost(robot, q + c), "q"),
        "JointLimitObjective.gradient": (
            lambda: JointLimitObjective().gradient(robot, q + 1j),
            "q",
        ),
        "ManipulabilityObjective.gradient": (
            lambda: objectives.ManipulabilityObjective().gradient(robot, q + c),
            "q",
        ),
        "proximities q": (
            lambda: objectives.proximities(
                robot, q + c, [objectives.PointObstacle(np.ones(3))], []
            ),
            "q",
        ),
    }
    return calls


def test_public_array_entry_points_refuse_complex_input() -> None:
    """Issue 18, item 10: complex input was made real (``fk(q + 0.5j) == fk(q)``) at 88
    of 91 entry points. Each is now a RedresError (and a ValueError) naming the argument,
    never a ComplexWarning (an error here: the filter below)."""
    calls = _complex_calls()
    functions = {name for name in rr.linalg.__all__ if inspect.isfunction(getattr(rr.linalg, name))}
    assert functions <= set(calls), f"rr.linalg functions not walked: {functions - set(calls)}"
    failures = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for label, (call, argument) in calls.items():
            try:
                call()
            except RedresError as exc:
                if not (isinstance(exc, ValueError) and argument in str(exc)):
                    failures[label] = f"{type(exc).__name__}: {exc}"
            except Exception as exc:  # the test reports every entry point
                failures[label] = f"raw {type(exc).__name__}: {exc}"
            else:
                failures[label] = "accepted (made real)"
    assert not failures, "\n".join(f"{k}: {v}" for k, v in failures.items())


def test_huge_integers_and_ragged_lists_are_shape_errors() -> None:
    with pytest.raises(ShapeError, match=r"q must be a vector of numbers; got \[1000.*characters"):
        as_vector([10**400, 0, 0], "q", 3)
    with pytest.raises(ShapeError, match=r"J must be a 2-D array of numbers"):
        as_matrix([[1.0, 2.0], [3.0]], "J")
    with pytest.raises(InvalidParameterError, match=r"gain must be a number; got 1000"):
        as_scalar(10**400, "gain")


def test_gains_are_a_nonnegative_scalar_or_one_per_entry() -> None:
    """The one scalar-or-per-row check (controller gains, servo gains, posture weights)."""
    assert as_gains(2, "gain") == 2.0 and isinstance(as_gains(2, "gain"), float)
    assert as_gains(np.float64(0.0), "gain") == 0.0
    given = np.array([1.0, 0.0, 3.0])
    out = as_gains(given, "kp", 3)
    assert np.array_equal(out, given) and out is not given  # a copy: the caller keeps its own
    assert np.array_equal(as_gains([1, 2], "weights"), [1.0, 2.0])  # any length without size
    with pytest.raises(InvalidParameterError, match=r"gain must be >= 0.0; got -1.0"):
        as_gains(-1.0, "gain")
    with pytest.raises(InvalidParameterError, match=r"kp must be >= 0 on every entry; got"):
        as_gains([1.0, -2.0, 3.0], "kp", 3)
    with pytest.raises(ShapeError, match=r"kd"):
        as_gains([1.0, 2.0], "kd", 3)
    with pytest.raises(NonFiniteError, match=r"gain"):
        as_gains(float("nan"), "gain")
    with pytest.raises(NonFiniteError, match=r"kp"):
        as_gains([1.0, np.inf, 0.0], "kp", 3)


def test_objectives_check_the_configuration_they_are_given() -> None:
    """JointLimitObjective().gradient(robot, nan_q) returned NaN (issue 18, item 6)."""
    from redres.errors import NonFiniteError
    from redres.objectives import PostureObjective

    robot = rr.models.panda()
    for objective in (JointLimitObjective(), PostureObjective()):
        with pytest.raises(NonFiniteError, match="q contains NaN"):
            objective.gradient(robot, np.full(7, np.nan))
        with pytest.raises(ShapeError, match=r"q must have shape \(7,\)"):
            objective.cost(robot, np.zeros(3))


@pytest.mark.parametrize("value", [True, np.True_, "1.5", b"1", "nan"])
def test_a_bool_or_text_is_no_number(value: Any) -> None:
    """float() reads "1.5", b"1" and True as numbers: a tolerance of True or a gain of
    "1.5" was accepted silently (the reliability campaign's silent accepts)."""
    with pytest.raises(InvalidParameterError, match="tol must be a number"):
        as_scalar(value, "tol")


@pytest.mark.parametrize("value", [[True, False, True], ["1", "2", "3"], [b"1", b"2", b"3"]])
def test_bool_and_text_arrays_are_no_vectors(value: Any) -> None:
    with pytest.raises(ShapeError, match="qd_max must be a vector of numbers"):
        as_vector(value, "qd_max", 3)
    with pytest.raises(ShapeError, match="q must be an array of numbers"):
        rr.batch.fk(rr.models.load("planar3"), [value])
