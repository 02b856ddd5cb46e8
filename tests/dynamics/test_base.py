"""Torque-law building blocks: gains, simple laws."""

from __future__ import annotations

import numpy as np
import pytest

from redres.dynamics import GravityCompensation, TaskGains, TorqueFunction, ZeroTorque
from redres.errors import InvalidParameterError, NonFiniteError, ShapeError


def test_default_damping_is_critical() -> None:
    gains = TaskGains.make(400.0, None, 6)
    np.testing.assert_allclose(gains.kd, 40.0)
    # Critical: the characteristic polynomial s² + K_d s + K_p has a double root.
    assert np.all(gains.kd**2 - 4.0 * gains.kp == pytest.approx(0.0))


def test_per_row_gains() -> None:
    gains = TaskGains.make([100, 100, 100, 25, 25, 25], [1, 2, 3, 4, 5, 6], 6)
    np.testing.assert_array_equal(gains.kp, [100, 100, 100, 25, 25, 25])
    np.testing.assert_array_equal(gains.kd, [1, 2, 3, 4, 5, 6])


@pytest.mark.parametrize(
    ("kp", "kd", "error"),
    [
        (-1.0, None, InvalidParameterError),
        (1.0, -2.0, InvalidParameterError),
        ([1.0, 2.0], None, ShapeError),
        (np.inf, None, NonFiniteError),
        (1.0, np.nan, NonFiniteError),
    ],
)
def test_bad_gains(kp, kd, error) -> None:
    with pytest.raises(error):
        TaskGains.make(kp, kd, 6)


def test_simple_laws(panda) -> None:
    q, qd = panda.neutral(), np.full(panda.n, 0.5)
    np.testing.assert_array_equal(ZeroTorque().step(panda, q, qd).tau, np.zeros(panda.n))
    np.testing.assert_allclose(
        GravityCompensation(kd=2.0).step(panda, q, qd).tau, panda.gravity(q) - 1.0
    )
    with pytest.raises(InvalidParameterError):
        GravityCompensation(kd=-1.0)
    with pytest.raises(InvalidParameterError, match="callable"):
        TorqueFunction(3.0, "x")  # type: ignore[arg-type]
    assert "zero_torque" in repr(ZeroTorque())
