"""The compiled IK iteration (redres.ik._kernels) against the reference path in Python.

:func:`redres.ik.ik` runs serial chains in one compiled call per attempt; the Python
iteration on Pinocchio (:class:`redres.ik.reference.ReferenceSolver`) is the oracle:
from the same start, with no restarts, both must take the same number of iterations
and end at the same configuration (up to rounding: the SO(3) logarithms differ in the
last bits). Also: the restart generator (plain Python = compiled, uniform, split-proof),
trees taking the reference path, and the target checks done in the kernel.
"""

from __future__ import annotations

import importlib

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres import _compile as _jit
from redres.errors import ShapeError

ik_module = importlib.import_module("redres.ik.solve")
NO_TIMEOUT = 60.0


def reference(monkeypatch: pytest.MonkeyPatch, *args: object, **kw: object) -> object:
    with monkeypatch.context() as patch:
        patch.setattr(ik_module, "_compiled", lambda robot, fid: None)
        return ik_module.ik(*args, **kw)


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
@pytest.mark.parametrize("kind", ["pose", "position", "preferred"])
def test_compiled_equals_reference(
    name: str, kind: str, builtin_robots: dict, monkeypatch: pytest.MonkeyPatch
) -> None:
    robot = builtin_robots[name]
    rng = np.random.default_rng(41)
    assert ik_module._compiled(robot, robot.frame_id(None)) is not None
    same = 0
    count = 40
    for k in range(count):
        T = robot.fk(robot.random_configuration(rng))
        q0 = robot.random_configuration(rng)
        kw: dict[str, object] = {"q0": q0, "max_restarts": 0, "timeout_s": NO_TIMEOUT,
                                 "analytic": False}  # the iterations compared  # fmt: skip
        target = T[:3, 3] if kind == "position" else T
        if kind == "preferred":
            kw["q_preferred"] = robot.random_configuration(rng, margin=0.3)
        fast = ik_module.ik(robot, target, **kw)
        slow = reference(monkeypatch, robot, target, **kw)
        assert fast.converged == slow.converged, (k, fast, slow)
        assert fast.message == slow.message and fast.restarts == slow.restarts == 0
        assert robot.within_limits(fast.q)
        if fast.iterations == slow.iterations:
            same += 1
            assert np.abs(fast.q - slow.q).max() < 1e-7, (k, fast.q - slow.q)
            assert abs(fast.position_error - slow.position_error) < 1e-9
            assert abs(fast.orientation_error - slow.orientation_error) < 1e-8
    # Rounding may move a threshold crossing (stall test, tolerance) by an iteration.
    assert same >= count - 2, same


def test_restarts_and_budgets_match_the_reference(
    builtin_robots: dict, monkeypatch: pytest.MonkeyPatch
) -> None:
    robot = builtin_robots["panda"]
    T = robot.fk(robot.neutral())
    T[:3, 3] = [5.0, 0.0, 0.5]
    kw = {"max_iterations": 50, "max_restarts": 5, "seed": 0, "timeout_s": NO_TIMEOUT}
    fast = ik_module.ik(robot, T, **kw)
    slow = reference(monkeypatch, robot, T, **kw)
    for result in (fast, slow):
        assert not result.converged and result.restarts == 5 and "restart budget" in result.message
    # The same restart configurations (the counter-based draws on both paths), so the
    # same best configuration of the reach.
    assert abs(fast.position_error - slow.position_error) < 1e-6
    assert np.abs(fast.q - slow.q).max() < 1e-5


