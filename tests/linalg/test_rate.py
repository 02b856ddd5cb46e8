"""rate_step: one resolved-rate step, qd = J# xd - k N grad, with its diagnostics."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redres.linalg as rl
from redres.errors import (
    InvalidParameterError,
    NonFiniteError,
    NotPositiveDefiniteError,
    ShapeError,
)
from redres.linalg import _backend

from .strategies import PROPERTY, Jac, jacobians, positive_weights, spd_matrices


def reference(J, xd, grad, k, damping=0.0, weights=None):
    """The step from the matrix functions: J# xd - k (I - J# J) grad."""
    if weights is not None:
        X = rl.weighted_pinv(J, weights, damping=damping)
    else:
        X = rl.damped_pinv(J, damping)
    n = J.shape[1]
    qd = X @ xd
    if grad is not None:
        qd = qd - k * (np.eye(n) - X @ J) @ grad
    return qd


@PROPERTY
@given(
    jac=jacobians(),
    seed=st.integers(0, 2**32 - 1),
    damping=st.sampled_from([0.0, 1e-3, 0.05, 1.0]),
    k=st.floats(-2.0, 2.0),
)
def test_rate_step_matches_matrix_functions(jac: Jac, seed: int, damping: float, k: float) -> None:
    m, n = jac.J.shape
    rng = np.random.default_rng(seed)
    xd, grad = rng.standard_normal(m), rng.standard_normal(n)
    qd, info, _ = rl.rate_step(jac.J, xd, grad, k_null=k, damping=damping)
    expected = reference(jac.J, xd, grad, k, damping)
    scale = 1.0 + np.abs(expected).max()
    tol = 1e-9 * scale * (1.0 if damping > 0 else min(jac.condition, 1e10) * 1e-2)
    np.testing.assert_allclose(qd, expected, atol=max(tol, 1e-9 * scale))
    _, expected_info = rl.damped_pinv(jac.J, damping, return_info=True)
    assert info.rank == expected_info.rank
    assert info.method == expected_info.method
    assert info.damping == damping


@PROPERTY
@given(jac=jacobians(shapes=((6, 7), (3, 7), (2, 3))), data=st.data())
def test_weighted_rate_step(jac: Jac, data: st.DataObject) -> None:
    m, n = jac.J.shape
    W = data.draw(st.one_of(spd_matrices(n), positive_weights(n)))
    damping = data.draw(st.sampled_from([0.0, 0.05]))
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    xd, grad = rng.standard_normal(m), rng.standard_normal(n)
    qd, info, _ = rl.rate_step(jac.J, xd, grad, k_null=0.7, damping=damping, weights=W)
    expected = reference(jac.J, xd, grad, 0.7, damping, W)
    np.testing.assert_allclose(qd, expected, atol=1e-7 * (1 + np.abs(expected).max()))
    assert info.method.startswith("weighted")


@pytest.mark.parametrize("selective", [False, True])
def test_adaptive_rate_step(backend: str, rng: np.random.Generator, selective: bool) -> None:
    J = np.diag([1.0, 0.02, 0.5]) @ rng.standard_normal((3, 7))
    xd, grad = rng.standard_normal(3), rng.standard_normal(7)
    law = rl.AdaptiveDamping(0.1, 0.2, selective)
    qd, info, _ = rl.rate_step(J, xd, grad, k_null=0.3, damping=law)
    Jp, ref_info = rl.damped_pinv(J, law, return_info=True)
    np.testing.assert_allclose(qd, Jp @ xd - 0.3 * (np.eye(7) - Jp @ J) @ grad, atol=1e-10)
    assert info.damping == pytest.approx(ref_info.damping, rel=1e-9) and info.damping > 0
    assert info.sigma_min == pytest.approx(ref_info.sigma_min, rel=1e-6)


def test_exact_step_tracks_the_task_and_descends_the_cost(backend: str, rng) -> None:
    # seed 000 eq. 6 / seed 003: the null-space term does not disturb the task and moves
    # downhill on the secondary cost D (DESIGN.md: -k N grad D).
    J = rng.standard_normal((3, 7))
    xd, grad = rng.standard_normal(3), rng.standard_normal(7)
    qd, info, _ = rl.rate_step(J, xd, grad, k_null=0.5)
    np.testing.assert_allclose(J @ qd, xd, atol=1e-12)
    qd_task, _, _ = rl.rate_step(J, xd)
    assert (qd - qd_task) @ grad < 0.0  # descent direction for D
    assert info.full_rank and info.method == "pinv" and info.damping == 0.0


def test_damped_null_term_disturbs_the_task_by_at_most_lambda_over_two(backend, rng) -> None:
    J = np.diag([1.0, 0.01]) @ rng.standard_normal((2, 5))
    grad = rng.standard_normal(5)
    lam = 0.05
    qd_null = rl.rate_step(J, np.zeros(2), grad, k_null=1.0, damping=lam)[0]
    assert np.linalg.norm(J @ qd_null) <= lam / 2 * np.linalg.norm(grad) * (1 + 1e-9)


