"""redres.batch.ik: item by item what rr.ik's compiled path finds, and what FK confirms.

Oracles: :func:`redres.ik.ik` (the same kernel called once per attempt, restarts keyed
by the integer seed it is given) with the same settings and no clock;
forward kinematics through Pinocchio (:meth:`Robot.fk`) for every solution.
"""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres import batch
from redres.errors import InvalidParameterError, NonFiniteError, ShapeError

SETTINGS = {"max_iterations": 40, "max_restarts": 3, "patience": 8, "tol_position": 1e-6}


def targets(robot: rr.Robot, rng: np.random.Generator, count: int) -> np.ndarray:
    """FK poses of random configurations, a third moved out of reach (budget spent)."""
    T = batch.fk(robot, np.array([robot.random_configuration(rng) for _ in range(count)]))
    T[::3, 0, 3] += 3.0  # 3 m away: beyond the reach of either arm
    return T


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_items_equal_rr_ik(name: str, builtin_robots: dict, rng: np.random.Generator) -> None:
    robot = builtin_robots[name]
    T = targets(robot, rng, 60)
    q0 = np.array([robot.random_configuration(rng) for _ in range(len(T))])
    keys = rng.integers(0, 2**62, len(T))
    result = batch.ik(robot, T, q0=q0, keys=keys, **SETTINGS)
    assert result.converged[1::3].mean() > 0.7 and not result.converged[::3].any()
    for i in range(len(T)):  # the iteration alone (analytic=False)
        single = rr.ik(robot, T[i], q0=q0[i], seed=int(keys[i]), timeout_s=None,
                       analytic=False, **SETTINGS)  # fmt: skip
        assert single.converged == result.converged[i], i
        assert single.restarts == result.restarts[i] and single.iterations == result.iterations[i]
        assert np.array_equal(single.q, result.q[i]), (i, single.q - result.q[i])
        assert single.position_error == result.position_error[i]
        assert single.orientation_error == result.orientation_error[i]


def test_solutions_put_the_frame_on_target(builtin_robots: dict, rng: np.random.Generator) -> None:
    robot = builtin_robots["panda"]
    T = targets(robot, rng, 30)[1::3]  # reachable ones
    result = batch.ik(robot, T, seed=3, solutions=4, max_restarts=12)
    assert (result.found >= 2).all()
    for i in range(len(T)):
        for s in range(result.found[i]):
            q = result.solutions[i, s]
            assert robot.within_limits(q)
            reached = robot.fk(q)  # Pinocchio, not the chain kernels
            assert np.linalg.norm(reached[:3, 3] - T[i, :3, 3]) <= 1e-6
            angle = np.arccos(np.clip((np.trace(reached[:3, :3].T @ T[i, :3, :3]) - 1) / 2, -1, 1))
            assert angle <= 1e-5 + 1e-7
        assert np.isnan(result.solutions[i, result.found[i] :]).all()
    assert np.array_equal(result.q, result.solutions[:, 0])


def test_threads_and_positions(builtin_robots: dict, rng: np.random.Generator) -> None:
    robot = builtin_robots["iiwa14"]
    T = targets(robot, rng, 90)
    one, two = (batch.ik(robot, T, seed=5, threads=t, **SETTINGS) for t in (1, 2))
    for a, b in zip(one, two):
        assert np.array_equal(a, b, equal_nan=True)
    points = batch.ik(robot, T[:, :3, 3], seed=5, **SETTINGS)  # position-only targets
    ok = points.converged
    reached = batch.fk(robot, points.q[ok])[:, :3, 3]
    assert np.abs(reached - T[ok, :3, 3]).max() <= 1e-6
    assert (points.orientation_error[ok] == 0.0).all()


def test_bad_input_names_the_item(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    T = np.tile(robot.fk(robot.neutral()), (4, 1, 1))
    bad = T.copy()
    bad[2, 0, 0] = np.nan
    with pytest.raises(NonFiniteError, match=r"targets\[2\]"):
        batch.ik(robot, bad)
    bad = T.copy()
    bad[1, :3, :3] *= 2.0
    with pytest.raises(ShapeError, match=r"targets\[1\] is not a homogeneous transform"):
        batch.ik(robot, bad)
    with pytest.raises(ShapeError, match=r"\(N, 4, 4\) or \(N, 3\)"):
        batch.ik(robot, T[0])
    with pytest.raises(ShapeError, match="keys"):
        batch.ik(robot, T, keys=[1, 2])
    with pytest.raises(InvalidParameterError, match="solutions"):
        batch.ik(robot, T, solutions=0)
    with pytest.raises(InvalidParameterError, match="max_iterations"):
        batch.ik(robot, T, max_iterations=0)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"max_iterations": 2**63}, "max_iterations must be an integer from 1 to 10,000,000"),
        ({"max_restarts": 10**30}, "max_restarts must be an integer from 0"),
        ({"patience": True}, "patience must be an integer"),
        ({"threads": "a"}, "threads must be a positive integer or None; got 'a'"),
        ({"seed": "x"}, "seed must be a numpy.random.Generator"),
        ({"solutions": 10**6}, "solutions must be an integer from 1 to 1024"),
    ],
)
def test_every_option_is_bounded_and_named(
    builtin_robots: dict, options: dict, message: str
) -> None:
    """A count of 2**63 wrapped around in the kernel and returned uninitialised q; other
    options raised Python's own errors (the reliability issue's reproductions)."""
    robot = builtin_robots["panda"]
    T = robot.fk(robot.neutral())[None]
    with pytest.raises(InvalidParameterError, match=message):
        batch.ik(robot, T, **options)


def test_no_robot_and_an_output_beyond_memory_are_refused(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    T = robot.fk(robot.neutral())
    with pytest.raises(InvalidParameterError, match=r"robot must be a redres.Robot .*; got None"):
        batch.ik(None, T[None])  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError, match="robot must be a redres.Robot"):
        batch.fk("panda", np.zeros((1, 7)))  # type: ignore[arg-type]
    many = np.broadcast_to(T, (10**9, 4, 4))  # no memory of its own: a view
    with pytest.raises(InvalidParameterError, match=r"GiB for its outputs.*chunks"):
        batch.ik(robot, many, solutions=8)


def test_a_batch_launched_in_pieces_equals_its_items(
    builtin_robots: dict, rng: np.random.Generator
) -> None:
    """rr.batch.ik launches the kernel on a few thousand targets at a time (Ctrl-C is seen
    between launches): the items past the first launch equal the same items alone."""
    robot = builtin_robots["panda"]
    q = np.array([robot.random_configuration(rng) for _ in range(4100)])
    T = batch.fk(robot, q)
    keys = rng.integers(0, 2**62, len(T))
    options = {"max_iterations": 30, "max_restarts": 0, "q0": q + 0.05}
    whole = batch.ik(robot, T, keys=keys, **options)
    part = slice(4090, 4100)  # across the first launch's end (4096)
    alone = batch.ik(robot, T[part], keys=keys[part], **{**options, "q0": q[part] + 0.05})
    for a, b in zip(whole, alone):
        assert np.array_equal(a[part], b, equal_nan=True)
