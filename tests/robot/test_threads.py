"""One Robot shared by threads: every controller, run and call gives what it gives alone.

The interpreter is made to switch threads every microsecond (``sys.setswitchinterval``)
so that the threads interleave inside each step; each threaded result must be
bit-identical to the same work done sequentially.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

import redres as rr
from redres.control import Circle
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, QPScheme, SNSScheme
from redres.tasks import FrameTask

STEPS = 500


@pytest.fixture
def fast_switching() -> Iterator[None]:
    previous = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        yield
    finally:
        sys.setswitchinterval(previous)


def _in_threads(jobs: list[Callable[[], Any]]) -> list[Any]:
    results: list[Any] = [None] * len(jobs)
    errors: list[BaseException] = []

    def run(i: int) -> None:
        try:
            results[i] = jobs[i]()
        except BaseException as exc:  # reported below, not lost in the thread
            errors.append(exc)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(len(jobs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    return results


def _loop(robot: rr.Robot, make_scheme: Callable[[], Any], offset: float) -> Callable[[], Any]:
    """A controller following a circle from its own start: returns every configuration."""

    def job() -> Any:
        task = FrameTask()
        controller = rr.Controller(robot, task, make_scheme(), dt=1e-3)
        q = robot.neutral() + offset
        circle = Circle(robot.fk(q), radius=0.05, period=2.0)
        out = []
        for k in range(STEPS):
            sample = circle.sample(k * 1e-3)
            task.set_target(sample.pose, sample.twist)
            q = controller.step(q)
            out.append(q.copy())
        return np.array(out)

    return job


SCHEMES = {
    "gradient projection (fused path)": lambda: GradientProjectionScheme(
        [JointLimitObjective()], k_null=5.0, damping=0.01
    ),
    "SNS": lambda: SNSScheme(dt=1e-3),
    "QP": lambda: QPScheme(dt=1e-3),
}


@pytest.mark.parametrize("scheme", list(SCHEMES))
def test_controllers_on_one_robot_in_threads(scheme: str, fast_switching: None) -> None:
    robot = rr.models.panda()
    jobs = [_loop(robot, SCHEMES[scheme], offset) for offset in (0.0, 0.1, 0.2, 0.3)]
    alone = [job() for job in jobs]
    together = _in_threads(jobs)
    for a, b in zip(alone, together):
        assert np.array_equal(a, b)


def test_runs_on_one_robot_in_threads(fast_switching: None) -> None:
    robot = rr.models.panda()

    def job(offset: float) -> Callable[[], Any]:
        def run() -> Any:
            q0 = robot.neutral() + offset
            circle = Circle(robot.fk(q0), radius=0.05, period=2.0)
            scheme = GradientProjectionScheme([JointLimitObjective()], k_null=5.0)
            log = rr.run(robot, FrameTask(), circle, scheme, dt=1e-3, duration=0.3, q0=q0,
                         progress=False)  # fmt: skip
            return log.q

        return run

    jobs = [job(0.0), job(0.1), job(0.2)]
    alone = [j() for j in jobs]
    together = _in_threads(jobs)
    for a, b in zip(alone, together):
        assert np.array_equal(a, b)


def test_robot_methods_in_threads(fast_switching: None) -> None:
    robot = rr.models.iiwa14()
    configurations = [robot.random_configuration(seed) for seed in range(4)]

    def job(q: np.ndarray) -> Callable[[], Any]:
        def calls() -> Any:
            out = []
            for _ in range(200):
                out += [robot.fk(q), robot.jacobian(q), robot.mass_matrix(q), robot.gravity(q)]
            return out

        return calls

    jobs = [job(q) for q in configurations]
    alone = [j() for j in jobs]
    together = _in_threads(jobs)
    for a, b in zip(alone, together):
        assert all(np.array_equal(x, y) for x, y in zip(a, b))


def test_a_copied_robot_computes_into_its_own_data() -> None:
    import pickle

    robot = rr.models.panda()
    copy = pickle.loads(pickle.dumps(robot))
    q = robot.neutral()
    assert np.array_equal(copy.fk(q), robot.fk(q))
    assert copy.data is not robot.data
