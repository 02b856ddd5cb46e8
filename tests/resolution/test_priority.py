"""Strict task priorities against their defining formulas, laws and singular cases.

Oracles: the Siciliano–Slotine recursion and Chiaverini's formula written out with
``numpy.linalg.pinv`` and explicit projectors ``I − A⁺A`` of the augmented Jacobians;
finite differences (redres.testing) for the task Jacobians; ``arccos`` for the look-at angle.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import redres as rr
from redres.errors import InvalidParameterError, NonFiniteError, ShapeError
from redres.linalg import AdaptiveDamping, adaptive_damping
from redres.resolution import PriorityResult, PriorityScheme, prioritized_velocity
from redres.tasks import ArmAngleTask, FrameTask, LookAtTask, PositionTask, PostureTask
from redres.testing import numerical_jacobian

METHODS = ("exact", "robust", "damped")


# ---------------------------------------------------------------------------- oracles
def pinv_cut(A: np.ndarray, tol: float) -> np.ndarray:
    """Pseudo-inverse skipping singular values <= tol (absolute)."""
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    inv = np.divide(1.0, s, out=np.zeros_like(s), where=s > tol)
    return (Vt.T * inv) @ U.T


def oracle_exact(Js: list[np.ndarray], xs: list[np.ndarray]) -> np.ndarray:
    """Siciliano & Slotine (1991) with dense projectors of the augmented Jacobians.

    Singular values of ``J_k P_{k−1}`` below ``1e-9 ‖J_k‖`` count as zero: once the higher
    levels use every joint, ``J_k P_{k−1}`` is rounding noise, not a matrix to invert.
    """
    n = Js[0].shape[1]
    qd, P, stacked = np.zeros(n), np.eye(n), np.zeros((0, n))
    for J, x in zip(Js, xs):
        qd = qd + pinv_cut(J @ P, 1e-9 * np.linalg.norm(J, 2)) @ (x - J @ qd)
        stacked = np.vstack([stacked, J])
        P = np.eye(n) - np.linalg.pinv(stacked, rcond=1e-10) @ stacked
    return qd


def oracle_robust(
    Js: list[np.ndarray], xs: list[np.ndarray], lam_max: float, eps: float
) -> np.ndarray:
    """Chiaverini (1997) eq. 34 / Antonelli (2009): sum of P_{k-1} J_k^# x_k."""
    n = Js[0].shape[1]
    qd, P, stacked = np.zeros(n), np.eye(n), np.zeros((0, n))
    for J, x in zip(Js, xs):
        smin = np.linalg.svd(J, compute_uv=False)[-1]
        lam = adaptive_damping(smin, lam_max, eps)
        J_damped = J.T @ np.linalg.inv(J @ J.T + lam**2 * np.eye(J.shape[0]))
        qd = qd + P @ J_damped @ x
        stacked = np.vstack([stacked, J])
        P = np.eye(n) - np.linalg.pinv(stacked, rcond=1e-10) @ stacked
    return qd


def random_levels(rng: np.random.Generator, n: int, rows: list[int]) -> tuple[list, list]:
    Js = [rng.normal(size=(m, n)) for m in rows]
    return Js, [rng.normal(size=m) for m in rows]


# ---------------------------------------------------------------------------- formulas
@pytest.mark.parametrize("rows", [[3, 2, 1], [2, 2, 2, 3], [6, 1, 7], [1, 1, 1, 1, 1]])
def test_exact_is_the_siciliano_slotine_recursion(
    rows: list[int], rng: np.random.Generator
) -> None:
    for _ in range(20):
        Js, xs = random_levels(rng, 7, rows)
        qd, levels = prioritized_velocity(Js, xs)
        assert np.allclose(qd, oracle_exact(Js, xs), atol=1e-9 * (1 + np.abs(qd).max()))
        freedom = 7
        for info, m in zip(levels, rows):  # generic matrices: ranks add up
            assert info.freedom == freedom and info.rank == min(m, freedom) and info.full_rank
            freedom -= info.rank