def test_singular_step_is_finite_with_diagnostics(backend: str) -> None:
    J = np.array([[-1.0, -0.5], [np.sqrt(3.0), np.sqrt(3.0) / 2.0]])  # seed 002
    qd, info, _ = rl.rate_step(J, np.array([-1.0, np.sqrt(3.0)]))
    np.testing.assert_allclose(qd, [0.8, 0.4], atol=1e-12)
    assert info.rank == 1 and not info.full_rank and info.sigma_min < 1e-12
    assert info.sigma_max == pytest.approx(np.sqrt(5.0))
    qd, info, _ = rl.rate_step(J, np.array([1.0, 0.0]), damping=0.1)
    assert np.isfinite(qd).all() and info.method == "damped"


def test_zero_jacobian(backend: str) -> None:
    grad = np.arange(4.0)
    qd, info, _ = rl.rate_step(np.zeros((2, 4)), np.ones(2), grad, k_null=2.0, damping=0.1)
    np.testing.assert_allclose(qd, -2.0 * grad)  # J# = 0, N = I
    assert info.rank == 0 and info.sigma_max == 0.0 and info.damping == 0.1


def test_fast_and_general_paths_agree(rng: np.random.Generator) -> None:
    J = rng.standard_normal((6, 7))
    xd, grad = rng.standard_normal(6), rng.standard_normal(7)
    fast = rl.rate_step(J, xd, grad, k_null=0.5, damping=0.05)
    # np.float64 scalars and lists go through the conversions of the general path
    slow = rl.rate_step(
        J.tolist(), list(xd), grad, k_null=np.float64(0.5), damping=np.float64(0.05)
    )
    np.testing.assert_allclose(fast[0], slow[0], atol=1e-13)
    assert fast[1] == slow[1]
    with _backend.jit_enabled(False):
        numpy = rl.rate_step(J, xd, grad, k_null=0.5, damping=0.05)
    np.testing.assert_allclose(fast[0], numpy[0], atol=1e-12)
    assert fast[1].rank == numpy[1].rank
    assert fast[1].sigma_min == pytest.approx(numpy[1].sigma_min, rel=1e-9)


@pytest.mark.parametrize("shape", [(7, 7), (6, 60), (8, 20)])
def test_large_sizes_use_numpy_and_agree(shape, rng: np.random.Generator) -> None:
    J = rng.standard_normal(shape)
    xd, grad = rng.standard_normal(shape[0]), rng.standard_normal(shape[1])
    qd, info, _ = rl.rate_step(J, xd, grad, k_null=0.5, damping=0.01)
    np.testing.assert_allclose(qd, reference(J, xd, grad, 0.5, 0.01), atol=1e-10)
    assert info.method == "damped"


def test_layouts_and_dtypes(rng: np.random.Generator) -> None:
    J = rng.standard_normal((6, 7))
    xd, grad = rng.standard_normal(6), rng.standard_normal(7)
    expected = rl.rate_step(J, xd, grad, damping=0.05)[0]
    for variant in (np.asfortranarray(J), J.astype(np.float32), J[:, ::-1][:, ::-1]):
        got = rl.rate_step(variant, xd, grad, damping=0.05)[0]
        np.testing.assert_allclose(
            got, expected, atol=1e-5 if variant.dtype == np.float32 else 1e-13
        )
    qd = rl.rate_step(J.astype(int), xd.astype(int), damping=1)[0]
    assert np.isfinite(qd).all()


# --- bad input ----------------------------------------------------------------------


