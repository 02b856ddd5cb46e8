"""Exact and weighted inverses: the worked examples of seeds 001/002 and their algebra."""

from __future__ import annotations

import math

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

from .strategies import PROPERTY, WIDE_SHAPES, Jac, jacobians, positive_weights, spd_matrices

SQRT3 = math.sqrt(3.0)

# --- seed 002, "Underconstrained Manipulators": planar RRR at q = (60, -30, 15) deg -------
# The slide prints J rounded to two decimals; its velocities follow from that printed J
# (with the J of the exact angles they would be (-3.53, 5.46, -0.40) and (-2.72, 5.46,
# -2.78)), so the printed J is the input here, as the seed README says.
J_RRR_PRINTED = np.array([[-2.07, -1.21, -0.71], [2.07, 1.57, 0.71]])


@pytest.mark.parametrize(
    ("weights", "expected"),
    [((1.0, 2.0, 3.0), (-3.59, 5.56, -0.41)), ((3.0, 2.0, 1.0), (-2.76, 5.56, -2.84))],
)
@pytest.mark.parametrize("form", ["vector", "matrix"])
def test_seed002_weighted_example(backend: str, weights, expected, form: str) -> None:
    W = np.array(weights) if form == "vector" else np.diag(weights)
    qd = rl.weighted_pinv(J_RRR_PRINTED, W) @ np.array([1.0, 1.0])
    np.testing.assert_allclose(qd, expected, atol=0.005)  # printed to 2 decimals
    np.testing.assert_allclose(J_RRR_PRINTED @ qd, [1.0, 1.0], atol=1e-12)


def test_seed002_weighting_shifts_motion_away_from_heavy_joints() -> None:
    # "Solution tries to have smaller |theta_3|" (W = diag(1,2,3)), "smaller |theta_1|" (3,2,1)
    v = np.array([1.0, 1.0])
    heavy_last = rl.weighted_pinv(J_RRR_PRINTED, [1.0, 2.0, 3.0]) @ v
    heavy_first = rl.weighted_pinv(J_RRR_PRINTED, [3.0, 2.0, 1.0]) @ v
    assert abs(heavy_last[2]) < abs(heavy_first[2])
    assert abs(heavy_first[0]) < abs(heavy_last[0])


# --- seed 002, "Left Pseudo-inverse": RR arm at q = (30, 30) deg, task (x, y, w) ----------
J_RR_TALL = np.array([[-1.366, -0.866], [1.366, 0.5], [1.0, 1.0]])


@pytest.mark.parametrize(
    ("v", "qd_expected", "xd_expected"),
    [
        ((1.0, 1.0, 1.0), (0.146, 0.107), (-0.293, 0.254, 0.254)),
        ((-2.0, 2.0, 2.0), (1.093, 0.8), (-2.186, 1.893, 1.893)),
    ],
)
def test_seed002_left_pinv_example(backend: str, v, qd_expected, xd_expected) -> None:
    qd = rl.left_pinv(J_RR_TALL) @ np.array(v)
    np.testing.assert_allclose(qd, qd_expected, atol=0.0005)  # printed to 3 decimals
    np.testing.assert_allclose(J_RR_TALL @ qd, xd_expected, atol=0.0005)


def test_seed002_left_pinv_minimises_task_error(rng: np.random.Generator) -> None:
    v = np.array([1.0, 1.0, 1.0])
    qd = rl.left_pinv(J_RR_TALL) @ v
    best = np.linalg.norm(J_RR_TALL @ qd - v)
    for _ in range(100):
        other = qd + 0.01 * rng.standard_normal(2)
        assert np.linalg.norm(J_RR_TALL @ other - v) >= best


# --- seed 002, "Singular Inverse Example": RR arm at q = (30, 0) deg -------------------
J_RR_SINGULAR = np.array([[-1.0, -0.5], [SQRT3, SQRT3 / 2.0]])


def test_seed002_singular_svd_example() -> None:
    np.testing.assert_allclose(rl.singular_values(J_RR_SINGULAR), [2.236, 0.0], atol=0.0005)
    U, _, Vt = np.linalg.svd(J_RR_SINGULAR)
    # First singular vectors as printed (up to a common sign): u1 = (-0.5, sqrt3/2),
    # v1 = (0.894, 0.447).
    sign = np.sign(U[0, 0] / -0.5)
    np.testing.assert_allclose(sign * U[:, 0], [-0.5, SQRT3 / 2.0], atol=1e-12)
    np.testing.assert_allclose(sign * Vt[0], [0.894, 0.447], atol=0.0005)
    J_pinv, info = rl.pinv(J_RR_SINGULAR, return_info=True)
    np.testing.assert_allclose(J_pinv, [[-0.2, 0.346], [-0.1, 0.173]], atol=0.0005)
    assert info.rank == 1 and not info.full_rank
    qd = J_pinv @ np.array([-1.0, SQRT3])
    np.testing.assert_allclose(qd, [0.8, 0.4], atol=1e-12)
    np.testing.assert_allclose(J_RR_SINGULAR @ qd, [-1.0, SQRT3], atol=1e-12)  # "Check"