def test_exact_with_a_dependent_level(rng: np.random.Generator) -> None:
    """A level whose rows repeat a higher level's adds nothing and loses rank."""
    Js, xs = random_levels(rng, 6, [2, 2])
    Js.insert(1, Js[0][:1].copy())
    xs.insert(1, rng.normal(size=1))
    qd, levels = prioritized_velocity(Js, xs)
    assert levels[1].rank == 0 and not levels[1].full_rank
    assert np.allclose(levels[1].contribution, 0.0, atol=1e-12)
    assert np.allclose(qd, oracle_exact(Js, xs), atol=1e-9)


def test_levels_met_exactly_or_in_least_squares(rng: np.random.Generator) -> None:
    """J_k q̇ = ẋ_k while the projected Jacobian has full row rank; otherwise the residual
    is orthogonal to everything level k could still change: (J_k P_{k−1})ᵀ r = 0."""
    for _ in range(20):
        Js, xs = random_levels(rng, 7, [3, 2, 4])  # the third level has 2 DOF for 4 rows
        qd, levels = prioritized_velocity(Js, xs)
        for J, x in zip(Js[:2], xs[:2]):
            assert np.allclose(J @ qd, x, atol=1e-10)
        stacked = np.vstack(Js[:2])
        P = np.eye(7) - np.linalg.pinv(stacked) @ stacked
        assert np.allclose((Js[2] @ P).T @ (Js[2] @ qd - xs[2]), 0.0, atol=1e-10)
        assert levels[2].freedom == 2 and levels[2].residual > 1e-3


def test_robust_is_chiaverini_formula(rng: np.random.Generator) -> None:
    damping = AdaptiveDamping(0.1, 0.5)
    for _ in range(20):
        Js, xs = random_levels(rng, 7, [3, 2, 1])
        Js[0][2] = Js[0][1] + 0.05 * rng.normal(size=7)  # near-singular level 1: damped
        qd, levels = prioritized_velocity(Js, xs, method="robust", damping=damping)
        assert np.allclose(qd, oracle_robust(Js, xs, 0.1, 0.5), atol=1e-10)
        assert levels[0].damping > 0.0


def test_damped_equals_exact_away_from_singularities(rng: np.random.Generator) -> None:
    damping = AdaptiveDamping(0.05, 1e-3)
    for _ in range(10):
        Js, xs = random_levels(rng, 7, [3, 2, 2])
        exact, _ = prioritized_velocity(Js, xs)
        damped, levels = prioritized_velocity(Js, xs, method="damped", damping=damping)
        assert all(info.damping == 0.0 and info.sigma_min > 1e-3 for info in levels)
        assert np.allclose(damped, exact, atol=1e-12)


def test_single_level_is_the_pseudo_inverse(rng: np.random.Generator) -> None:
    J, x = rng.normal(size=(4, 6)), rng.normal(size=4)
    qd, (info,) = prioritized_velocity([J], [x])
    assert np.allclose(qd, np.linalg.pinv(J) @ x, atol=1e-12)
    assert info.level == 1 and info.freedom == 6 and info.residual < 1e-12


def test_no_freedom_left(rng: np.random.Generator) -> None:
    Js, xs = random_levels(rng, 4, [4, 2])
    qd, levels = prioritized_velocity(Js, xs)
    assert levels[1].freedom == 0 and levels[1].rank == 0 and levels[1].sigma_min == 0.0
    assert np.allclose(qd, np.linalg.solve(Js[0], xs[0]))


# ---------------------------------------------------------------------------- strictness
def robot_levels(robot: rr.Robot, q: np.ndarray) -> list[np.ndarray]:
    """Tip position, elbow height, camera look-at (2 rows), posture: 3 + 1 + 2 + 7 rows."""
    look = LookAtTask(None, target=[0.6, -0.2, 0.1])
    return [
        robot.jacobian(q)[:3],
        robot.jacobian(q, "elbow")[2:3],
        look.compute(robot, q).jacobian,
        np.eye(robot.n),
    ]


