"""Payloads, and what exactly is load independent (Featherstone & Khatib 1997).

Claim checked: for a load rigidly fixed to body B and the full 6-row task of B, J̄ does not
change with the load and Λ grows by the load's spatial inertia. More generally J̄ is
invariant exactly when the load's kinetic energy depends on the task velocity alone
(``M_L − M = Jᵀ I J``). Each variant below says whether it should hold; the test prints
the relative change of J̄ it measured.
"""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.dynamics import Payload, payload_spatial_inertia, with_gravity, with_payload
from redres.dynamics.osc import task_disturbance
from redres.errors import (
    FrameNotFoundError,
    InvalidParameterError,
    NonFiniteError,
    NotPositiveDefiniteError,
    ShapeError,
)
from redres.linalg import dynamically_consistent_pinv, task_space_inertia

HOLDS, FAILS = 1e-9, 1e-3
COM = (0.03, -0.02, 0.05)


def rotational_inertia(seed: int = 5) -> np.ndarray:
    R = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))[0]
    return R @ np.diag([0.010, 0.020, 0.015]) @ R.T


def hat(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def spatial_inertia_by_hand(mass, c, I_c) -> np.ndarray:
    """[[m 1, −m ĉ], [m ĉ, I_c − m ĉ ĉ]] about a point, c = centre of mass from it."""
    C = hat(np.asarray(c, dtype=float))
    return np.block([[mass * np.eye(3), -mass * C], [mass * C, I_c - mass * C @ C]])


RIGID = dict(mass=2.0, com=COM, inertia="I")  # "I": rotational_inertia()
POINT = dict(mass=2.0)
OFFSET = dict(mass=2.0, com=(0.0, 0.0, 0.05))
SPIN = dict(mass=0.0, inertia="I")
XYZ, RXYZ = [0, 1, 2], [3, 4, 5]

# (name, load, task frame key, rows, reference, damping, expected)
VARIANTS = [
    ("rigid load, 6-D task at the tip", RIGID, "tip", None, "world", 0.0, HOLDS),
    ("rigid load, 6-D task, other frame, same body", RIGID, "same_body", None, "world", 0, HOLDS),
    ("rigid load, 6-D task in local axes", RIGID, "tip", None, "local", 0.0, HOLDS),
    ("rigid load, 6-D task of the wrist (previous body)", RIGID, "wrist", None, "world", 0, FAILS),
    ("rigid load, position task (3 rows)", RIGID, "tip", XYZ, "world", 0.0, FAILS),
    ("point mass at the task point, position task", POINT, "tip", XYZ, "world", 0.0, HOLDS),
    ("point mass 5 cm off the task point, position task", OFFSET, "tip", XYZ, "world", 0, FAILS),
    ("massless rotational inertia, orientation task", SPIN, "tip", RXYZ, "world", 0.0, HOLDS),
    ("point mass at the task point, orientation task", POINT, "tip", RXYZ, "world", 0.0, FAILS),
    ("rigid load, 6-D task, damped J_bar (0.05)", RIGID, "tip", None, "world", 0.05, FAILS),
]


def frame_name(robot: rr.Robot, key: str) -> str:
    return {
        "tip": robot.tip,
        "wrist": "wrist",
        "same_body": "flange" if robot.name == "panda" else "link7",
    }[key]


def make_payload(kwargs: dict, frame: str) -> Payload:
    kw = dict(kwargs)
    if kw.get("inertia") == "I":
        kw["inertia"] = rotational_inertia()
    return Payload(frame=frame, **kw)


@pytest.mark.parametrize("variant", VARIANTS, ids=[v[0] for v in VARIANTS])
def test_load_independence_variants(arm: rr.Robot, rng, variant) -> None:
    name, kwargs, key, rows, reference, damping, expected = variant
    loaded = with_payload(arm, make_payload(kwargs, arm.tip))
    frame = frame_name(arm, key)
    change = 0.0
    for _ in range(6):
        q = arm.random_configuration(rng, margin=0.1)
        J = arm.jacobian(q, frame, reference)
        J = J if rows is None else J[rows]
        J_bar = dynamically_consistent_pinv(J, arm.mass_matrix(q), damping=damping)
        J_bar_loaded = dynamically_consistent_pinv(J, loaded.mass_matrix(q), damping=damping)
        change = max(change, np.linalg.norm(J_bar_loaded - J_bar) / np.linalg.norm(J_bar))
    print(f"\n{arm.name}: {name}: max relative change of J_bar {change:.1e}")
    if expected == HOLDS:
        assert change <= HOLDS
    else:
        assert change >= FAILS


@pytest.mark.parametrize("reference", ["world", "local"])
def test_lambda_grows_by_the_load_spatial_inertia(arm: rr.Robot, rng, reference) -> None:
    """Λ_L = Λ + I_L, I_L the load in the task coordinates (6-D task of the load's body)."""
    I_c = rotational_inertia()
    payload = Payload(2.0, COM, I_c)
    loaded = with_payload(arm, payload)
    for _ in range(5):
        q = arm.random_configuration(rng, margin=0.1)
        J = arm.jacobian(q, None, reference)
        Lam = task_space_inertia(J, arm.mass_matrix(q))
        Lam_loaded = task_space_inertia(J, loaded.mass_matrix(q))
        R = arm.fk(q)[:3, :3]
        if reference == "world":  # the same load, about the tip origin, world axes
            expected = spatial_inertia_by_hand(2.0, R @ np.asarray(COM), R @ I_c @ R.T)
        else:
            expected = spatial_inertia_by_hand(2.0, COM, I_c)
        # Relative to Λ_L: near a singularity Λ is large and Λ_L − Λ loses digits.
        residual = np.linalg.norm(Lam_loaded - (Lam + expected))
        assert residual <= 1e-11 * np.linalg.norm(Lam_loaded)
        np.testing.assert_allclose(
            payload_spatial_inertia(arm, q, payload, None, reference), expected, atol=1e-12
        )


def test_mass_matrix_gains_the_load_seen_through_its_jacobian(panda, rng) -> None:
    """M_L − M = J_Bᵀ I_L J_B (local Jacobian of the frame carrying the load)."""
    I_c = rotational_inertia()
    payload = Payload(1.5, COM, I_c, frame="hand")
    loaded = with_payload(panda, payload)
    I_L = spatial_inertia_by_hand(1.5, COM, I_c)
    np.testing.assert_allclose(payload.spatial_inertia(), I_L, atol=1e-12)
    for _ in range(3):
        q = panda.random_configuration(rng)
        J_B = panda.jacobian(q, "hand", "local")
        np.testing.assert_allclose(
            loaded.mass_matrix(q) - panda.mass_matrix(q), J_B.T @ I_L @ J_B, atol=1e-12
        )


def test_nominal_projector_stays_consistent_on_the_loaded_robot(arm: rr.Robot, rng) -> None:
    """The practical meaning: a controller unaware of the load keeps its null-space torques
    out of a 6-D task — but not out of a 3-D one."""
    loaded = with_payload(arm, Payload(2.0, COM, rotational_inertia()))
    worst6, least3 = 0.0, np.inf
    for _ in range(6):
        q = arm.random_configuration(rng, margin=0.1)
        M, M_L = arm.mass_matrix(q), loaded.mass_matrix(q)
        tau0 = rng.normal(scale=10.0, size=arm.n)
        for rows in (slice(0, 6), slice(0, 3)):
            J = arm.jacobian(q)[rows]
            J_bar = dynamically_consistent_pinv(J, M)
            null = tau0 - J.T @ (J_bar.T @ tau0)
            rel = np.linalg.norm(task_disturbance(J, M_L, null)) / np.linalg.norm(
                task_disturbance(J, M_L, tau0)
            )
            if rows == slice(0, 6):
                worst6 = max(worst6, rel)
            else:
                least3 = min(least3, rel)
    print(
        f"\n{arm.name}: nominal projector on the loaded robot, relative task acceleration: "
        f"6-D task max {worst6:.1e}, position task min {least3:.1e}"
    )
    assert worst6 <= HOLDS
    assert least3 >= 1e-4


def test_copies_leave_the_robot_untouched(panda) -> None:
    q = panda.neutral()
    M, g = panda.mass_matrix(q), panda.gravity(q)
    loaded = with_payload(panda, Payload(3.0))
    floating = with_gravity(panda, (0.0, 0.0, 0.0))
    np.testing.assert_array_equal(panda.mass_matrix(q), M)
    np.testing.assert_array_equal(panda.gravity(q), g)
    assert np.abs(floating.gravity(q)).max() == 0.0
    assert loaded.tip == panda.tip and loaded.n == panda.n
    np.testing.assert_array_equal(loaded.tau_max, panda.tau_max)
    # A 3 kg point mass at the TCP adds 3 * 9.81 N along -z there: g_L − g = J_vᵀ (0, 0, m g).
    J_v = panda.jacobian(q)[:3]
    np.testing.assert_allclose(loaded.gravity(q) - g, J_v.T @ [0.0, 0.0, 3.0 * 9.81], atol=1e-10)


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        (dict(mass=-1.0), InvalidParameterError),
        (dict(mass=float("nan")), NonFiniteError),
        (dict(mass=1.0, com=(0.0, 0.0)), ShapeError),
        (dict(mass=1.0, inertia=np.diag([1.0, -1.0, 1.0])), NotPositiveDefiniteError),
        (dict(mass=1.0, inertia=np.triu(np.ones((3, 3)))), NotPositiveDefiniteError),
    ],
)
def test_bad_payloads(kwargs, error) -> None:
    with pytest.raises(error):
        Payload(**kwargs)


def test_unknown_frame(panda) -> None:
    with pytest.raises(FrameNotFoundError, match="valid frames"):
        with_payload(panda, Payload(1.0, frame="gripper"))
    with pytest.raises(InvalidParameterError):
        with_payload(panda, 1.0)  # type: ignore[arg-type]
