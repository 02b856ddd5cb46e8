"""The torques of the dynamically consistent inverse by QR against exact rational
arithmetic near singularities (the oracle: ``fractions.Fraction`` Gaussian elimination on
the float64 inputs), and against the formula through ``J̄`` away from them."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import redres as rr
from redres.dynamics import operational_space_torque
from redres.dynamics.consistent import ConsistentFactor, consistent_torques


def _solve_exact(A: list[list[Fraction]], B: list[list[Fraction]]) -> list[list[Fraction]]:
    """``A⁻¹ B`` exactly (Gauss–Jordan with a non-zero pivot), ``A`` square."""
    size, cols = len(A), len(B[0])
    rows = [A[i][:] + B[i][:] for i in range(size)]
    for k in range(size):
        pivot = next(i for i in range(k, size) if rows[i][k] != 0)
        rows[k], rows[pivot] = rows[pivot], rows[k]
        inv = 1 / rows[k][k]
        rows[k] = [x * inv for x in rows[k]]
        for i in range(size):
            if i != k and rows[i][k] != 0:
                f = rows[i][k]
                rows[i] = [x - f * y for x, y in zip(rows[i], rows[k], strict=True)]
    return [row[size : size + cols] for row in rows]


def _exact_torques(
    J: np.ndarray, M: np.ndarray, a: np.ndarray, tau: np.ndarray, lam: float
) -> tuple[np.ndarray, np.ndarray]:
    """``Jᵀ Λ a`` and ``Jᵀ J̄ᵀ τ`` with ``Λ = (J M⁻¹ Jᵀ + λ² I)⁻¹``, ``J̄ = M⁻¹ Jᵀ Λ``, in
    exact arithmetic on the float64 inputs, rounded once at the end."""
    m, n = J.shape
    Jf = [[Fraction(float(x)) for x in row] for row in J]
    Mf = [[Fraction(float(x)) for x in row] for row in M]
    JT = [[Jf[r][c] for r in range(m)] for c in range(n)]
    X = _solve_exact(Mf, [JT[c] + [Fraction(float(tau[c]))] for c in range(n)])  # M⁻¹[Jᵀ τ]
    lam2 = Fraction(lam) ** 2
    A = [[sum((Jf[r][c] * X[c][s] for c in range(n)), Fraction(0)) + (lam2 if r == s else 0)
          for s in range(m)] for r in range(m)]  # fmt: skip
    rhs = [[Fraction(float(a[r])), sum((Jf[r][c] * X[c][m] for c in range(n)), Fraction(0))]
           for r in range(m)]  # fmt: skip
    Y = _solve_exact(A, rhs)  # Λ a and Λ J M⁻¹ τ = J̄ᵀ τ
    out = [[float(sum((JT[c][r] * Y[r][k] for r in range(m)), Fraction(0))) for c in range(n)]
           for k in range(2)]  # fmt: skip
    return np.array(out[0]), np.array(out[1])


def _near_singular(robot: rr.Robot, count: int, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``count`` pairs ``(J, M)`` where ``σ_min / σ_max`` of ``J M^{-1/2}`` is in
    ``[1e-4, 2e-3]``: where a solve with ``J M⁻¹ Jᵀ`` (condition 1e6–1e8) loses digits."""
    rng = np.random.default_rng(seed)
    found: list[tuple[np.ndarray, np.ndarray]] = []
    while len(found) < count:
        q = rng.uniform(robot.q_min, robot.q_max)
        J, M = robot.jacobian(q), robot.mass_matrix(q)
        s = np.linalg.svd(J @ np.linalg.inv(np.linalg.cholesky(M)).T, compute_uv=False)
        if 1e-4 <= s[-1] / s[0] <= 2e-3:
            found.append((J, M))
    return found


@pytest.mark.parametrize("lam", [0.0, 0.05])
@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_qr_torques_equal_exact_arithmetic_near_singularities(name: str, lam: float) -> None:
    """Measured (8 states each): the QR torques within 3.0e-14 of exact arithmetic, relative
    to max(1, max|τ|); the former ``M J̄ a`` and ``Jᵀ J̄ᵀ τ`` 3.3e-12 (panda, λ = 0)."""
    robot = rr.models.load(name)
    rng = np.random.default_rng(3)
    worst = 0.0
    for J, M in _near_singular(robot, 8, 5):
        a = rng.uniform(-10.0, 10.0, 6)
        tau = M @ rng.uniform(-5.0, 5.0, robot.n)
        qr = ConsistentFactor(J, M, lam)  # NumPy; then the compiled kernel (when compiled)
        task, proj = _exact_torques(J, M, a, tau, lam)
        scale = max(1.0, float(np.abs(task).max()), float(np.abs(tau).max()))
        for got in ((qr.task(a), qr.project(tau)), consistent_torques(J, M, lam, a, tau)):
            worst = max(worst, float(np.abs(got[0] - task).max()) / scale,
                        float(np.abs(got[1] - proj).max()) / scale)  # fmt: skip
    assert worst < 1e-13, worst


@pytest.mark.parametrize("damping", [0.0, 0.02])
def test_qr_torques_equal_the_formula_through_j_bar_away_from_singularities(
    damping: float,
) -> None:
    robot = rr.models.panda()
    rng = np.random.default_rng(9)
    checked = 0
    for _ in range(200):
        q = 0.5 * rng.uniform(robot.q_min, robot.q_max)
        J, M = robot.jacobian(q), robot.mass_matrix(q)
        J_bar, stats = rr.linalg.dynamically_consistent_pinv(J, M, damping=damping,
                                                             return_info=True)  # fmt: skip
        if stats.sigma_min < 0.01 * stats.sigma_max:
            continue
        a, tau0 = rng.uniform(-10.0, 10.0, 6), M @ rng.uniform(-5.0, 5.0, robot.n)
        out = operational_space_torque(J, M, np.zeros(robot.n), a, tau0, damping=damping)
        scale = max(1.0, float(np.abs(out.tau).max()))
        assert np.abs(out.task - M @ (J_bar @ a)).max() < 1e-13 * scale
        assert np.abs(out.null - (tau0 - J.T @ (J_bar.T @ tau0))).max() < 1e-13 * scale
        checked += 1
    assert checked >= 50


def test_a_truncated_inverse_keeps_the_formula_through_j_bar() -> None:
    """Undamped at a singularity (rank 5 of 6), the torque is the truncated ``J̄``'s."""
    robot = rr.models.panda()
    q = np.zeros(robot.n)  # the stretched arm: rank 5
    J, M = robot.jacobian(q), robot.mass_matrix(q)
    a, tau0 = np.arange(1.0, 7.0), M @ np.linspace(-1.0, 1.0, robot.n)
    out = operational_space_torque(J, M, np.zeros(robot.n), a, tau0)
    assert out.info.rank == 5
    J_bar = rr.linalg.dynamically_consistent_pinv(J, M)
    assert np.allclose(out.task, M @ (J_bar @ a), rtol=0.0, atol=1e-12 * np.abs(out.tau).max())
    assert np.allclose(out.null, tau0 - J.T @ (J_bar.T @ tau0), rtol=0.0,
                       atol=1e-12 * np.abs(out.tau).max())  # fmt: skip
