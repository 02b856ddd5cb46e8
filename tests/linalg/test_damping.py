"""Damped least-squares inverses, fixed and adaptive (Nakamura-Hanafusa, Wampler, ...)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redres.linalg as rl
from redres.errors import InvalidParameterError, NonFiniteError

from .strategies import PROPERTY, Jac, build, jacobians


def dls(J: np.ndarray, lam: float) -> np.ndarray:
    """The textbook formula J^T (J J^T + lambda^2 I)^-1."""
    return J.T @ np.linalg.inv(J @ J.T + lam**2 * np.eye(J.shape[0]))


@PROPERTY
@given(jac=jacobians(), lam=st.floats(1e-3, 1.0))
def test_damped_pinv_is_the_formula(jac: Jac, lam: float) -> None:
    X, info = rl.damped_pinv(jac.J, lam, return_info=True)
    np.testing.assert_allclose(X, dls(jac.J, lam), atol=1e-9 / lam)
    assert info.damping == lam and info.method == "damped"


@PROPERTY
@given(jac=jacobians(), lam=st.floats(1e-4, 10.0))
def test_damped_entries_bounded_by_one_over_two_lambda(jac: Jac, lam: float) -> None:
    # every gain sigma / (sigma^2 + lambda^2) <= 1 / (2 lambda), hence ||J#||_2 too
    X = rl.damped_pinv(jac.J, lam)
    assert np.isfinite(X).all()
    assert np.abs(X).max() <= (1.0 + 1e-9) / (2.0 * lam)
    assert np.linalg.norm(X, 2) <= (1.0 + 1e-9) / (2.0 * lam)


@PROPERTY
@given(jac=jacobians(kinds=("full",), max_condition=1e3))
def test_damped_tends_to_exact_as_damping_vanishes(jac: Jac) -> None:
    exact = rl.pinv(jac.J)
    s_min = jac.sigma[-1]
    previous = np.inf
    for lam in (1e-1, 1e-2, 1e-3, 1e-4):
        lam = lam * s_min
        error = np.abs(rl.damped_pinv(jac.J, lam) - exact).max()
        # sigma/(sigma^2+lam^2) - 1/sigma = -lam^2 / (sigma (sigma^2 + lam^2))
        assert error <= 2.0 * lam**2 / s_min**3 * np.sqrt(jac.J.size) + 1e-9 / s_min
        assert error <= previous
        previous = error


def test_zero_damping_is_the_pseudo_inverse(backend: str, rng: np.random.Generator) -> None:
    J = rng.standard_normal((3, 5))
    X, info = rl.damped_pinv(J, 0.0, return_info=True)
    np.testing.assert_allclose(X, np.linalg.pinv(J), atol=1e-12)
    assert info.method == "pinv" and info.damping == 0.0


def test_damped_singular_is_finite(backend: str) -> None:
    J = np.array([[-1.0, -0.5], [np.sqrt(3.0), np.sqrt(3.0) / 2.0]])  # seed 002, q=(30, 0)
    X, info = rl.damped_pinv(J, 0.1, return_info=True)
    np.testing.assert_allclose(X, dls(J, 0.1), atol=1e-12)
    assert info.rank == 1 and info.sigma_min == pytest.approx(0.0, abs=1e-12)


def test_zero_and_extreme_magnitudes_stay_finite(backend: str) -> None:
    for J in (np.zeros((3, 4)), 1e200 * np.eye(3, 4), 1e-200 * np.eye(3, 4)):
        for lam in (0.0, 0.1):
            X = rl.damped_pinv(J, lam)
            assert np.isfinite(X).all()
            s = np.abs(J).max()
            t = max(s, lam)  # gain s / (s^2 + lam^2) without overflowing the squares
            gain = 0.0 if s == 0 else (s / t) / (t * ((s / t) ** 2 + (lam / t) ** 2))
            if gain > 1e-150:
                np.testing.assert_allclose(X, gain * np.eye(4, 3), rtol=1e-12, atol=0)
            else:  # lambda / s overflows in the scaled kernel: a zero, still finite, is fine
                assert np.abs(X).max() <= 2.0 * gain


# --- adaptive damping -------------------------------------------------------------------


def test_adaptive_law_values() -> None:
    law = rl.AdaptiveDamping(max_damping=0.2, threshold=0.1)
    assert law.damping_for(0.1) == 0.0
    assert law.damping_for(0.5) == 0.0
    assert law.damping_for(0.0) == pytest.approx(0.2)
    # lambda^2 = (1 - (s/eps)^2) lambda_max^2 (Chiaverini, Siciliano & Egeland 1994)
    assert law.damping_for(0.05) == pytest.approx(0.2 * np.sqrt(1 - 0.25))
    assert rl.adaptive_damping(0.0999999, 0.2, 0.1) == pytest.approx(0.0, abs=1e-3)


@pytest.mark.parametrize("selective", [False, True])
def test_adaptive_is_exact_away_from_singularities(backend: str, selective: bool) -> None:
    J = build((3, 6), np.array([2.0, 1.0, 0.5]), seed=3)
    X, info = rl.adaptive_damped_pinv(J, 0.3, 0.1, selective=selective, return_info=True)
    np.testing.assert_allclose(X, np.linalg.pinv(J), atol=1e-12)
    assert info.damping == 0.0
    assert info.method == ("selective" if selective else "adaptive")


def test_adaptive_uniform_damps_with_the_law(backend: str) -> None:
    sigma = np.array([2.0, 1.0, 0.02])
    J = build((3, 6), sigma, seed=4)
    X, info = rl.adaptive_damped_pinv(J, 0.3, 0.1, return_info=True)
    lam = 0.3 * np.sqrt(1 - 0.2**2)
    assert info.damping == pytest.approx(lam, rel=1e-9)
    assert info.sigma_min == pytest.approx(0.02, rel=1e-9)
    np.testing.assert_allclose(X, dls(J, lam), atol=1e-10)


def test_selective_damps_only_small_singular_values(backend: str) -> None:
    sigma = np.array([2.0, 0.05, 0.01])
    J = build((3, 6), sigma, seed=5)
    X, info = rl.adaptive_damped_pinv(J, 0.3, 0.1, selective=True, return_info=True)
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    lam2 = 0.09 * (1 - (s / 0.1) ** 2) * (s < 0.1)
    gains = s / (s**2 + lam2)
    np.testing.assert_allclose(X, (Vt.T * gains) @ U.T, atol=1e-10)
    assert gains[0] == pytest.approx(1 / 2.0)  # undamped direction
    assert info.damping == pytest.approx(np.sqrt(lam2.max()))


@PROPERTY
@given(jac=jacobians(), selective=st.booleans())
def test_adaptive_is_finite_and_bounded(jac: Jac, selective: bool) -> None:
    X, info = rl.adaptive_damped_pinv(jac.J, 0.1, 0.05, selective=selective, return_info=True)
    assert np.isfinite(X).all()
    assert 0.0 <= info.damping <= 0.1
    if info.sigma_min >= 0.05:
        assert info.damping == 0.0


def test_adaptive_is_continuous_across_the_threshold(backend: str) -> None:
    # the law gives lambda = 0 at sigma_min = eps: no jump when entering the region
    eps = 0.1
    results = []
    for s_min in (eps * (1 + 1e-9), eps * (1 - 1e-9)):
        J = build((3, 6), np.array([1.0, 0.5, s_min]), seed=6)
        results.append(rl.adaptive_damped_pinv(J, 0.5, eps))
    np.testing.assert_allclose(results[0], results[1], atol=1e-6)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"max_damping": -0.1, "threshold": 0.1}, InvalidParameterError, "max_damping"),
        ({"max_damping": 0.1, "threshold": 0.0}, InvalidParameterError, "threshold"),
        ({"max_damping": 0.1, "threshold": -1.0}, InvalidParameterError, "threshold"),
        ({"max_damping": np.nan, "threshold": 0.1}, NonFiniteError, "max_damping"),
        ({"max_damping": 0.1, "threshold": np.inf}, NonFiniteError, "threshold"),
        ({"max_damping": "a", "threshold": 0.1}, InvalidParameterError, "max_damping"),
    ],
)
def test_bad_adaptive_parameters(kwargs, error, match: str) -> None:
    with pytest.raises(error, match=match):
        rl.AdaptiveDamping(**kwargs)


@pytest.mark.parametrize(
    ("damping", "error"),
    [(-0.1, InvalidParameterError), (np.nan, NonFiniteError), (np.inf, NonFiniteError)],
)
def test_bad_damping_is_rejected_by_name(backend: str, damping: float, error) -> None:
    with pytest.raises(error, match="damping"):
        rl.damped_pinv(np.eye(2), damping)


def _scaled_dls(A: np.ndarray, mu: float, s: float) -> np.ndarray:
    """Oracle: ``J#(s A, s mu) = J#(A, mu) / s`` (the damped inverse depends on the
    damping only through sigma / lambda), from NumPy's SVD of the unscaled ``A``."""
    U, sv, Vt = np.linalg.svd(A, full_matrices=False)
    return (Vt.T * (sv / (sv**2 + mu**2))) @ U.T / s


