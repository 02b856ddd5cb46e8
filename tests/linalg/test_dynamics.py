"""Seed 004: task-space inertia and the dynamically consistent inverse."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redres.linalg as rl
from redres.errors import NonFiniteError, NotPositiveDefiniteError, ShapeError
from redres.linalg.dynamics import _decompose, _decompose_svd

from .strategies import PROPERTY, WIDE_SHAPES, Jac, jacobians, spd_matrices


@PROPERTY
@given(jac=jacobians(shapes=WIDE_SHAPES, kinds=("full",), max_condition=1e3), data=st.data())
def test_seed004_identities(jac: Jac, data: st.DataObject) -> None:
    J = jac.J
    m, n = J.shape
    M = data.draw(spd_matrices(n))
    M_inv = np.linalg.inv(M)
    Lam = rl.task_space_inertia(J, M)
    J_bar = rl.dynamically_consistent_pinv(J, M)
    expected_Lam = np.linalg.inv(J @ M_inv @ J.T)
    scale = np.abs(expected_Lam).max()
    np.testing.assert_allclose(Lam, expected_Lam, atol=1e-8 * scale)
    np.testing.assert_allclose(J_bar, M_inv @ J.T @ expected_Lam, atol=1e-8 * scale)
    np.testing.assert_allclose(J @ J_bar, np.eye(m), atol=1e-8)  # J J_bar = I
    # null-space torques produce no task acceleration: J M^-1 (I - J^T J_bar^T) = 0
    P = rl.dynamically_consistent_projector(J, M)
    np.testing.assert_allclose(P, np.eye(n) - J.T @ J_bar.T, atol=1e-10 * scale)
    np.testing.assert_allclose(J @ M_inv @ P, 0.0, atol=1e-8 * np.abs(J @ M_inv).max())


@PROPERTY
@given(jac=jacobians(shapes=WIDE_SHAPES), data=st.data())
def test_dynamically_consistent_is_weighted_by_mass(jac: Jac, data: st.DataObject) -> None:
    # J_bar minimises kinetic energy qd^T M qd / 2: the weighted inverse with W = M
    M = data.draw(spd_matrices(jac.J.shape[1]))
    J_bar, info = rl.dynamically_consistent_pinv(jac.J, M, return_info=True)
    X = rl.weighted_pinv(jac.J, M)  # compiled path for these sizes
    # near-singular: both carry rounding amplified by the condition number (up to 1e9)
    rtol = 1e-4 if jac.kind == "near" else 1e-7
    np.testing.assert_allclose(J_bar, X, atol=rtol * max(1.0, np.abs(X).max()))
    assert info.method == "dynamically-consistent"


@PROPERTY
@given(jac=jacobians(), data=st.data(), lam=st.floats(1e-3, 1.0))
def test_damped_variant_is_finite_and_matches_formula(jac: Jac, data, lam: float) -> None:
    J = jac.J
    m, n = J.shape
    M = data.draw(spd_matrices(n))
    Lam, info = rl.task_space_inertia(J, M, damping=lam, return_info=True)
    J_bar = rl.dynamically_consistent_pinv(J, M, damping=lam)
    M_inv = np.linalg.inv(M)
    expected = np.linalg.inv(J @ M_inv @ J.T + lam**2 * np.eye(m))
    assert np.isfinite(Lam).all() and np.isfinite(J_bar).all()
    np.testing.assert_allclose(Lam, expected, atol=1e-8 * np.abs(expected).max())
    np.testing.assert_allclose(
        J_bar, M_inv @ J.T @ expected, atol=1e-7 * max(1, np.abs(J_bar).max())
    )
    assert info.damping == lam and info.method == "dynamically-consistent-damped"


def test_singular_jacobian_gives_finite_truncated_inertia() -> None:
    J = np.array([[-1.0, -0.5], [np.sqrt(3.0), np.sqrt(3.0) / 2.0]])  # seed 002 singular RR
    M = np.array([[2.0, 0.3], [0.3, 1.0]])
    Lam, info = rl.task_space_inertia(J, M, return_info=True)
    assert np.isfinite(Lam).all() and info.rank == 1 and not info.full_rank
    J_bar = rl.dynamically_consistent_pinv(J, M)
    # still a generalized inverse: J J_bar J = J
    np.testing.assert_allclose(J @ J_bar @ J, J, atol=1e-10)


def test_adaptive_damping_is_accepted() -> None:
    J = np.array([[1.0, 0.0, 0.0], [0.0, 1e-6, 0.0]])
    Lam, info = rl.task_space_inertia(
        J, np.eye(3), damping=rl.AdaptiveDamping(0.1, 0.01), return_info=True
    )
    assert np.isfinite(Lam).all() and info.damping > 0.09
    assert info.method == "dynamically-consistent-adaptive"


@pytest.mark.parametrize(
    ("M", "error", "match"),
    [
        (np.eye(4), ShapeError, "M must be a 3x3"),
        (np.diag([1.0, 0.0, 1.0]), NotPositiveDefiniteError, "M must be .*positive definite"),
        (np.diag([1.0, -1.0, 1.0]), NotPositiveDefiniteError, "Cholesky"),
        (
            np.array([[1.0, 0.2, 0], [0.0, 1.0, 0], [0, 0, 1.0]]),
            NotPositiveDefiniteError,
            "symmetric",
        ),
        (np.full((3, 3), np.nan), NonFiniteError, "M"),
    ],
)
@pytest.mark.parametrize(
    "fn",
    [rl.task_space_inertia, rl.dynamically_consistent_pinv, rl.dynamically_consistent_projector],
)
def test_bad_mass_matrix(fn, M, error, match: str) -> None:
    with pytest.raises(error, match=match):
        fn(np.ones((2, 3)), M)


def test_negative_damping_is_rejected() -> None:
    with pytest.raises(ValueError, match="damping"):
        rl.task_space_inertia(np.ones((2, 3)), np.eye(3), damping=-1.0)


@PROPERTY
@given(jac=jacobians(), data=st.data())
def test_compiled_path_matches_the_lapack_reference(jac: Jac, data: st.DataObject) -> None:
    """The kernel (one factorisation of J L^-T, Cholesky or Jacobi SVD) against the LAPACK
    SVD reference, for every damping mode, wide, square and tall J, near-singular ones too."""
    J = jac.J
    M = data.draw(spd_matrices(J.shape[1]))
    modes = [0.0, 0.05, rl.AdaptiveDamping(0.1, 0.2), rl.AdaptiveDamping(0.1, 0.2, True)]
    damping = data.draw(st.sampled_from(modes))
    Lam, J_bar, _, stats, method = _decompose(J, M, damping, 1e-10)
    Lam_ref, J_bar_ref, _, stats_ref, method_ref = _decompose_svd(J, M, damping, 1e-10)
    assert method == method_ref
    assert stats[0] == stats_ref[0]  # rank
    np.testing.assert_allclose(stats[1:], stats_ref[1:], rtol=1e-6, atol=1e-12)
    # near-singular undamped: both amplify rounding by the condition number
    loose = jac.kind == "near" and damping == 0.0
    rtol = 1e-4 if loose else 1e-8
    np.testing.assert_allclose(Lam, Lam_ref, rtol=0, atol=rtol * max(1.0, np.abs(Lam_ref).max()))
    np.testing.assert_allclose(J_bar, J_bar_ref, rtol=0,
                               atol=rtol * max(1.0, np.abs(J_bar_ref).max()))  # fmt: skip
    np.testing.assert_array_equal(Lam, Lam.T)


def test_large_problems_use_the_reference_path(rng: np.random.Generator) -> None:
    J = rng.standard_normal((8, 60))  # beyond the kernels (m <= 6, n <= 50)
    A = rng.standard_normal((60, 60))
    M = A @ A.T + 60 * np.eye(60)
    Lam = rl.task_space_inertia(J, M)
    np.testing.assert_allclose(Lam, np.linalg.inv(J @ np.linalg.solve(M, J.T)), rtol=1e-9)


@pytest.mark.parametrize("shape", [(8, 9), (12, 12), (10, 20)])
@pytest.mark.parametrize("damping", [0.0, 0.05])
def test_stacked_sizes_match_the_reference(shape, damping, rng: np.random.Generator) -> None:
    """7–12 rows with m <= n also run in the kernel; it agrees with the LAPACK reference."""
    m, n = shape
    J = rng.standard_normal(shape)
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)
    Lam, J_bar, _, stats, _ = _decompose(J, M, damping, 1e-10)
    Lam_ref, J_bar_ref, _, stats_ref, _ = _decompose_svd(J, M, damping, 1e-10)
    np.testing.assert_allclose(Lam, Lam_ref, rtol=0, atol=1e-9 * np.abs(Lam_ref).max())
    np.testing.assert_allclose(J_bar, J_bar_ref, rtol=0, atol=1e-9 * np.abs(J_bar_ref).max())
    assert stats[0] == stats_ref[0] == m
