"""Operational-space control: Λ and J̄ against the direct formulas, dynamic consistency of
the null-space torque (Panda, iiwa14), the exact closed-loop task dynamics, bad input."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.control import Hold
from redres.dynamics import (
    OperationalSpaceController,
    operational_space_torque,
    simulate,
    task_disturbance,
)
from redres.dynamics.osc import dynamic_inverse
from redres.errors import (
    InvalidParameterError,
    NonFiniteError,
    NotPositiveDefiniteError,
    ShapeError,
)
from redres.objectives import PostureObjective
from redres.tasks import ArmAngleTask, FrameTask

N_STATES = 12


def states(robot: rr.Robot, rng: np.random.Generator, count: int = N_STATES):
    """Random states inside the limits: q, q̇ (|q̇| ≤ 1 rad/s)."""
    for _ in range(count):
        yield robot.random_configuration(rng, margin=0.05), rng.uniform(-1.0, 1.0, robot.n)


def task_acceleration(robot: rr.Robot, q, qd, J, tau, base=None) -> np.ndarray:
    """``J q̈`` from Pinocchio's ABA: the oracle for what a torque does to the task (with
    ``base``: what ``tau`` adds to the task acceleration under ``base``)."""
    if base is None:
        return J @ robot.forward_dynamics(q, qd, tau)
    return J @ (robot.forward_dynamics(q, qd, tau) - robot.forward_dynamics(q, qd, base))


def test_lambda_and_jbar_match_the_direct_formulas(arm: rr.Robot, rng) -> None:
    for q, _ in states(arm, rng):
        J, M = arm.jacobian(q), arm.mass_matrix(q)
        M_inv = np.linalg.inv(M)
        Lam = np.linalg.inv(J @ M_inv @ J.T)
        J_bar = M_inv @ J.T @ Lam
        scale = np.linalg.norm(J_bar)
        np.testing.assert_allclose(
            rr.linalg.task_space_inertia(J, M), Lam, rtol=1e-9, atol=1e-9 * np.abs(Lam).max()
        )
        assert np.linalg.norm(rr.linalg.dynamically_consistent_pinv(J, M) - J_bar) <= 1e-9 * scale
        ours, info = dynamic_inverse(J, M, 0.0, 1e-10)
        assert np.linalg.norm(ours - J_bar) <= 1e-9 * scale
        assert info.full_rank
        np.testing.assert_allclose(J @ ours, np.eye(6), atol=1e-9)
        # M J̄ = Jᵀ Λ: the identity the controller uses to skip Λ.
        np.testing.assert_allclose(M @ J_bar, J.T @ Lam, atol=1e-9 * np.abs(J.T @ Lam).max())


def test_null_torques_do_not_accelerate_the_task(arm: rr.Robot, rng) -> None:
    """Seed 004 eq. 13: J M⁻¹ (I − Jᵀ J̄ᵀ) τ₀ = 0; with J⁺ it is not, and we say how much."""
    worst_dynamic, kinematic = 0.0, []
    for q, qd in states(arm, rng):
        J, M, b = arm.jacobian(q), arm.mass_matrix(q), arm.bias(q, qd)
        command = rng.normal(size=6)
        tau0 = rng.normal(scale=10.0, size=arm.n)
        for projector in ("dynamic", "kinematic"):
            out = operational_space_torque(J, M, b, command, tau0, projector=projector)
            base = out.tau - out.null
            caused = task_acceleration(arm, q, qd, J, out.tau, base)
            raw = task_acceleration(arm, q, qd, J, base + tau0, base)
            relative = np.linalg.norm(caused) / np.linalg.norm(raw)
            if projector == "dynamic":
                worst_dynamic = max(worst_dynamic, relative)
            else:
                kinematic.append(relative)
    print(
        f"\n{arm.name}: task acceleration from projected random tau0, relative to the "
        f"unprojected one: dynamic max {worst_dynamic:.1e}; kinematic min "
        f"{min(kinematic):.2e} median {np.median(kinematic):.2e} max {max(kinematic):.2e}"
    )
    assert worst_dynamic <= 1e-9
    assert np.median(kinematic) > 1e-2


def test_task_disturbance_matches_forward_dynamics(panda: rr.Robot, rng) -> None:
    for q, qd in states(panda, rng, 4):
        J, M = panda.jacobian(q), panda.mass_matrix(q)
        tau = rng.normal(size=panda.n)
        expected = task_acceleration(panda, q, qd, J, tau, np.zeros(panda.n))
        np.testing.assert_allclose(
            task_disturbance(J, M, tau), expected, atol=1e-9 * np.linalg.norm(expected)
        )


@pytest.mark.parametrize("compensation", ["joint", "task"])
def test_task_acceleration_equals_the_servo_command(arm: rr.Robot, rng, compensation) -> None:
    """With the exact model, ẍ = J q̈ + J̇ q̇ = ẍ*: every row obeys ë + K_d ė + K_p e = 0."""
    for q, qd in states(arm, rng, 6):
        J, M, b = arm.jacobian(q), arm.mass_matrix(q), arm.bias(q, qd)
        jdot_qd = arm.jacobian_dot(q, qd) @ qd
        xdd_star = rng.normal(size=6)
        tau0 = rng.normal(scale=5.0, size=arm.n)
        out = operational_space_torque(J, M, b, xdd_star - jdot_qd, tau0, compensation=compensation)
        xdd = task_acceleration(arm, q, qd, J, out.tau) + jdot_qd
        np.testing.assert_allclose(xdd, xdd_star, atol=1e-9 * max(1.0, np.abs(xdd_star).max()))


def test_joint_and_task_compensation_differ_by_the_null_space_bias(panda, rng) -> None:
    q, qd = next(states(panda, rng, 1))
    J, M, b = panda.jacobian(q), panda.mass_matrix(q), panda.bias(q, qd)
    a = rng.normal(size=6)
    joint = operational_space_torque(J, M, b, a, compensation="joint")
    task = operational_space_torque(J, M, b, a, compensation="task")
    J_bar = np.linalg.solve(M, J.T) @ np.linalg.inv(J @ np.linalg.solve(M, J.T))
    np.testing.assert_allclose(
        joint.tau - task.tau, (np.eye(panda.n) - J.T @ J_bar.T) @ b, atol=1e-9 * np.abs(b).max()
    )


def test_null_torque_from_an_acceleration_is_its_projection(panda, rng) -> None:
    """τ₀ = M q̈₀ through I − Jᵀ J̄ᵀ moves the joints by (I − J̄ J) q̈₀."""
    q, _ = next(states(panda, rng, 1))
    J, M = panda.jacobian(q), panda.mass_matrix(q)
    qdd0 = rng.normal(size=panda.n)
    out = operational_space_torque(J, M, np.zeros(panda.n), np.zeros(6), M @ qdd0)
    J_bar = rr.linalg.dynamically_consistent_pinv(J, M)
    np.testing.assert_allclose(np.linalg.solve(M, out.null), qdd0 - J_bar @ (J @ qdd0), atol=1e-9)


def test_damped_projector_leaks_by_the_closed_form(panda, rng) -> None:
    """J M⁻¹ (I − Jᵀ J̄_λᵀ) = λ² (J M⁻¹ Jᵀ + λ² I)⁻¹ J M⁻¹, and → 0 with λ."""
    q, _ = next(states(panda, rng, 1))
    J, M = panda.jacobian(q), panda.mass_matrix(q)
    JMi = J @ np.linalg.inv(M)
    tau0 = rng.normal(size=panda.n)
    leaks = []
    for lam in (1e-1, 1e-2, 1e-3):
        out = operational_space_torque(J, M, np.zeros(panda.n), np.zeros(6), tau0, damping=lam)
        expected = lam**2 * np.linalg.solve(JMi @ J.T + lam**2 * np.eye(6), JMi @ tau0)
        np.testing.assert_allclose(JMi @ out.null, expected, atol=1e-9)
        leaks.append(np.linalg.norm(JMi @ out.null))
    assert leaks[0] > leaks[1] > leaks[2]


def test_regulation_error_decays_like_the_servo(panda) -> None:
    """Start 2 cm off target: the error follows ë + K_d ė + K_p e = 0 (critically damped,
    e(t) = e0 (1 + ω t) exp(−ω t), ω = √K_p)."""
    q0 = panda.neutral()
    T = panda.fk(q0)
    T[:3, 3] += [0.02, 0.0, 0.0]
    law = OperationalSpaceController(kp=100.0, objectives=[PostureObjective(q0)])
    log = simulate(panda, law, Hold(T, 0.6), dt=1e-3, q0=q0)
    t, e = log.t, log.position_error
    expected = 0.02 * (1.0 + 10.0 * t) * np.exp(-10.0 * t)
    deviation = np.max(np.abs(e - expected))
    print(f"\nregulation: max |e - e_servo| = {deviation:.2e} m (e0 = 2 cm)")
    assert deviation < 0.02 * 1e-2  # 1 % of e0: zero-order hold of a 1 kHz loop
    assert e[-1] < 0.02 * 0.02


def test_controller_matches_the_bare_function(panda, rng) -> None:
    q, qd = next(states(panda, rng, 1))
    task = FrameTask()
    law = OperationalSpaceController(
        task,
        kp=[100, 100, 100, 50, 50, 50],
        kd=20.0,
        objectives=[PostureObjective(panda.neutral())],
        null_kp=4.0,
        null_kd=2.0,
    )
    step = law.step(panda, q, qd)
    J, M, b = panda.jacobian(q), panda.mass_matrix(q), panda.bias(q, qd)
    e = task.full_error(panda.fk(q))
    command = (
        np.r_[100, 100, 100, 50, 50, 50] * e - 20.0 * (J @ qd) - panda.jacobian_dot(q, qd) @ qd
    )
    tau0 = M @ (-4.0 * (q - panda.neutral()) - 2.0 * qd)
    expected = operational_space_torque(J, M, b, command, tau0)
    np.testing.assert_allclose(step.tau, expected.tau, atol=1e-9 * np.abs(expected.tau).max())
    np.testing.assert_allclose(step.tau_null, expected.null, atol=1e-9)


def test_partial_task_rows(panda, rng) -> None:
    q, qd = next(states(panda, rng, 1))
    law = OperationalSpaceController(FrameTask(rows="xyz"))
    law.step(panda, q, qd)
    tau0 = rng.normal(size=panda.n)
    J = panda.jacobian(q)[:3]
    out = operational_space_torque(J, panda.mass_matrix(q), panda.bias(q, qd), np.zeros(3), tau0)
    assert np.linalg.norm(task_disturbance(J, panda.mass_matrix(q), out.null)) < 1e-9


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"kp": -1.0}, InvalidParameterError),
        ({"kd": -0.1}, InvalidParameterError),
        ({"kp": [1.0, 2.0]}, ShapeError),
        ({"kp": float("nan")}, NonFiniteError),
        ({"null_kp": -1.0}, InvalidParameterError),
        ({"null_kd": -1.0}, InvalidParameterError),
        ({"projector": "pseudo"}, InvalidParameterError),
        ({"compensation": "none"}, InvalidParameterError),
        ({"damping": -0.1}, InvalidParameterError),
        ({"null_torque": 3.0}, InvalidParameterError),
    ],
)
def test_bad_controller_parameters(kwargs, error) -> None:
    with pytest.raises(error):
        OperationalSpaceController(**kwargs)


def test_task_must_be_a_frame_task() -> None:
    with pytest.raises(InvalidParameterError, match="FrameTask"):
        OperationalSpaceController(ArmAngleTask("shoulder", "elbow", "wrist"))  # type: ignore[arg-type]


def test_bad_mass_matrices(panda, rng) -> None:
    q = panda.neutral()
    J, M, b = panda.jacobian(q), panda.mass_matrix(q), np.zeros(panda.n)
    a = np.zeros(6)
    with pytest.raises(ShapeError, match="M"):
        operational_space_torque(J, M[:6, :6], b, a)
    not_spd = M.copy()
    not_spd[0, 0] = -1.0
    with pytest.raises(NotPositiveDefiniteError, match="M"):
        operational_space_torque(J, not_spd, b, a)
    asymmetric = M + np.triu(np.ones_like(M), 1)
    with pytest.raises(NotPositiveDefiniteError, match="M"):
        operational_space_torque(J, asymmetric, b, a)
    with pytest.raises(NotPositiveDefiniteError):
        task_disturbance(J, not_spd, b)
    nan_M = M.copy()
    nan_M[1, 2] = np.nan
    with pytest.raises(NonFiniteError, match="M"):
        operational_space_torque(J, nan_M, b, a)


def test_bad_vectors_are_named(panda) -> None:
    q = panda.neutral()
    J, M = panda.jacobian(q), panda.mass_matrix(q)
    with pytest.raises(ShapeError, match="bias"):
        operational_space_torque(J, M, np.zeros(6), np.zeros(6))
    with pytest.raises(ShapeError, match="command"):
        operational_space_torque(J, M, np.zeros(7), np.zeros(5))
    with pytest.raises(NonFiniteError, match="tau0"):
        operational_space_torque(J, M, np.zeros(7), np.zeros(6), np.full(7, np.inf))


def test_non_finite_states_are_rejected(panda) -> None:
    law = OperationalSpaceController()
    q = panda.neutral()
    with pytest.raises(NonFiniteError, match="qd"):
        law.step(panda, q, np.full(panda.n, np.nan))
    bad_q = q.copy()
    bad_q[3] = np.inf
    with pytest.raises(NonFiniteError, match="q"):
        law.step(panda, bad_q, np.zeros(panda.n))