@pytest.mark.parametrize("s", [1e-150, 1e-160, 1e-190])
@pytest.mark.parametrize("mu", [1e-3, 1.0, 30.0])
def test_damping_whose_square_underflows_is_still_applied(
    backend: str, rng: np.random.Generator, s: float, mu: float
) -> None:
    """lambda = s mu below 1e-150 on a J of entries about s: lambda^2 (and sigma^2) are
    subnormal or zero in float64; the inverse must still be the damped one (it was the
    undamped one, or lost five digits, before)."""
    A = rng.standard_normal((5, 7))
    ref = _scaled_dls(A, mu, s)
    for return_info in (False, True):
        out = rl.damped_pinv(s * A, s * mu, return_info=return_info)
        X = out[0] if return_info else out
        np.testing.assert_allclose(X, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())
    _, info = rl.damped_pinv(s * A, s * mu, return_info=True)
    assert info.damping == pytest.approx(s * mu, rel=1e-12)
    sv = np.linalg.svd(A, compute_uv=False)
    assert info.sigma_max == pytest.approx(s * sv[0], rel=1e-10)
    spec = rl.AdaptiveDamping(s * mu, s * 10.0 * sv[0])  # always inside the damped region
    X = rl.damped_pinv(s * A, spec)
    lam = s * mu * np.sqrt(1.0 - (sv[-1] / (10.0 * sv[0])) ** 2)
    np.testing.assert_allclose(X, _scaled_dls(A, lam / s, s), rtol=1e-10,
                               atol=1e-10 * np.abs(ref).max())  # fmt: skip
