"""The QP scheme under hard limits: bounds never broken, tasks exact when feasible, KKT
optimality of both QPs, levels as a sequence of QPs, clear errors without a backend.

Oracles: NumPy's pseudo-inverse and the gradient-projection and task-priority formulas,
the Karush-Kuhn-Tucker conditions checked directly, SciPy's HiGHS for task feasibility,
a second backend (ProxQP) and the limits themselves.
"""

from __future__ import annotations

import re
import sys

import numpy as np
import pytest
from scipy.optimize import linprog

import redres as rr
from redres.errors import InvalidParameterError, MissingDependencyError, install_hint
from redres.objectives import JointLimitObjective
from redres.resolution import (
    JointLimits,
    QPScheme,
    SNSScheme,
    run_violation,
    step_violation,
)
from redres.scenarios.spec import builtin
from redres.tasks import PostureTask
from redres.testing import random_limit_states, step_from_states

DT = 1e-3
STEPS = 2000  # the full 10,000 run in benchmarks/hard_limits.py


def task_feasible(J: np.ndarray, xd: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """HiGHS: is there a q̇ in the box with J q̇ = ẋ (to 1e-9)?"""
    res = linprog(np.zeros(J.shape[1]), A_eq=J, b_eq=xd, bounds=list(zip(lo, hi)),
                  method="highs")  # fmt: skip
    return bool(res.status == 0 and np.allclose(J @ res.x, xd, atol=1e-9))


def kkt_residual(grad: np.ndarray, qd: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 A: np.ndarray | None = None) -> float:  # fmt: skip
    """Largest violation of the KKT conditions of ``min f s.t. A q̇ = b, lo ≤ q̇ ≤ hi`` at a
    feasible ``qd`` with ``∇f = grad``: ``grad = Aᵀλ − μ_lo + μ_hi`` (multiplier signs by the
    active side, zero off the bounds), λ by least squares on the free joints."""
    at_hi, at_lo = qd >= hi - 1e-9, qd <= lo + 1e-9
    free = ~(at_hi | at_lo)
    r = grad.copy()
    if A is not None and A.size:
        lam = np.linalg.lstsq(A[:, free].T, grad[free], rcond=None)[0] if free.any() else 0.0
        r = grad - A.T @ lam
    worst = float(np.abs(r[free]).max()) if free.any() else 0.0
    worst = max(worst, float(np.max(r[at_hi & ~at_lo], initial=0.0)))  # needs r ≤ 0
    worst = max(worst, float(np.max(-r[at_lo & ~at_hi], initial=0.0)))  # needs r ≥ 0
    return worst


@pytest.fixture(scope="module")
def panda_steps() -> tuple:
    robot = rr.models.panda()
    states = random_limit_states(robot, np.random.default_rng(11), STEPS)
    scheme = QPScheme(dt=DT)
    results = step_from_states(scheme, robot, states)
    return robot, JointLimits.from_robot(robot), list(zip(states, results))


def test_no_bound_is_ever_violated(panda_steps: tuple) -> None:
    _, lim, steps = panda_steps
    worst = max(step_violation(lim, q, r.qd, prev, DT).worst for (q, prev, _, _), r in steps)
    assert worst <= 1e-9


def test_feasible_tasks_are_executed_exactly_and_only_those(panda_steps: tuple) -> None:
    _, _, steps = panda_steps
    exact = 0
    for (_, _, J, xd), r in steps:
        lo, hi = r.details.bounds
        assert r.feasible == task_feasible(J, xd, lo, hi)
        if r.feasible:
            exact += 1
            assert np.linalg.norm(J @ r.qd - xd) <= 1e-9 * (1 + np.linalg.norm(xd))
        else:
            assert r.binding  # an infeasible answer always names its bounds
    assert 200 <= exact <= STEPS - 200  # both cases really exercised


def test_both_qps_are_optimal(panda_steps: tuple) -> None:
    """KKT: exact steps minimise ‖q̇‖ on {J q̇ = ẋ} ∩ box; the others minimise
    ‖J q̇ − ẋ‖² + λ²‖q̇‖² on the box."""
    _, _, steps = panda_steps
    lam2 = 1e-6
    for (_, _, J, xd), r in steps:
        lo, hi = r.details.bounds
        if r.feasible:
            assert kkt_residual(r.qd, r.qd, lo, hi, J) <= 1e-8
        else:
            grad = J.T @ (J @ r.qd - xd) + lam2 * r.qd
            assert kkt_residual(grad, r.qd, lo, hi) <= 1e-8


def test_proxqp_backend_agrees(panda_steps: tuple) -> None:
    """Same decisions and optima (ProxQP, an augmented-Lagrangian solver, reaches these
    ill-conditioned least-squares optima only to ~1e-4 relative; DAQP's is never worse,
    and the KKT test above certifies it)."""
    robot, _, steps = panda_steps
    scheme = QPScheme(dt=DT, solver="proxqp", solver_options={"eps_abs": 1e-10, "eps_rel": 0.0})
    for (q, prev, J, xd), r in steps[:60]:
        scheme.qd_prev = prev
        other = scheme.step(robot, q, J, xd)
        assert other.feasible == r.feasible
        if r.feasible:
            assert np.linalg.norm(r.qd) <= np.linalg.norm(other.qd) * (1 + 1e-6)
        else:
            mine, theirs = (np.sum((J @ x - xd) ** 2) + 1e-6 * np.sum(x**2)
                            for x in (r.qd, other.qd))  # fmt: skip
            assert mine <= theirs + 1e-12
            assert theirs <= mine * (1 + 1e-3) + 1e-12


def well_conditioned(robot: rr.Robot, rng: np.random.Generator) -> tuple:
    while True:
        q = robot.random_configuration(rng, margin=0.2)
        J = robot.jacobian(q)
        if np.linalg.svd(J, compute_uv=False)[-1] > 0.05:
            return q, J


def test_without_active_bounds_it_is_gradient_projection(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    objective = JointLimitObjective()
    plain = QPScheme(dt=DT, qdd_max=np.inf)
    secondary = QPScheme(dt=DT, qdd_max=np.inf, objectives=[objective], k_null=2.0)
    for _ in range(10):
        q, J = well_conditioned(robot, rng)
        xd = rng.normal(size=6) * 0.02
        Jp = np.linalg.pinv(J)
        r = plain.step(robot, q, J, xd)
        assert r.feasible and np.allclose(r.qd, Jp @ xd, atol=1e-10)
        r = secondary.step(robot, q, J, xd)
        expected = Jp @ xd - 2.0 * (np.eye(7) - Jp @ J) @ objective.gradient(robot, q)
        assert np.allclose(r.qd, expected, atol=1e-10)
        assert np.allclose(r.null_term, r.qd - Jp @ (J @ r.qd), atol=1e-12)
        s = np.linalg.svd(J, compute_uv=False)
        assert r.info.sigma_min == pytest.approx(s[-1], rel=1e-8) and r.info.rank == 6


def test_levels_are_a_sequence_of_qps(rng: np.random.Generator) -> None:
    """Level 2 (posture, 7 rows, one degree of freedom left) never disturbs level 1; without
    active bounds it is the task-priority least-squares solution (to the regularisation)."""
    robot = rr.models.panda()
    posture = PostureTask(robot.neutral())
    single = QPScheme(dt=DT, qdd_max=np.inf)
    levels = QPScheme(dt=DT, qdd_max=np.inf, levels=[posture], gain=5.0)
    for _ in range(10):
        q, J = well_conditioned(robot, rng)
        xd = rng.normal(size=6) * 0.02
        r = levels.step(robot, q, J, xd)
        assert np.allclose(J @ r.qd, J @ single.step(robot, q, J, xd).qd, atol=1e-10)
        x2 = 5.0 * (robot.neutral() - q)
        Jp = np.linalg.pinv(J)
        N = np.eye(7) - Jp @ J
        expected = Jp @ xd + np.linalg.pinv(N) @ (x2 - Jp @ xd)  # J2 = I
        if np.all(np.abs(expected) < 1.0):  # no bound active
            assert np.allclose(r.qd, expected, atol=1e-5)
            assert r.details.level_residuals[1] == pytest.approx(
                np.linalg.norm(expected - x2), rel=1e-4
            )


def test_infeasible_step_is_reported_not_raised() -> None:
    robot = rr.models.panda()
    q = robot.neutral()
    J = robot.jacobian(q)
    scheme = QPScheme(dt=DT)
    r = scheme.step(robot, q, J, np.array([1.0, 0, 0, 0, 0, 0]))  # from rest: impossible
    assert not r.feasible and r.details.residual > 0.5
    kinds = {b.kind for b in r.binding}
    assert kinds == {"acceleration"}
    assert np.all(np.abs(r.qd) <= robot.qdd_max * DT + 1e-15)


def test_singular_jacobian_gives_finite_bounded_output() -> None:
    robot = rr.models.planar([1.0, 1.0, 1.0])
    q = np.zeros(3)  # stretched: no velocity along x
    J = robot.jacobian(q)[[0, 1, 5]]
    scheme = QPScheme(dt=DT, qd_max=1.0, qdd_max=50.0)
    r = scheme.step(robot, q, J, np.array([0.3, 0.0, 0.0]))
    assert np.all(np.isfinite(r.qd)) and not r.feasible
    assert r.info.rank == 2 and not r.info.full_rank
    assert step_violation(scheme.limits(robot), q, r.qd, None, DT).worst == 0.0
    assert r.details.residual == pytest.approx(0.3, rel=1e-3)  # nothing moves along x


def test_task_weights_shift_the_least_violating_answer() -> None:
    robot = rr.models.panda()
    q = robot.neutral()
    J = robot.jacobian(q)
    xd = np.array([1.0, 0, 0, 0, 0, 1.0])
    default = QPScheme(dt=DT).step(robot, q, J, xd)
    weighted = QPScheme(dt=DT, task_weights=[1, 1, 1, 100, 100, 100]).step(robot, q, J, xd)
    rot = lambda r: np.linalg.norm((J @ r.qd - xd)[3:])  # noqa: E731
    assert rot(weighted) < rot(default)


def test_missing_backend_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    import qpsolvers

    monkeypatch.setattr(qpsolvers, "available_solvers", [])
    with pytest.raises(MissingDependencyError, match=re.escape(install_hint("qp"))):
        QPScheme()
    monkeypatch.setitem(sys.modules, "qpsolvers", None)  # import qpsolvers -> ImportError
    with pytest.raises(MissingDependencyError, match=re.escape(install_hint("qp"))):
        QPScheme()
    assert issubclass(MissingDependencyError, ImportError)


def test_bad_parameters() -> None:
    with pytest.raises(InvalidParameterError):
        QPScheme(damping=0.0)
    with pytest.raises(InvalidParameterError):
        QPScheme(task_weights=[1.0, -1.0])
    with pytest.raises(InvalidParameterError):
        QPScheme(levels=[[]])


def test_panda_circle_keeps_every_limit_and_tracks() -> None:
    scenario = builtin("panda_joint_limit_circle")
    robot = scenario.robot
    log = rr.control.run(robot, scenario.task(), scenario.trajectory, QPScheme(dt=DT),
                         q0=scenario.q0, dt=DT)  # fmt: skip
    assert log.steps == 10_000
    assert run_violation(JointLimits.from_robot(robot), log.q, log.qd, DT).worst <= 1e-9
    summary = log.summary()
    assert summary["min_joint_limit_margin_rad"] >= -1e-12
    assert summary["max_position_error_m"] <= 0.01
    assert summary["rms_position_error_m"] <= 1e-3


def test_warm_started_daqp_model_agrees_with_cold_daqp_solves(rng: np.random.Generator) -> None:
    """WarmQP through daqp.Model (warm active sets) and through daqp.solve (its fallback
    for DAQP without Model) give the same optimum on a sequence of related QPs."""
    daqp = pytest.importorskip("daqp")
    from types import SimpleNamespace

    from redres.resolution.hard_limits._solvers import WarmQP

    n, m = 7, 6
    sense = np.zeros(n + m, dtype=np.intc)
    sense[n:] = 5
    J = rng.normal(size=(m, n))
    xd = rng.normal(size=m)
    box = np.full(n, 1.0)
    first = {"H": np.eye(n), "f": np.zeros(n), "A": J, "bupper": np.r_[box, xd],
             "blower": np.r_[-box, xd], "sense": sense}  # fmt: skip
    warm = WarmQP(daqp, {"primal_tol": 1e-10}, **first)
    cold = WarmQP(SimpleNamespace(solve=daqp.solve), {"primal_tol": 1e-10}, **dict(first))
    assert warm._model is not None and cold._model is None
    solved = 0
    for _ in range(400):
        J = J + 0.05 * rng.normal(size=J.shape)
        xd = rng.uniform(0.05, 1.5) * rng.normal(size=m)
        hi = rng.uniform(0.2, 1.0, n)
        data = {"f": rng.normal(size=n), "A": J, "bupper": np.r_[hi, xd], "blower": np.r_[-hi, xd]}
        x_warm, flag_warm = warm.solve(**data)
        x_cold, flag_cold = cold.solve(**data)
        assert (flag_warm > 0) == (flag_cold > 0)
        if flag_warm > 0:
            solved += 1
            assert np.allclose(x_warm, x_cold, rtol=0, atol=1e-9)
            assert np.all(np.abs(x_warm) <= hi + 1e-9) and np.allclose(J @ x_warm, xd, atol=1e-9)
    assert 40 < solved < 360  # both feasible and infeasible problems were met


def test_a_failed_resize_leaves_the_scheme_usable(rng: np.random.Generator) -> None:
    """task_weights of the wrong size for a new task: a clear error, and the scheme goes on
    with the old size exactly as a fresh one would (nothing half-rebuilt)."""
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.3)
    J, xd = robot.jacobian(q), rng.uniform(-0.1, 0.1, 6)
    used, fresh = QPScheme(dt=DT, task_weights=np.ones(6)), QPScheme(dt=DT, task_weights=np.ones(6))
    used.step(robot, q, J, xd)
    with pytest.raises(rr.errors.ShapeError, match="task_weights"):
        used.step(robot, q, J[:3], xd[:3])
    used.qd_prev = fresh.qd_prev = None
    for _ in range(3):
        a, b = used.step(robot, q, J, xd), fresh.step(robot, q, J, xd)
        np.testing.assert_array_equal(a.qd, b.qd)


def test_step_checks_its_inputs(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.3)
    J, xd = robot.jacobian(q), rng.uniform(-0.1, 0.1, 6)
    for make in (QPScheme, SNSScheme):
        a, b = make(dt=DT), make(dt=DT)
        qd = a.step(robot, q, np.asfortranarray(J), xd.tolist()).qd
        np.testing.assert_allclose(qd, b.step(robot, q, J, xd).qd, rtol=0, atol=1e-15)
        qd[:] = 99.0  # the caller's array: the scheme's state is its own copy
        assert np.all(np.abs(a.qd_prev) < 99.0)
        with pytest.raises(rr.errors.ShapeError):
            a.step(robot, q, J[:, :5], xd)


def test_unknown_daqp_settings_are_refused() -> None:
    pytest.importorskip("daqp")
    with pytest.raises(InvalidParameterError, match="primal_tolerance"):
        QPScheme(dt=DT, solver_options={"primal_tolerance": 1e-9})
