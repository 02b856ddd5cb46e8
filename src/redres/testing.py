"""Finite-difference oracles for checking Jacobians, gradients and command streams.

The one shared helper of the test suite, public so that users can check their own tasks
and objectives the same way. Central differences of order h²; configurations are perturbed
with ``pinocchio.integrate`` so that the helpers stay right for any joint type.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import pinocchio as pin

from ._validate import FloatArray

if TYPE_CHECKING:
    from .robot import Reference, Robot

__all__ = [
    "CommandViolation",
    "assert_jacobian_close",
    "command_violations",
    "frame_jacobian_fd",
    "jacobian_dot_fd",
    "numerical_gradient",
    "numerical_jacobian",
    "random_limit_states",
]


def _perturbed(q0: FloatArray, eps: float, model: Any) -> Iterator[tuple[FloatArray, FloatArray]]:
    """``(q ⊕ h eᵢ, q ⊕ −h eᵢ)`` for each coordinate ``i``: ``pin.integrate`` on ``model``,
    plain addition without one."""
    for dq in eps * np.eye(q0.size):
        if model is None:
            yield q0 + dq, q0 - dq
        else:
            yield pin.integrate(model, q0, dq), pin.integrate(model, q0, -dq)


def numerical_jacobian(
    f: Callable[[FloatArray], Any], q: Any, eps: float = 1e-6, model: Any = None
) -> FloatArray:
    """Central-difference Jacobian ``∂f/∂q`` of a vector function, shape ``(m, n)``.

    Args:
        f: function of the configuration returning a vector (or scalar).
        q: configuration, shape ``(n,)``.
        eps: step, rad or m.
        model: a Pinocchio model to perturb ``q`` with ``pin.integrate`` (default: plain
            addition, right for revolute and prismatic joints).
    """
    pairs = _perturbed(np.asarray(q, dtype=float), eps, model)
    return np.column_stack(
        [(np.atleast_1d(f(qp)) - np.atleast_1d(f(qm))) / (2.0 * eps) for qp, qm in pairs]
    )


def numerical_gradient(f: Callable[[FloatArray], float], q: Any, eps: float = 1e-6) -> FloatArray:
    """Central-difference gradient of a scalar function, shape ``(n,)``."""
    return numerical_jacobian(lambda x: np.array([f(x)]), q, eps)[0]


def frame_jacobian_fd(
    robot: Robot,
    q: Any,
    frame: str | None = None,
    reference: Reference = "world",
    eps: float = 1e-6,
) -> FloatArray:
    """Frame Jacobian by central differences of :meth:`Robot.fk`, shape ``(6, n)``.

    Linear rows: derivative of the frame origin, in world axes (``"world"``) or in the
    frame's axes (``"local"``). Angular rows: the SO(3) logarithm of the rotation between
    the two perturbed poses, ``log(R₊ R₋ᵀ)/2h`` (world) or ``log(R₋ᵀ R₊)/2h`` (local).
    """
    q0 = np.asarray(q, dtype=float)
    R0 = robot.fk(q0, frame)[:3, :3]
    J = np.zeros((6, robot.n))
    for i, (qp, qm) in enumerate(_perturbed(q0, eps, robot.model)):
        Tp, Tm = robot.fk(qp, frame), robot.fk(qm, frame)
        v = (Tp[:3, 3] - Tm[:3, 3]) / (2 * eps)
        if reference == "world":
            w = pin.log3(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * eps)
        else:
            v = R0.T @ v
            w = pin.log3(Tm[:3, :3].T @ Tp[:3, :3]) / (2 * eps)
        J[:, i] = np.concatenate([v, w])
    return J


def jacobian_dot_fd(
    robot: Robot,
    q: Any,
    qd: Any,
    frame: str | None = None,
    reference: Reference = "world",
    eps: float = 1e-6,
) -> FloatArray:
    """``dJ/dt`` along ``qd`` by central differences of :meth:`Robot.jacobian`, ``(6, n)``."""
    q0, v = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    Jp = robot.jacobian(pin.integrate(robot.model, q0, eps * v), frame, reference)
    Jm = robot.jacobian(pin.integrate(robot.model, q0, -eps * v), frame, reference)
    return (Jp - Jm) / (2 * eps)


def assert_jacobian_close(
    J: Any, J_ref: Any, *, atol: float = 1e-6, rtol: float = 1e-6, name: str = "Jacobian"
) -> None:
    """Raise ``AssertionError`` naming the worst entry when ``J`` and ``J_ref`` differ."""
    A, B = np.asarray(J, dtype=float), np.asarray(J_ref, dtype=float)
    if A.shape != B.shape:
        raise AssertionError(f"{name}: shape {A.shape} != reference shape {B.shape}")
    err = np.abs(A - B) - (atol + rtol * np.abs(B))
    if np.any(err > 0) or not np.isfinite(A).all():
        idx = np.unravel_index(int(np.argmax(err)), A.shape)
        raise AssertionError(
            f"{name} differs from the reference at {idx}: {A[idx]!r} vs {B[idx]!r} "
            f"(max abs error {np.max(np.abs(A - B)):.3e}, atol={atol}, rtol={rtol})"
        )


def random_limit_states(
    robot: Robot, rng: np.random.Generator, count: int, dt: float = 1e-3
) -> list[tuple[FloatArray, FloatArray, FloatArray, FloatArray]]:
    """Random states ``(q, q̇_prev, J, ẋ)`` near the joint limits, for hard-limit schemes.

    ``q``: uniform, then ~30 % of the joints moved to within 2 cm of a limit (some exactly
    on it); ``qd_prev``: at rest, slow or fast, halved until the box is viable (a state
    reachable by a run that kept its limits); ``ẋ``: random (0.1 mm/s to 1 m/s) or the
    current task velocity perturbed and amplified. ``J`` is the tip Jacobian (6 x n).
    """
    from .resolution.hard_limits import JointLimits, velocity_bounds

    lim = JointLimits.from_robot(robot)
    out = []
    for k in range(count):
        q = robot.random_configuration(rng)
        near, upper = rng.random(robot.n) < 0.3, rng.random(robot.n) < 0.5
        gap = rng.choice([0.0, 1e-6, 1e-3, 0.02], size=robot.n)
        q = np.where(near, np.where(upper, lim.q_max - gap, lim.q_min + gap), q)
        prev = rng.uniform(-1, 1, robot.n) * lim.qd_max * rng.choice([0.0, 0.01, 0.3, 1.0])
        while not velocity_bounds(lim, q, prev, dt).viable:
            prev = 0.5 * prev
        J = robot.jacobian(q)
        if k % 2:
            xd = rng.normal(size=6) * 10 ** rng.uniform(-4, 0)
        else:
            xd = J @ (prev + rng.normal(size=robot.n) * 10 ** rng.uniform(-3, -1))
            xd *= rng.choice([1.0, 1.5, 3.0])
        out.append((q, prev, J, xd))
    return out


def step_from_states(
    scheme: Any, robot: Robot, states: list[tuple[FloatArray, FloatArray, FloatArray, FloatArray]]
) -> list[Any]:
    """``scheme.step`` from each ``(q, q̇_prev, J, ẋ)`` of :func:`random_limit_states`, the
    previous velocity set first (``scheme.qd_prev``); the list of ``StepResult``."""
    results = []
    for q, prev, J, xd in states:
        scheme.qd_prev = prev
        results.append(scheme.step(robot, q, J, xd))
    return results


class CommandViolation(NamedTuple):
    """A command over a limit: ``cycle`` (0: the first command), ``quantity``
    (``"velocity"``, ``"acceleration"`` or ``"jerk"``), ``joint``, and ``ratio`` of the
    value to the limit (> 1)."""

    cycle: int
    quantity: str
    joint: int
    ratio: float


def command_violations(
    qd: Any,
    dt: float,
    limits: tuple[Any, Any, Any],
    qd0: Any = None,
    qdd0: Any = None,
) -> list[CommandViolation]:
    """Every joint-velocity command of a stream that a robot checking finite differences
    would refuse, in order: ``|q̇ₖ|``, ``|q̇ₖ − q̇ₖ₋₁|/dt`` and the difference of those over
    ``dt`` against ``limits`` (velocity, acceleration, jerk; each a number or ``(n,)``),
    the first command differenced against the measured ``qd0`` and ``qdd0`` (default: at
    rest), as the Franka arms check each 1 kHz cycle.

    ``qd``: the stream, ``(cycles, n)``, rad/s (a joint-position stream's differences over
    ``dt``, with its measured start prepended, are one).
    """
    v = np.atleast_2d(np.asarray(qd, dtype=float))
    n = v.shape[1]
    v_start = np.zeros(n) if qd0 is None else np.asarray(qd0, dtype=float)
    a_start = np.zeros(n) if qdd0 is None else np.asarray(qdd0, dtype=float)
    a = np.diff(np.vstack([v_start, v]), axis=0) / dt
    j = np.diff(np.vstack([a_start, a]), axis=0) / dt
    found = []
    for name, values, limit in zip(("velocity", "acceleration", "jerk"), (v, a, j), limits):
        ratio = np.abs(values) / np.asarray(limit, dtype=float)
        for k, i in zip(*np.nonzero(ratio > 1.0)):
            found.append(CommandViolation(int(k), name, int(i), float(ratio[k, i])))
    return sorted(found)
