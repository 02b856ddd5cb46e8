"""Acceleration-level resolution (seed 004 eq. 9) and computed torque."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.dynamics import AccelerationController, OperationalSpaceController, resolve_acceleration
from redres.errors import InvalidParameterError, NotPositiveDefiniteError, ShapeError
from redres.objectives import JointLimitObjective, PostureObjective


def random_state(robot: rr.Robot, rng: np.random.Generator):
    return robot.random_configuration(rng, margin=0.05), rng.uniform(-1.0, 1.0, robot.n)


@pytest.mark.parametrize("inverse", ["dynamic", "kinematic"])
def test_resolved_acceleration_realises_the_task(arm: rr.Robot, rng, inverse) -> None:
    """J q̈ + J̇ q̇ = ẍ whatever q̈₀, and the ABA of the computed torque gives that q̈."""
    for _ in range(5):
        q, qd = random_state(arm, rng)
        J, M = arm.jacobian(q), arm.mass_matrix(q)
        jdot_qd = arm.jacobian_dot(q, qd) @ qd
        xdd, qdd0 = rng.normal(size=6), rng.normal(size=arm.n)
        qdd, info = resolve_acceleration(J, M, xdd, jdot_qd, qdd0, inverse=inverse)
        assert info.full_rank
        np.testing.assert_allclose(J @ qdd + jdot_qd, xdd, atol=1e-9 * np.abs(xdd).max())
        tau = arm.inverse_dynamics(q, qd, qdd)
        np.testing.assert_allclose(
            arm.forward_dynamics(q, qd, tau), qdd, atol=1e-8 * np.abs(qdd).max()
        )


def test_the_two_inverses_project_differently(panda, rng) -> None:
    """The null-space part is the M-weighted (J̄) or Euclidean (J⁺) projection of q̈₀."""
    q, _ = random_state(panda, rng)
    J, M = panda.jacobian(q), panda.mass_matrix(q)
    qdd0 = rng.normal(size=panda.n)
    zero = np.zeros(6)
    dyn, _ = resolve_acceleration(J, M, zero, zero, qdd0, inverse="dynamic")
    kin, _ = resolve_acceleration(J, None, zero, zero, qdd0, inverse="kinematic")
    J_pinv = np.linalg.pinv(J)
    np.testing.assert_allclose(kin, qdd0 - J_pinv @ J @ qdd0, atol=1e-10)
    M_inv = np.linalg.inv(M)
    J_bar = M_inv @ J.T @ np.linalg.inv(J @ M_inv @ J.T)
    np.testing.assert_allclose(dyn, qdd0 - J_bar @ J @ qdd0, atol=1e-9)
    # J̄ minimises the kinetic-energy metric: ‖dyn − qdd0‖_M ≤ ‖kin − qdd0‖_M.
    assert (dyn - qdd0) @ M @ (dyn - qdd0) <= (kin - qdd0) @ M @ (kin - qdd0) + 1e-12
    assert np.linalg.norm(dyn - kin) > 1e-3


def test_dynamic_acceleration_controller_equals_osc(arm: rr.Robot, rng) -> None:
    """With J̄ and τ₀ = M q̈₀ the two laws are the same torque (M J̄ = Jᵀ Λ,
    M (I − J̄ J) = (I − Jᵀ J̄ᵀ) M)."""
    objectives = [PostureObjective(arm.neutral()), (JointLimitObjective(), 0.5)]
    osc = OperationalSpaceController(kp=225.0, objectives=objectives, null_kp=9.0, null_kd=3.0)
    acc = AccelerationController(kp=225.0, objectives=objectives, null_kp=9.0, null_kd=3.0)
    target = arm.fk(arm.neutral())
    osc.task.set_target(target)
    acc.task.set_target(target)
    osc.reset()
    acc.reset()
    for _ in range(5):
        q, qd = random_state(arm, rng)
        a, b = osc.step(arm, q, qd), acc.step(arm, q, qd)
        np.testing.assert_allclose(b.tau, a.tau, atol=1e-8 * np.abs(a.tau).max())
        np.testing.assert_allclose(b.tau_null, a.tau_null, atol=1e-8 * np.abs(a.tau).max())


def test_bad_input(panda) -> None:
    q = panda.neutral()
    J, M = panda.jacobian(q), panda.mass_matrix(q)
    z = np.zeros(6)
    with pytest.raises(InvalidParameterError, match="needs M"):
        resolve_acceleration(J, None, z, z)
    with pytest.raises(InvalidParameterError, match="inverse"):
        resolve_acceleration(J, M, z, z, inverse="pseudo")  # type: ignore[arg-type]
    with pytest.raises(ShapeError, match="M"):
        resolve_acceleration(J, np.eye(6), z, z)
    with pytest.raises(NotPositiveDefiniteError, match="M"):
        resolve_acceleration(J, -M, z, z)
    with pytest.raises(ShapeError, match="qdd0"):
        resolve_acceleration(J, M, z, z, np.zeros(3))
    with pytest.raises(InvalidParameterError):
        AccelerationController(kd=-1.0)
