"""Damped inverses of tiny Jacobians with tiny damping (issue 18, item 10): ``λ²`` and
``σ²`` underflow in float64, yet ``J#(J, λ) = c J#(c J, c λ)`` (Wampler 1986: the damped
inverse depends on ``λ`` only through ``σ/λ``) is representable, so it must be returned,
or refused by name when it overflows. Oracle: the same inverse at unit scale, divided by
the scale."""

from __future__ import annotations

import numpy as np
import pytest

from redres.errors import InvalidParameterError
from redres.linalg import AdaptiveDamping, damped_pinv


@pytest.mark.parametrize("scale", [1e-160, 1e-210, 1e-250, 1e-300, 1e-305])
@pytest.mark.parametrize("shape", [(3, 5), (6, 7), (2, 2)])
def test_tiny_jacobian_and_damping_give_the_rescaled_inverse(scale: float, shape) -> None:
    A = np.random.default_rng(3).standard_normal(shape)
    X = damped_pinv(A * scale, 0.5 * scale)
    expected = damped_pinv(A, 0.5)
    np.testing.assert_allclose(X * scale, expected, rtol=1e-12, atol=1e-14)


def test_adaptive_damping_below_the_tiny_scale_is_not_zero() -> None:
    A = np.random.default_rng(4).standard_normal((3, 5))
    X = damped_pinv(A * 1e-250, AdaptiveDamping(1e-250, 1e-240))
    expected = damped_pinv(A, AdaptiveDamping(1.0, 1e10))
    np.testing.assert_allclose(X * 1e-250, expected, rtol=1e-12, atol=1e-14)


def test_an_inverse_beyond_float64_is_refused_by_name() -> None:
    A = np.random.default_rng(5).standard_normal((3, 5))
    with pytest.raises(InvalidParameterError, match="overflows float64"):
        damped_pinv(A * 1e-310, 1e-310)