@pytest.mark.parametrize("fn", [rl.square_inverse, rl.generalized_inverse])
def test_seed002_singular_square_falls_back_to_svd(backend: str, fn) -> None:
    J_inv, info = fn(J_RR_SINGULAR, return_info=True)
    np.testing.assert_allclose(J_inv, rl.pinv(J_RR_SINGULAR), atol=1e-12)
    assert info.method == "pinv" and info.rank == 1 and info.damping == 0.0


# --- seed 001: the weighted inverse of a square Jacobian is its inverse -----------------


@PROPERTY
@given(
    jac=jacobians(shapes=((2, 2), (3, 3), (6, 6)), kinds=("full",)),
    seed=st.integers(0, 2**32 - 1),
    full=st.booleans(),
)
def test_seed001_weighted_inverse_of_square_is_inverse(jac: Jac, seed: int, full: bool) -> None:
    n = jac.J.shape[0]
    rng = np.random.default_rng(seed)
    if full:
        A = rng.standard_normal((n, n))
        W = A @ A.T + n * np.eye(n)
    else:
        W = 10.0 ** rng.uniform(-1, 1, n)
    expected = np.linalg.inv(jac.J)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(rl.weighted_pinv(jac.J, W), expected, atol=1e-9 * scale)


# --- definitions as printed in seeds 001/002 -------------------------------------------


def test_right_pinv_matches_formula(backend: str, rng: np.random.Generator) -> None:
    J = rng.standard_normal((3, 7))
    J_r, info = rl.right_pinv(J, return_info=True)
    np.testing.assert_allclose(J_r, J.T @ np.linalg.inv(J @ J.T), atol=1e-12)
    np.testing.assert_allclose(J @ J_r, np.eye(3), atol=1e-12)  # J J_r^+ = I
    assert info.method == "right" and info.full_rank and info.rank == 3


def test_left_pinv_matches_formula(backend: str, rng: np.random.Generator) -> None:
    J = rng.standard_normal((7, 4))
    J_l, info = rl.left_pinv(J, return_info=True)
    np.testing.assert_allclose(J_l, np.linalg.inv(J.T @ J) @ J.T, atol=1e-12)
    np.testing.assert_allclose(J_l @ J, np.eye(4), atol=1e-12)  # J_l^+ J = I
    assert info.method == "left" and info.full_rank


def test_square_inverse_matches_inv(backend: str, rng: np.random.Generator) -> None:
    J = rng.standard_normal((6, 6)) + 3.0 * np.eye(6)
    np.testing.assert_allclose(rl.square_inverse(J), np.linalg.inv(J), atol=1e-12)


def test_weighted_pinv_minimises_weighted_norm(rng: np.random.Generator) -> None:
    # seed 001: qd = J_W^+ xd minimises qd^T W qd / 2 subject to J qd = xd
    J = rng.standard_normal((2, 5))
    A = rng.standard_normal((5, 5))
    W = A @ A.T + np.eye(5)
    xd = rng.standard_normal(2)
    qd = rl.weighted_pinv(J, W) @ xd
    np.testing.assert_allclose(J @ qd, xd, atol=1e-12)
    Z = rl.nullspace_basis(J)
    for _ in range(50):
        other = qd + Z @ rng.standard_normal(Z.shape[1])
        assert other @ W @ other >= qd @ W @ qd - 1e-12


@PROPERTY
@given(jac=jacobians(shapes=WIDE_SHAPES, kinds=("full", "deficient")))
def test_weighted_with_identity_is_pinv(jac: Jac) -> None:
    n = jac.J.shape[1]
    expected = rl.pinv(jac.J)
    scale = max(1.0, np.abs(expected).max())
    for W in (np.ones(n), np.eye(n)):
        np.testing.assert_allclose(rl.weighted_pinv(jac.J, W), expected, atol=1e-9 * scale)


@PROPERTY
@given(jac=jacobians(), data=st.data())
def test_weighted_pinv_is_generalized_inverse(jac: Jac, data: st.DataObject) -> None:
    n = jac.J.shape[1]
    W = data.draw(st.one_of(spd_matrices(n), positive_weights(n)))
    X, info = rl.weighted_pinv(jac.J, W, return_info=True)
    assert np.isfinite(X).all()
    if info.full_rank and info.condition < 1e6 and jac.J.shape[0] <= n:
        np.testing.assert_allclose(jac.J @ X, np.eye(jac.J.shape[0]), atol=1e-7)


def test_generalized_inverse_dispatch(rng: np.random.Generator) -> None:
    cases = {
        (6, 6): "square",
        (3, 7): "right",
        (7, 3): "left",
    }
    for shape, method in cases.items():
        J = rng.standard_normal(shape)
        X, info = rl.generalized_inverse(J, return_info=True)
        np.testing.assert_allclose(X, np.linalg.pinv(J), atol=1e-10)
        assert info.method == method
    J = rng.standard_normal((3, 7))
    assert rl.generalized_inverse(J, damping=0.1, return_info=True)[1].method == "damped"
    assert rl.generalized_inverse(J, weights=np.ones(7), return_info=True)[1].method == "weighted"
    info = rl.generalized_inverse(J, weights=np.ones(7), damping=0.1, return_info=True)[1]
    assert info.method == "weighted-damped"
    adaptive = rl.AdaptiveDamping(0.1, 0.05)
    assert rl.generalized_inverse(J, damping=adaptive, return_info=True)[1].method == "adaptive"


