"""Subnormal and near-overflow inputs (issue 18, item 10): a finite, bounded answer or a
clear ``RedresError``, never inf or NaN, on every path (compiled kernels and NumPy).

The oracle for the bounded answers is the same call on the matrix rescaled to unit size:
``pinv(s A) = pinv(A) / s`` and ``damped_pinv(s A, s lam) = damped_pinv(A, lam) / s``
(the singular values scale by ``s``), checked where both sides are representable.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from _cases import SCHEMES, finite

import redres as rr
from redres.errors import InvalidParameterError, RedresError
from redres.linalg import _backend as be

L = rr.linalg


@pytest.fixture(params=["compiled", "numpy"])
def backend(request: pytest.FixtureRequest) -> Iterator[str]:
    with be.jit_enabled(request.param == "compiled"):
        yield request.param


def _pattern(entry: float) -> np.ndarray:
    """A rank-2 3x7 Jacobian-like matrix whose entries are ``±entry`` or 0."""
    J = np.zeros((3, 7))
    J[0, :3] = entry, -entry, entry
    J[2, 5:] = -entry, entry
    return J


LINALG: dict[str, Callable[[np.ndarray], Any]] = {
    "pinv": L.pinv,
    "right_pinv": L.right_pinv,
    "damped_pinv": lambda J: L.damped_pinv(J, 0.05),
    "adaptive_damped_pinv": lambda J: L.adaptive_damped_pinv(J, 0.1, 0.05),
    "weighted_pinv": lambda J: L.weighted_pinv(J, np.eye(7)),
    "nullspace_projector": L.nullspace_projector,
    "rate_step": lambda J: L.rate_step(J, np.ones(3)).qd,
    "rate_step damped": lambda J: L.rate_step(J, np.ones(3), np.ones(7), damping=0.05).qd,
}


@pytest.mark.parametrize("name", sorted(LINALG))
@pytest.mark.parametrize("entry", [5e-324, 1e-310, 1e-250])
def test_subnormal_jacobians_count_as_zero(backend: str, name: str, entry: float) -> None:
    """Entries below TINY_SCALE (1e-200): J# = 0 and N = I (rank 0), finite, not 1/5e-324."""
    value = LINALG[name](_pattern(entry))
    assert finite(value), (name, value)
    n = 7
    expected = np.eye(n) if name == "nullspace_projector" else np.zeros_like(value)
    if name == "rate_step damped":  # J = 0: qd = -k_null grad
        expected = -np.ones(n)
    np.testing.assert_array_equal(value, expected)
    _, info = L.pinv(_pattern(entry), return_info=True)
    assert info.rank == 0 and finite([info.sigma_min, info.sigma_max])


@pytest.mark.parametrize("entry", [1e-190, 1e-140, 1e120, 1e150, 1e300])
def test_tiny_and_huge_jacobians_scale_exactly(backend: str, entry: float) -> None:
    """Within range, the inverses are the unit-size ones rescaled (module docstring); the
    damped one where the damping's square is representable too (``lam`` of 1e-190 squared
    underflows: not a case of a Jacobian's size)."""
    A = _pattern(1.0) + np.diag([0.5, 0.25, 0.125, 0, 0, 0, 0])[:3]
    J = A * entry
    np.testing.assert_allclose(L.pinv(J) * entry, L.pinv(A), rtol=1e-12, atol=1e-14)
    if 1e-140 <= entry <= 1e150:
        np.testing.assert_allclose(
            L.damped_pinv(J, 0.05 * entry) * entry, L.damped_pinv(A, 0.05), rtol=1e-9,
            atol=1e-14,
        )  # fmt: skip


EDGE: dict[str, Callable[[np.ndarray], Any]] = {
    **LINALG,
    "pinv info": lambda J: L.pinv(J, return_info=True)[1][2:4],
    "damped_pinv info": lambda J: L.damped_pinv(J, 0.05, return_info=True)[1][2:4],
    "rate_step info": lambda J: L.rate_step(J, np.ones(3)).info[2:4],
    "manipulability": L.manipulability,
    "singular_values": L.singular_values,
    "condition_number": L.condition_number,
}


@pytest.mark.parametrize("name", sorted(EDGE))
@pytest.mark.parametrize("entry", [1e300, 1.7e308])
def test_jacobian_at_the_edge_of_overflow(backend: str, name: str, entry: float) -> None:
    """Entries of ±1e300 or ±1.7e308: a finite answer (scaled factorisation), or, where the
    answer itself (a singular value, the manipulability) overflows, an error saying so."""
    try:
        value = EDGE[name](_pattern(entry))
    except InvalidParameterError as exc:
        assert "overflows float64" in str(exc)
        return
    assert finite(value), (name, value)


@pytest.mark.parametrize("name", sorted(SCHEMES))
@pytest.mark.parametrize("xd_entry", [1.7e308, 1e51])
def test_schemes_refuse_task_velocities_that_overflow(
    backend: str, name: str, xd_entry: float
) -> None:
    """xd = 1.7e308 gave NaN joint velocities; now a RedresError naming xd."""
    robot = rr.models.panda()
    q = robot.neutral()
    with pytest.raises(InvalidParameterError, match=r"xd must lie within ±1e\+50"):
        SCHEMES[name]().step(robot, q, robot.jacobian(q), np.full(6, xd_entry))


@pytest.mark.parametrize("name", sorted(SCHEMES))
def test_schemes_answer_finitely_up_to_the_bound(backend: str, name: str) -> None:
    """At the bound itself (1e50) every scheme answers, finitely; with a subnormal J
    (counting as zero) too."""
    robot = rr.models.panda()
    q = robot.neutral()
    J = robot.jacobian(q)
    for J_used, xd in ((J, np.full(6, 1e50)), (J * 5e-324, np.ones(6))):
        try:
            result = SCHEMES[name]().step(robot, q, J_used, xd)
        except RedresError:
            continue  # a clear error is allowed; a non-finite answer is not
        assert finite(result.qd), (name, result.qd)


def test_rate_step_refuses_task_velocities_that_overflow(backend: str) -> None:
    J = rr.models.panda().jacobian(np.zeros(7))
    with pytest.raises(InvalidParameterError, match=r"xd must lie within"):
        L.rate_step(J, np.full(6, 1.7e308))
    assert finite(L.rate_step(J, np.full(6, 1e50)).qd)
