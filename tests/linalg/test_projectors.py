"""Null-space projectors consistent with each inverse; Moore-Penrose conditions."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redres.linalg as rl
from redres.errors import InvalidParameterError, ShapeError

from .strategies import PROPERTY, WIDE_SHAPES, Jac, jacobians, positive_weights, spd_matrices


@PROPERTY
@given(jac=jacobians())
def test_moore_penrose_identities_hold_for_pinv(jac: Jac) -> None:
    X = rl.pinv(jac.J)
    residuals = rl.moore_penrose_residuals(jac.J, X)
    # relative residuals grow with the condition of the inverted part (near: up to 1e9)
    tol = 1e-13 * min(jac.condition, 1e10) + 1e-12
    assert residuals.max() <= tol, residuals
    assert rl.is_moore_penrose(jac.J, X, tol=max(tol, 1e-8))


@PROPERTY
@given(jac=jacobians(kinds=("full", "deficient")))
def test_moore_penrose_identities_hold_for_compiled_exact_inverses(jac: Jac) -> None:
    X = rl.generalized_inverse(jac.J)
    assert rl.moore_penrose_residuals(jac.J, X).max() <= 1e-8


@PROPERTY
@given(jac=jacobians())
def test_exact_projector_annihilates_and_is_idempotent(jac: Jac) -> None:
    N, info = rl.nullspace_projector(jac.J, return_info=True)
    scale = np.abs(jac.J).max()
    np.testing.assert_allclose(jac.J @ N, 0.0, atol=1e-9 * scale)
    np.testing.assert_allclose(N @ N, N, atol=1e-9)
    np.testing.assert_allclose(N, N.T, atol=1e-9)
    n = jac.J.shape[1]
    assert np.trace(N) == pytest.approx(n - info.rank, abs=1e-6)


@PROPERTY
@given(jac=jacobians(shapes=WIDE_SHAPES, kinds=("full", "deficient")), data=st.data())
def test_weighted_projector_matches_weighted_inverse(jac: Jac, data: st.DataObject) -> None:
    n = jac.J.shape[1]
    W = data.draw(st.one_of(spd_matrices(n), positive_weights(n)))
    N = rl.nullspace_projector(jac.J, weights=W)
    X = rl.weighted_pinv(jac.J, W)
    np.testing.assert_allclose(N, np.eye(n) - X @ jac.J, atol=1e-9)
    scale = np.abs(jac.J).max()
    np.testing.assert_allclose(jac.J @ N, 0.0, atol=1e-8 * scale)
    np.testing.assert_allclose(N @ N, N, atol=1e-8)
    Wm = np.diag(W) if W.ndim == 1 else W
    WN = Wm @ N  # self-adjoint in the W inner product
    np.testing.assert_allclose(WN, WN.T, atol=1e-8 * np.abs(Wm).max())


@PROPERTY
@given(jac=jacobians(), lam=st.floats(1e-3, 1.0))
def test_damped_projector_matches_damped_inverse(jac: Jac, lam: float) -> None:
    n = jac.J.shape[1]
    N = rl.nullspace_projector(jac.J, damping=lam)
    X = rl.damped_pinv(jac.J, lam)
    np.testing.assert_allclose(N, np.eye(n) - X @ jac.J, atol=1e-9)
    # not an exact projector: J N = lambda^2 (J J^T + lambda^2)^-1 J, ||J N|| <= lambda / 2
    assert np.linalg.norm(jac.J @ N, 2) <= lam / 2.0 * (1.0 + 1e-9) + 1e-12


def test_damped_projector_is_not_the_exact_one(rng: np.random.Generator) -> None:
    J = np.diag([1.0, 0.01]) @ rng.standard_normal((2, 4))
    exact = rl.nullspace_projector(J)
    damped = rl.nullspace_projector(J, damping=0.05)
    assert np.abs(exact - damped).max() > 0.1  # the pitfall STYLE.md warns about


def test_projector_from_a_given_inverse(rng: np.random.Generator) -> None:
    J = rng.standard_normal((3, 6))
    X = rl.weighted_pinv(J, np.arange(1.0, 7.0))
    np.testing.assert_allclose(rl.nullspace_projector(J, X), np.eye(6) - X @ J, atol=0)
    with pytest.raises(ShapeError, match="J_pinv"):
        rl.nullspace_projector(J, X.T)
    with pytest.raises(InvalidParameterError, match="J_pinv"):
        rl.nullspace_projector(J, X, damping=0.1)
    with pytest.raises(InvalidParameterError, match="return_info"):
        rl.nullspace_projector(J, X, return_info=True)


@PROPERTY
@given(jac=jacobians())
def test_nullspace_basis(jac: Jac) -> None:
    Z = rl.nullspace_basis(jac.J)
    n = jac.J.shape[1]
    rank = rl.pinv(jac.J, return_info=True)[1].rank
    assert Z.shape == (n, n - rank)
    np.testing.assert_allclose(Z.T @ Z, np.eye(n - rank), atol=1e-10)
    np.testing.assert_allclose(jac.J @ Z, 0.0, atol=1e-9 * np.abs(jac.J).max())
    # The compiled kernel's exact projector carries an error ~ eps * kappa in the
    # near-singular directions (its right singular vectors come from rotated rows of J);
    # LAPACK's SVD behind nullspace_basis does not.
    tol = 1e-9 + 1e-15 * min(jac.condition, 1e10)
    np.testing.assert_allclose(Z @ Z.T, rl.nullspace_projector(jac.J), atol=tol)


def test_seed002_rr_nullspace() -> None:
    # singular RR arm at q = (30, 0) deg: the null space is v2 = (-0.447, 0.894)
    J = np.array([[-1.0, -0.5], [np.sqrt(3.0), np.sqrt(3.0) / 2.0]])
    Z = rl.nullspace_basis(J)
    assert Z.shape == (2, 1)
    np.testing.assert_allclose(np.abs(Z[:, 0]), [0.447, 0.894], atol=0.0005)


def test_damped_inverse_fails_moore_penrose(rng: np.random.Generator) -> None:
    J = rng.standard_normal((3, 5))
    res = rl.moore_penrose_residuals(J, rl.damped_pinv(J, 0.5))
    assert res.jxj > 1e-3
    assert not rl.is_moore_penrose(J, rl.damped_pinv(J, 0.5))


def test_weighted_inverse_is_only_a_generalized_inverse(rng: np.random.Generator) -> None:
    J = rng.standard_normal((2, 4))
    X = rl.weighted_pinv(J, [1.0, 2.0, 3.0, 4.0])
    res = rl.moore_penrose_residuals(J, X)
    assert res.jxj < 1e-12 and res.xjx < 1e-12 and res.jx_symmetric < 1e-12
    assert res.xj_symmetric > 1e-3  # X J is not symmetric unless W = c I


def test_moore_penrose_checks_shapes() -> None:
    with pytest.raises(ShapeError, match="J_pinv"):
        rl.moore_penrose_residuals(np.ones((2, 3)), np.ones((2, 3)))
