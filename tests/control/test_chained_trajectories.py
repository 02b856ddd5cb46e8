"""Chained trajectories and the ramped figure eight: twists are the derivatives of the
positions (central differences), the chain is continuous, a jump is refused."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.control import Chain, Circle, FigureEight, Line
from redres.errors import InvalidParameterError


def _check_derivatives(traj: rr.control.Trajectory, times: np.ndarray, h: float = 1e-6) -> None:
    for t in times:
        s = traj.sample(t)
        p_plus, p_minus = traj.sample(t + h).pose[:3, 3], traj.sample(t - h).pose[:3, 3]
        np.testing.assert_allclose(s.twist[:3], (p_plus - p_minus) / (2 * h), atol=1e-6)
        v_plus, v_minus = traj.sample(t + h).twist[:3], traj.sample(t - h).twist[:3]
        np.testing.assert_allclose(s.acceleration[:3], (v_plus - v_minus) / (2 * h), atol=1e-4)


def test_ramped_figure_eight_starts_at_rest_and_is_consistent() -> None:
    T0 = rr.models.panda().fk(rr.models.panda().neutral())
    eight = FigureEight(T0, 0.1, 0.06, 2.0, ramp=0.5)
    start = eight.sample(0.0)
    np.testing.assert_allclose(start.pose, T0, atol=1e-15)
    np.testing.assert_allclose(start.twist, 0.0, atol=1e-15)  # no velocity jump
    assert eight.duration == pytest.approx(2.0 + 0.25)
    _check_derivatives(eight, np.linspace(0.01, 2.2, 23))
    plain = FigureEight(T0, 0.1, 0.06, 2.0)
    # after the ramp the path is the plain eight delayed by ramp/2
    np.testing.assert_allclose(eight.sample(1.5).pose, plain.sample(1.25).pose, atol=1e-12)


def test_a_line_then_a_circle_is_one_continuous_trajectory() -> None:
    T0 = rr.models.panda().fk(rr.models.panda().neutral())
    line = Line(T0, T0[:3, 3] + [0.05, 0.0, 0.0], 1.0)
    chain = line.then(lambda T: Circle(T, 0.03, 1.5))
    assert isinstance(chain, Chain) and chain.duration == pytest.approx(2.5)
    np.testing.assert_allclose(chain.sample(0.4).pose, line.sample(0.4).pose, atol=0)
    circle = chain.parts[1]
    np.testing.assert_allclose(chain.sample(1.7).pose, circle.sample(0.7).pose, atol=0)
    for t in (1.0 - 1e-9, 1.0, 1.0 + 1e-9):  # continuous where they meet
        np.testing.assert_allclose(
            chain.sample(t).pose[:3, 3], line.sample(1.0).pose[:3, 3], atol=1e-9
        )
    _check_derivatives(chain, [0.3, 0.8, 1.3, 2.2])
    longer = chain.then(lambda T: Line(T, T[:3, 3] + [0, 0, 0.02], 0.5))
    assert len(longer.parts) == 3 and len(chain.parts) == 2  # then() makes a new chain
    log = rr.run(rr.models.panda(), rr.tasks.FrameTask(), longer,
                 rr.resolution.PseudoInverseScheme(), dt=2e-3)  # fmt: skip
    assert log.position_error.max() < 1e-3


def test_a_jump_between_parts_is_refused() -> None:
    T0 = np.eye(4)
    with pytest.raises(InvalidParameterError, match="starts 0.1 m from where the chain ends"):
        Line(T0, [0.1, 0, 0], 1.0).then(Circle(T0, 0.05, 1.0))
    with pytest.raises(InvalidParameterError, match="at least one"):
        Chain([])