def test_the_reference_path_restarts_where_the_compiled_one_does() -> None:
    """Restart r of key s is the counter-based draw of (s, 0, r, j) in the restart box on
    both paths (the reference path drew from NumPy's generator: other answers than the
    compiled path's for one seed)."""
    from redres.ik.options import limit_arrays

    robot = rr.models.panda()
    lo, hi = limit_arrays(robot.q_min, robot.q_max)[2:4]
    draw = ik_module._restarts(12345, lo, hi)
    module = ik_module.KERNELS.module()
    for r in (1, 2, 7):
        expected = lo + (hi - lo) * np.array([module.uniform(12345, 0, r, j) for j in range(7)])
        assert np.array_equal(draw(r), expected)
        assert robot.within_limits(draw(r))
    assert not np.array_equal(draw(1), draw(2))


@pytest.mark.parametrize("lam", [0.0, 1e-3, 0.05])
@pytest.mark.parametrize("blocked", [[1, 3], [0, 2, 5], [0, 1, 2, 3, 4, 5, 6]])
def test_dual_step_equals_the_rate_step_with_zeroed_columns(
    lam: float, blocked: list[int], builtin_robots: dict
) -> None:
    """The dual form over the free columns = redres.linalg.rate_step on J with the
    blocked columns zeroed (its SVD path), task part and null-space part."""
    module = _jit.groups()["ik"].compiled("_step_kernels")
    robot = builtin_robots["panda"]
    rng = np.random.default_rng(len(blocked))
    for _ in range(10):
        J = robot.jacobian(robot.random_configuration(rng))
        e, grad = rng.normal(size=6), rng.normal(size=7)
        mask = np.zeros(7, dtype=bool)
        mask[blocked] = True
        grad[mask] = 0.0
        Jz = np.where(mask, 0.0, J)
        ref = rr.linalg.rate_step(Jz, e, grad, k_null=0.3, damping=lam, return_null=True)
        out, null = np.empty(7), np.empty(7)
        ok = module._dual_step(J, e, 6, mask, int((~mask).sum()), grad, 0.3, lam, out, null)
        assert ok
        scale = 1.0 + np.abs(ref.qd).max()
        assert np.abs(out - ref.qd).max() < 1e-9 * scale
        assert np.abs(null - ref.null_term).max() < 1e-9 * scale


def test_restart_generator() -> None:
    compiled = _jit.groups()["ik"].compiled()
    plain = _jit.groups()["ik"].module(plain=True)
    assert compiled is not None and plain is not None
    draws = np.array([compiled.uniform(2**61 + 5, 3, r, c) for r in range(50) for c in range(40)])
    again = np.array([plain.uniform(2**61 + 5, 3, r, c) for r in range(50) for c in range(40)])
    assert np.array_equal(draws, again)  # the plain-Python twin draws the same numbers
    assert draws.min() >= 0.0 and draws.max() < 1.0
    assert abs(draws.mean() - 0.5) < 0.02 and abs(draws.var() - 1 / 12) < 0.01
    other = [compiled.uniform(2**61 + 5, 4, 0, c) for c in range(40)]
    assert len(set(other) & set(draws[:40])) == 0  # another item, another stream


def test_attempts_split_across_calls_give_the_same_answer(builtin_robots: dict) -> None:
    robot = builtin_robots["iiwa14"]
    module = _jit.groups()["ik"].compiled()
    links, axes, kinds, limits = ik_module._compiled(robot, robot.frame_id(None))[1]
    T = robot.fk(robot.neutral())
    T[:3, 3] += [2.0, 0.0, 0.0]  # unreachable: every attempt runs
    packed = ik_module._options_of(1e-6, 1e-5, 8, 0, 1.0, 0.5, 0.1, None, 10, 1e-5)[1]
    problem = ik_module._problem(T, packed, None)
    ends = []
    # (first, stop) ranges, and the iteration budget per call (``spend``): a call ends
    # after the attempt that reaches it, the caller calls again for the rest.
    for chunks, spend in (([(0, 5)], 10**9), ([(0, 1), (1, 3), (3, 5)], 10**9),
                          ([(0, 5)], 1), ([(0, 5)], 9)):  # fmt: skip
        io = np.zeros(2 * 7 + 6)
        io[:7] = robot.neutral()
        io[14:17] = np.inf
        total, calls = 0, []
        for first, stop in chunks:
            while first < stop:
                status, attempts, used = module.solve_packed(
                    links, axes, kinds, limits, problem, io, 6, False, 12345, first, stop, spend
                )
                assert status != module.CONVERGED and 1 <= attempts <= stop - first
                first += attempts
                total += used
                calls.append((attempts, used))
        ends.append((io.copy(), total, calls))
    for io, total, _ in ends[1:]:
        assert np.array_equal(ends[0][0], io) and ends[0][1] == total
    each = [used for attempts, used in ends[2][2]]  # spend 1: one attempt a call
    assert len(each) == 5 and all(1 <= used <= 8 for used in each)
    grouped, made, spent = [], 0, 0  # spend 9: a call ends once its iterations reach 9
    for used in each:
        made, spent = made + 1, spent + used
        if spent >= 9:
            grouped.append(made)
            made = spent = 0
    grouped += [made] if made else []
    assert [attempts for attempts, _ in ends[3][2]] == grouped


