"""The controller's one-call hard-limit step (``redres.control._box_path``).

Oracle: the same controller with the one-call step switched off (``_box = False``: the
chain kernel's front end, then the scheme's ``_step`` in Python, the path it replaces),
step by step in closed loop along circles that drive the joints into their position,
velocity and acceleration limits, on the Panda, the iiwa14, a planar arm (two task rows)
and DH robots with prismatic joints; with and without the diagonal quadratic costs; after
a reset; through the ill-conditioned branch (the LP again on orthonormal rows). For the
QP, whose compiled solvers replace DAQP, the reference steps from the one-call
controller's own states (its ``q``, previous velocity and verdict) and the two must agree
to DAQP's tolerance with the same active bounds. And the limits themselves, checked on
the applied motion.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from test_fused_chain import dh_robot

import redres as rr
from redres.control import Circle, Controller
from redres.control._box_path import BoxStep
from redres.errors import NonFiniteError, ShapeError
from redres.linalg import _backend
from redres.objectives import JointLimitObjective, ManipulabilityObjective, PostureObjective
from redres.resolution import QPScheme, SNSScheme
from redres.tasks import FrameTask

DT = 1e-3


@pytest.fixture(autouse=True)
def _compiled() -> None:
    if _backend.kernels() is None:
        pytest.skip("compiled kernels unavailable")


def pair(
    robot: rr.Robot, rows: list[str] | None, objectives: Any, kind: type = SNSScheme, **kw: Any
) -> list[Controller]:
    """Two controllers of the same job: the one-call step, and the path it replaces."""
    made = []
    for box in (True, False):
        scheme = kind(dt=DT, objectives=objectives, k_null=2.0, **kw)
        c = Controller(robot, FrameTask(rows=rows), scheme, gain=60.0, dt=DT)
        assert c.path == "frame" and c.kinematics == "chain"
        if not box:
            c._box = False
        made.append(c)
    assert isinstance(made[0]._box, BoxStep), "the one-call step did not apply"
    return made


def assert_same_step(a: Controller, b: Controller) -> None:
    ra, rb = a.result, b.result
    assert ra is not None and rb is not None
    np.testing.assert_allclose(ra.qd, rb.qd, rtol=0, atol=1e-13)
    np.testing.assert_allclose(ra.null_term, rb.null_term, rtol=0, atol=1e-13)
    assert ra.feasible == rb.feasible
    assert list(ra.binding) == list(rb.binding)
    da, db = ra.details, rb.details
    assert (da.method, da.relaxed) == (db.method, db.relaxed)
    assert da.scale == pytest.approx(db.scale, abs=1e-12)
    for x, y in zip(da.bounds, db.bounds, strict=True):
        np.testing.assert_array_equal(x, y)
    assert ra.info == rb.info
    np.testing.assert_array_equal(a.error, b.error)
    np.testing.assert_array_equal(a.pose, b.pose)
    np.testing.assert_array_equal(a.qd, ra.qd)


#: The models without velocity or acceleration limits get them from the scheme.
LIMITS = {"planar": {"qd_max": 1.5, "qdd_max": 15.0}, "dh": {"qd_max": 1.0, "qdd_max": 10.0}}
CASES = [
    ("panda", None, ()),
    ("panda", None, [JointLimitObjective()]),
    ("iiwa14", None, [(JointLimitObjective(), 1.0), (PostureObjective(), 0.5)]),
    ("planar", ["x", "y"], [JointLimitObjective()]),
    ("dh", None, ()),
]


def _robot(name: str) -> rr.Robot:
    if name == "planar":
        return rr.models.planar([1.0, 0.8, 0.5])
    if name == "dh":
        return dh_robot(np.random.default_rng(3), "modified")
    return rr.models.load(name)


@pytest.mark.parametrize(("name", "rows", "objectives"), CASES)
def test_one_call_step_equals_the_frame_path_in_closed_loop(
    name: str, rows: list[str] | None, objectives: Any
) -> None:
    """Bits of the frame path where no cost is set (the same kernels on the same numbers);
    with costs the secondary velocity ``−k a ∘ (q − r)`` is summed in another order than
    the objectives' own gradients: 1e-13."""
    robot = _robot(name)
    rng = np.random.default_rng(11)
    q0 = robot.random_configuration(rng, margin=0.1)
    home = robot.fk(q0)
    # a fast, wide circle: the command leaves the velocity and acceleration box
    circle = Circle(home, radius=0.25, period=0.8)
    a, b = pair(robot, rows, objectives, **LIMITS.get(name, {}))
    qa, qb = q0.copy(), q0.copy()
    limits = a.scheme.limits(robot)  # type: ignore[attr-defined]
    prev, methods = np.zeros(robot.n), set()
    for k in range(400):
        sample = circle.sample(k * DT)
        a.task.set_target(sample.pose, sample.twist)
        b.task.set_target(sample.pose, sample.twist)
        qa_next, qb_next = a.step(qa), b.step(qb)
        assert_same_step(a, b)
        if not objectives:
            np.testing.assert_array_equal(qa_next, qb_next)
        np.testing.assert_allclose(qa_next, qb_next, rtol=0, atol=1e-12)
        qd = a.result.qd  # type: ignore[union-attr]
        assert np.all(qa_next >= limits.q_min - 1e-12) and np.all(qa_next <= limits.q_max + 1e-12)
        assert np.all(np.abs(qd) <= limits.qd_max + 1e-12)
        assert np.all(np.abs(qd - prev) <= limits.qdd_max * DT + 1e-9)
        methods.add(a.result.details.method)  # type: ignore[union-attr]
        prev, qa, qb = qd, qa_next, qb_next
    assert methods - {"sns"}, f"the circle never saturated: {methods}"


