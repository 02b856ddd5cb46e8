"""redres.batch: every item equals the single call bit for bit, whatever the threads.

Oracles: the single calls item by item (``SerialChain.fk`` / ``jacobian``,
``linalg.rate_step``: bit-identical, the same per-item kernels), Pinocchio through
``Robot.fk`` / ``Robot.jacobian`` (1e-12), the batch's own reference loop, and the same
batch on one thread and on several.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres import _compile as _jit
from redres import batch
from redres.errors import InvalidParameterError, NonFiniteError, ShapeError
from redres.robot.chain import NotSerialChainError

ARMS = ("panda", "iiwa14", "planar")
N = 300  # several chunks of the parallel loop (CHUNK = 64)
DAMPINGS = (0.0, 0.02, rr.linalg.AdaptiveDamping(0.2, 0.1))


@pytest.fixture(params=ARMS)
def robot(request: pytest.FixtureRequest, builtin_robots: dict[str, rr.Robot]) -> rr.Robot:
    if request.param == "planar":
        return rr.models.planar([1.0, 0.8, 0.6, 0.4])
    return builtin_robots[request.param]


def configurations(robot: rr.Robot, rng: np.random.Generator, count: int = N) -> np.ndarray:
    """Random configurations, a few outside the limits, and a singular one (all zeros)."""
    span = robot.q_max - robot.q_min
    q = rng.uniform(robot.q_min - 0.2 * span, robot.q_max + 0.2 * span, (count, robot.n))
    q[7] = 0.0
    return q


def test_fk_and_jacobians_equal_the_single_calls(robot: rr.Robot, rng: np.random.Generator) -> None:
    q = configurations(robot, rng)
    frames = (None, robot.frames()[len(robot.frames()) // 2])
    for frame in frames:
        chain = robot.chain(frame)
        T = batch.fk(robot, q, frame)
        assert T.shape == (N, 4, 4)
        for reference in ("world", "local"):
            poses = np.empty((N, 4, 4))
            J = batch.jacobian(robot, q, frame, reference, poses=poses)
            assert J.shape == (N, 6, robot.n)
            assert np.array_equal(J, batch.jacobian(robot, q, frame, reference))
            assert np.array_equal(T, poses)
            for i in range(N):
                assert np.array_equal(J[i], chain.jacobian(q[i], reference)), (frame, i)
            for i in range(0, N, 37):  # Pinocchio, the reference
                np.testing.assert_allclose(J[i], robot.jacobian(q[i], frame, reference),
                                           rtol=0, atol=1e-12)  # fmt: skip
        for i in range(N):
            assert np.array_equal(T[i], chain.fk(q[i])), (frame, i)
        for i in range(0, N, 37):
            np.testing.assert_allclose(T[i], robot.fk(q[i], frame), rtol=0, atol=1e-12)


@pytest.mark.parametrize("damping", DAMPINGS, ids=["exact", "damped", "adaptive"])
def test_rate_steps_equal_the_single_calls(
    robot: rr.Robot, rng: np.random.Generator, damping: float | rr.linalg.AdaptiveDamping
) -> None:
    q = configurations(robot, rng)
    xd = rng.normal(size=(N, 6))
    grad = rng.normal(size=(N, robot.n))
    chain = robot.chain()
    cases = [
        (xd, None, None),
        (xd[0], grad, None),  # one task velocity for all
        (xd, grad[0], rng.uniform(0.5, 2.0, robot.n)),  # one gradient, diagonal weights
    ]
    for x, g, w in cases:
        step = batch.rate_step(robot, q, x, g, k_null=3.0, damping=damping, weights=w)
        assert step.qd.shape == (N, robot.n)
        for i in range(N):
            xi = x if x.ndim == 1 else x[i]
            gi = None if g is None else (g if g.ndim == 1 else g[i])
            single = rr.linalg.rate_step(
                chain.jacobian(q[i]), xi, gi, k_null=3.0, damping=damping, weights=w
            )
            assert np.array_equal(step.qd[i], single.qd), (i, step.qd[i] - single.qd)
            assert step.info(i) == single.info, i
    assert not step.full_rank[7] or (robot.n > 6 and step.sigma_min[7] > 0)


def test_without_info_fixed_damping_skips_the_singular_values(
    robot: rr.Robot, rng: np.random.Generator
) -> None:
    """``return_info=False``: the Cholesky solve of ``J Jᵀ + λ² I`` without eigenvalues,
    equal to the single call bit for bit where that one takes its Cholesky path, and to
    the normal equations (NumPy) everywhere, singular items included."""
    q = configurations(robot, rng)
    q[11] = q[7] + 1e-7  # near the singular configuration
    xd, grad = rng.normal(size=(N, 6)), rng.normal(size=(N, robot.n))
    chain = robot.chain()
    for g, w in ((None, None), (grad, rng.uniform(0.5, 2.0, robot.n))):
        full = batch.rate_step(robot, q, xd, g, k_null=2.0, damping=0.02, weights=w)
        lean = batch.rate_step(
            robot, q, xd, g, k_null=2.0, damping=0.02, weights=w, return_info=False
        )
        assert np.all(lean.rank == -1) and not lean.full_rank.any()
        assert np.isnan(lean.sigma_min).all() and np.isnan(lean.sigma_max).all()
        assert np.all(lean.damping == 0.02) and lean.method == full.method
        cholesky = full.sigma_min >= 1e-3 * full.sigma_max
        assert np.array_equal(lean.qd[cholesky], full.qd[cholesky])
        assert not cholesky[7]  # the singular item takes the SVD path with its info
        Winv = np.ones(robot.n) if w is None else 1.0 / w
        for i in range(N):
            J = chain.jacobian(q[i])
            gi = np.zeros(robot.n) if g is None else g[i]
            # qd = -k g + W^-1 Jᵀ (J W^-1 Jᵀ + λ² I)^-1 (xd + k J g): the damped weighted step
            y = np.linalg.solve((J * Winv) @ J.T + 0.02**2 * np.eye(6), xd[i] + 2.0 * J @ gi)
            expected = Winv * (J.T @ y) - 2.0 * gi
            np.testing.assert_allclose(lean.qd[i], expected, rtol=0, atol=1e-9, err_msg=str(i))
        assert np.array_equal(
            lean.qd, batch.rate_step(robot, q, xd, g, k_null=2.0, damping=0.02, weights=w,
                                     return_info=False, threads=1).qd
        )  # fmt: skip
    # A damping too small to make J Jᵀ + λ² I well conditioned, and the other modes: the
    # singular values are needed to choose the factorisation, and reported.
    for damping in (1e-6, 0.0, DAMPINGS[2]):
        lean = batch.rate_step(robot, q, xd, damping=damping, return_info=False)
        full = batch.rate_step(robot, q, xd, damping=damping)
        for a, b in zip(lean, full, strict=True):
            assert np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b


def test_full_weights_equal_the_single_calls(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    q, xd = configurations(robot, rng, 70), rng.normal(size=6)
    W = robot.mass_matrix(robot.neutral())
    step = batch.rate_step(robot, q, xd, damping=0.01, weights=W)
    for i in range(len(q)):
        single = rr.linalg.rate_step(robot.chain().jacobian(q[i]), xd, damping=0.01, weights=W)
        assert np.array_equal(step.qd[i], single.qd) and step.info(i) == single.info
    assert step.method == "weighted-damped"


def test_results_do_not_depend_on_the_number_of_threads(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    q, xd, grad = configurations(robot, rng, 1000), rng.normal(size=(1000, 6)), rng.normal(size=7)
    one = batch.rate_step(robot, q, xd, grad, damping=0.01, threads=1)
    T_one = np.empty((1000, 4, 4))
    J_one = batch.jacobian(robot, q, reference="local", poses=T_one, threads=1)
    for threads in (2, None):
        many = batch.rate_step(robot, q, xd, grad, damping=0.01, threads=threads)
        for a, b in zip(one[:-1], many[:-1], strict=True):
            assert np.array_equal(a, b)
        T = np.empty((1000, 4, 4))
        assert np.array_equal(
            batch.jacobian(robot, q, None, "local", poses=T, threads=threads), J_one
        )
        assert np.array_equal(T, T_one)
        assert np.array_equal(batch.fk(robot, q, threads=threads), T_one)


def test_read_only_input_reuses_the_compiled_kernels(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    q, xd, w = configurations(robot, rng, 10), rng.normal(size=6), np.ones(robot.n)
    expected = batch.rate_step(robot, q, xd, damping=0.01, weights=w).qd
    for array in (q, xd, w):
        array.flags.writeable = False
    kernels = _jit.groups()["batch"].compiled()
    if kernels is None or not hasattr(kernels.rate_steps, "signatures"):
        pytest.skip("the batch kernels are not compiled")
    before = len(kernels.rate_steps.signatures)
    assert np.array_equal(batch.rate_step(robot, q, xd, damping=0.01, weights=w).qd, expected)
    assert len(kernels.rate_steps.signatures) == before  # no second compilation


def test_the_reference_loop_gives_the_same_answers(
    rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    robot = rr.models.iiwa14()
    q, xd = configurations(robot, rng, 40), rng.normal(size=(40, 6))

    def calls() -> list[object]:
        T = np.empty((40, 4, 4))
        J = batch.jacobian(robot, q, reference="local", poses=T)
        return [J, T, batch.fk(robot, q), *batch.rate_step(robot, q, xd, q, damping=0.05)]

    compiled = calls()
    monkeypatch.setattr(batch.KERNELS, "compiled", lambda module=None: None)  # compiling behind
    for x, y in zip(compiled, calls(), strict=True):
        assert np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y
    q[3, 2] = np.nan
    with pytest.raises(NonFiniteError, match=r"q\[3\] contains NaN"):
        batch.rate_step(robot, q, xd)


# ---------------------------------------------------------------------- bad input


def test_ragged_and_misshaped_input_name_the_item(builtin_robots: dict[str, rr.Robot]) -> None:
    robot = builtin_robots["panda"]
    good = [robot.neutral().tolist()] * 4
    ragged = [*good[:2], [0.1] * 6, good[0]]
    with pytest.raises(ShapeError, match=r"q\[2\] has shape \(6,\); every row of q .*\(7,\)"):
        batch.fk(robot, ragged)
    with pytest.raises(ShapeError, match=r"q\[1\] is not a vector of 7 numbers"):
        batch.jacobian(robot, [good[0], "abc"])
    with pytest.raises(ShapeError, match=r"q must have shape \(N, 7\); got shape \(4, 6\)"):
        batch.jacobian(robot, np.zeros((4, 6)))
    with pytest.raises(ShapeError, match=r"for one item use q\[None\]"):
        batch.fk(robot, robot.neutral())
    with pytest.raises(ShapeError, match=r"xd\[3\] has shape \(5,\)"):
        batch.rate_step(robot, good, [[0.0] * 6] * 3 + [[0.0] * 5])
    with pytest.raises(
        ShapeError, match=r"xd must have shape \(4, 6\) or \(6,\); got shape \(3, 6\)"
    ):
        batch.rate_step(robot, good, np.zeros((3, 6)))
    with pytest.raises(ShapeError, match=r"grad must have shape \(4, 7\) or \(7,\)"):
        batch.rate_step(robot, good, np.zeros(6), np.zeros((4, 6)))
    with pytest.raises(InvalidParameterError, match="reference must be 'world' or 'local'"):
        batch.jacobian(robot, good, reference="base")  # type: ignore[arg-type]
    with pytest.raises(ShapeError, match=r"poses must be a writeable .* \(4, 4, 4\)"):
        batch.jacobian(robot, good, poses=np.empty((3, 4, 4)))
    with pytest.raises(InvalidParameterError, match="threads must be a positive integer"):
        batch.fk(robot, good, threads=0)
    with pytest.raises(InvalidParameterError, match="damping"):
        batch.rate_step(robot, good, np.zeros(6), damping=-1.0)


@pytest.mark.parametrize(
    ("where", "message"),
    [("q", r"q\[5\] contains NaN or infinity"), ("xd", r"xd\[5\] contains NaN or infinity"),
     ("grad", r"grad\[5\] contains NaN or infinity")],
)  # fmt: skip
def test_non_finite_input_names_the_item(
    where: str, message: str, rng: np.random.Generator, builtin_robots: dict[str, rr.Robot]
) -> None:
    robot = builtin_robots["panda"]
    arrays = {"q": configurations(robot, rng, 9), "xd": np.ones((9, 6)), "grad": np.ones((9, 7))}
    arrays[where][5, 1] = np.inf if where == "xd" else np.nan
    with pytest.raises(NonFiniteError, match=message):
        batch.rate_step(robot, arrays["q"], arrays["xd"], arrays["grad"])
    if where == "q":
        with pytest.raises(NonFiniteError, match=message):
            batch.fk(robot, arrays["q"])
        with pytest.raises(NonFiniteError, match=message):
            batch.jacobian(robot, arrays["q"], reference="local")
    shared = np.ones(6)
    shared[0] = np.nan
    with pytest.raises(NonFiniteError, match=r"^xd contains NaN"):
        batch.rate_step(robot, arrays["q"] * 0, shared)


def test_a_model_that_is_not_a_serial_chain_is_refused() -> None:
    model = pin.Model()
    model.name = "tree"
    trunk = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "trunk")
    left = model.addJoint(trunk, pin.JointModelRY(), pin.SE3.Random(), "left")
    right = model.addJoint(trunk, pin.JointModelRY(), pin.SE3.Random(), "right")
    model.addFrame(pin.Frame("left_tip", left, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    model.addFrame(pin.Frame("right_tip", right, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    robot = rr.Robot(model, tip="right_tip")
    q = np.zeros((3, 3))
    for call in (batch.fk, batch.jacobian, lambda r, q: batch.rate_step(r, q, np.zeros(6))):
        with pytest.raises(NotSerialChainError, match="joint 'left' is not on the chain"):
            call(robot, q)
    assert batch.fk(robot, q, "left_tip").shape == (3, 4, 4)  # its serial branch is fine


def test_an_empty_batch_gives_empty_arrays(builtin_robots: dict[str, rr.Robot]) -> None:
    robot = builtin_robots["panda"]
    q = np.zeros((0, 7))
    assert batch.fk(robot, q).shape == (0, 4, 4)
    assert batch.jacobian(robot, q).shape == (0, 6, 7)
    step = batch.rate_step(robot, q, np.zeros(6))
    assert step.qd.shape == (0, 7) and step.rank.shape == (0,)
