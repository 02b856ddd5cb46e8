"""Hypothesis strategies for redres.linalg: Jacobians with a chosen rank and conditioning.

``J = U diag(sigma) V^T`` with random orthogonal ``U`` and ``V`` drawn from a seed that
hypothesis chooses (so failures shrink to a seed and a few scalars), and singular values
spread log-uniformly between ``sigma_max`` and ``sigma_max / condition``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypothesis import settings
from hypothesis import strategies as st

# deadline=None: the first call of a compiled kernel includes its compilation or cache load.
PROPERTY = settings(max_examples=40, deadline=None)

# The shapes of the issue: redundant arms (6x7, 3x7, 2x3), square (6x6), tall (7x6).
SHAPES = ((6, 7), (3, 7), (2, 3), (6, 6), (7, 6))
WIDE_SHAPES = ((6, 7), (3, 7), (2, 3), (6, 6))


@dataclass(frozen=True)
class Jac:
    """A generated Jacobian with the singular values it was built from."""

    J: np.ndarray
    sigma: np.ndarray  # descending, length min(m, n), zeros for the deficient part
    kind: str  # "full", "deficient" or "near" (one singular value tiny but nonzero)

    @property
    def rank(self) -> int:
        return int((self.sigma > 0.0).sum())

    @property
    def condition(self) -> float:
        return float(self.sigma[0] / self.sigma[-1]) if self.sigma[-1] > 0 else np.inf


def orthogonal(rng: np.random.Generator, size: int) -> np.ndarray:
    """A random orthogonal matrix (QR of a Gaussian matrix, signs fixed)."""
    Q, R = np.linalg.qr(rng.standard_normal((size, size)))
    return Q * np.sign(np.diag(R))


def build(shape: tuple[int, int], sigma: np.ndarray, seed: int) -> np.ndarray:
    """``U[:, :k] diag(sigma) V[:, :k]^T`` for random orthogonal U, V."""
    m, n = shape
    k = min(m, n)
    rng = np.random.default_rng(seed)
    U = orthogonal(rng, m)[:, :k]
    V = orthogonal(rng, n)[:, :k]
    return (U * sigma) @ V.T


@st.composite
def jacobians(
    draw: st.DrawFn,
    shapes: tuple[tuple[int, int], ...] = SHAPES,
    kinds: tuple[str, ...] = ("full", "full", "deficient", "near"),
    max_condition: float = 1e4,
) -> Jac:
    """A Jacobian of one of ``shapes`` with rank and condition number chosen by hypothesis.

    * ``full``: full rank, condition number in ``[1, max_condition]``;
    * ``deficient``: rank ``r < min(m, n)`` (exact zeros in sigma);
    * ``near``: full rank, but the smallest singular value is ``1e-9 .. 1e-5`` of the largest.
    """
    shape = draw(st.sampled_from(shapes))
    kind = draw(st.sampled_from(kinds))
    seed = draw(st.integers(0, 2**32 - 1))
    k = min(shape)
    top = 10.0 ** draw(st.floats(-1.0, 1.0))
    log_cond = draw(st.floats(0.0, float(np.log10(max_condition))))
    sigma = top * np.logspace(0.0, -log_cond, k)
    if kind == "deficient":
        rank = draw(st.integers(0, k - 1)) if k > 1 else 0
        sigma[rank:] = 0.0
    elif kind == "near":
        sigma[-1] = sigma[0] * 10.0 ** draw(st.floats(-9.0, -5.0))
        sigma = np.sort(sigma)[::-1]
    return Jac(build(shape, sigma, seed), sigma, kind)


@st.composite
def spd_matrices(draw: st.DrawFn, n: int, max_condition: float = 1e3) -> np.ndarray:
    """A symmetric positive definite ``n x n`` matrix (a mass or weight matrix)."""
    seed = draw(st.integers(0, 2**32 - 1))
    log_cond = draw(st.floats(0.0, float(np.log10(max_condition))))
    rng = np.random.default_rng(seed)
    Q = orthogonal(rng, n)
    eig = 10.0 ** rng.uniform(-log_cond / 2, log_cond / 2, n)
    M = (Q * eig) @ Q.T
    return 0.5 * (M + M.T)


@st.composite
def positive_weights(draw: st.DrawFn, n: int) -> np.ndarray:
    """Diagonal weights in ``[0.1, 10]``."""
    seed = draw(st.integers(0, 2**32 - 1))
    return 10.0 ** np.random.default_rng(seed).uniform(-1.0, 1.0, n)