@pytest.mark.parametrize("name", ["panda", "iiwa14", "srs7"])
@pytest.mark.parametrize("method", METHODS)
def test_lower_levels_never_change_higher_levels(
    name: str, method: str, builtin_robots: dict, rng: np.random.Generator
) -> None:
    """Adding a level, or changing the lowest one, leaves every higher level's achieved
    task velocity unchanged to 1e-10 (the property that defines strict priority)."""
    robot = builtin_robots[name]
    worst = 0.0
    for _ in range(15):
        q = robot.random_configuration(rng, margin=0.1)
        Js = robot_levels(robot, q)
        xs = [rng.normal(size=J.shape[0]) for J in Js]
        # prefix[k]: levels 1..k+1 only
        prefix = [
            prioritized_velocity(Js[: k + 1], xs[: k + 1], method=method)[0] for k in range(4)
        ]
        posture = [*xs[:3], rng.normal(size=robot.n)]
        new_posture = prioritized_velocity(Js, posture, method=method)[0]
        other_camera = [*Js[:2], rng.normal(size=(2, robot.n)), Js[3]]
        new_level3 = prioritized_velocity(other_camera, xs, method=method)[0]
        checks = [(i, prefix[k]) for i in range(4) for k in range(i, 4)]
        checks += [(i, new_posture) for i in range(3)] + [(i, new_level3) for i in range(2)]
        for i, qd in checks:  # level i achieves what it achieves when it is the lowest
            worst = max(worst, float(np.abs(Js[i] @ qd - Js[i] @ prefix[i]).max()))
    assert worst <= 1e-10, f"{name}/{method}: a lower level moved a higher one by {worst:.2e}"