@pytest.mark.parametrize("where", ["J", "xd", "grad"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
@pytest.mark.parametrize("damping", [0.0, 0.1, rl.AdaptiveDamping(0.1, 0.1)])
def test_non_finite_inputs_are_named(backend: str, where: str, value: float, damping) -> None:
    args = {"J": np.ones((2, 3)), "xd": np.ones(2), "grad": np.ones(3)}
    args[where] = args[where].copy()
    args[where].flat[1] = value
    with pytest.raises(NonFiniteError, match=rf"^{where} contains"):
        rl.rate_step(args["J"], args["xd"], args["grad"], damping=damping)


@pytest.mark.parametrize(
    ("J", "xd", "grad", "match"),
    [
        (np.ones(3), np.ones(1), None, "J must be"),
        (np.ones((0, 3)), np.ones(0), None, "J must be a non-empty"),
        (np.ones((2, 3)), np.ones(3), None, r"xd must have shape \(2,\)"),
        (np.ones((2, 3)), np.ones((2, 1)), None, "xd must have shape"),
        (np.ones((2, 3)), np.ones(2), np.ones(2), r"grad must have shape \(3,\)"),
        (np.ones((2, 3)), np.ones(2), np.ones(0), r"grad must have shape \(3,\)"),
        (np.ones((2, 3)), np.ones(2), np.ones((3, 1)), "grad must"),
        (np.ones((8, 3)), np.ones(2), None, r"xd must have shape \(8,\)"),
        ([["a"]], [1.0], None, "J must be an array of numbers"),
    ],
)
def test_wrong_shapes(backend: str, J, xd, grad, match: str) -> None:
    with pytest.raises(ShapeError, match=match):
        rl.rate_step(J, xd, grad)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"damping": -0.1}, InvalidParameterError, "damping"),
        ({"damping": np.nan}, NonFiniteError, "damping"),
        ({"damping": float("inf")}, NonFiniteError, "damping"),
        ({"damping": "x"}, InvalidParameterError, "damping"),
        ({"k_null": np.nan}, NonFiniteError, "k_null"),
        ({"k_null": "x"}, InvalidParameterError, "k_null"),
        ({"rcond": -1.0}, InvalidParameterError, "rcond"),
        ({"rcond": float("inf")}, NonFiniteError, "rcond"),
        ({"weights": np.ones(2)}, ShapeError, "weights"),
        ({"weights": np.array([1.0, 0.0, 1.0])}, NotPositiveDefiniteError, "weights"),
        ({"weights": -np.eye(3)}, NotPositiveDefiniteError, "weights"),
        ({"weights": np.array([1.0, np.nan, 1.0])}, NonFiniteError, "weights"),
    ],
)
def test_bad_parameters(backend: str, kwargs, error, match: str) -> None:
    with pytest.raises(error, match=match):
        rl.rate_step(np.ones((2, 3)), np.ones(2), np.ones(3), **kwargs)


@PROPERTY
@given(jac=jacobians(), data=st.data())
def test_returned_null_term_is_the_secondary_part(jac: Jac, data: st.DataObject) -> None:
    """``return_null``: ``null = qd − J# xd`` with ``J# xd`` the step without a gradient and
    ``null`` the step of ``xd = 0`` alone (linearity), for every inverse and weighting."""
    m, n = jac.J.shape
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    xd, grad = rng.standard_normal(m), rng.standard_normal(n)
    damping = data.draw(
        st.sampled_from([0.0, 0.05, rl.AdaptiveDamping(0.1, 0.2), rl.AdaptiveDamping(0.1, 0.2,
                                                                                     True)])
    )  # fmt: skip
    weights = data.draw(st.sampled_from([None, "diagonal"]))
    w = rng.uniform(0.5, 2.0, n) if weights else None
    kwargs = {"damping": damping, "weights": w}
    qd, info, null = rl.rate_step(jac.J, xd, grad, k_null=0.8, return_null=True, **kwargs)
    qd_alone, info_alone, _ = rl.rate_step(jac.J, xd, grad, k_null=0.8, **kwargs)
    task, _, _ = rl.rate_step(jac.J, xd, **kwargs)
    secondary, _, _ = rl.rate_step(jac.J, np.zeros(m), grad, k_null=0.8, **kwargs)
    scale = 1.0 + np.abs(qd).max() + np.abs(task).max()
    assert np.array_equal(qd, qd_alone) and info == info_alone
    np.testing.assert_allclose(qd - null, task, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(null, secondary, rtol=0, atol=1e-9 * scale)


def test_returned_null_term_on_every_path(backend: str, rng: np.random.Generator) -> None:
    """Fast lane, general kernel and NumPy (also beyond the kernels' sizes), J = 0, no
    gradient: the null term is ``qd − J# xd``."""
    A = rng.standard_normal((7, 7))
    full = A @ A.T + 7 * np.eye(7)  # a full SPD weight matrix
    cases = [((6, 7), {}), ((6, 7), {"damping": 0.1}), ((3, 7), {"weights": np.ones(7) * 2}),
             ((6, 7), {"weights": full}), ((6, 7), {"weights": full, "damping": 0.05}),
             ((6, 60), {"damping": 0.05}), ((2, 4), {"zero": True})]  # fmt: skip
    for (m, n), kwargs in cases:
        J = np.zeros((m, n)) if kwargs.pop("zero", False) else rng.standard_normal((m, n))
        xd, grad = rng.standard_normal(m), rng.standard_normal(n)
        qd, _, null = rl.rate_step(J, xd, grad, k_null=1.5, return_null=True, **kwargs)
        step = rl.rate_step(J, xd, **kwargs)
        assert isinstance(step, rl.RateStep) and step.null_term is None  # not computed
        task = step.qd
        np.testing.assert_allclose(qd - null, task, rtol=0, atol=1e-10)
        _, _, none = rl.rate_step(J, xd, return_null=True, **kwargs)
        assert np.array_equal(none, np.zeros(n))