def test_state_is_the_schemes_own() -> None:
    """``qd_prev`` after each step is the scheme's copy; a reset starts from rest again,
    as on the frame path; stepping the scheme directly in between is seen."""
    robot = rr.models.panda()
    a, b = pair(robot, None, ())
    q = robot.random_configuration(np.random.default_rng(2), margin=0.3)
    target = robot.fk(q)
    target[:3, 3] += [0.05, -0.02, 0.03]
    for c in (a, b):
        c.task.set_target(target)
    for _ in range(3):
        a.step(q), b.step(q)
    np.testing.assert_array_equal(a.scheme.qd_prev, b.scheme.qd_prev)  # type: ignore[attr-defined]
    assert a.scheme.qd_prev is not a.result.qd  # type: ignore[attr-defined,union-attr]
    a.scheme.reset(), b.scheme.reset()
    a.step(q), b.step(q)
    assert_same_step(a, b)
    state = a.task.compute(robot, q)
    for c in (a, b):  # the scheme stepped by hand: the controller continues from it
        c.scheme.step(robot, q, state.jacobian, state.command(60.0))
    a.step(q), b.step(q)
    assert_same_step(a, b)


def test_the_ill_conditioned_branch_is_the_schemes(monkeypatch: pytest.MonkeyPatch) -> None:
    """A planar arm stretched out (``J`` exactly singular), moving sideways, then asked to
    reach further out: no scale of the task is feasible within the box around its
    velocity, the kernel flags the step ill-conditioned, the scheme's LP on orthonormal
    rows finishes it, and the applied ``q⁺`` is integrated from the final ``q̇``."""
    robot = rr.models.planar([1.0, 0.8, 0.5])
    calls = []
    original = SNSScheme._orthonormal_lp

    def spy(*args: Any) -> Any:
        calls.append(1)
        return original(*args)

    monkeypatch.setattr(SNSScheme, "_orthonormal_lp", staticmethod(spy))
    a, b = pair(robot, ["x", "y"], (), **LIMITS["planar"])
    q = np.zeros(robot.n)
    side, out = robot.fk(q), robot.fk(q)
    side[1, 3] += 0.3
    out[0, 3] += 0.3
    for target, steps in ((side, 20), (out, 3)):
        for c in (a, b):
            c.task.set_target(target)
        for _ in range(steps):
            qa, qb = a.step(q), b.step(q)
            assert_same_step(a, b)
            np.testing.assert_array_equal(qa, qb)
            np.testing.assert_array_equal(qa, q + a.result.qd * DT)  # type: ignore[union-attr]
    assert a.result.details.method == "nearest"  # type: ignore[union-attr]
    assert len(calls) == 6, "the ill-conditioned branch was not taken on both paths"


def test_where_it_does_not_apply() -> None:
    """Costs without a diagonal quadratic form, a subclass, and Pinocchio kinematics keep
    the frame path."""
    panda = rr.models.panda()

    class Own(SNSScheme):
        pass

    for scheme in (SNSScheme(dt=DT, objectives=[ManipulabilityObjective()]), Own(dt=DT)):
        assert Controller(panda, FrameTask(), scheme, dt=DT)._box is False


