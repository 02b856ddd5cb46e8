"""SNS under hard limits: bounds never broken, tasks exact when feasible, largest scale else.

Oracles: NumPy's pseudo-inverse, the gradient-projection formula, a brute-force line search
over the task scale (the feasibility of one scale is an interval test in the one-dimensional
null space of a 6 x 7 Jacobian), exact enumeration of the vertices of the (scale,
null-space) polygon, and the limits themselves (the simplex alone against SciPy's HiGHS:
test_lp.py).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import redres as rr
from redres.errors import NonFiniteError, ShapeError
from redres.objectives import JointLimitObjective
from redres.resolution import (
    JointLimits,
    PseudoInverseScheme,
    SNSScheme,
    run_violation,
    step_violation,
)
from redres.scenarios.spec import builtin
from redres.testing import random_limit_states, step_from_states

DT = 1e-3
STEPS = 10_000
PAIRS = np.array(list(itertools.combinations(range(16), 2))).T


def scale_oracle(J: np.ndarray, xd: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple:
    """Brute force for a 6 x 7 J: q̇ = s p + z v (p = J⁺ẋ, v spans null(J)).

    A scale s is feasible when the z-intervals of the seven joints intersect, i.e. when
    ``gap(s) = max_i z_lo,i(s) − min_i z_hi,i(s) ≤ 0``; ``gap`` is convex (a max of linear
    functions minus a min of linear functions), so its feasible set is an interval. The
    line search finds its most feasible point, then the right end of the feasible interval,
    each by eight successively finer grids of 101 scales. Independently, every vertex of
    the polygon ``{(s, z)}`` is enumerated.

    Returns ``(gap, largest s by line search, largest s by vertex enumeration)``, the last
    two None when no s in [0, 1] is feasible.
    """
    p = np.linalg.pinv(J) @ xd
    v = np.linalg.svd(J)[2][-1]
    assert np.all(v != 0.0)

    # z ≥ (c_lo − s p)/v and z ≤ (c_hi − s p)/v, with c_lo/c_hi the bound of each side
    c_lo, c_hi = np.where(v > 0, lo, hi) / v, np.where(v > 0, hi, lo) / v
    slope = -p / v

    def gaps(s: np.ndarray) -> np.ndarray:
        s = s[:, None]
        return (c_lo + s * slope).max(axis=1) - (c_hi + s * slope).min(axis=1)

    def gap(s: float) -> float:
        return float(gaps(np.array([s]))[0])

    a, b = 0.0, 1.0  # zoom in on the minimum of gap: 8 grids of 101 points
    for _ in range(8):
        grid = np.linspace(a, b, 101)
        k = int(np.argmin(gaps(grid)))
        a, b = grid[max(k - 1, 0)], grid[min(k + 1, 100)]
    line = None
    s_best = min((grid[k], 0.0, 1.0), key=gap)  # the ends too: {0} may be all
    if gap(s_best) <= 1e-12:
        if gap(1.0) <= 1e-12:
            line = 1.0
        else:  # zoom in on the right end of {gap <= 0}
            a, b = s_best, 1.0
            for _ in range(8):
                grid = np.linspace(a, b, 101)
                k = int(np.flatnonzero(gaps(grid) <= 1e-12)[-1])
                a, b = grid[k], grid[k + 1]
            line = a
    # vertices of {(s, z)}: pairs of lines s p_i + z v_i = lo_i | hi_i, s = 0, s = 1
    a_ = np.concatenate([p, p, [1.0, 1.0]])
    b_ = np.concatenate([v, v, [0.0, 0.0]])
    c_ = np.concatenate([lo, hi, [0.0, 1.0]])
    i, j = PAIRS
    det = a_[i] * b_[j] - a_[j] * b_[i]
    keep = np.abs(det) >= 1e-14
    i, j, det = i[keep], j[keep], det[keep]
    s = (c_[i] * b_[j] - c_[j] * b_[i]) / det
    z = (a_[i] * c_[j] - a_[j] * c_[i]) / det
    qd = s[:, None] * p + z[:, None] * v
    ok = (s >= -1e-9) & (s <= 1 + 1e-9)
    ok &= np.all(qd >= lo - 1e-9, axis=1) & np.all(qd <= hi + 1e-9, axis=1)
    vertex = float(s[ok].max()) if ok.any() else None
    return gap, line, vertex


@pytest.fixture(scope="module")
def panda_steps() -> tuple[rr.Robot, JointLimits, list]:
    robot = rr.models.panda()
    states = random_limit_states(robot, np.random.default_rng(8), STEPS)
    scheme = SNSScheme(dt=DT)
    results = step_from_states(scheme, robot, states)
    return robot, JointLimits.from_robot(robot), list(zip(states, results))


def test_no_bound_is_ever_violated(panda_steps: tuple) -> None:
    _, lim, steps = panda_steps
    worst = max(step_violation(lim, q, r.qd, prev, DT).worst for (q, prev, _, _), r in steps)
    assert worst <= 1e-9


def test_feasible_tasks_are_executed_exactly(panda_steps: tuple) -> None:
    _, _, steps = panda_steps
    count = 0
    for (_, _, J, xd), r in steps:
        if r.feasible:
            count += 1
            assert r.details.scale == 1.0
            assert np.linalg.norm(J @ r.qd - xd) <= 1e-9 * (1 + np.linalg.norm(xd))
    assert count >= 1000  # the sample really exercises the feasible case


def test_infeasible_tasks_keep_their_direction_at_the_largest_scale(panda_steps: tuple) -> None:
    """Against the brute-force line search and the vertex enumeration, every step: when
    SNS scales, s is the largest feasible scale; when it reports no feasible scale, none
    exists; and when it reports feasible, s = 1 is feasible."""
    _, _, steps = panda_steps
    methods: dict[str, int] = {}
    for (_, _, J, xd), r in steps:
        method = r.details.method
        methods[method] = methods.get(method, 0) + 1
        lo, hi = r.details.bounds
        gap, line, vertex = scale_oracle(J, xd, lo, hi)
        s = r.details.scale
        if method == "nearest":
            assert line is None and vertex is None
            continue
        assert line is not None and vertex is not None
        assert abs(s - vertex) <= 1e-9 and abs(s - line) <= 1e-7
        assert np.linalg.norm(J @ r.qd - s * xd) <= 1e-9 * (1 + np.linalg.norm(xd))
        if s < 1.0:
            assert gap(s + 1e-8) > 0.0
    assert methods.get("sns-scaled", 0) >= 100 and methods.get("lp", 0) >= 100


def well_conditioned(robot: rr.Robot, rng: np.random.Generator) -> tuple:
    """A configuration 0.2 rad inside the limits where σ_min(J) > 0.05, and J there."""
    while True:
        q = robot.random_configuration(rng, margin=0.2)
        J = robot.jacobian(q)
        if np.linalg.svd(J, compute_uv=False)[-1] > 0.05:
            return q, J


def test_without_active_bounds_sns_is_the_pseudo_inverse(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    scheme = SNSScheme(dt=DT, qdd_max=np.inf)  # no acceleration limit: a wide box
    for _ in range(20):
        q, J = well_conditioned(robot, rng)
        xd = rng.normal(size=6) * 0.02
        scheme.reset()
        r = scheme.step(robot, q, J, xd)
        assert r.details.method == "sns" and not r.binding
        assert np.allclose(r.qd, np.linalg.pinv(J) @ xd, atol=1e-12)
        assert np.allclose(r.null_term, 0.0, atol=1e-12)
        s = np.linalg.svd(J, compute_uv=False)
        assert r.info.sigma_min == pytest.approx(s[-1], rel=1e-8)
        assert r.info.sigma_max == pytest.approx(s[0], rel=1e-12) and r.info.rank == 6


def test_with_objectives_and_no_active_bound_it_is_gradient_projection(
    rng: np.random.Generator,
) -> None:
    robot = rr.models.panda()
    objective = JointLimitObjective()
    scheme = SNSScheme(dt=DT, objectives=[objective], k_null=2.0, qdd_max=np.inf)
    for _ in range(10):
        q, J = well_conditioned(robot, rng)
        xd = rng.normal(size=6) * 0.02
        r = scheme.step(robot, q, J, xd)
        Jp = np.linalg.pinv(J)
        expected = Jp @ xd - 2.0 * (np.eye(7) - Jp @ J) @ objective.gradient(robot, q)
        assert r.details.method == "sns"
        assert np.allclose(r.qd, expected, atol=1e-10)
        assert np.allclose(r.null_term, r.qd - Jp @ (J @ r.qd), atol=1e-12)


def test_saturated_joint_sits_on_its_bound_and_the_task_is_still_met(
    rng: np.random.Generator,
) -> None:
    """Joint 5 1 µrad from its upper limit, the minimum-norm solution pushing it there: SNS
    saturates it at the position bound and meets the task with the other joints."""
    robot = rr.models.panda()
    for _ in range(1000):  # the other six joints must be able to do the task alone
        q, _ = well_conditioned(robot, rng)
        q[4] = robot.q_max[4] - 1e-6
        J = robot.jacobian(q)
        if np.linalg.svd(np.delete(J, 4, axis=1), compute_uv=False)[-1] > 0.02:
            break
    xd = J @ np.eye(7)[4] * 0.05  # the task that joint 5 alone would do at 0.05 rad/s
    assert (np.linalg.pinv(J) @ xd)[4] > 1e-3  # the minimum-norm solution crosses the limit
    scheme = SNSScheme(dt=DT, qdd_max=np.inf)
    r = scheme.step(robot, q, J, xd)
    assert r.feasible and np.allclose(J @ r.qd, xd, atol=1e-12)
    assert r.qd[4] == pytest.approx(1e-3, rel=1e-9)  # 1 µrad in one 1 ms step
    assert (4, "upper", "position") in [b[:3] for b in r.binding]


def test_state_and_reset() -> None:
    robot = rr.models.panda()
    q = robot.neutral()
    J, xd = robot.jacobian(q), np.array([0.2, 0, 0, 0, 0, 0])
    scheme = SNSScheme(dt=DT)
    first = scheme.step(robot, q, J, xd)
    assert np.all(np.abs(first.qd) <= robot.qdd_max * DT + 1e-15)  # from rest
    second = scheme.step(robot, q, J, xd)
    assert np.all(np.abs(second.qd - first.qd) <= robot.qdd_max * DT + 1e-12)
    assert second.details.scale > first.details.scale  # accelerating toward the task
    scheme.reset()
    assert scheme.qd_prev is None
    assert np.allclose(scheme.step(robot, q, J, xd).qd, first.qd, atol=1e-15)


def test_singular_jacobian_gives_finite_bounded_output() -> None:
    robot = rr.models.planar([1.0, 1.0, 1.0])
    q = np.zeros(3)  # stretched: no velocity along x
    J = robot.jacobian(q)[[0, 1, 5]]
    scheme = SNSScheme(dt=DT, qd_max=1.0, qdd_max=50.0)
    r = scheme.step(robot, q, J, np.array([0.3, 0.0, 0.0]))
    assert np.all(np.isfinite(r.qd)) and r.details.scale == 0.0
    assert r.info.rank == 2 and not r.info.full_rank
    assert step_violation(scheme.limits(robot), q, r.qd, None, DT).worst == 0.0


def test_bad_input() -> None:
    robot = rr.models.panda()
    q = robot.neutral()
    J = robot.jacobian(q)
    with pytest.raises(NonFiniteError, match="xd"):
        SNSScheme().step(robot, q, J, np.array([np.nan, 0, 0, 0, 0, 0]))
    with pytest.raises(ShapeError, match="J"):
        SNSScheme().step(robot, q, J[:, :6], np.zeros(6))
    with pytest.raises(rr.errors.InvalidParameterError):
        SNSScheme(dt=0.0)


def test_panda_circle_keeps_every_limit_and_tracks() -> None:
    """The scenario that drives the pseudo-inverse 0.23 rad past joint 2's limit: 10 s at
    1 kHz with SNS breaks no limit and keeps the TCP within a few millimetres."""
    scenario = builtin("panda_joint_limit_circle")
    robot = scenario.robot
    lim = JointLimits.from_robot(robot)
    runs = {}
    for scheme in (PseudoInverseScheme(), SNSScheme(dt=DT)):
        runs[scheme.name] = rr.control.run(robot, scenario.task(), scenario.trajectory, scheme,
                                           q0=scenario.q0, dt=DT)  # fmt: skip
    pinv, sns = runs["pinv"], runs["sns"]
    assert sns.steps == 10_000
    assert run_violation(lim, pinv.q, pinv.qd, DT).position > 0.1  # the scenario's point
    assert run_violation(lim, sns.q, sns.qd, DT).worst <= 1e-9
    summary = sns.summary()
    assert summary["min_joint_limit_margin_rad"] >= -1e-12
    assert summary["max_position_error_m"] <= 0.01
    assert summary["rms_position_error_m"] <= 1e-3
    assert sns.orientation_error.max() <= 1e-3


def _met(robot: rr.Robot, scheme: SNSScheme, q, qd_prev, J, xd) -> tuple:
    """SNS's step from ``qd_prev``: ``(relative residual, method, box violation)``."""
    scheme.qd_prev = np.array(qd_prev, dtype=float)
    result = scheme.step(robot, np.asarray(q, dtype=float), J, xd)
    lo, hi = result.details.bounds
    outside = max(float(np.max(result.qd - hi)), float(np.max(lo - result.qd)), 0.0)
    residual = float(np.linalg.norm(J @ result.qd - xd) / np.linalg.norm(xd))
    return residual, result.details.method, outside


def test_feasible_task_at_an_exactly_singular_jacobian_is_met() -> None:
    """Issue 18, item 3: the planar 3R folded at its limit (rank 2), a task in the range of
    J that a box velocity meets exactly (DAQP and HiGHS do): SNS returned scale 0 and a
    residual of 0.028 of 0.036, as ``J Jᵀ`` has no Cholesky factor. The saturation now
    solves with a ridge-regularised factor, refined to the least-squares solution."""
    robot = rr.models.planar()
    q = [np.pi, -np.pi, np.pi - 1e-9]
    J = robot.jacobian(np.array(q))[[0, 1, 5]]
    assert np.linalg.svd(J, compute_uv=False)[-1] < 1e-15  # exactly singular
    xd = np.array([2.53e-11, 0.0256468, -0.0253003])
    scheme = SNSScheme(1e-3, qd_max=3, qdd_max=20)
    residual, method, outside = _met(robot, scheme, q, [0.0073213, -0.0147677, -0.0257017],
                                     J, xd)  # fmt: skip
    assert residual < 1e-12 and method == "sns" and outside <= 1e-12
