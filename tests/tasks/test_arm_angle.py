"""The arm angle (seed 000 §2.1): definition, analytic Jacobian, self-motion."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres.tasks import ArmAngleTask, arm_angle_from_points, arm_angles
from redres.testing import assert_jacobian_close, numerical_jacobian

ARMS = ["iiwa14", "srs7", "panda"]


def test_arm_angle_of_textbook_points() -> None:
    """Shoulder at the origin, wrist on x, reference z: the reference plane is x-z, so an
    elbow above the line has φ = 0, beside it (−y) +90° about x, below it 180°."""
    s, w, v = np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    cases = [((0.5, 0.0, 0.3), 0.0), ((0.5, -0.3, 0.0), np.pi / 2), ((0.5, 0.3, 0.0), -np.pi / 2)]
    for elbow, expected in cases:
        assert arm_angle_from_points(s, np.array(elbow), w, v).phi == pytest.approx(expected)
    below = arm_angle_from_points(s, np.array([0.5, 0.0, -0.3]), w, v).phi
    assert abs(below) == pytest.approx(np.pi)


def test_arm_angle_matches_the_seed_formula(rng: np.random.Generator) -> None:
    """tan φ = ŵᵀ(l × p)/(l · p) with p = (I − ŵŵᵀ)e, l = (w × v) × w, literally."""
    for _ in range(50):
        s, e_pt, w_pt, v = (rng.normal(size=3) for _ in range(4))
        w, e = w_pt - s, e_pt - s
        wh = w / np.linalg.norm(w)
        p = e - wh * (wh @ e)
        l = np.cross(np.cross(w, v), w)
        expected = np.arctan2(wh @ np.cross(l, p), l @ p)
        assert arm_angle_from_points(s, e_pt, w_pt, v).phi == pytest.approx(expected, abs=1e-12)


def _geometric_arm_angle(s: np.ndarray, e_pt: np.ndarray, w_pt: np.ndarray, v: np.ndarray) -> float:
    """An independent construction: the orthonormal frame (x̂, ŷ, ŵ) with x̂ the unit
    component of ``v`` normal to the shoulder-wrist line (the reference plane's side of
    ``v``, i.e. the direction of l), ŷ = ŵ × x̂; φ is the polar angle of the elbow's
    offset in the (x̂, ŷ) plane."""
    wh = (w_pt - s) / np.linalg.norm(w_pt - s)
    x = v - wh * (wh @ v)
    x /= np.linalg.norm(x)
    y = np.cross(wh, x)
    offset = e_pt - s
    return float(np.arctan2(offset @ y, offset @ x))


def test_batched_arm_angles_match_a_geometric_construction(rng: np.random.Generator) -> None:
    """arm_angles on arrays (4, 5, 3) against the frame construction, point by point."""
    s, e_pt, w_pt = (rng.normal(size=(4, 5, 3)) for _ in range(3))
    v = rng.normal(size=3)
    phi = arm_angles(s, e_pt, w_pt, v)
    assert phi.shape == (4, 5)
    for i in np.ndindex(4, 5):
        expected = _geometric_arm_angle(s[i], e_pt[i], w_pt[i], v)
        assert phi[i] == pytest.approx(expected, abs=1e-12)
        assert arm_angle_from_points(s[i], e_pt[i], w_pt[i], v).phi == pytest.approx(
            expected, abs=1e-12
        )


def test_turning_the_elbow_about_the_line_adds_the_turn(rng: np.random.Generator) -> None:
    """Rodrigues' rotation of the elbow by β about the shoulder-wrist line adds β to φ."""
    s, e_pt, w_pt = (rng.normal(size=(30, 3)) for _ in range(3))
    v = rng.normal(size=3)
    beta = rng.uniform(-np.pi, np.pi, 30)
    axis = (w_pt - s) / np.linalg.norm(w_pt - s, axis=1, keepdims=True)
    r = e_pt - s
    c, s_ = np.cos(beta)[:, None], np.sin(beta)[:, None]
    along = axis * np.sum(axis * r, axis=1, keepdims=True)
    turned = r * c + np.cross(axis, r) * s_ + along * (1 - c)
    change = arm_angles(s, s + turned, w_pt, v) - arm_angles(s, e_pt, w_pt, v)
    np.testing.assert_allclose(np.angle(np.exp(1j * (change - beta))), 0.0, atol=1e-10)


@pytest.mark.parametrize("name", ARMS)
def test_values_of_many_configurations_match_one_at_a_time(
    name: str, builtin_robots: dict, rng: np.random.Generator
) -> None:
    """arm_angles of batch poses (the self-motion sweeps' path) against value and the
    geometric construction on Pinocchio's frame placements."""
    robot = builtin_robots[name]
    q = np.array([robot.random_configuration(rng) for _ in range(12)])
    task = ArmAngleTask()
    s, e, w = (rr.batch.fk(robot, q, f)[:, :3, 3] for f in ("shoulder", "elbow", "wrist"))
    many = arm_angles(s, e, w, task.reference)
    assert many == pytest.approx(task.values(robot, q), abs=1e-12)
    for qi, phi in zip(q, many):
        points = [robot.fk(qi, f)[:3, 3] for f in ("shoulder", "elbow", "wrist")]
        assert phi == pytest.approx(_geometric_arm_angle(*points, task.reference), abs=1e-10)
        assert phi == pytest.approx(task.value(robot, qi), abs=1e-12)