# ---------------------------------------------------------------------------- singularity
def planar_singular_levels(d: float) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Planar 3R arm, unit links. Level 1: tip (x, y); level 2: height y of joint 3.

    With the tip fixed, joint 3 moves on a circle about the tip, i.e. horizontally when the
    last link is vertical (q1 + q2 + q3 = π/2): there J_2 P_1 = 0 although J_1 has full
    rank and J_2 ≠ 0. ``d`` is the distance (rad, on q3) from that configuration.
    """
    robot = rr.models.planar([1.0, 1.0, 1.0])
    q = np.array([0.3, 1.1, math.pi / 2 - 1.4 + d])
    J1 = robot.jacobian(q)[[0, 1]]
    J2 = robot.jacobian(q, "link2")[[1]]
    return [J1, J2], [np.array([0.1, -0.05]), np.array([0.1])]


def test_algorithmic_singularity_exact_blows_up_robust_stays_bounded() -> None:
    distances = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7]
    table = {"exact": [], "robust": [], "damped": [], "sigma": [], "flag": []}
    for d in distances:
        Js, xs = planar_singular_levels(d)
        for method in METHODS:
            qd, levels = prioritized_velocity(Js, xs, method=method)
            table[method].append(float(np.linalg.norm(qd)))
            assert np.allclose(Js[0] @ qd, xs[0], atol=1e-6), "level 1 must hold"
        table["sigma"].append(levels[1].sigma_min)
        table["flag"].append(levels[1].algorithmic_singularity)
    report = "\n".join(
        f"d={d:7.0e}  sigma_min(J2 P1)={s:9.3e}  |qd| exact={e:10.4g}  robust={r:7.4f}  "
        f"damped={m:7.4f}"
        for d, s, e, r, m in zip(
            distances, table["sigma"], table["exact"], table["robust"], table["damped"]
        )
    )
    print("\nalgorithmic singularity (planar 3R):\n" + report)
    exact, robust = np.array(table["exact"]), np.array(table["robust"])
    # exact: |qd| ~ c/d (within 5 % of the 1/d law below d = 1e-3) and huge near it
    c = exact * np.array(distances)
    assert np.all(np.abs(c[2:] / c[-1] - 1.0) < 0.05), report
    assert exact[-1] > 1e5, report
    # robust: bounded by |J1^+ x1| + |J2^+| |x2| (‖P‖ ≤ 1), and barely changes
    Js, xs = planar_singular_levels(distances[-1])
    bound = np.linalg.norm(np.linalg.pinv(Js[0]) @ xs[0])
    bound += np.linalg.norm(np.linalg.pinv(Js[1]), 2) * np.linalg.norm(xs[1])
    assert np.all(robust <= bound + 1e-12) and np.ptp(robust) < 0.1 * robust.max(), report
    # damped: each gain sigma / (sigma^2 + lambda(sigma)^2) of the adaptive law is bounded
    grid = np.linspace(1e-9, 1.0, 2001)
    lam = np.array([adaptive_damping(s, 0.05, 0.05) for s in grid])
    gain = float(np.max(grid / (grid**2 + lam**2)))
    residual = np.linalg.norm(xs[1]) + np.linalg.norm(Js[1] @ np.linalg.pinv(Js[0]) @ xs[0])
    assert np.all(np.array(table["damped"]) <= 1.01 * (bound + gain * residual)), report
    # diagnostics: sigma_min of the projected Jacobian ∝ d, flagged once below threshold
    sigma = np.array(table["sigma"])
    assert np.allclose(sigma / np.array(distances), sigma[-1] / distances[-1], rtol=0.05)
    assert table["flag"] == [s < 1e-2 for s in sigma], report


def test_exactly_at_the_algorithmic_singularity_everything_is_finite() -> None:
    Js, xs = planar_singular_levels(0.0)
    for method in METHODS:
        qd, levels = prioritized_velocity(Js, xs, method=method)
        assert np.all(np.isfinite(qd)) and np.linalg.norm(qd) < 1.0
        assert levels[1].rank == 0 and levels[1].algorithmic_singularity
        assert np.allclose(Js[0] @ qd, xs[0], atol=1e-12)


# ---------------------------------------------------------------------------- tasks
def test_look_at_jacobian_and_feedforward_match_finite_differences(
    builtin_robots: dict, rng: np.random.Generator
) -> None:
    robot = builtin_robots["panda"]
    task = LookAtTask("hand", target=[0.5, 0.3, 0.2])
    point = task.point.copy()

    def value_at_point(p: np.ndarray) -> np.ndarray:
        task.point = p
        v = task.evaluate(robot, q)[0]
        task.point = point
        return v

    for _ in range(10):
        q = robot.random_configuration(rng)
        v, J, D = task.evaluate(robot, q)
        assert_close(J, numerical_jacobian(lambda x: task.evaluate(robot, x)[0], q), 1e-7)
        assert_close(D, numerical_jacobian(value_at_point, point), 1e-7)
        # |v| is the angle between the z axis and the line of sight
        T = robot.fk(q, "hand")
        sight = point - T[:3, 3]
        angle = math.acos(np.clip(T[:3, 2] @ sight / np.linalg.norm(sight), -1.0, 1.0))
        assert abs(np.linalg.norm(v) - angle) < 1e-12
        assert abs(task.angle(robot, q) - angle) < 1e-12
    velocity = rng.normal(size=3)
    task.set_target(point, velocity)
    state = task.compute(robot, q)
    assert np.allclose(state.error, -task.evaluate(robot, q)[0])
    assert np.allclose(state.feedforward, -D @ velocity, atol=1e-12)


def assert_close(A: np.ndarray, B: np.ndarray, atol: float) -> None:
    assert np.abs(A - B).max() <= atol * (1 + np.abs(B).max()), np.abs(A - B).max()


def test_look_at_near_the_axis_and_at_the_antipode() -> None:
    """Series branch near v = 0 agrees with finite differences; the antipode is finite."""
    robot = rr.models.srs7()
    q = robot.neutral()
    T = robot.fk(q)
    task = LookAtTask(target=T[:3, 3] + T[:3, :3] @ [1e-7, -2e-7, 0.5])
    v, J, _ = task.evaluate(robot, q)
    assert np.linalg.norm(v) < 1e-6
    assert_close(J, numerical_jacobian(lambda x: task.evaluate(robot, x)[0], q, 1e-7), 1e-6)
    task.set_target(T[:3, 3] - 0.5 * T[:3, 2])  # exactly behind the frame
    v, J, D = task.evaluate(robot, q)
    assert abs(np.linalg.norm(v) - math.pi) < 1e-6
    assert np.all(np.isfinite(J)) and np.all(np.isfinite(D))
    task.set_target(T[:3, 3])  # at the frame origin: undefined, zero
    assert np.all(task.compute(robot, q).jacobian == 0.0)
    with pytest.raises(InvalidParameterError):
        LookAtTask().compute(robot, q)


def test_look_at_clik_turns_the_axis_onto_the_target() -> None:
    robot = rr.models.panda()
    task = LookAtTask("hand", target=[0.6, -0.3, 0.0])
    q = robot.neutral()
    angles = []
    for _ in range(80):
        state = task.compute(robot, q)
        q = q + np.linalg.pinv(state.jacobian) @ (10.0 * state.error) * 0.02
        angles.append(task.angle(robot, q))
    assert angles[0] > 0.3 and angles[-1] < 1e-3
    assert all(b < a for a, b in itertools.pairwise(angles))


def test_posture_task(builtin_robots: dict, rng: np.random.Generator) -> None:
    robot = builtin_robots["iiwa14"]
    q_ref = robot.random_configuration(rng)
    q = robot.random_configuration(rng)
    state = PostureTask(q_ref).compute(robot, q)
    assert np.allclose(state.error, q_ref - q) and np.allclose(state.jacobian, np.eye(7))
    sub = PostureTask(q_ref, joints=[1, 3]).compute(robot, q)
    assert np.allclose(sub.error, (q_ref - q)[[1, 3]])
    assert_close(sub.jacobian, numerical_jacobian(lambda x: x[[1, 3]], q), 1e-9)
    assert np.allclose(PostureTask().compute(robot, q).error, robot.neutral() - q)
    with pytest.raises(ShapeError):
        PostureTask(np.zeros(3)).compute(robot, q)
    with pytest.raises(InvalidParameterError):
        PostureTask(joints=[1, 1])
    with pytest.raises(InvalidParameterError):
        PostureTask(joints=[9]).compute(robot, q)


# ---------------------------------------------------------------------------- scheme
def test_scheme_step_reports_levels(builtin_robots: dict, rng: np.random.Generator) -> None:
    robot = builtin_robots["panda"]
    q = robot.random_configuration(rng, margin=0.2)
    elbow = FrameTask("elbow", rows=["z"])
    scheme = PriorityScheme([elbow, PostureTask()], gain=[5.0, 1.0])
    assert scheme.name == "priority"
    J, xd = robot.jacobian(q)[:3], rng.normal(size=3) * 0.1
    result = scheme.step(robot, q, J, xd)
    levels = result.details.levels
    assert [info.level for info in levels] == [1, 2, 3]
    assert np.allclose(J @ result.qd, xd, atol=1e-12)
    assert np.linalg.norm(J @ result.null_term) < 1e-12 and np.linalg.norm(result.null_term) > 0
    assert result.info.rank == 3 and not result.algorithmic_singularity
    Js = [J, robot.jacobian(q, "elbow")[2:3], np.eye(7)]
    xs = [xd, 5.0 * elbow.compute(robot, q).error, robot.neutral() - q]
    assert np.allclose(result.qd, oracle_exact(Js, xs), atol=1e-10)


def test_scheme_in_run_pose_first_elbow_second_posture_third() -> None:
    """Panda: the TCP pose follows a circle, the elbow drops 2 cm, the posture fills the
    rest; the exact and robust variants both leave the pose tracking as good as the plain
    pseudo-inverse, the exact one also meets the elbow height."""
    robot = rr.models.panda()
    q0 = robot.neutral()
    q0[2] += 0.5  # at the ready pose the elbow height is at an extremum of the self-motion
    circle = rr.control.Circle(robot.fk(q0), radius=0.05, period=2.0)
    baseline = rr.run(
        robot, FrameTask(), circle, rr.resolution.PseudoInverseScheme(), duration=1.5, q0=q0
    )
    T_elbow = robot.fk(q0, "elbow")
    T_elbow[2, 3] -= 0.02
    for method, tol in (("exact", 1e-3), ("robust", 2e-2)):
        elbow = FrameTask("elbow", rows=["z"])
        elbow.set_target(T_elbow)
        scheme = PriorityScheme([elbow, PostureTask(q0)], gain=[3.0, 1.0], method=method)
        log = rr.run(robot, FrameTask(), circle, scheme, duration=1.5, q0=q0, gain=50.0)
        bound = 2 * baseline.summary()["max_position_error_m"] + 1e-6
        assert log.summary()["max_position_error_m"] < bound, method
        assert not log.scaled.any() and not log.extra["algorithmic_singularity"].any()
        error = abs(robot.fk(log.extra["final_q"], "elbow")[2, 3] - T_elbow[2, 3])
        assert error < tol, (method, error)


def test_scheme_keeps_a_camera_on_target_while_the_hand_moves() -> None:
    """Panda: the TCP position follows a circle; a camera on the hand turns onto a point
    on the table and stays on it; the posture fills the remaining freedom."""
    robot = rr.models.panda()
    robot.add_frame("camera", "hand", np.eye(4))
    q0 = robot.neutral()
    look = LookAtTask("camera", target=[0.5, 0.0, 0.0])
    circle = rr.control.Circle(robot.fk(q0), radius=0.08, period=2.0)
    scheme = PriorityScheme([look, PostureTask(q0)], gain=[6.0, 1.0])
    log = rr.run(robot, PositionTask(), circle, scheme, duration=1.5, q0=q0, gain=50.0)
    angles = [look.angle(robot, q) for q in log.q[::100]]
    assert angles[0] > 0.3 and angles[-1] < 1e-3, angles
    assert all(b < a for a, b in itertools.pairwise(angles)), angles
    assert log.summary()["max_position_error_m"] < 1e-4 and not log.scaled.any()


def test_scheme_reset_restores_held_arm_angle() -> None:
    robot = rr.models.iiwa14()
    task = ArmAngleTask()
    scheme = PriorityScheme([task])
    scheme.step(robot, robot.neutral(), robot.jacobian(robot.neutral()), np.zeros(6))
    assert task.target is not None
    scheme.reset()
    assert task.target is None


# ---------------------------------------------------------------------------- bad input
def test_bad_input() -> None:
    J, x = np.ones((2, 4)), np.ones(2)
    with pytest.raises(InvalidParameterError):
        prioritized_velocity([], [])
    with pytest.raises(ShapeError):
        prioritized_velocity([J, np.ones((1, 5))], [x, np.ones(1)])
    with pytest.raises(ShapeError):
        prioritized_velocity([J], [np.ones(3)])
    with pytest.raises(ShapeError):
        prioritized_velocity([J], [x, x])
    with pytest.raises(NonFiniteError):
        prioritized_velocity([J, np.full((1, 4), np.nan)], [x, np.ones(1)])
    with pytest.raises(InvalidParameterError):
        prioritized_velocity([J], [x], method="fast")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError):
        PriorityScheme([PostureTask()], gain=[1.0, 2.0])
    with pytest.raises(InvalidParameterError):
        PriorityScheme([[]])
    with pytest.raises(InvalidParameterError):
        PriorityScheme(method="best")  # type: ignore[arg-type]


def test_the_result_is_named(rng: np.random.Generator) -> None:
    Js = [rng.standard_normal((2, 5)), rng.standard_normal((1, 5))]
    result = prioritized_velocity(Js, [np.ones(2), np.ones(1)])
    assert isinstance(result, PriorityResult)
    assert result.qd is result[0] and result.levels is result[1]
    assert [level.level for level in result.levels] == [1, 2]
