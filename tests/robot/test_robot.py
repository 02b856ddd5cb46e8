"""Robot kinematics and dynamics against independent oracles (finite differences, closed
forms, Pinocchio's RNEA), and the errors for bad input."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.errors import (
    FrameNotFoundError,
    InvalidParameterError,
    JointLimitError,
    NonFiniteError,
    RedresError,
    ShapeError,
)
from redres.testing import assert_jacobian_close, frame_jacobian_fd, jacobian_dot_fd

ROBOTS = ["iiwa14", "panda", "planar2", "planar3", "srs7"]


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("reference", ["world", "local"])
def test_jacobian_matches_finite_differences_of_fk(
    name: str, reference: str, builtin_robots: dict[str, rr.Robot], rng: np.random.Generator
) -> None:
    robot = builtin_robots[name]
    for _ in range(5):
        q = robot.random_configuration(rng)
        for frame in (None, *robot.frames()[-3:]):
            J = robot.jacobian(q, frame, reference)  # type: ignore[arg-type]
            assert J.shape == (6, robot.n)
            J_fd = frame_jacobian_fd(robot, q, frame, reference)  # type: ignore[arg-type]
            assert_jacobian_close(J, J_fd, atol=2e-8, rtol=1e-6, name=f"{name}:{frame}")


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("reference", ["world", "local"])
def test_jacobian_dot_matches_finite_differences(
    name: str, reference: str, builtin_robots: dict[str, rr.Robot], rng: np.random.Generator
) -> None:
    robot = builtin_robots[name]
    for _ in range(5):
        q = robot.random_configuration(rng)
        qd = rng.uniform(-1.0, 1.0, robot.n)
        dJ = robot.jacobian_dot(q, qd, reference=reference)  # type: ignore[arg-type]
        dJ_fd = jacobian_dot_fd(robot, q, qd, reference=reference)  # type: ignore[arg-type]
        assert_jacobian_close(dJ, dJ_fd, atol=1e-7, rtol=1e-6, name=f"{name} dJ")


@pytest.mark.parametrize("reference", ["world", "local"])
@pytest.mark.parametrize("name", ROBOTS)
def test_kinematics_returns_fk_and_jacobian_of_one_pass(
    name: str, reference: str, builtin_robots: dict[str, rr.Robot], rng: np.random.Generator
) -> None:
    robot = builtin_robots[name]
    robot.fk(robot.random_configuration(rng))  # leave another configuration in the data
    q = robot.random_configuration(rng)
    T, J = robot.kinematics(q, reference=reference)  # type: ignore[arg-type]
    assert np.allclose(T, robot.fk(q), rtol=0, atol=1e-14)
    assert np.allclose(J, robot.jacobian(q, reference=reference), rtol=0, atol=1e-14)  # type: ignore[arg-type]


def test_world_and_local_jacobians_differ_by_the_frame_rotation(
    rng: np.random.Generator,
) -> None:
    robot = rr.models.panda()
    q = robot.random_configuration(rng)
    R = robot.fk(q)[:3, :3]
    J_world, J_local = robot.jacobian(q), robot.jacobian(q, reference="local")
    assert np.allclose(J_world[:3], R @ J_local[:3], atol=1e-12)
    assert np.allclose(J_world[3:], R @ J_local[3:], atol=1e-12)


@pytest.mark.parametrize("name", ROBOTS)
def test_mass_matrix_is_spd_and_inverse_dynamics_agrees(
    name: str, builtin_robots: dict[str, rr.Robot], rng: np.random.Generator
) -> None:
    robot = builtin_robots[name]
    for _ in range(5):
        q = robot.random_configuration(rng)
        qd, qdd = rng.normal(size=robot.n), rng.normal(size=robot.n)
        M = robot.mass_matrix(q)
        assert np.array_equal(M, M.T)
        assert np.linalg.eigvalsh(M).min() > 0.0
        tau = robot.inverse_dynamics(q, qd, qdd)
        assert np.allclose(M @ qdd + robot.bias(q, qd), tau, atol=1e-10, rtol=1e-10)
        assert np.allclose(robot.bias(q, np.zeros(robot.n)), robot.gravity(q), atol=1e-12)
        assert np.allclose(robot.forward_dynamics(q, qd, tau), qdd, atol=1e-8)


def test_planar_two_link_dynamics_match_the_textbook_closed_form(
    rng: np.random.Generator,
) -> None:
    """Two uniform rods (m, l, I = m l²/12) in a vertical plane (Spong, Hutchinson and
    Vidyasagar, Robot Modeling and Control, section 7.4)."""
    l1, l2, m1, m2, g = 0.7, 0.5, 1.3, 0.8, 9.81
    links = [
        {
            "a": l,
            "alpha": 0.0,
            "d": 0.0,
            "mass": m,
            "com": (-l / 2, 0.0, 0.0),
            "inertia": np.diag([0.0, 1.0, 1.0]) * m * l**2 / 12,
        }
        for l, m in ((l1, m1), (l2, m2))
    ]
    # Base turned +90° about x: the arm's plane is the world x-z plane, gravity in-plane.
    base = np.eye(4)
    base[1:3, 1:3] = [[0.0, -1.0], [1.0, 0.0]]
    robot = rr.Robot.from_dh(links, base=base)
    I1, I2, c1_, c2_ = m1 * l1**2 / 12, m2 * l2**2 / 12, l1 / 2, l2 / 2
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, 2)
        c2 = np.cos(q[1])
        M11 = m1 * c1_**2 + m2 * (l1**2 + c2_**2 + 2 * l1 * c2_ * c2) + I1 + I2
        M12 = m2 * (c2_**2 + l1 * c2_ * c2) + I2
        M22 = m2 * c2_**2 + I2
        assert np.allclose(robot.mass_matrix(q), [[M11, M12], [M12, M22]], atol=1e-12)
        g1 = (m1 * c1_ + m2 * l1) * g * np.cos(q[0]) + m2 * c2_ * g * np.cos(q.sum())
        g2 = m2 * c2_ * g * np.cos(q.sum())
        assert np.allclose(robot.gravity(q), [g1, g2], atol=1e-12)


def test_armature_adds_to_the_mass_matrix_diagonal(rng: np.random.Generator) -> None:
    links = [
        {
            "a": 0.4,
            "alpha": 0.3,
            "d": 0.1,
            "mass": 1.0,
            "com": (0.1, 0, 0),
            "inertia": np.eye(3) * 0.01,
        }
        for _ in range(3)
    ]
    plain = rr.Robot.from_dh(links)
    armature = [0.5, 0.25, 0.125]
    geared = rr.Robot.from_dh([dict(rec, armature=a) for rec, a in zip(links, armature)])
    q = rng.uniform(-1, 1, 3)
    assert np.allclose(geared.mass_matrix(q) - plain.mass_matrix(q), np.diag(armature))


def test_random_configuration_is_seeded_and_within_limits(builtin_robots: dict) -> None:
    for robot in builtin_robots.values():
        a = robot.random_configuration(7)
        b = robot.random_configuration(np.random.default_rng(7))
        assert np.array_equal(a, b)
        qs = np.array([robot.random_configuration(i) for i in range(200)])
        assert np.all(qs >= robot.q_min) and np.all(qs <= robot.q_max)
        assert robot.within_limits(robot.neutral())
        inner = robot.random_configuration(3, margin=0.1)
        assert np.all(robot.joint_limit_margin(inner) >= 0.1)


def test_limits_are_copies() -> None:
    robot = rr.models.panda()
    robot.q_min[0] = 100.0
    assert robot.q_min[0] == pytest.approx(-2.8973)
    model = robot.model  # the oracle: Pinocchio's own limit vectors
    assert np.array_equal(robot.q_min, model.lowerPositionLimit)
    assert np.array_equal(robot.q_max, model.upperPositionLimit)
    assert np.array_equal(robot.qd_max, np.abs(model.upperVelocityLimit))
    assert np.array_equal(robot.tau_max, np.abs(model.upperEffortLimit))
    for name in ("q_min", "q_max", "qd_max", "qdd_max", "qddd_max", "tau_max"):
        before = getattr(robot, name)
        getattr(robot, name)[:] = 7.0  # a copy: the robot keeps its limits
        assert np.array_equal(getattr(robot, name), before), name
        with pytest.raises(AttributeError, match=f"Robot.{name} is read-only"):
            setattr(robot, name, before)


def test_add_frame_places_a_frame_rigidly(rng: np.random.Generator) -> None:
    robot = rr.models.srs7()
    T = np.eye(4)
    T[:3, 3] = [0.0, 0.0, 0.2]
    robot.add_frame("probe", "tool", T)
    q = robot.random_configuration(rng)
    assert np.allclose(robot.fk(q, "probe"), robot.fk(q) @ T, atol=1e-12)
    assert "probe" in robot.frames()
    with pytest.raises(InvalidParameterError, match="already exists"):
        robot.add_frame("probe", "tool", T)


# ---------------------------------------------------------------- bad input
def test_wrong_length_q_is_a_shape_error() -> None:
    robot = rr.models.panda()
    with pytest.raises(ShapeError, match=r"q must have shape \(7,\); got shape \(6,\)"):
        robot.fk(np.zeros(6))
    with pytest.raises(ValueError):
        robot.jacobian([[0.0] * 7])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_q_is_rejected_by_name(bad: float) -> None:
    robot = rr.models.iiwa14()
    q = robot.neutral()
    q[3] = bad
    for call in (robot.fk, robot.jacobian, robot.mass_matrix, robot.gravity):
        with pytest.raises(NonFiniteError, match="q contains NaN or infinity"):
            call(q)
    with pytest.raises(NonFiniteError, match="qd contains"):
        robot.bias(robot.neutral(), q)


def test_unknown_frame_lists_the_valid_frames() -> None:
    robot = rr.models.panda()
    with pytest.raises(FrameNotFoundError) as info:
        robot.fk(robot.neutral(), "gripper")
    message = str(info.value)
    assert "'gripper'" in message and "tcp" in message and "flange" in message
    assert isinstance(info.value, KeyError) and isinstance(info.value, RedresError)


def test_unknown_reference_is_rejected() -> None:
    robot = rr.models.planar([1.0, 1.0])
    with pytest.raises(InvalidParameterError, match="'world' or 'local'"):
        robot.jacobian([0.1, 0.2], reference="global")  # type: ignore[arg-type]


def test_inverted_limits_are_rejected() -> None:
    with pytest.raises(JointLimitError, match="q_min = 1.0 > q_max = -1.0"):
        rr.Robot.from_dh([{"a": 1.0, "alpha": 0.0, "d": 0.0, "q_min": 1.0, "q_max": -1.0}])


def test_home_outside_the_limits_is_rejected() -> None:
    links = [{"a": 1.0, "alpha": 0.0, "d": 0.0, "q_min": -1.0, "q_max": 1.0}]
    with pytest.raises(JointLimitError, match="outside the limits"):
        rr.Robot.from_dh(links, home=[2.0])


@pytest.mark.parametrize("jit", [True, False])
@pytest.mark.parametrize("name", ROBOTS)
def test_jacobian_derivatives_are_the_partials(
    name: str, jit: bool, builtin_robots: dict[str, rr.Robot], rng: np.random.Generator
) -> None:
    """∂J/∂qᵢ from one Jacobian (compiled kernel or NumPy) equals J̇ along eᵢ and central
    differences of J."""
    from redres.linalg import _backend

    robot = builtin_robots[name]
    q = robot.random_configuration(rng)
    with _backend.jit_enabled(jit):
        D = robot.jacobian_derivatives(q)
    eye = np.eye(robot.n)
    for i in range(robot.n):
        assert np.allclose(D[i], robot.jacobian_dot(q, eye[i]), atol=1e-12)
        fd = (robot.jacobian(q + 1e-6 * eye[i]) - robot.jacobian(q - 1e-6 * eye[i])) / 2e-6
        assert np.allclose(D[i], fd, atol=1e-7)


def test_jacobian_derivatives_with_a_prismatic_joint(rng: np.random.Generator) -> None:
    links = [
        {"a": 0.3, "alpha": 0.5, "d": 0.1},
        {"a": 0.2, "alpha": -0.4, "d": 0.0, "joint": "prismatic", "q_min": -0.5, "q_max": 0.5},
        {"a": 0.1, "alpha": 0.9, "d": 0.2},
    ]
    robot = rr.Robot.from_dh(links)
    q = robot.random_configuration(rng)
    D = robot.jacobian_derivatives(q)
    for i in range(3):
        e = np.eye(3)[i]
        fd = (robot.jacobian(q + 1e-6 * e) - robot.jacobian(q - 1e-6 * e)) / 2e-6
        assert np.allclose(D[i], fd, atol=1e-7)


def test_add_frame_names_must_be_strings() -> None:
    """add_frame(name=5) was a raw Boost.Python ArgumentError (issue 18, item 11)."""
    robot = rr.models.planar([1.0, 1.0])
    with pytest.raises(rr.errors.InvalidParameterError, match="frame names are strings; got 5"):
        robot.add_frame(5, "tool", np.eye(4))  # type: ignore[arg-type]