@pytest.mark.parametrize("fn", [rl.right_pinv, rl.left_pinv, rl.square_inverse, rl.pinv])
@pytest.mark.parametrize("rank", [0, 1, 2])
def test_rank_deficient_exact_inverses_are_finite(backend: str, fn, rank: int) -> None:
    shape = {rl.right_pinv: (3, 5), rl.left_pinv: (5, 3)}.get(fn, (3, 3))
    rng = np.random.default_rng(rank)
    J = rng.standard_normal((shape[0], rank)) @ rng.standard_normal((rank, shape[1]))
    X, info = fn(J, return_info=True)
    assert np.isfinite(X).all()
    np.testing.assert_allclose(X, np.linalg.pinv(J, rcond=1e-10), atol=1e-9)
    assert info.rank == rank and not info.full_rank and info.method == "pinv"


def test_info_condition_is_finite() -> None:
    info = rl.pinv(J_RR_SINGULAR, return_info=True)[1]
    assert info.condition == pytest.approx(1.0 / np.finfo(float).eps)
    info = rl.pinv(np.diag([2.0, 0.5]), return_info=True)[1]
    assert info.condition == pytest.approx(4.0)


# --- bad input ------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize(
    "call",
    [
        lambda J: rl.pinv(J),
        lambda J: rl.right_pinv(J),
        lambda J: rl.weighted_pinv(J, np.ones(3)),
        lambda J: rl.damped_pinv(J, 0.1),
        lambda J: rl.square_inverse(J[:, :2]),
        lambda J: rl.generalized_inverse(J),
        lambda J: rl.left_pinv(J.T),
        lambda J: rl.adaptive_damped_pinv(J, 0.1, 0.05),
        lambda J: rl.nullspace_projector(J),
        lambda J: rl.nullspace_projector(J, np.zeros((3, 2))),
        lambda J: rl.dynamically_consistent_pinv(J, np.eye(3)),
        lambda J: rl.damped_pinv(np.tile(J, 20), 0.1),  # 2 x 60: beyond the kernels
        lambda J: rl.task_space_inertia(np.tile(J, 20), np.eye(60)),
    ],
)
def test_non_finite_jacobian_is_rejected_by_name(backend: str, bad: float, call) -> None:
    J = np.ones((2, 3))
    J[1, 1] = bad
    with pytest.raises(NonFiniteError, match=r"\bJ\b"):
        call(J)


@pytest.mark.parametrize(
    ("J", "fn", "match"),
    [
        (np.ones(3), rl.pinv, "J must be"),
        (np.ones((2, 3, 1)), rl.pinv, "J must be"),
        (np.ones((0, 3)), rl.pinv, "at least one row"),
        (np.ones((4, 3)), rl.right_pinv, "wide"),
        (np.ones((2, 3)), rl.left_pinv, "tall"),
        (np.ones((2, 3)), rl.square_inverse, "square"),
        ([["a", "b"]], rl.pinv, "J must be"),
    ],
)
def test_wrong_shapes_are_rejected(J, fn, match: str) -> None:
    with pytest.raises(ShapeError, match=match):
        fn(J)


@pytest.mark.parametrize(
    ("W", "error", "match"),
    [
        (np.ones(4), ShapeError, r"W must be .*\(3,\).*\(3, 3\)"),
        (np.eye(4), ShapeError, "W must be"),
        (np.array([1.0, 0.0, 2.0]), NotPositiveDefiniteError, "W must be positive definite"),
        (np.array([1.0, -1.0, 2.0]), NotPositiveDefiniteError, "W must be positive definite"),
        (np.diag([1.0, 1.0, 0.0]), NotPositiveDefiniteError, "W must be positive definite"),
        (np.diag([1.0, -2.0, 1.0]), NotPositiveDefiniteError, "W"),
        (
            np.array([[1.0, 0.5, 0], [0.0, 1.0, 0], [0, 0, 1.0]]),
            NotPositiveDefiniteError,
            "symmetric",
        ),
        (np.array([1.0, np.nan, 1.0]), NonFiniteError, "W"),
        (np.full((3, 3), np.inf), NonFiniteError, "W"),
    ],
)
def test_bad_weights_are_rejected(backend: str, W, error, match: str) -> None:
    with pytest.raises(error, match=match):
        rl.weighted_pinv(np.ones((2, 3)), W)


@pytest.mark.parametrize("rcond", [-1e-3, np.nan, "x"])
def test_bad_rcond_is_rejected(rcond) -> None:
    with pytest.raises((InvalidParameterError, NonFiniteError), match="rcond"):
        rl.pinv(np.eye(2), rcond=rcond)


def test_errors_are_value_errors() -> None:
    with pytest.raises(ValueError):
        rl.pinv(np.array([[np.nan]]))