def test_a_tree_takes_the_reference_path() -> None:
    model = pin.Model()
    model.name = "tree"
    trunk = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "trunk")
    placement = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.5]))
    left = model.addJoint(trunk, pin.JointModelRY(), placement, "left")
    right = model.addJoint(trunk, pin.JointModelRY(), placement, "right")
    tip = pin.SE3(np.eye(3), np.array([0.4, 0.0, 0.0]))
    model.addFrame(pin.Frame("left_tip", left, 0, tip, pin.FrameType.OP_FRAME))
    model.addFrame(pin.Frame("right_tip", right, 0, tip, pin.FrameType.OP_FRAME))
    model.lowerPositionLimit = np.full(3, -2.0)
    model.upperPositionLimit = np.full(3, 2.0)
    robot = rr.Robot(model, tip="right_tip")
    assert ik_module._compiled(robot, robot.frame_id(None)) is None
    assert ik_module._compiled(robot, robot.frame_id("left_tip")) is not None
    q_true = np.array([0.3, -0.2, 0.4])
    for frame in ("right_tip", "left_tip"):
        p = robot.fk(q_true, frame)[:3, 3]
        result = ik_module.ik(robot, p, frame, seed=0, timeout_s=NO_TIMEOUT)
        assert result.converged, result
        assert np.linalg.norm(robot.fk(result.q, frame)[:3, 3] - p) <= 1e-6


