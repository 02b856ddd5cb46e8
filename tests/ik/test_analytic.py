"""Analytic IK at a given q7 (redres.ik.analytic): every solution checked by Pinocchio's
FK, the original configuration recovered on 10,000 random poses per arm, the singular
and boundary cases flagged without NaN, and the solution counts checked against an
independent numerical enumeration (Newton from many seeds on joints 1-6)."""

from __future__ import annotations

import math
import os

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres.ik import _analytic_codes as codes
from redres.ik import analytic
from redres.ik._analytic_codes import AnalyticFlag
from redres.ik.analytic import NotAnalyticError, analytic_arm, at_q7, at_q7_batch
from redres.models.franka import FR3

TOL = 1e-10  # m, rad: FK of every solution away from singular sets
SAME = 1e-6  # rad: a solution equal to the original configuration


def _fr3() -> rr.Robot:
    """The Panda's geometry under the FR3's joint limits (redres.models.franka)."""
    model = pin.Model(rr.models.panda().model)
    model.lowerPositionLimit = np.array(FR3.q_min)
    model.upperPositionLimit = np.array(FR3.q_max)
    return rr.Robot(model, tip="tcp", name="fr3")


def _file_iiwa14() -> rr.Robot:
    """A file arm, detected from its axes: MuJoCo Menagerie's iiwa14 MJCF (not DH)."""
    return rr.models.menagerie("iiwa14")


ARMS = {"panda": rr.models.panda, "fr3": _fr3, "iiwa14": rr.models.iiwa14, "srs7": rr.models.srs7,
        "iiwa14 file": _file_iiwa14}  # fmt: skip


@pytest.fixture(scope="module", params=sorted(ARMS))
def arm(request: pytest.FixtureRequest) -> rr.Robot:
    return ARMS[request.param]()


def _wrapped(q: np.ndarray) -> np.ndarray:
    return np.asarray((q + np.pi) % (2 * np.pi) - np.pi)


def _pin_error(robot: rr.Robot, q: np.ndarray, T: np.ndarray) -> tuple[float, float]:
    """Position (m) and rotation (rad) error of Pinocchio's FK at ``q`` against ``T``."""
    data = robot.model.createData()
    fid = robot.frame_id(None)
    pin.framesForwardKinematics(robot.model, data, q)
    M = data.oMf[fid]
    rotation = float(np.linalg.norm(pin.log3(T[:3, :3].T @ M.rotation)))
    return float(np.linalg.norm(M.translation - T[:3, 3])), rotation


