"""An iiwa14 path (a 15 cm circle, four turns in 10 s): the plan from the same start keeps
a larger minimum joint-limit margin than the local schemes; a circle the arm cannot
follow is reported with its first impossible sample (a pose out of reach), and the local
scheme loses the path."""

from __future__ import annotations

import numpy as np

import redres as rr
from redres.control.trajectories import Circle
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme, WeightedLeastNormScheme
from redres.tasks import FrameTask

Q0 = np.array([0.3, 0.8, 0.2, -1.2, 0.3, 0.9, 0.1])


def _run(robot: rr.Robot, path: Circle) -> dict[str, rr.control.RunLog]:
    schemes = {
        "pseudo-inverse": PseudoInverseScheme(),
        "gradient projection": GradientProjectionScheme([JointLimitObjective()], k_null=5.0),
        "weighted least norm": WeightedLeastNormScheme(),
    }
    return {label: rr.run(robot, FrameTask(), path, scheme, q0=Q0, gain=50.0)
            for label, scheme in schemes.items()}  # fmt: skip


def test_plan_beats_the_local_schemes_on_an_iiwa14_circle() -> None:
    robot = rr.models.iiwa14()
    path = Circle(robot.fk(Q0), 0.15, 2.5, normal=(1.0, 0.0, 0.0), turns=4)
    # 720 arm-angle values: a step of 0.0087 rad; with 360 the arm angle cannot turn fast
    # enough at the start and the grid's optimum (0.47385 rad) stays 3e-5 rad below
    # gradient projection's 0.47387
    plan = rr.plan_path(robot, path, dt=0.01, resolution=720, q0=Q0)
    assert plan.feasible and np.abs(plan.q[0] - Q0).max() < 1e-9
    for label, log in _run(robot, path).items():
        summary = log.summary()
        assert summary["max_position_error_m"] < 1e-4, label
        assert plan.objective >= summary["min_joint_limit_margin_rad"], label
    assert plan.objective > 0.477  # measured 0.4778; the local schemes 0.4687-0.4739


def test_a_circle_out_of_reach_is_reported() -> None:
    robot = rr.models.iiwa14()
    path = Circle(robot.fk(Q0), 0.15, 2.5, normal=(0.0, 0.0, 1.0), turns=4)
    plan = rr.plan_path(robot, path, dt=0.01, resolution=90, q0=Q0)
    assert not plan.feasible and plan.stats.first_infeasible == 41
    assert rr.self_motion(robot, path.sample(0.41).pose).empty  # out of reach there
    assert not any(rr.self_motion(robot, path.sample(0.01 * k).pose).empty for k in range(41))
    log = rr.run(robot, FrameTask(), path, PseudoInverseScheme(), q0=Q0, duration=1.0)
    assert log.position_error.max() > 0.1  # the local scheme loses the path


def test_refinement_converges_on_the_iiwa14_circle() -> None:
    """The optimum changes by < 1 % between the two finest arm-angle grids. One turn of the
    circle (251 samples) instead of four, to keep the test short: the optimum binds at
    the start (measured: 0.47780 rad on one turn and on four, at 720, 1080 and 1440
    values). 720 and 1440 values from the same start are nested grids (the values are
    ``ψ(q0) + 2πi/P``), so the finer optimum is at least the coarser one."""
    robot = rr.models.iiwa14()
    path = Circle(robot.fk(Q0), 0.15, 2.5, normal=(1.0, 0.0, 0.0), turns=1)
    optimum = {count: rr.plan_path(robot, path, dt=0.01, resolution=count, q0=Q0).objective
               for count in (720, 1440)}  # fmt: skip
    assert optimum[1440] >= optimum[720] > 0.477
    assert abs(optimum[1440] - optimum[720]) / optimum[1440] < 0.01
