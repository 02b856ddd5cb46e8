"""Denavit–Hartenberg construction: both conventions against hand-multiplied transforms,
prismatic joints, inertias in the link frame, and malformed records."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.errors import (
    DHParameterError,
    InvalidParameterError,
    JointLimitError,
    NotPositiveDefiniteError,
    ShapeError,
)
from redres.testing import assert_jacobian_close, frame_jacobian_fd


def rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def trans(x: float, y: float, z: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = [x, y, z]
    return T


RECORDS = [
    {"a": 0.1, "alpha": 0.4, "d": 0.3, "theta": 0.2},
    {"a": 0.5, "alpha": -1.1, "d": 0.05, "joint": "prismatic", "q_min": -0.2, "q_max": 0.4},
    {"a": 0.0, "alpha": 1.5708, "d": -0.2, "theta": -0.7},
    {"a": 0.25, "alpha": 0.0, "d": 0.1},
]


def by_hand(q: np.ndarray, convention: str, base: np.ndarray, tool: np.ndarray) -> np.ndarray:
    T = base.copy()
    for rec, qi in zip(RECORDS, q):
        theta = rec.get("theta", 0.0) + (qi if rec.get("joint") != "prismatic" else 0.0)
        d = rec["d"] + (qi if rec.get("joint") == "prismatic" else 0.0)
        if convention == "standard":
            T = T @ rot_z(theta) @ trans(0, 0, d) @ trans(rec["a"], 0, 0) @ rot_x(rec["alpha"])
        else:
            T = T @ rot_x(rec["alpha"]) @ trans(rec["a"], 0, 0) @ rot_z(theta) @ trans(0, 0, d)
    return T @ tool


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_fk_is_the_product_of_dh_transforms(convention: str, rng: np.random.Generator) -> None:
    base = trans(0.1, -0.2, 0.3) @ rot_z(0.3) @ rot_x(-0.2)
    tool = trans(0.0, 0.0, 0.15) @ rot_z(-np.pi / 4)
    robot = rr.Robot.from_dh(RECORDS, convention, base=base, tool=tool)  # type: ignore[arg-type]
    for _ in range(10):
        q = robot.random_configuration(rng)
        assert np.allclose(robot.fk(q), by_hand(q, convention, base, tool), atol=1e-12)
        assert_jacobian_close(robot.jacobian(q), frame_jacobian_fd(robot, q), atol=1e-8)


def test_seed_002_column_rule_for_prismatic_and_revolute(rng: np.random.Generator) -> None:
    """Seed 002: J_i = [z_{i-1}; 0] (prismatic), [z_{i-1} × (p_e − p_{i-1}); z_{i-1}]."""
    robot = rr.Robot.from_dh(RECORDS, "standard")
    q = robot.random_configuration(rng)
    p_e = robot.fk(q)[:3, 3]
    frames = ["base", "link1", "link2", "link3"]
    J = robot.jacobian(q)
    for i, rec in enumerate(RECORDS):
        T_prev = robot.fk(q, frames[i])
        z, p = T_prev[:3, 2], T_prev[:3, 3]
        expected = (
            np.concatenate([z, np.zeros(3)])
            if rec.get("joint") == "prismatic"
            else np.concatenate([np.cross(z, p_e - p), z])
        )
        assert np.allclose(J[:, i], expected, atol=1e-12)


def test_inertia_is_expressed_in_the_link_frame(rng: np.random.Generator) -> None:
    """A point mass at com in DH frame 1 has gravity torque m g (x-offset of the mass)."""
    com = (0.2, -0.1, 0.3)
    links = [{"a": 0.4, "alpha": np.pi / 2, "d": 0.0, "mass": 2.0, "com": com}]
    base = rot_x(np.pi / 2)  # joint axis horizontal, so gravity acts on it
    robot = rr.Robot.from_dh(links, base=base)
    q = rng.uniform(-1.0, 1.0, 1)
    p_mass = (robot.fk(q, "link1") @ np.array([*com, 1.0]))[:3]
    axis, origin = robot.fk(q, "base")[:3, 2], robot.fk(q, "base")[:3, 3]
    force = np.array([0.0, 0.0, -9.81 * 2.0])
    expected = -axis @ np.cross(p_mass - origin, force)  # torque needed to hold the mass
    assert robot.gravity(q)[0] == pytest.approx(expected, abs=1e-12)


def test_dhlink_records_and_dicts_are_equivalent(rng: np.random.Generator) -> None:
    records = [rr.DHLink(a=0.3, alpha=0.2, d=0.1, mass=1.0, com=(0.1, 0.0, 0.0))] * 2
    dicts = [{"a": 0.3, "alpha": 0.2, "d": 0.1, "mass": 1.0, "com": (0.1, 0.0, 0.0)}] * 2
    q = rng.uniform(-1, 1, 2)
    a, b = rr.Robot.from_dh(records), rr.Robot.from_dh(dicts)
    assert np.allclose(a.fk(q), b.fk(q)) and np.allclose(a.mass_matrix(q), b.mass_matrix(q))


def test_default_limits() -> None:
    robot = rr.Robot.from_dh([{"a": 1.0, "alpha": 0.0, "d": 0.0}])
    assert robot.q_min[0] == -np.pi and robot.q_max[0] == np.pi
    assert np.isinf(robot.qd_max[0]) and np.isinf(robot.tau_max[0])


@pytest.mark.parametrize(
    ("record", "message"),
    [
        ({"a": 1.0, "alpha": 0.0}, r"record 0: missing required key\(s\) \['d'\]"),
        ({"a": 1.0, "alpha": 0.0, "d": 0.0, "lenght": 2}, "unknown key.*'lenght'.*valid keys"),
        ({"a": 1.0, "alpha": 0.0, "d": 0.0, "joint": "spherical"}, "'revolute' or 'prismatic'"),
        ({"a": "one", "alpha": 0.0, "d": 0.0}, "record 0: a must be a number"),
        ({"a": np.inf, "alpha": 0.0, "d": 0.0}, "a must be finite"),
        ({"a": 1.0, "alpha": 0.0, "d": 0.0, "mass": -1.0}, "mass and armature must be >= 0"),
        ({"a": 1.0, "alpha": 0.0, "d": 0.0, "com": (1.0, 2.0)}, "com must be 3 finite"),
        ("a=1", "must be a DHLink or a dict"),
    ],
)
def test_malformed_dh_records(record: object, message: str) -> None:
    with pytest.raises(DHParameterError, match=message):
        rr.Robot.from_dh([record])  # type: ignore[list-item]


def test_non_spd_inertia_is_rejected() -> None:
    record = {"a": 1.0, "alpha": 0.0, "d": 0.0, "mass": 1.0, "inertia": -np.eye(3)}
    with pytest.raises(NotPositiveDefiniteError, match="record 0: inertia"):
        rr.Robot.from_dh([record])


def test_bad_convention_base_and_empty_links() -> None:
    rec = [{"a": 1.0, "alpha": 0.0, "d": 0.0}]
    with pytest.raises(DHParameterError, match="'standard' or 'modified'"):
        rr.Robot.from_dh(rec, "craig")  # type: ignore[arg-type]
    with pytest.raises(DHParameterError, match="non-empty sequence"):
        rr.Robot.from_dh([])
    with pytest.raises(ShapeError, match="base must be a 4x4"):
        rr.Robot.from_dh(rec, base=np.eye(3))
    with pytest.raises(ShapeError, match="not a rotation"):
        rr.Robot.from_dh(rec, tool=np.diag([2.0, 1.0, 1.0, 1.0]))
    assert isinstance(DHParameterError("x"), ValueError)


def test_non_physical_limits_and_records_are_refused() -> None:
    """A negative qd_max or tau_max was silently made positive and qd_max = 0 accepted (a
    joint that can never move); a non-numeric com raised a raw ValueError; two joints of
    one name were accepted. Each is now a DHParameterError naming the record and key."""
    base = {"a": 0.3, "alpha": 0.0, "d": 0.0, "q_min": -1.0, "q_max": 1.0}
    for key, value in (("qd_max", -2.0), ("qd_max", 0.0), ("tau_max", -5.0), ("qdd_max", -1.0)):
        with pytest.raises(rr.errors.DHParameterError, match=f"record 0: {key} must be > 0"):
            rr.Robot.from_dh([{**base, key: value}, base])
    with pytest.raises(rr.errors.DHParameterError, match="record 0: com and inertia"):
        rr.Robot.from_dh([{**base, "mass": 1.0, "com": "nil"}])
    with pytest.raises(rr.errors.DHParameterError, match="repeated: j"):
        rr.Robot.from_dh([{**base, "name": "j"}, {**base, "name": "j"}])
    robot = rr.Robot.from_dh([{**base, "qd_max": 2.0, "tau_max": np.inf}, base])
    assert robot.qd_max[0] == 2.0 and robot.tau_max[0] == np.inf  # positive and inf kept


def unbounded_arm() -> rr.Robot:
    return rr.Robot.from_dh(
        [
            dict(a=0.0, alpha=0.0, d=0.0, theta=4.0, joint="prismatic"),
            dict(a=0.5, alpha=0.0, d=0.0, q_min=-np.inf, q_max=np.inf),
            dict(a=0.4, alpha=0.0, d=0.0),
        ]
    )


def test_joints_without_limits_build_unbounded() -> None:
    """Limits are optional (issue 18, item 8): a prismatic joint without them is ±inf."""
    robot = unbounded_arm()
    assert robot.q_min[:2].tolist() == [-np.inf, -np.inf] and robot.q_max[2] == np.pi
    q = np.array([3.0, 0.2, -0.1])
    assert np.isfinite(robot.fk(q)).all() and robot.within_limits(q)
    cost = rr.objectives.JointLimitObjective()
    assert np.isfinite(cost.gradient(robot, q)).all() and cost.gradient(robot, q)[0] == 0.0
    wln = rr.resolution.WeightedLeastNormScheme()
    for _ in range(2):
        weights = wln.weights(robot, q)
    assert np.isfinite(weights).all() and weights[0] == weights[1] == 1.0


def test_functions_that_need_finite_limits_say_so() -> None:
    robot = unbounded_arm()
    with pytest.raises(JointLimitError, match=r"finite limits; joint 'joint1' has \[-inf, inf\]"):
        robot.random_configuration(0)
    arm = rr.models.planar([1.0, 1.0])
    with pytest.raises(InvalidParameterError, match="margin must be >= 0"):
        arm.random_configuration(0, margin=-1.0)
    for rng in ("x", -1, 1.5):
        with pytest.raises(InvalidParameterError, match="rng must be"):
            arm.random_configuration(rng)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("record", "message"),
    [
        (dict(a=1e300, alpha=0.5, d=0.1), r"\|a\| must be <= 1000 \(SI units\); got 1e\+300"),
        (dict(a=0.1, alpha=0.0, d=-2e3), r"\|d\| must be <= 1000"),
        (dict(a=0.1, alpha=0.0, d=0.0, mass=1e300), r"\|mass\| must be <= 1e\+06"),
        (dict(a=0.1, alpha=0.0, d=0.0, com=(0, 0, 1e300)), r"com must be 3 finite numbers within"),
        (dict(a=0.1, alpha=0.0, d=0.0, name=5), r"name must be a string; got 5"),
        (dict(a=10**400, alpha=0.0, d=0.0), r"a must be a number"),
    ],
)
def test_non_physical_records_are_refused(record: dict, message: str) -> None:
    """Found by tests/test_fuzz.py: a = 1e300 gave a NaN mass matrix, a name of 5 and a
    400-digit integer raw TypeError/OverflowError."""
    with pytest.raises(DHParameterError, match=message):
        rr.Robot.from_dh([record])
