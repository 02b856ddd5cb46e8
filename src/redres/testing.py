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


class CollisionScene(NamedTuple):
    """A random scene that drives an arm into obstacles (:func:`collision_scene`).

    Attributes:
        q0: start configuration ``(n,)``, rad, clear of every obstacle and of itself.
        q1: the configuration whose tip position ``end`` the path goes to, rad.
        end: the tip's goal position ``(3,)``, m (a straight line from ``fk(q0)``).
        obstacles: spheres, boxes, capsules and sometimes a half-space, placed on the
            links at configurations between ``q0`` and ``q1``.
    """

    q0: FloatArray
    q1: FloatArray
    end: FloatArray
    obstacles: list[Any]


def _random_rotation(rng: np.random.Generator) -> FloatArray:
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    return Q if np.linalg.det(Q) > 0 else -Q


def collision_scene(
    robot: Robot,
    rng: np.random.Generator,
    *,
    clear: float = 0.03,
    spread: float = 0.8,
    allowed: Any = (),
    tries: int = 10_000,
) -> CollisionScene:
    """A random start ``q0`` inside the limits, a nearby ``q1`` (normal steps of
    ``spread`` rad) and one to three obstacles (sphere, box or capsule, 2–8 cm) centred on
    a link capsule's axis at a configuration on the straight joint-space way from ``q0``
    to ``q1``, and in a third of the scenes a table (half-space) the tip path goes below:
    the tip path from ``fk(q0)`` to ``fk(q1)`` drives the arm into them. Drawn again until
    every pair of the robot's capsules and the obstacles (self pairs too, as
    :class:`~redres.collision.CollisionModel` chooses them) is at least ``clear`` m apart
    at ``q0``, and no obstacle touches the arm at its neutral pose (where the model would
    leave the pair out) but the table under the base capsule (joint 1: its distance to a
    horizontal plane never changes). ``allowed``: pairs left out (as
    :class:`~redres.collision.Collisions` takes them).

    Raises:
        RuntimeError: no scene found in ``tries`` draws (the arm's capsules overlap
            each other in most configurations: allow those pairs).
    """
    from .collision import (
        BoxObstacle,
        CapsuleObstacle,
        CollisionModel,
        PlaneObstacle,
        SphereObstacle,
    )

    lo, hi = robot.q_min, robot.q_max
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    frames = robot.model.frames
    caps = [c for c in robot.capsules if frames[robot.frame_id(c.frame)].parentJoint > 1]
    for _ in range(tries):
        q0 = mid + 0.8 * half * rng.uniform(-1.0, 1.0, robot.n)
        q1 = np.clip(q0 + rng.normal(0.0, spread, robot.n), mid - 0.9 * half, mid + 0.9 * half)
        obstacles: list[Any] = []
        for k in range(int(rng.integers(1, 4))):
            q = q0 + rng.uniform(0.3, 0.9) * (q1 - q0)
            cap = caps[int(rng.integers(len(caps)))]
            T = robot.fk(q, cap.frame)
            point = T[:3, :3] @ (cap.a + rng.uniform() * (cap.b - cap.a)) + T[:3, 3]
            size, kind = rng.uniform(0.02, 0.08), int(rng.integers(3))
            name = f"o{k}"
            if kind == 0:
                obstacles.append(SphereObstacle(point, size, name))
            elif kind == 1:
                half_extents = rng.uniform(0.5, 1.0, 3) * size
                obstacles.append(BoxObstacle(point, half_extents, _random_rotation(rng), name))
            else:
                axis = rng.normal(size=3)
                axis *= rng.uniform(0.05, 0.15) / np.linalg.norm(axis)
                obstacles.append(CapsuleObstacle(point - axis, point + axis, 0.5 * size, name))
        end = robot.fk(q1)[:3, 3]
        if rng.uniform() < 1.0 / 3.0:
            height = end[2] + rng.uniform(0.0, 0.1)
            obstacles.append(PlaneObstacle(np.array([0.0, 0.0, 1.0]), height, "table"))
        model = CollisionModel(robot, obstacles, safety=0.0, allowed=allowed)
        base = {c.name for c in robot.capsules} - {c.name for c in caps}
        left_out = [e for e in model.excluded if e[1] != "table" or e[0] not in base]
        if model.distances(q0).min(initial=np.inf) >= clear and not any(
            e[1] in {o.name for o in obstacles} for e in left_out
        ):
            return CollisionScene(q0, q1, end, obstacles)
    raise RuntimeError(f"no collision scene for {robot.name} in {tries} draws")