def test_target_checks_in_the_kernel_keep_the_messages(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    T = robot.fk(robot.neutral())
    bad_bottom = T.copy()
    bad_bottom[3, 0] = 1e-3
    with pytest.raises(ShapeError, match="homogeneous"):
        ik_module.ik(robot, bad_bottom)
    sheared = T.copy()
    sheared[0, 1] += 1e-3
    with pytest.raises(ShapeError, match="not a rotation"):
        ik_module.ik(robot, sheared)
    mirrored = T.copy()
    mirrored[:3, 0] *= -1.0
    with pytest.raises(ShapeError, match="not a rotation"):
        ik_module.ik(robot, mirrored)
    nan = T.copy()
    nan[1, 2] = np.nan
    result = ik_module.ik(robot, nan)
    assert not result.converged and "NaN" in result.message and result.iterations == 0
    assert robot.within_limits(result.q)
    readonly = T.copy()
    readonly.flags.writeable = False
    assert ik_module.ik(robot, readonly, seed=0).converged
    fortran = np.asfortranarray(T)
    assert ik_module.ik(robot, fortran, seed=0).converged


def test_restarts_are_drawn_in_the_middle_of_each_range() -> None:
    """The sampling box: RESTART_SPAN of each finite range about its middle (by hand),
    [-pi, pi] clipped to a half-infinite range, on both paths."""
    from redres.ik.options import RESTART_SPAN, limit_arrays
    from redres.ik.reference import ReferenceSolver

    lo = np.array([-2.0, 0.0, -np.inf, -1.0])
    hi = np.array([2.0, 3.0, np.inf, np.inf])
    limits = limit_arrays(lo, hi)
    assert np.allclose(limits[2, :2], [-2.0 * RESTART_SPAN, 1.5 - 1.5 * RESTART_SPAN])
    assert np.allclose(limits[3, :2], [2.0 * RESTART_SPAN, 1.5 + 1.5 * RESTART_SPAN])
    assert np.array_equal(limits[2, 2:], [-np.pi, -1.0])
    assert np.array_equal(limits[3, 2:], [np.pi, np.pi])
    robot = rr.models.panda()
    solver = ReferenceSolver(robot, robot.frame_id(None), (np.zeros(3), None),
                             ik_module._options_of(1e-6, 1e-5, 10, 0, 1.0, 0.5, 0.1, None,
                                                   10, 1e-5)[0], None, None)  # fmt: skip
    box = limit_arrays(robot.q_min, robot.q_max)[2:4]
    assert np.array_equal(box, [solver.sample_lo, solver.sample_hi])


@pytest.mark.parametrize("compiled", [True, False])
def test_a_flat_error_ends_the_attempt(
    compiled: bool, builtin_robots: dict, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Out of reach, the error soon stops falling: each attempt ends after some
    tens of iterations (error not 1 % lower in 3), not the budget (``patience`` is 100)."""
    robot = builtin_robots["iiwa14"]
    T = robot.fk(robot.neutral())
    T[:3, 3] += [3.0, 0.0, 0.0]
    kw = {"max_iterations": 100, "patience": 100, "max_restarts": 5, "timeout_s": None,
          "seed": 2}  # fmt: skip
    call = ik_module.ik if compiled else (lambda *a, **k: reference(monkeypatch, *a, **k))
    result = call(robot, T, **kw)
    assert not result.converged and result.restarts == 5
    assert result.iterations < 6 * 100 // 2, result.iterations  # without it: 6 * 100


@pytest.mark.parametrize("lam", [0.0, 0.02])
@pytest.mark.parametrize("smallest", [0.2, 0.01, 1e-5])
def test_primal_step_equals_the_rate_step(lam: float, smallest: float) -> None:
    """The Cholesky step = redres.linalg.rate_step (task part, null-space part), and its
    σ_min: ``threshold`` (0.05) when above it, the rate step's below; −1 (the caller takes
    the rate step) where that one takes its SVD (σ_min/σ_max < 1e-3)."""
    module = _jit.groups()["ik"].compiled("_step_kernels")
    rng = np.random.default_rng(int(1 / smallest))
    for _ in range(10):
        U, _r = np.linalg.qr(rng.normal(size=(6, 6)))
        V, _r = np.linalg.qr(rng.normal(size=(7, 7)))
        s = np.geomspace(2.0, smallest, 6)
        J = U @ np.diag(s) @ V[:6]
        e, grad = rng.normal(size=6), rng.normal(size=7)
        out, null, mats, vecs = np.empty(7), np.empty(7), np.empty((3, 6, 6)), np.empty((6, 6))
        sigma = module._primal_step(J, e, 6, grad, 0.3, lam, 0.05, out, null, mats, vecs)
        if smallest < 2e-3:
            assert sigma == -1.0
            continue
        ref = rr.linalg.rate_step(J, e, grad, k_null=0.3, damping=lam, return_null=True)
        assert abs(ref.info.sigma_min - smallest) < 1e-9  # the Jacobian as built
        expected = 0.05 if smallest > 0.05 else ref.info.sigma_min
        assert abs(sigma - expected) < 1e-12
        scale = 1.0 + np.abs(ref.qd).max()
        assert np.abs(out - ref.qd).max() < 1e-9 * scale
        assert np.abs(null - ref.null_term).max() < 1e-9 * scale
