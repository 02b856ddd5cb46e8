"""``rr.ik_all`` and ``rr.self_motion``: every solution at one value of the redundancy
parameter, and per branch the parameter intervals within the joint limits, checked by
forward kinematics, by the other parametrisation's closed form, and by dense sampling."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.errors import InvalidParameterError, NonFiniteError
from redres.ik.analytic import IKSolutions, IKSolutionsBatch
from redres.ik.solutions import END_TOL
from redres.ik.srs import NotSRSError


def _in_limits(robot: rr.Robot, rng: np.random.Generator, count: int) -> np.ndarray:
    return rng.uniform(robot.q_min, robot.q_max, (count, robot.n))


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_ik_all_at_q7_single_and_batch(name: str) -> None:
    robot = rr.models.load(name)
    qs = _in_limits(robot, np.random.default_rng(0), 20)
    T = np.array([robot.fk(q) for q in qs])
    batch = rr.ik_all(robot, T, q7=qs[:, 6])
    assert isinstance(batch, IKSolutionsBatch)
    for i, q in enumerate(qs):
        one = rr.ik_all(robot, T[i], q7=q[6])
        assert isinstance(one, IKSolutions) and one.count == batch.count[i]
        assert np.array_equal(one.q, batch.q[i, : one.count])
        assert np.min(np.abs(one.q - q).max(axis=1)) < 1e-9  # the original is there
        for x in one.q:
            assert np.abs(robot.fk(x) - T[i]).max() < 1e-10


def test_ik_all_at_the_arm_angle_of_an_srs_arm() -> None:
    robot = rr.models.iiwa14()
    task = rr.tasks.ArmAngleTask()
    qs = _in_limits(robot, np.random.default_rng(1), 20)
    for q in qs:
        T, phi = robot.fk(q), float(task.values(robot, q[None])[0])
        found = rr.ik_all(robot, T, arm_angle=phi)
        assert isinstance(found, IKSolutions) and 1 <= found.count <= 8
        assert np.min(np.abs(found.q - q).max(axis=1)) < 1e-8
        for x, inside in zip(found.q, found.within_limits):
            assert np.abs(robot.fk(x) - T).max() < 1e-10
            assert abs(float(task.values(robot, x[None])[0]) - phi) < 1e-8
            assert inside == bool(np.all((x >= robot.q_min) & (x <= robot.q_max)))
        assert found.residual.max() < 1e-10
    batch = rr.ik_all(robot, np.array([robot.fk(q) for q in qs]), arm_angle=0.2)
    assert isinstance(batch, IKSolutionsBatch) and batch.q.shape == (20, 8, 7)


def test_ik_all_refuses_what_it_cannot_answer() -> None:
    panda = rr.models.panda()
    T = panda.fk(panda.neutral())
    with pytest.raises(InvalidParameterError, match="exactly one of q7"):
        rr.ik_all(panda, T)
    with pytest.raises(InvalidParameterError, match="exactly one of q7"):
        rr.ik_all(panda, T, q7=0.1, arm_angle=0.2)
    with pytest.raises(NotSRSError):
        rr.ik_all(panda, T, arm_angle=0.2)
    with pytest.raises(NonFiniteError, match="q7"):
        rr.ik_all(panda, T, q7=float("nan"))
    with pytest.raises(InvalidParameterError, match="parameter must be 'q7' or 'arm_angle'"):
        rr.self_motion(panda, T, parameter="q4")  # type: ignore[arg-type]
    with pytest.raises(NotSRSError):
        rr.self_motion(panda, T, parameter="arm_angle")
    motion = rr.self_motion(panda, T, parameter="q7")
    for bad in (0.0, float("nan"), -3.0):
        with pytest.raises((InvalidParameterError, NonFiniteError), match="per_radian"):
            motion.sample(bad)


def _inside(intervals: tuple, x: float, tol: float = 0.0) -> bool:
    return any(lo - tol <= x <= hi + tol for lo, hi in intervals)


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_self_motion_in_q7_against_dense_sampling(name: str) -> None:
    robot = rr.models.load(name)
    rng = np.random.default_rng(2)
    for q in _in_limits(robot, rng, 5):
        T = robot.fk(q)
        motion = rr.self_motion(robot, T, parameter="q7")
        original = rr.ik_all(robot, T, q7=q[6])
        hit = int(np.argmin(np.abs(original.q - q).max(axis=1)))
        assert _inside(motion.intervals[int(original.branch[hit])], q[6])
        # every end is where the branch appears or leaves (or a limit of q7)
        for b, arcs in enumerate(motion.intervals):
            for lo, hi in arcs:
                for end, outward in ((lo, -1.0), (hi, 1.0)):
                    here = rr.ik_all(robot, T, q7=end)
                    assert np.any((here.branch == b) & here.within_limits)
                    beyond = end + outward * 1e-6
                    if robot.q_min[6] < beyond < robot.q_max[6]:
                        there = rr.ik_all(robot, T, q7=beyond)
                        assert not np.any((there.branch == b) & there.within_limits)
        # a dense grid (another grid than the function's) agrees away from the ends
        grid = np.linspace(robot.q_min[6], robot.q_max[6], 3001)
        found = rr.ik_all(robot, np.broadcast_to(T, (len(grid), 4, 4)), q7=grid)
        for b in range(8):
            present = np.any((found.branch == b) & found.within_limits, axis=1)
            for x, p in zip(grid, present):
                if not _inside(motion.intervals[b], x, 1e-3) or _inside(motion.intervals[b], x):
                    assert p == _inside(motion.intervals[b], x, 10 * END_TOL), (b, x)


def test_the_two_parametrisations_agree_on_an_srs_arm() -> None:
    """Configurations sampled along the arm-angle self-motion (Shimizu's closed form) all
    lie, by their q7, inside the q7 self-motion (the other closed form), and conversely."""
    robot = rr.models.iiwa14()
    task = rr.tasks.ArmAngleTask()
    for q in _in_limits(robot, np.random.default_rng(3), 4):
        T = robot.fk(q)
        by_angle = rr.self_motion(robot, T)
        by_q7 = rr.self_motion(robot, T, parameter="q7")
        assert by_angle.parameter == "arm_angle" and by_q7.parameter == "q7"
        union = tuple(arc for arcs in by_q7.intervals for arc in arcs)
        values, configs, _ = by_angle.sample(10)
        assert len(values) > 0
        for x in configs:
            assert np.abs(robot.fk(x) - T).max() < 1e-10
            assert _inside(union, float(x[6]), 1e-9)
        _, configs, _ = by_q7.sample(10)
        union = tuple(arc for arcs in by_angle.intervals for arc in arcs)
        for x in configs:
            phi = float(task.values(robot, x[None])[0])
            assert _inside(union, phi, 1e-9) or _inside(union, phi + 2 * np.pi, 1e-9)


def test_compiled_arm_angle_form_equals_the_numpy_one() -> None:
    """One pose at an arm angle (the compiled closed form, rr.ik_all's single-pose path)
    against the batch form (srs.py on NumPy): the same solutions, branches and limit
    tests; every solution meets the pose by Pinocchio's FK; the plain-Python twin of the
    kernel agrees."""
    import pinocchio as pin

    from redres.ik import _analytic_codes as codes
    from redres.ik import analytic
    from redres.ik.solutions import _srs, at_arm_angle

    robot = rr.models.iiwa14()
    task = rr.tasks.ArmAngleTask()
    rng = np.random.default_rng(4)
    qs = _in_limits(robot, rng, 200)
    T = np.array([robot.fk(q) for q in qs])
    phis = task.values(robot, qs) + rng.uniform(-0.5, 0.5, len(qs))  # not only the own angle
    batch = rr.ik_all(robot, T, arm_angle=phis)
    data = robot.model.createData()
    plain = analytic.KERNELS.module("_arm_angle_kernels", plain=True)
    srs = _srs(robot, None)
    for i in range(len(qs)):
        one = at_arm_angle(robot, T[i], arm_angle=float(phis[i]))
        k = one.count
        assert k == batch.count[i] and np.isnan(one.q7)
        # near a spherical group's singularity (sin q2 or sin q6 small) the two orders
        # of rounding part as eps / sin: compare to that
        weak = np.minimum(np.abs(np.sin(one.q[:, 1])), np.abs(np.sin(one.q[:, 5])))
        assert (np.abs(one.q - batch.q[i, :k]).max(axis=1) < 1e-13 / weak).all()
        assert np.array_equal(one.branch, batch.branch[i, :k])
        assert np.array_equal(one.within_limits, batch.within_limits[i, :k])
        assert (one.residual < 1e-10).all()  # the chain's FK, on first access
        for x in one.q:
            pin.framesForwardKinematics(robot.model, data, x)
            M = data.oMf[robot.frame_id(None)]
            assert np.linalg.norm(M.translation - T[i, :3, 3]) < 1e-10
            assert np.linalg.norm(pin.log3(T[i, :3, :3].T @ M.rotation)) < 1e-10
        if i < 5:
            out = np.zeros((codes.N_ROWS, codes.N_VALUES))
            code = plain.solve_arm_angle(srs.constants, T[i], float(phis[i]), out)
            assert code & codes.COUNT_MASK == k
            assert (np.abs(out[:k, :7] - one.q).max(axis=1) < 1e-13 / weak).all()
    with pytest.raises(NonFiniteError, match="arm_angle"):
        at_arm_angle(robot, T[0], arm_angle=float("inf"))
    far = T[0].copy()
    far[:3, 3] += 5.0
    assert at_arm_angle(robot, far, arm_angle=0.0).count == 0
