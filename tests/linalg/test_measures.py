"""Singular values, condition number and manipulability (with its gradient)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given

import redres.linalg as rl
from redres.errors import NonFiniteError, ShapeError

from .strategies import PROPERTY, Jac, jacobians

SQRT3 = np.sqrt(3.0)


def planar_jacobian(q: np.ndarray, links: np.ndarray) -> np.ndarray:
    """Positional Jacobian (x, y) of a planar serial arm (seed 002, J_RRR without w)."""
    angles = np.cumsum(q)
    J = np.zeros((2, q.size))
    for i in range(q.size):
        J[0, i] = -np.sum(links[i:] * np.sin(angles[i:]))
        J[1, i] = np.sum(links[i:] * np.cos(angles[i:]))
    return J


def jacobian_derivatives(q: np.ndarray, links: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """dJ/dq_k by central differences, shape (n, m, n)."""
    out = []
    for k in range(q.size):
        dq = np.zeros(q.size)
        dq[k] = h
        out.append((planar_jacobian(q + dq, links) - planar_jacobian(q - dq, links)) / (2 * h))
    return np.array(out)


@PROPERTY
@given(jac=jacobians())
def test_singular_values_and_sigma_min(jac: Jac) -> None:
    s = rl.singular_values(jac.J)
    np.testing.assert_allclose(s, jac.sigma, atol=1e-12 * jac.sigma[0])
    assert rl.sigma_min(jac.J) == pytest.approx(jac.sigma[-1], abs=1e-12 * jac.sigma[0])


@PROPERTY
@given(jac=jacobians())
def test_condition_number_is_finite(jac: Jac) -> None:
    kappa = rl.condition_number(jac.J)
    assert np.isfinite(kappa) and 1.0 <= kappa <= 1.0 / np.finfo(float).eps
    if jac.kind == "full":
        assert kappa == pytest.approx(jac.condition, rel=1e-8)


def test_condition_number_of_singular_matrices_is_capped() -> None:
    cap = 1.0 / np.finfo(float).eps
    assert rl.condition_number(np.zeros((2, 3))) == cap
    assert rl.condition_number([[-1.0, -0.5], [SQRT3, SQRT3 / 2]]) == cap  # seed 002


@PROPERTY
@given(jac=jacobians())
def test_manipulability_is_sqrt_det(jac: Jac) -> None:
    m, n = jac.J.shape
    w = rl.manipulability(jac.J)
    if m > n:
        assert w == 0.0
    else:
        top = jac.sigma[0] ** m
        assert w == pytest.approx(np.prod(jac.sigma), rel=1e-8, abs=1e-14 * top)
        if jac.kind == "full":  # det(J J^T) is only accurate when J is well conditioned
            expected = np.sqrt(np.linalg.det(jac.J @ jac.J.T))
            assert w == pytest.approx(expected, rel=1e-6)


def test_seed002_singular_rr_has_zero_manipulability() -> None:
    assert rl.manipulability([[-1.0, -0.5], [SQRT3, SQRT3 / 2]]) == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("q", [(0.3, 0.9, -0.5), (1.0, -0.4, 0.7), (0.2, 0.1, 0.05)])
def test_manipulability_gradient_matches_finite_differences(q) -> None:
    q = np.array(q)
    links = np.array([1.0, 0.8, 0.5])
    grad = rl.manipulability_gradient(planar_jacobian(q, links), jacobian_derivatives(q, links))
    h = 1e-6
    fd = np.array(
        [
            (
                rl.manipulability(planar_jacobian(q + h * e, links))
                - rl.manipulability(planar_jacobian(q - h * e, links))
            )
            / (2 * h)
            for e in np.eye(3)
        ]
    )
    np.testing.assert_allclose(grad, fd, atol=1e-7)


def test_manipulability_gradient_detects_a_wrong_derivative() -> None:
    q = np.array([0.3, 0.9, -0.5])
    links = np.array([1.0, 0.8, 0.5])
    J = planar_jacobian(q, links)
    good = rl.manipulability_gradient(J, jacobian_derivatives(q, links))
    bad = rl.manipulability_gradient(J, 1.1 * jacobian_derivatives(q, links))
    assert np.abs(good - bad).max() > 1e-3


def test_manipulability_gradient_at_singularity_is_finite() -> None:
    q = np.array([0.5, 0.0, 0.0])  # stretched arm: rank 1
    links = np.array([1.0, 1.0, 1.0])
    grad = rl.manipulability_gradient(planar_jacobian(q, links), jacobian_derivatives(q, links))
    assert np.isfinite(grad).all()
    # moving joint 2 or 3 away from 0 increases w from 0: the gradient is nonzero there
    assert np.abs(grad[1:]).max() > 0.1


def test_manipulability_gradient_tall_is_zero() -> None:
    assert (rl.manipulability_gradient(np.ones((3, 2)), np.zeros((2, 3, 2))) == 0).all()


def test_manipulability_gradient_checks_input() -> None:
    with pytest.raises(ShapeError, match=r"dJ_dq must have shape \(n, m, n\) = \(3, 2, 3\)"):
        rl.manipulability_gradient(np.ones((2, 3)), np.zeros((2, 3, 3)))
    with pytest.raises(NonFiniteError, match="dJ_dq"):
        rl.manipulability_gradient(np.ones((2, 3)), np.full((3, 2, 3), np.nan))


@pytest.mark.parametrize(
    "fn", [rl.manipulability, rl.singular_values, rl.condition_number, rl.sigma_min]
)
def test_measures_reject_non_finite(fn) -> None:
    with pytest.raises(NonFiniteError, match="J"):
        fn(np.array([[1.0, np.inf]]))
