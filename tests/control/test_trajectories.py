"""Trajectories: twists and accelerations are the derivatives of the poses."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres.control import Circle, FigureEight, Hold, Line, MinimumJerk, minimum_jerk
from redres.resolution import PseudoInverseScheme
from redres.tasks import ArmAngleTask, FrameTask

T0 = np.eye(4)
T0[:3, 3] = [0.4, 0.1, 0.5]
T1 = np.eye(4)
T1[:3, :3] = pin.exp3(np.array([0.3, -0.5, 0.8]))
T1[:3, 3] = [0.2, -0.2, 0.7]

TRAJECTORIES = {
    "circle": Circle(T0, 0.1, 2.0, normal=(0.2, 1.0, 0.3), phase=0.7, ramp=0.5),
    "eight": FigureEight(T0, 0.15, 0.1, 3.0, normal=(1.0, 0.0, 0.0)),
    "min_jerk": MinimumJerk(T0, T1, 2.0),
    "line": Line(T0, [0.5, 0.3, 0.2], 1.5),
}


@pytest.mark.parametrize("name", sorted(TRAJECTORIES))
def test_twist_and_acceleration_are_derivatives(name: str) -> None:
    traj = TRAJECTORIES[name]
    h = 1e-6
    for t in np.linspace(0.05, traj.duration - 0.05, 13):
        s, sp, sm = traj.sample(t), traj.sample(t + h), traj.sample(t - h)
        v = (sp.pose[:3, 3] - sm.pose[:3, 3]) / (2 * h)
        w = pin.log3(sp.pose[:3, :3] @ sm.pose[:3, :3].T) / (2 * h)
        assert np.allclose(s.twist, np.concatenate([v, w]), atol=1e-7)
        assert np.allclose(s.acceleration, (sp.twist - sm.twist) / (2 * h), atol=1e-6)


def test_circle_geometry_and_start() -> None:
    circle = TRAJECTORIES["circle"]
    assert np.allclose(circle.sample(0.0).pose, T0)
    assert np.allclose(circle.sample(0.0).twist, 0.0)  # the ramp starts from rest
    for t in np.linspace(0, circle.duration, 50):
        p = circle.sample(t).pose[:3, 3]
        assert np.linalg.norm(p - circle.center) == pytest.approx(0.1, abs=1e-12)
    assert np.allclose(circle.sample(circle.duration).pose[:3, 3], T0[:3, 3], atol=1e-12)


def test_minimum_jerk_endpoints() -> None:
    assert minimum_jerk(0.0) == (0.0, 0.0, 0.0) and minimum_jerk(1.0)[0] == 1.0
    traj = TRAJECTORIES["min_jerk"]
    assert np.allclose(traj.sample(0.0).pose, T0) and np.allclose(traj.sample(2.0).pose, T1)
    assert np.allclose(traj.sample(2.0).twist, 0.0)
    assert np.allclose(Hold(T1, 1.0).sample(0.3).pose, T1)


def test_bad_trajectory_input() -> None:
    with pytest.raises(rr.errors.InvalidParameterError, match="radius must be > 0"):
        Circle(T0, 0.0, 1.0)
    with pytest.raises(rr.errors.ShapeError, match="start_pose must be a 4x4"):
        Circle(np.eye(3), 0.1, 1.0)
    with pytest.raises(rr.errors.NonFiniteError):
        Line(T0, [np.nan, 0.0, 0.0], 1.0)
    with pytest.raises(rr.errors.InvalidParameterError, match="duration must be >= 1e-09"):
        MinimumJerk(T0, T1, 0.0)


def test_non_physical_times_and_non_finite_parameters_are_refused() -> None:
    """NaN turns or phase were accepted (a NaN path), a 5e-324 s period overflowed the rate
    and a 1e-300 s line divided by zero; each is now a RedresError naming the parameter."""
    robot = rr.models.panda()
    start = robot.fk(robot.neutral())
    cases = [
        (lambda: Circle(start, 0.1, 1.0, turns=float("nan")), "turns"),
        (lambda: Circle(start, 0.1, 1.0, phase=float("nan")), "phase"),
        (lambda: Circle(start, 0.1, 5e-324), "period"),
        (lambda: FigureEight(start, 0.1, 0.1, 1.0, turns=-1.0), "turns"),
        (lambda: Line(start, [0.0, 0.0, 0.0], 1e-300), "duration"),
        (lambda: Hold(start, 0.0), "duration"),
        (lambda: ArmAngleTask(target=float("nan")), "target"),
        (lambda: rr.run(robot, FrameTask(), "circle", PseudoInverseScheme()), "trajectory"),
    ]
    for make, name in cases:
        with pytest.raises(rr.errors.RedresError, match=name):
            make()


@pytest.mark.parametrize("make", [Circle, lambda T, *a, **k: FigureEight(T, 0.1, *a, **k)])
def test_a_zero_normal_is_refused_and_extreme_ones_are_directions(make) -> None:
    """FigureEight did not check its normal (issue 18, item 11): one check in _plane_axes."""
    with pytest.raises(rr.errors.InvalidParameterError, match="normal must be a non-zero"):
        make(T0, 0.1, 2.0, normal=(0.0, 0.0, 0.0))
    for normal in ((0.0, 0.0, 1e-200), (0.0, 0.0, 1e300)):
        sample = make(T0, 0.1, 2.0, normal=normal).sample(0.3)
        assert np.isfinite(sample.pose).all() and np.isfinite(sample.twist).all()