def test_bad_input_is_named() -> None:
    robot = rr.models.panda()
    c = pair(robot, None, ())[0]
    q = robot.neutral()
    with pytest.raises(NonFiniteError, match="q contains NaN"):
        c.step(np.full(robot.n, np.nan))
    with pytest.raises(ShapeError, match=r"q must have shape \(7,\)"):
        c.step(q[:5])
    assert c.result is None  # nothing reported from a step that raised
    c.step(q)
    assert c.result is not None and c.result.feasible


def _solve_long(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``A x = b`` by Gaussian elimination with partial pivoting in ``np.longdouble``
    (x86's 80-bit extended precision, eps 1.1e-19)."""
    A, b = A.astype(np.longdouble), b.astype(np.longdouble)
    k = len(b)
    for i in range(k):
        p = i + int(np.argmax(np.abs(A[i:, i])))
        A[[i, p]], b[[i, p]] = A[[p, i]], b[[p, i]]
        for r in range(i + 1, k):
            f = A[r, i] / A[i, i]
            A[r, i:] -= f * A[i, i:]
            b[r] -= f * b[i]
    x = np.zeros(k, np.longdouble)
    for i in range(k - 1, -1, -1):
        x[i] = (b[i] - A[i, i + 1 :] @ x[i + 1 :]) / A[i, i]
    return x


def kkt_answer(c: Controller, result: Any, bounds: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The optimum, on its active set, of the QP the step solved, in extended precision:
    the bound joints at their bounds, the rest from the exact QP's ``x_F = q̇_0,F + J_Fᵀy``,
    ``J_F J_Fᵀ y = ẋ − J_A x_A − J_F q̇_0,F``, or the least-violating QP's normal equations
    ``P_FF x_F = −c_F − P_FA x_A`` (its ``P``, ``c`` as the step built them)."""
    from redres.control import _box_kernels as kernels

    box = c._box
    assert isinstance(box, BoxStep)
    n, m = c.robot.n, box._xd.shape[0]
    qd0 = kernels._views.py_func(box._state, n, m)[1]
    P, cost = kernels._qp_views.py_func(box._state, n, m)[4:6]
    J, xd = box._Jm, box._xd
    x = np.zeros(n, np.longdouble)
    held = np.zeros(n, bool)
    for b in result.binding:
        held[b.joint] = True
        x[b.joint] = bounds[0][b.joint] if b.side == "lower" else bounds[1][b.joint]
    free = ~held
    if result.feasible:  # the exact QP
        JF = J[:, free].astype(np.longdouble)
        r = xd - J[:, held].astype(np.longdouble) @ x[held] - JF @ qd0[free]
        x[free] = qd0[free] + JF.T @ _solve_long(JF @ JF.T, r)
    else:
        rhs = -cost[free] - P[np.ix_(free, held)].astype(np.longdouble) @ x[held]
        x[free] = _solve_long(P[np.ix_(free, free)], rhs)
    return x


EPS = float(np.finfo(float).eps)


def condition(c: Controller, result: Any) -> float:
    """The condition number of the system behind the step's answer on its active set:
    ``J_F J_Fᵀ`` (the exact QP) or ``P_FF`` (the least-violating one)."""
    from redres.control import _box_kernels as kernels

    box = c._box
    assert isinstance(box, BoxStep)
    free = np.ones(c.robot.n, bool)
    free[[b.joint for b in result.binding]] = False
    if not free.any():
        return 1.0
    if result.feasible:
        JF = box._Jm[:, free]
        return float(np.linalg.cond(JF @ JF.T))
    P = kernels._qp_views.py_func(box._state, c.robot.n, box._xd.shape[0])[4]
    return float(np.linalg.cond(P[np.ix_(free, free)]))


@pytest.mark.parametrize(("name", "rows", "objectives"), CASES)
def test_qp_one_call_step_equals_the_schemes_step_on_its_states(
    monkeypatch: pytest.MonkeyPatch, name: str, rows: list[str] | None, objectives: Any
) -> None:
    """Every step of a closed loop: the same feasibility, box, bounds held and verdict as
    DAQP's; ``q̇`` equal to the optimum on that active set (:func:`kkt_answer`, extended
    precision) to 1e-12 plus ten rounding errors times the condition number of the system
    solved (:func:`condition`: the least-violating QP's ``P`` has that of ``J_F`` squared
    over ``λ²``, up to 1e7 where a held joint leaves ``J_F`` singular, and there both
    answers are some 5e-11 off); the compiled and DAQP's answers within 1e-9 of each
    other; the steps handed back to the scheme's own path
    (a solver breakdown, the refinement on orthonormal rows) are counted and few."""
    robot = _robot(name)
    a, b = pair(robot, rows, objectives, QPScheme, **LIMITS.get(name, {}))
    handed = []
    own_step = QPScheme._step

    def spy(self: QPScheme, *args: Any) -> Any:
        if self is a.scheme:
            handed.append(1)
        return own_step(self, *args)

    monkeypatch.setattr(QPScheme, "_step", spy)
    rng = np.random.default_rng(5)
    q = robot.random_configuration(rng, margin=0.1)
    # from rest the acceleration limits hold the tool back (the task is infeasible), then
    # it catches up with the circle and tracks it exactly
    circle = Circle(robot.fk(q), radius=0.1, period=2.0)
    limits = a.scheme.limits(robot)  # type: ignore[attr-defined]
    verdicts, prev, worst = set(), np.zeros(robot.n), 0.0
    for k in range(400):
        sample = circle.sample(k * DT)
        for c in (a, b):
            c.task.set_target(sample.pose, sample.twist)
        sa, sb = a.scheme, b.scheme
        sb.qd_prev = None if sa.qd_prev is None else sa.qd_prev.copy()  # type: ignore[attr-defined]
        sb._infeasible_before = sa._infeasible_before  # type: ignore[attr-defined]
        qa_next = a.step(q)
        b.step(q)
        ra, rb = a.result, b.result
        assert ra is not None and rb is not None
        assert ra.feasible == rb.feasible, k
        assert sa._infeasible_before == sb._infeasible_before, k  # type: ignore[attr-defined]
        da, db = ra.details, rb.details
        for x, y in zip(da.bounds, db.bounds, strict=True):
            np.testing.assert_array_equal(x, y)
        assert [(p.joint, p.side) for p in ra.binding] == [(p.joint, p.side) for p in rb.binding]
        exact = kkt_answer(a, ra, da.bounds)
        size = max(1.0, float(np.abs(exact).max()))
        ours, daqp = (float(np.abs(x - exact).max()) / size for x in (ra.qd, rb.qd))
        # a backward-stable solve is off by about eps times the condition number
        assert ours <= 1e-12 + 10 * EPS * condition(a, ra), (k, ours, daqp)
        worst = max(worst, float(np.abs(ra.qd - rb.qd).max()) / size)
        np.testing.assert_allclose(qa_next, q + ra.qd * DT, rtol=0, atol=0)
        assert da.residual == pytest.approx(db.residual, abs=1e-9 * max(1.0, db.residual))
        assert np.all(qa_next >= limits.q_min - 1e-12) and np.all(qa_next <= limits.q_max + 1e-12)
        assert np.all(np.abs(ra.qd) <= limits.qd_max + 1e-12)
        assert np.all(np.abs(ra.qd - prev) <= limits.qdd_max * DT + 1e-9)
        verdicts.add(ra.feasible)
        prev, q = ra.qd, qa_next
    assert False in verdicts, "the task never saturated"
    assert True in verdicts or name == "dh", "the task never tracked"  # dh: 6 joints, 6 rows
    assert worst <= 1e-9, worst
    assert len(handed) <= 4, f"{len(handed)} of 400 steps went back to the scheme's own path"


def test_qp_where_it_does_not_apply() -> None:
    """Levels, collision rows and other backends keep the frame path."""
    panda = rr.models.panda()
    schemes = [
        QPScheme(dt=DT, levels=[FrameTask(rows=["x"])]),
        QPScheme(dt=DT, collisions=rr.Collisions(influence=0.1, safety=0.01, self_collision=True)),
        QPScheme(dt=DT, solver="proxqp"),
    ]
    for scheme in schemes:
        assert Controller(panda, FrameTask(), scheme, dt=DT)._box is False
    assert isinstance(Controller(panda, FrameTask(), QPScheme(dt=DT), dt=DT)._box, BoxStep)
