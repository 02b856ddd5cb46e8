"""The compiled fast path: agreement with the NumPy reference, lazy import, cache fallback."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import redres.linalg as rl
from redres.linalg import _backend

from .strategies import PROPERTY, Jac, jacobians, orthogonal, positive_weights, spd_matrices

kernels = pytest.importorskip("redres.linalg._kernels")
eigen = pytest.importorskip("redres.linalg._eigen_kernels")

SRC = os.path.join(os.path.dirname(__file__), "..", "..", "src")


def run_python(code: str, **env: str) -> str:
    """Run code in a fresh interpreter (with src on the path) and return its stdout."""
    environment = dict(os.environ, PYTHONPATH=os.path.abspath(SRC), **env)
    result = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        env=environment,
        check=True,
        timeout=1200,
    )
    return result.stdout.strip()


def extremes(A: np.ndarray) -> tuple[float, float]:
    size = A.shape[0]
    d, e, v, p = (np.zeros(size) for _ in range(4))
    T = np.tril(A).copy()
    eigen._tridiagonalize(T, size, d, e, v, p)
    return eigen._extreme_eigenvalues(d, e, size, True)


@pytest.mark.parametrize(
    "sigma",
    [
        [1.0],
        [2.0, 1.0],
        [3.0, 2.0, 1.0, 0.5, 0.2, 0.1],
        [1.0, 1.0, 1.0, 1.0, 1.0, 1.0],  # six-fold eigenvalue
        [1.0, 1.0, 1.0, 0.1, 0.1, 0.1],  # two clusters
        [1.0, 1.0 + 1e-9, 0.5, 0.5 + 1e-12, 0.01, 0.01],  # near-multiple
        [1.0, 0.0, 0.0, 0.0],  # rank one
        [5.0, 1e-3, 1e-3],
    ],
)
def test_extreme_eigenvalues_of_gram_matrices(sigma) -> None:
    s = np.array(sigma)
    for seed in range(5):
        Q = orthogonal(np.random.default_rng(seed), s.size)
        A = (Q * s**2) @ Q.T
        low, high = extremes(A)
        reference = np.linalg.eigvalsh(A)
        assert high == pytest.approx(reference[-1], rel=1e-13)
        assert abs(low - reference[0]) <= 1e-13 * reference[-1]


def test_extreme_eigenvalues_of_diagonal_and_zero() -> None:
    assert extremes(np.diag([3.0, 1.0, 2.0])) == (1.0, 3.0)
    assert extremes(np.zeros((3, 3))) == (0.0, 0.0)


@PROPERTY
@given(
    jac=jacobians(),
    mode=st.sampled_from(["exact", "fixed", "adaptive", "selective"]),
    weighting=st.sampled_from(["none", "diagonal", "full"]),
    data=st.data(),
)
def test_compiled_inverse_matches_numpy(jac: Jac, mode: str, weighting: str, data) -> None:
    J = jac.J
    n = J.shape[1]
    damping = {
        "exact": 0.0,
        "fixed": 0.05,
        "adaptive": rl.AdaptiveDamping(0.1, 0.3),
        "selective": rl.AdaptiveDamping(0.1, 0.3, selective=True),
    }[mode]
    weights = {
        "none": None,
        "diagonal": data.draw(positive_weights(n)),
        "full": data.draw(spd_matrices(n, max_condition=100.0)),
    }[weighting]
    results = {}
    for enabled in (True, False):
        with _backend.jit_enabled(enabled):
            results[enabled] = (
                rl.nullspace_projector(J, weights=weights, damping=damping, return_info=True),
                rl.generalized_inverse(J, weights=weights, damping=damping),
            )
    (N_c, info_c), X_c = results[True]
    (N_n, info_n), X_n = results[False]
    # near-singular exact inverses amplify rounding by kappa (see test_projectors)
    kappa = 1.0 if mode != "exact" else min(jac.condition, 1e10)
    scale = 1.0 + np.abs(X_n).max()
    np.testing.assert_allclose(X_c, X_n, atol=1e-9 * scale * max(1.0, kappa * 1e-6))
    np.testing.assert_allclose(
        N_c, N_n, atol=1e-9 * max(1.0, kappa * 1e-5) * (1 + np.abs(N_n).max())
    )
    assert info_c.rank == info_n.rank
    assert info_c.method == info_n.method
    assert info_c.sigma_max == pytest.approx(info_n.sigma_max, rel=1e-9)
    assert abs(info_c.sigma_min - info_n.sigma_min) <= 1e-9 * info_n.sigma_max
    assert info_c.damping == pytest.approx(info_n.damping, rel=1e-6, abs=1e-12)


def test_fast_lane_entry_point_matches_dispatcher(rng: np.random.Generator) -> None:
    entry = _backend.fast_step()
    J = rng.standard_normal((6, 7))
    xd, grad = rng.standard_normal(6), rng.standard_normal(7)
    out1, out2, null1, null2 = np.empty(7), np.empty(7), np.empty(7), np.empty(7)
    r1 = entry(J, xd, grad, out1, null1, 0.5, 0.05, 1e-10)
    r2 = kernels.step(J, xd, grad, out2, null2, 0.5, 0.05, 1e-10)
    assert r1 == r2
    np.testing.assert_array_equal(out1, out2)
    np.testing.assert_array_equal(null1, null2)


def test_import_redres_does_not_import_numba() -> None:
    out = run_python(
        """
        import sys
        import redres
        import redres.linalg as rl
        print("numba" in sys.modules)
        rl.pinv([[1.0, 2.0]])  # the SVD path needs no kernel
        print("numba" in sys.modules)
        rl.damped_pinv([[1.0, 2.0]], 0.1)  # the compiled path imports it on demand
        print("numba" in sys.modules)
        """
    )
    assert out.split() == ["False", "False", "True"]


def test_environment_variable_disables_the_kernels() -> None:
    out = run_python(
        """
        import sys
        import redres.linalg as rl
        from redres.linalg import _backend
        qd, info, _ = rl.rate_step([[1.0, 0.0, 1.0]], [1.0], damping=0.1)
        print(_backend.kernels() is None, "numba" in sys.modules, info.method)
        """,
        REDRES_DISABLE_JIT="1",
    )
    assert out.split() == ["True", "False", "damped"]


@pytest.mark.parametrize("shape", [(7, 7), (8, 9), (9, 12), (12, 12), (12, 30)])
@pytest.mark.parametrize("kind", ["full", "deficient", "near"])
def test_stacked_sizes_in_the_kernels_match_lapack(
    shape: tuple[int, int], kind: str, rng: np.random.Generator
) -> None:
    """7–12 rows with m <= n (augmented and stacked priority Jacobians) run in the kernels:
    they agree with the LAPACK path (kernels disabled) for every inverse and the step."""
    import redres.linalg as rl

    m, n = shape
    J = rng.standard_normal(shape)
    if kind != "full":  # make the last row a combination of the others, or nearly
        J[-1] = J[0] + J[1] + (1e-7 * rng.standard_normal(n) if kind == "near" else 0.0)
    xd, grad = rng.standard_normal(m), rng.standard_normal(n)
    calls = {
        "damped": lambda: rl.damped_pinv(J, 0.05),
        "adaptive": lambda: rl.adaptive_damped_pinv(J, 0.1, 0.2),
        "selective": lambda: rl.adaptive_damped_pinv(J, 0.1, 0.2, selective=True),
        "generalized": lambda: rl.generalized_inverse(J),
        "projector": lambda: rl.nullspace_projector(J),
        "step": lambda: rl.rate_step(J, xd, grad, k_null=0.7, damping=0.05)[0],
        "exact step": lambda: rl.rate_step(J, xd, grad, k_null=0.7)[0],
    }
    compiled = {name: call() for name, call in calls.items()}
    with _backend.jit_enabled(False):
        reference = {name: call() for name, call in calls.items()}
    for name, value in compiled.items():
        ref = reference[name]
        # near-singular undamped results carry rounding amplified by the condition number
        undamped = name in ("generalized", "projector", "exact step")
        tol = 1e-3 if kind == "near" and undamped else 1e-9
        np.testing.assert_allclose(value, ref, rtol=0, atol=tol * max(1.0, np.abs(ref).max()),
                                   err_msg=name)  # fmt: skip


def _damped_oracle(J: np.ndarray, lam: float) -> np.ndarray:
    """``J^T (J J^T + lam^2 I)^-1 = V diag(sigma / (sigma^2 + lam^2)) U^T`` from NumPy's
    SVD (LAPACK), accurate even where ``J J^T + lam^2 I`` is ill-conditioned."""
    U, sigma, Vt = np.linalg.svd(J, full_matrices=False)
    return (Vt.T * (sigma / (sigma**2 + lam * lam))) @ U.T


@pytest.mark.parametrize("lam", [1e-3, 0.05, 1.0])
@pytest.mark.parametrize("shape", [(6, 7), (3, 7), (6, 6), (2, 5), (8, 5)])
def test_the_lazy_lane_gives_the_damped_inverse(shape, lam, rng: np.random.Generator) -> None:
    """Fixed damping without statistics (``damped_pinv`` without ``return_info``) goes
    straight to a Cholesky solve; it equals the defining formula and the eager kernel,
    at a generic, a near-singular and an exactly singular Jacobian."""
    m, n = shape
    U, _ = np.linalg.qr(rng.normal(size=(m, m)))
    V, _ = np.linalg.qr(rng.normal(size=(n, n)))
    k = min(m, n)
    for tail in (0.3, 1e-7, 0.0):
        sigma = np.linspace(2.0, tail, k)
        J = U[:, :k] @ np.diag(sigma) @ V[:, :k].T
        lazy = rl.damped_pinv(J, lam)
        eager, info = rl.damped_pinv(J, lam, return_info=True)
        oracle = _damped_oracle(J, lam)
        # the damped inverse's own conditioning: d/dsigma [sigma / (sigma^2 + lam^2)] is
        # up to 1/lam^2, so rounding J by eps ||J|| moves J# by up to eps ||J|| / lam^2
        tol = 1e-10 * np.abs(oracle).max() + 50 * np.finfo(float).eps * 2.0 / lam**2
        assert np.abs(lazy - oracle).max() <= tol
        assert np.abs(lazy - eager).max() <= tol
        assert info.rank >= 0 and np.isfinite(info.sigma_min)  # the eager lane still tells


def test_the_lazy_lane_skips_the_singular_values_only_when_it_may() -> None:
    """The kernel reports rank -1 (not computed) when ``lam^2 >= 1e-6 trace(J J^T)``, and
    computes them as FIXED does below that (the Cholesky bound would not hold)."""
    rng = np.random.default_rng(3)
    J = rng.normal(size=(6, 7))
    trace = float(np.trace(J @ J.T))
    empty = np.zeros((0, 0))
    for lam, skipped in ((1.01e-3 * np.sqrt(trace), True), (0.99e-3 * np.sqrt(trace), False)):
        Jp = np.empty((7, 6))
        status, rank, smin, _, used = kernels.inverse(
            J, np.zeros(0), empty, Jp, empty, empty, 0, _backend.codes.LAZY, lam, 0.0, 1.0, 1e-10
        )
        assert status == 0 and used == lam
        assert (rank == -1 and np.isnan(smin)) if skipped else (rank == 6 and smin > 0)
        assert np.allclose(Jp, _damped_oracle(J, lam), rtol=0, atol=1e-10)


@pytest.mark.parametrize("with_grad", [False, True])
@pytest.mark.parametrize("with_null", [False, True])
def test_the_lazy_rate_step_gives_the_bits_of_the_general_path(
    with_grad: bool, with_null: bool
) -> None:
    """``_step`` with LAZY damping takes the one-pass ``_lazy_step`` (J itself, the Gram
    matrix factored in place); FIXED damping takes the general path (eigenvalues first,
    then the same Cholesky solve): the joint velocities and null-space terms are the same
    bits. Below the shift bound, and with a NaN, LAZY falls back and reports as FIXED."""
    rng = np.random.default_rng(11)
    codes = _backend.codes
    for trial in range(50):
        J = rng.normal(size=(6, 7)) * 10.0 ** rng.uniform(-3, 3)
        xd, grad = rng.normal(size=6), rng.normal(size=7) if with_grad else np.zeros(0)
        lam = float(np.sqrt(np.trace(J @ J.T))) * (0.1 if trial % 2 else 2e-3)
        results = {}
        for mode in (codes.LAZY, codes.FIXED):
            out, null = np.empty(7), np.empty(7 if with_null else 0)
            status, rank, *_ = kernels._step(
                J, xd, grad, out, null, 0.7, codes.NO_WEIGHTS, np.zeros(0), np.zeros((0, 0)),
                mode, lam, 0.0, 1.0, 1e-10,
            )  # fmt: skip
            assert status == codes.OK
            results[mode] = (out, null, rank)
        assert results[codes.LAZY][2] == -1 and results[codes.FIXED][2] == 6
        np.testing.assert_array_equal(results[codes.LAZY][0], results[codes.FIXED][0])
        np.testing.assert_array_equal(results[codes.LAZY][1], results[codes.FIXED][1])
        expected = _damped_oracle(J, lam) @ xd
        if with_grad:
            Jp = _damped_oracle(J, lam)
            expected -= 0.7 * (np.eye(7) - Jp @ J) @ grad
        np.testing.assert_allclose(results[codes.LAZY][0], expected, rtol=1e-9, atol=1e-9)
    J = rng.normal(size=(6, 7))
    small = 1e-4 * float(np.sqrt(np.trace(J @ J.T)))  # below the shift bound: eigenvalues
    out = np.empty(7)
    args = (np.zeros(0), out, np.zeros(0), 0.0, codes.NO_WEIGHTS, np.zeros(0), np.zeros((0, 0)))
    status, rank, *_ = kernels._step(J, np.ones(6), *args, codes.LAZY, small, 0.0, 1.0, 1e-10)
    assert status == codes.OK and rank == 6
    bad = np.ones(6)
    bad[2] = np.nan
    status, *_ = kernels._step(J, bad, *args, codes.LAZY, 0.5, 0.0, 1.0, 1e-10)
    assert status == codes.XD_NONFINITE