def test_point_gradients_match_finite_differences(rng: np.random.Generator) -> None:
    for _ in range(20):
        pts = [rng.normal(size=3) for _ in range(3)]
        v = rng.normal(size=3)
        angle = arm_angle_from_points(*pts, v)
        for i, grad in enumerate((angle.d_shoulder, angle.d_elbow, angle.d_wrist)):

            def phi_of(x: np.ndarray, i: int = i, pts: list = pts, v: np.ndarray = v) -> np.ndarray:
                moved = list(pts)
                moved[i] = x
                return np.array([arm_angle_from_points(*moved, v).phi])

            assert_jacobian_close(grad[None], numerical_jacobian(phi_of, pts[i]), atol=1e-8)


@pytest.mark.parametrize("name", ARMS)
def test_arm_angle_jacobian_matches_finite_differences(
    name: str, builtin_robots: dict, rng: np.random.Generator
) -> None:
    robot = builtin_robots[name]
    task = ArmAngleTask()
    for _ in range(10):
        q = robot.random_configuration(rng)
        _, row = task.evaluate(robot, q)
        fd = numerical_jacobian(lambda x: np.array([task.value(robot, x)]), q)
        assert_jacobian_close(row[None], fd, atol=1e-7, rtol=1e-6)


@pytest.mark.parametrize("name", ["iiwa14", "srs7"])
def test_wrist_joints_do_not_move_the_arm_angle(name: str, builtin_robots: dict) -> None:
    """Seed 000: J_φ = [x x x x 0 0 0] on an S-R-S arm."""
    robot = builtin_robots[name]
    q = robot.random_configuration(5)
    _, row = ArmAngleTask().evaluate(robot, q)
    assert np.allclose(row[4:], 0.0, atol=1e-12)
    assert np.linalg.norm(row[:4]) > 1e-3


@pytest.mark.parametrize("name", ARMS)
def test_self_motion_keeps_the_pose_and_turns_the_elbow(
    name: str, builtin_robots: dict, rng: np.random.Generator
) -> None:
    """Integrate q̇ along the null space of J (pure self-motion): the end-effector pose
    stays fixed while φ changes."""
    robot = builtin_robots[name]
    task = ArmAngleTask()
    q = robot.neutral()
    T0 = robot.fk(q)
    phi0 = task.value(robot, q)

    def self_motion(x: np.ndarray) -> np.ndarray:
        basis = rr.linalg.nullspace_basis(robot.jacobian(x))
        assert basis.shape == (robot.n, 1)
        _, row = task.evaluate(robot, x)
        return 0.5 * basis[:, 0] * np.sign(row @ basis[:, 0])  # unit speed, φ increasing

    h = 0.01
    for _ in range(30):  # classical Runge–Kutta: the drift off the self-motion manifold is O(h⁵)
        k1 = self_motion(q)
        k2 = self_motion(q + h / 2 * k1)
        k3 = self_motion(q + h / 2 * k2)
        k4 = self_motion(q + h * k3)
        q = q + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    T1 = robot.fk(q)
    assert np.linalg.norm(T1[:3, 3] - T0[:3, 3]) < 1e-9
    assert np.linalg.norm(pin.log3(T1[:3, :3] @ T0[:3, :3].T)) < 1e-9
    assert task.value(robot, q) - phi0 > 0.05


def test_stretched_arm_reports_an_undefined_angle() -> None:
    robot = rr.models.srs7()
    q = np.zeros(7)  # elbow straight: elbow on the shoulder–wrist line
    angle, row = ArmAngleTask(reference=(1.0, 0.0, 0.0)).evaluate(robot, q)
    assert angle.conditioning == 0.0 and np.all(row == 0.0)


def test_reference_must_be_nonzero() -> None:
    with pytest.raises(rr.errors.InvalidParameterError, match="non-zero"):
        ArmAngleTask(reference=(0.0, 0.0, 0.0))


def test_arm_angles_refuse_complex_and_mismatched_points() -> None:
    s, e, w = np.zeros(3), np.array([0.3, 0.0, 0.3]), np.array([0.0, 0.0, 0.6])
    v = np.array([0.0, 0.0, 1.0])
    with pytest.raises(rr.errors.InvalidParameterError, match="elbow must be real"):
        arm_angles(s, e + 0.5j, w, v)
    with pytest.raises(rr.errors.ShapeError, match="3-vectors"):
        arm_angles(s, np.zeros((4, 3)), np.zeros((5, 3)), v)
    with pytest.raises(rr.errors.ShapeError, match="3-vectors"):
        arm_angles(s[:2], e[:2], w[:2], v[:2])