def _poses(robot: rr.Robot, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = rng.uniform(robot.q_min, robot.q_max, size=(count, robot.n))
    return q, np.array([robot.fk(x) for x in q])


def test_every_solution_meets_the_pose_by_pinocchio(arm: rr.Robot) -> None:
    q, T = _poses(arm, 150, 1)
    checked = 0
    for x, pose in zip(q, T):
        found = at_q7(arm, pose, q7=float(x[6]))
        assert found.flags == 0  # random poses: away from the singular sets
        assert 1 <= len(found) <= 8 and np.isfinite(found.q).all()
        assert len(set(found.branch.tolist())) == len(found)
        for sol, pos, rot in zip(found.q, found.position_error, found.rotation_error):
            assert sol[6] == x[6]
            p_err, r_err = _pin_error(arm, sol, pose)
            assert p_err < TOL and r_err < TOL
            assert abs(pos - p_err) < 1e-12 and abs(rot - r_err) < 1e-12  # the kernel's own FK
            checked += 1
    assert checked > 150


def test_the_original_configuration_is_found_on_10000_poses(arm: rr.Robot) -> None:
    q, _ = _poses(arm, 10_000, 2)
    T = rr.batch.fk(arm, q)
    found = at_q7_batch(arm, T, q[:, 6])
    assert (found.count >= 1).all() and np.isfinite(found.q).all()
    rows = np.arange(8)[None, :] < found.count[:, None]
    assert (found.residual[rows] < TOL).all()
    near = np.abs(_wrapped(found.q - q[:, None, :])).max(axis=2)
    near = np.where(rows & found.within_limits, near, np.inf).min(axis=1)
    for i in np.flatnonzero(near >= SAME):  # near a singular set (a stretched elbow): the
        # problem itself is ill-conditioned, a solution's error about eps / sigma_min
        sigma = np.linalg.svd(arm.jacobian(q[i])[:, :6], compute_uv=False)[-1]
        assert near[i] < max(SAME, 1e-14 / sigma), (i, near[i], sigma)
    assert (near < SAME).mean() > 0.999
    mask = found.within_limits[rows]  # every in-limit solution really is within the limits
    solutions = found.q[rows][mask]
    assert ((solutions >= arm.q_min - 1e-12) & (solutions <= arm.q_max + 1e-12)).all()


def test_batch_equals_single_calls_bit_for_bit_at_any_thread_count() -> None:
    robot = rr.models.panda()
    q, T = _poses(robot, 64, 3)
    from redres import _compile

    previous = _compile.threads(1)
    try:
        one = at_q7_batch(robot, T, q[:, 6])
    finally:
        _compile.threads(previous)
    many = at_q7_batch(robot, T, q[:, 6])
    for field in ("q", "branch", "within_limits", "position_error", "count", "flags"):
        assert np.array_equal(getattr(one, field), getattr(many, field))
    for i in range(len(q)):
        single = at_q7(robot, T[i], q7=float(q[i, 6]))
        k = len(single)
        assert k == one.count[i]
        assert np.array_equal(single.q, one.q[i, :k])
        assert np.array_equal(single.branch, one.branch[i, :k])
        # the single call's FK errors (on first access) are the batch kernel's
        assert np.array_equal(single.position_error, one.position_error[i, :k])
        assert np.array_equal(single.rotation_error, one.rotation_error[i, :k])
    assert (one.branch[np.arange(8)[None, :] >= one.count[:, None]] == -1).all()


def test_batch_without_residuals_gives_the_same_solutions_at_any_thread_count() -> None:
    """``residuals=False`` skips the FK errors only: every other field is the one with
    them, bit for bit, on one thread and on all; the errors are NaN on the solutions and
    0 in the padding."""
    robot = rr.models.panda()
    q, T = _poses(robot, 64, 5)
    from redres import _compile

    full = at_q7_batch(robot, T, q[:, 6])
    previous = _compile.threads(1)
    try:
        one = at_q7_batch(robot, T, q[:, 6], residuals=False)
    finally:
        _compile.threads(previous)
    many = at_q7_batch(robot, T, q[:, 6], residuals=False)
    for field in ("q", "branch", "within_limits", "solution_flags", "count", "flags"):
        assert np.array_equal(getattr(one, field), getattr(full, field))
        assert np.array_equal(getattr(many, field), getattr(full, field))
    solution = one.branch >= 0
    for field in ("position_error", "rotation_error", "residual"):
        value = getattr(many, field)
        assert np.isnan(value[solution]).all() and (value[~solution] == 0.0).all()


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_plain_python_twin_gives_the_same_solutions(name: str) -> None:
    robot = ARMS[name]()
    arm = analytic_arm(robot)
    plain = analytic.KERNELS.module(plain=True)
    residuals = analytic.KERNELS.module("_residual_kernels", plain=True)
    q, T = _poses(robot, 5, 7)
    for x, pose in zip(q, T):
        ref = at_q7(robot, pose, q7=float(x[6]))
        out = np.zeros((codes.N_ROWS, codes.N_VALUES))
        code = plain.solve_pose(arm.arm, pose, float(x[6]), out)
        count = code & codes.COUNT_MASK
        assert (count, code >> codes.FLAG_SHIFT) == (len(ref), int(ref.flags))
        residuals.errors(arm.links, arm.axes, arm.kinds, out, count)
        assert np.allclose(out[:count, :7], ref.q, atol=1e-12, rtol=0.0)
        assert np.array_equal(out[:count, codes.BRANCH], ref.branch)
        assert np.allclose(out[:count, codes.POSITION_ERROR], ref.position_error, atol=1e-14)


@pytest.mark.parametrize("name", sorted(ARMS))
def test_the_turned_shoulder_solution_equals_the_general_one(name: str) -> None:
    """Where the shoulder's axes allow it (slot TWIN), the second shoulder solution is
    the first turned; the general subproblem 2 (TWIN off) gives the same solutions."""
    robot = ARMS[name]()
    arm = analytic_arm(robot)
    assert arm.arm[codes.TWIN] == 1.0  # all four arms: k1 ⊥ k2, k3 = ±k1
    general = arm.arm.copy()
    general[codes.TWIN] = 0.0
    module = analytic.KERNELS.module()
    q, T = _poses(robot, 50, 8)
    for x, pose in zip(q, T):
        ref = at_q7(robot, pose, q7=float(x[6]))
        out = np.zeros((codes.N_ROWS, codes.N_VALUES))
        code = module.solve_pose(general, pose, float(x[6]), out)
        assert code & codes.COUNT_MASK == len(ref)
        assert np.abs(_wrapped(out[: len(ref), :7] - ref.q)).max() < 1e-12
        assert np.array_equal(out[: len(ref), codes.BRANCH], ref.branch)


# ---------------------------------------------------------------------- special cases


def _check_finite(found: analytic.IKSolutions) -> None:
    for value in (found.q, found.position_error, found.rotation_error):
        assert np.isfinite(value).all()


def test_shoulder_singularity_is_flagged() -> None:
    robot = rr.models.panda()
    q = np.array([0.4, 0.0, -0.3, -1.8, 0.2, 1.9, 0.5])  # q2 = 0: axes 1 and 3 aligned
    found = at_q7(robot, robot.fk(q), q7=q[6])
    _check_finite(found)
    assert found.flags & AnalyticFlag.SHOULDER_SINGULAR
    singular = (found.solution_flags & AnalyticFlag.SHOULDER_SINGULAR) != 0
    assert singular.any() and (found.residual < TOL).all()
    for sol in found.q[singular]:  # q1 + q3 is what is fixed; it is split evenly
        assert sol[0] + sol[2] == pytest.approx(q[0] + q[2], abs=1e-9)
        assert sol[0] == pytest.approx(sol[2], abs=1e-9)


def test_stretched_elbow_is_flagged() -> None:
    robot = rr.models.iiwa14()
    q4 = analytic_arm(robot).arm[codes.DELTA]  # the extreme of |W − S| in q4: a double root
    q = np.array([0.3, 0.5, -0.2, q4, 0.4, -0.6, 0.7])
    found = at_q7(robot, robot.fk(q), q7=q[6])
    _check_finite(found)
    assert found.flags & AnalyticFlag.ELBOW_STRETCHED
    assert len(found) <= 4 and (found.residual < 1e-8).all()


def test_merged_branches_are_flagged() -> None:
    from scipy.optimize import brentq

    robot = rr.models.panda()
    q = np.array([0.2, 0.4, 0.1, -1.5, 0.0, 1.7, 0.3])
    data = robot.model.createData()

    def tangency(q5: float) -> float:  # z5 in the plane of S→W and z6: a double root in φ
        x = q.copy()
        x[4] = q5
        pin.framesForwardKinematics(robot.model, data, x)
        frame = {name: data.oMf[robot.frame_id(name)] for name in ("shoulder", "wrist")}
        z5 = data.oMi[5].rotation[:, 2]
        z6 = data.oMi[6].rotation[:, 2]
        w = frame["wrist"].translation - frame["shoulder"].translation
        return float(np.cross(z5, w) @ z6)

    grid = np.linspace(-2.8, 2.8, 57)
    values = [tangency(g) for g in grid]
    i = next(i for i in range(len(grid) - 1) if values[i] * values[i + 1] < 0)
    q[4] = brentq(tangency, grid[i], grid[i + 1], xtol=1e-15)
    found = at_q7(robot, robot.fk(q), q7=q[6])
    _check_finite(found)
    assert found.flags & AnalyticFlag.BRANCHES_MERGED
    assert (found.residual < 1e-8).all()
    assert np.abs(_wrapped(found.q - q)).max(axis=1).min() < 1e-6


def test_unreachable_pose_gives_no_solution_and_no_nan() -> None:
    robot = rr.models.panda()
    T = robot.fk(robot.neutral())
    T[:3, 3] += [3.0, 0.0, 0.0]
    found = at_q7(robot, T, q7=0.0)
    assert len(found) == 0 and found.q.shape == (0, 7)
    assert found.flags == AnalyticFlag.UNREACHABLE
    batch = at_q7_batch(robot, np.stack((T, robot.fk(robot.neutral()))), [0.0, robot.neutral()[6]])
    assert batch.count.tolist()[0] == 0 and batch.count[1] >= 1
    assert batch.flags[0] == AnalyticFlag.UNREACHABLE and np.isfinite(batch.q).all()


def test_bad_input_is_refused_by_name() -> None:
    robot = rr.models.panda()
    T = robot.fk(robot.neutral())
    bad = T.copy()
    bad[0, 0] = np.nan
    with pytest.raises(rr.errors.NonFiniteError):
        at_q7(robot, bad, q7=0.0)
    with pytest.raises(rr.errors.NonFiniteError, match="q7"):
        at_q7(robot, T, q7=math.inf)
    with pytest.raises(rr.errors.InvalidParameterError, match="q7 is required"):
        at_q7(robot, T, q7=None)  # type: ignore[arg-type]
    with pytest.raises(rr.errors.ShapeError):
        at_q7(robot, 2.0 * T, q7=0.0)
    with pytest.raises(rr.errors.NonFiniteError, match=r"T\[1\]"):
        at_q7_batch(robot, np.stack((T, bad)), 0.0)
    # the same solutions from a list, a read-only array and a numpy scalar q7
    ref = at_q7(robot, T, q7=0.1)
    frozen = T.copy()
    frozen.flags.writeable = False
    for pose, q7 in ((T.tolist(), 0.1), (frozen, np.float64(0.1)), (np.asfortranarray(T), 0.1)):
        assert np.array_equal(at_q7(robot, pose, q7=q7).q, ref.q)


def test_arms_without_the_structure_are_refused() -> None:
    import dataclasses

    from redres.models.panda import panda_links

    with pytest.raises(NotAnalyticError, match=r"7 revolute joints.*rr\.ik"):
        analytic_arm(rr.models.planar([1.0, 1.0, 1.0]))
    for joint, why in ((2, "axis 3 misses"), (5, "axes 5 and 6 do not meet")):
        links = panda_links()
        links[joint] = dataclasses.replace(links[joint], a=0.02)  # an offset axis
        with pytest.raises(NotAnalyticError, match=f"{why}.*0.02 m.*rr.ik"):
            analytic_arm(rr.Robot.from_dh(links, "modified"))
    assert issubclass(NotAnalyticError, ValueError)
    assert issubclass(NotAnalyticError, rr.errors.RedresError)


@pytest.mark.parametrize("name", ["panda", "fr3", "iiwa14", "xarm7"])
def test_shipped_menagerie_arms(name: str) -> None:
    robot = rr.models.menagerie(name)  # MJCF frames and axes, not DH: the same closed form
    q, T = _poses(robot, 100, 6)
    for x, pose in zip(q, T):
        found = at_q7(robot, pose, q7=float(x[6]))
        assert (found.residual < TOL).all()
        assert np.abs(_wrapped(found.q - x)).max(axis=1).min() < SAME
        for sol in found.q[:2]:
            assert max(_pin_error(robot, sol, pose)) < TOL


# ---------------------------------------------------------------------- enumeration


def _newton_enumeration(robot: rr.Robot, T: np.ndarray, q7: float, seeds: np.ndarray) -> list:
    """Distinct solutions (wrapped) of Newton's method on joints 1-6 from each seed."""
    chain = robot.chain(None)
    found: list[np.ndarray] = []
    for seed in seeds:
        q = np.append(seed, q7)
        for _ in range(60):
            state = chain.pose_error(q, T, validate=False)
            e = state.error
            if np.abs(e).max() < 1e-13:
                break
            J = state.jacobian[:, :6]
            step = np.linalg.lstsq(J, e, rcond=1e-12)[0]
            scale = min(1.0, 0.5 / max(np.abs(step).max(), 1e-300))
            q[:6] += scale * step
        if np.abs(chain.pose_error(q, T, validate=False).error).max() < 1e-10:
            w = _wrapped(q)
            if not any(np.abs(_wrapped(w - f)).max() < 1e-6 for f in found):
                found.append(w)
    return found


def _enumeration_agrees(robot: rr.Robot, poses: int, seeds: int, seed: int) -> float:
    rng = np.random.default_rng(seed)
    q, T = _poses(robot, poses, seed)
    complete = 0
    for x, pose in zip(q, T):
        numerical = _newton_enumeration(robot, pose, x[6], rng.uniform(-np.pi, np.pi, (seeds, 6)))
        closed = _wrapped(at_q7(robot, pose, q7=x[6]).q)
        gaps = np.abs(_wrapped(closed[:, None] - closed[None])).max(axis=2)
        assert (gaps + np.eye(len(closed)) > 1e-6).all()  # distinct (each one is real: FK)
        for sol in numerical:  # nothing the closed form misses
            assert np.abs(_wrapped(closed - sol)).max(axis=1).min() < 1e-6
        complete += len(numerical) == len(closed)
    return complete / poses


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_solution_counts_match_a_numerical_enumeration(name: str) -> None:
    # Newton misses small basins at times (the Panda's, with 64 seeds, about one pose in
    # eight); what it finds the closed form must have, and all of it in most poses
    share = _enumeration_agrees(ARMS[name](), 25, 64, 4)
    assert share >= 0.8, share


@pytest.mark.skipif(os.environ.get("REDRES_SLOW") != "1", reason="slow: REDRES_SLOW=1 runs it")
@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_solution_counts_match_a_numerical_enumeration_500(name: str) -> None:
    share = _enumeration_agrees(ARMS[name](), 500, 128, 5)
    assert share >= 0.8, share


def test_root_arguments_decide_which_branches_exist() -> None:
    """``roots``: the elbow's argument is ``cos(q4 − δ)`` of the configuration that made the
    pose (not solved for: drawn), and at other values of ``q7`` a pair ``(b, b ^ 2)`` of
    elbow root ``i4`` exists exactly where its ``|y| < 1`` (away from ±1, where the roots
    merge or vanish); none where ``|x| > 1``."""
    robot = rr.models.panda()
    arm = analytic_arm(robot)
    q, T = _poses(robot, 200, 11)
    own = at_q7_batch(robot, T, q[:, 6], residuals=False)
    delta = arm.arm[codes.DELTA]
    np.testing.assert_allclose(own.roots[:, 0], np.cos(q[:, 3] - delta), rtol=0, atol=1e-9)
    rng = np.random.default_rng(12)
    q7 = rng.uniform(robot.q_min[6], robot.q_max[6], 200)
    found = at_q7_batch(robot, T, q7, residuals=False)
    x = found.roots[:, 0]
    exists = np.zeros((200, 8), dtype=bool)
    rows, slots = np.nonzero(found.branch >= 0)
    exists[rows, found.branch[rows, slots]] = True
    out_of_reach = np.abs(x) > 1.0 + 1e-6
    assert not exists[out_of_reach].any() and np.isnan(found.roots[out_of_reach, 1:]).all()
    checked = 0
    for i4 in (0, 1):
        y = found.roots[:, 1 + i4]
        clear = np.isfinite(y) & (np.abs(np.abs(y) - 1.0) > 1e-6)
        pair = exists[:, 4 * i4] & exists[:, 4 * i4 + 2]
        none = ~exists[:, 4 * i4 : 4 * i4 + 4].any(axis=1)
        assert (pair[clear] == (np.abs(y[clear]) < 1.0)).all()
        assert (none[clear] == (np.abs(y[clear]) > 1.0)).all()
        checked += int(clear.sum())
    assert checked > 200  # both roots seen, on both sides of ±1
