"""The compiled dense QP solvers of the hard-limit step (``_dense_qp_kernels``): the box QP
(least violating) and the exact QP ``min ½‖x − x0‖² s.t. J x = b, lo ≤ x ≤ hi``.

Oracles: DAQP (``primal_tol=1e-10``, as :class:`~redres.resolution.QPScheme` calls it),
ProxQP through qpsolvers, the Karush-Kuhn-Tucker conditions checked directly, SciPy's HiGHS
for feasibility, and Farkas' lemma for every infeasible verdict. Agreement: ``x`` to 1e-12 of
``‖x‖∞ + 1`` where the active sets agree (else 1e-10), both widened by the condition number
of the free block over 1e4 (the data's own accuracy: neither solver can do better, and a
high-precision solve of the same block shows it); the states are random problems of the
hard-limit sizes and every QP :class:`~redres.resolution.QPScheme` solves on the states of
``test_qp.py`` and ``test_near_singular.py``.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import daqp
import numpy as np
import pytest
import qpsolvers
from scipy.optimize import linprog

import redres as rr
from redres import _compile
from redres.resolution import QPScheme
from redres.resolution.hard_limits import _solvers
from redres.resolution.hard_limits._compiled import kernels
from redres.testing import random_limit_states, step_from_states

from .test_near_singular import near_singular_tasks

K = kernels("_dense_qp_kernels")
COMPILED = _compile.enabled()
COUNT = 3000 if COMPILED else 300  # random problems per size
STATES = 2000 if COMPILED else 300  # hard-limit states replayed (test_qp.py runs 2000)
SIZES = [(7, 3), (7, 4), (7, 5), (7, 6), (6, 3), (6, 6), (9, 6)]


def solve_eq(J, b, x0, lo, hi, x=None, active=None) -> tuple[int, int, np.ndarray, np.ndarray]:
    m, n = J.shape
    x = np.zeros(n) if x is None else x.copy()
    active = np.zeros(n, np.int8) if active is None else active.copy()
    work = np.zeros(K.work_shape(n, m))
    flag, it = K.eq_box_qp(J, b, x0, lo, hi, x, work, active)
    return flag, it, x, active


def solve_box(P, c, lo, hi, x=None, active=None) -> tuple[int, int, np.ndarray, np.ndarray]:
    n = c.shape[0]
    x = np.zeros(n) if x is None else x.copy()
    active = np.zeros(n, np.int8) if active is None else active.copy()
    flag, it = K.box_qp(P, c, lo, hi, x, np.zeros(K.work_shape(n)), active)
    return flag, it, x, active


def daqp_qp(H, f, A, b, lo, hi) -> tuple[np.ndarray | None, np.ndarray]:
    """DAQP's optimum (None: infeasible) and its active bounds (−1, 0, +1)."""
    n, m = f.shape[0], b.shape[0]
    sense = np.zeros(n + m, np.intc)
    sense[n:] = 5
    x, _, flag, info = daqp.solve(H, f, A, np.concatenate([hi, b]), np.concatenate([lo, b]),
                                  sense, primal_tol=1e-10)  # fmt: skip
    lam = info["lam"][:n]
    return (x if flag > 0 else None), np.sign(lam).astype(np.int8)


def farkas(J, b, lo, hi, y) -> bool:
    """``y`` proves ``{J x = b, lo ≤ x ≤ hi}`` empty."""
    c = J.T @ y
    return bool(y @ b > np.maximum(c * lo, c * hi).sum() + 1e-9 * (abs(y) @ abs(b)))


def feasible(J, b, lo, hi) -> bool | None:
    """HiGHS' verdict, None when it is too close to call (the task met to 1e-7 only)."""
    res = linprog(np.zeros(J.shape[1]), A_eq=J, b_eq=b, bounds=list(zip(lo, hi)), method="highs")
    if res.status == 2:
        return False
    if res.status == 0 and np.allclose(J @ res.x, b, atol=1e-11, rtol=0):
        return True
    return None


def kappa(M: np.ndarray) -> float:
    return float(np.linalg.cond(M)) if M.size else 1.0


def tolerance(x: np.ndarray, same: bool, block: np.ndarray) -> float:
    """1e-12 (same active set) or 1e-10 of ``‖x‖∞ + 1``, times ``κ(block)/1e3`` when larger
    (a forward error bound: about 5 ε κ)."""
    return (1e-12 if same else 1e-10) * (1.0 + np.abs(x).max()) * max(1.0, kappa(block) * 1e-3)


def reference(H, f, J, b, lo, hi, active) -> np.ndarray:
    """The optimum on a given active set by LAPACK, refined once: an oracle independent of
    both solvers. With equalities (``H = I``): ``x_F = x0_F + J_F⁺(b − J x)``, the
    minimum-norm least-squares solution by SVD (error ~ ε κ(J_F), where the KKT matrix's
    solve loses κ(J_F)²); without: ``P_FF x_F = −(c + P x_A)_F``."""
    F = np.flatnonzero((active == 0) & (lo < hi))
    x = np.where(active > 0, hi, lo).astype(float)
    if J.size:
        x[F] = -f[F]
    for _ in range(2):
        if J.size:
            x[F] += np.linalg.lstsq(J[:, F], b - J @ x, rcond=None)[0]
        elif F.size:
            x[F] += np.linalg.solve(H[np.ix_(F, F)], -(H @ x + f)[F])
    return x


def eq_kkt(J, b, x0, lo, hi, x, active) -> float:
    """Largest violation of the exact QP's KKT conditions at ``x`` with ``active``."""
    worst = max(float(np.abs(J @ x - b).max(initial=0.0)), float((lo - x).max()),
                float((x - hi).max()))  # fmt: skip
    free = active == 0
    g = x - x0
    nu = np.linalg.lstsq(J[:, free].T, g[free], rcond=None)[0] if free.any() else np.zeros(len(b))
    r = g - J.T @ nu  # the bounds' multipliers: ≥ 0 at lo, ≤ 0 at hi, 0 when free
    fixed = lo == hi
    worst = max(worst, float(np.abs(r[free]).max(initial=0.0)))
    worst = max(worst, float((-r[(active < 0) & ~fixed]).max(initial=0.0)))
    return max(worst, float(r[(active > 0) & ~fixed].max(initial=0.0)))


def box_kkt(P, c, lo, hi, x) -> float:
    """Projected-gradient residual of the box QP at ``x`` (0 exactly at the optimum)."""
    return float(np.abs(x - np.clip(x - (P @ x + c), lo, hi)).max())


def random_eq(rng: np.random.Generator, n: int, m: int) -> tuple[np.ndarray, ...]:
    """A random exact QP: boxes tight to loose, ``x0`` inside or out, targets small to
    large (some infeasible), Jacobian-like conditioning."""
    U, _, Vt = np.linalg.svd(rng.normal(size=(m, n)), full_matrices=False)
    J = (U * 10.0 ** rng.uniform(-2, 0.5, m)) @ Vt
    width = 10.0 ** rng.uniform(-2, 0.5)
    lo, hi = -width * rng.uniform(0.0, 1.0, n), width * rng.uniform(0.0, 1.0, n)
    fixed = rng.random(n) < 0.03
    lo[fixed] = hi[fixed]
    x0 = rng.normal(size=n) * 10.0 ** rng.uniform(-2, 0.5)
    stretch = 1.0 if rng.random() < 0.5 else rng.uniform(0.5, 3)  # > 1: often infeasible
    b = stretch * (J @ (lo + (hi - lo) * rng.uniform(0, 1, n)))
    return J, b, x0, lo, hi


def random_box(rng: np.random.Generator, n: int, m: int) -> tuple[np.ndarray, ...]:
    """A random least-violating QP ``P = JᵀWJ + λ²I``, ``c = −JᵀWẋ − λ²q̇_0``."""
    J, b, x0, lo, hi = random_eq(rng, n, m)
    w, lam2 = rng.uniform(0.5, 2.0, m), 10.0 ** rng.uniform(-6, -2)
    P = J.T @ (w[:, None] * J) + lam2 * np.eye(n)
    return P, -J.T @ (w * b) - lam2 * x0, lo, hi


def check_eq(J, b, x0, lo, hi, result, counts: dict[str, int]) -> None:
    flag, _, x, active = result
    xd, dactive = daqp_qp(np.eye(len(x0)), -x0, J, b, lo, hi)
    if flag == -1:
        counts["breakdown"] += 1
        return
    if flag == 0:
        assert xd is None, "called infeasible, DAQP solved it"
        counts["infeasible"] += 1
        return
    assert flag == 1
    assert eq_kkt(J, b, x0, lo, hi, x, active) <= 1e-9 * (1 + np.abs(x).max() + np.abs(b).max())
    if xd is None:  # DAQP missed a feasible task; HiGHS must not call it infeasible
        assert feasible(J, b, lo, hi) is not False
        counts["daqp_missed"] += 1
        return
    compare(np.eye(len(x0)), -x0, J, b, lo, hi, x, active, xd, dactive, counts)


def compare(H, f, J, b, lo, hi, x, active, xd, dactive, counts: dict[str, int]) -> None:
    """Where the active sets agree: ``x`` equals the LAPACK solve on it to 1e-12 and DAQP's
    to 1e-10 (DAQP's own accuracy, seen off by 3e-12 on a vertex); else DAQP's to 1e-10."""
    free = active == 0
    block = H[np.ix_(free, free)] if not J.size else J[:, free] @ J[:, free].T
    same = bool(np.all(active[lo < hi] == dactive[lo < hi]))
    if same:
        ref = reference(H, f, J, b, lo, hi, active)
        assert np.abs(x - ref).max() <= tolerance(ref, True, block), np.abs(x - ref).max()
        off = np.abs(x - ref).max() / (1 + np.abs(ref).max())
        counts["over_1e-12_lapack"] += int(off > 1e-12)
    assert np.abs(x - xd).max() <= tolerance(xd, False, block), (same, np.abs(x - xd).max())
    off = np.abs(x - xd).max() / (1 + np.abs(xd).max())
    counts["over_1e-12_daqp"] += int(off > 1e-12)
    counts["over_1e-10_daqp"] += int(off > 1e-10)
    counts["same" if same else "other"] += 1


def check_box(P, c, lo, hi, result, counts: dict[str, int]) -> None:
    flag, _, x, active = result
    xd, dactive = daqp_qp(P, c, np.zeros((0, len(c))), np.zeros(0), lo, hi)
    assert xd is not None
    if flag == -1:
        counts["breakdown"] += 1
        return
    assert flag == 1 and np.all(lo <= x) and np.all(x <= hi)
    assert box_kkt(P, c, lo, hi, x) <= 1e-12 * (1 + np.abs(c).max() + np.abs(P).max())
    compare(P, c, np.zeros((0, len(c))), np.zeros(0), lo, hi, x, active, xd, dactive, counts)


def tally() -> dict[str, int]:
    names = ("same", "other", "infeasible", "breakdown", "daqp_missed")
    return dict.fromkeys((*names, "over_1e-12_lapack", "over_1e-12_daqp", "over_1e-10_daqp"), 0)


@pytest.mark.parametrize(("n", "m"), SIZES)
def test_exact_qp_agrees_with_daqp_and_kkt(n: int, m: int) -> None:
    rng = np.random.default_rng(100 * n + m)
    counts = tally()
    for _ in range(COUNT):
        J, b, x0, lo, hi = random_eq(rng, n, m)
        result = solve_eq(J, b, x0, lo, hi)
        check_eq(J, b, x0, lo, hi, result, counts)
        # warm: from its own answer (no iteration), then from a wrong active set
        flag, it, x, _ = solve_eq(J, b, x0, lo, hi, result[2], result[3])
        assert flag == result[0]
        if flag == 1:
            assert it == 0 and np.abs(x - result[2]).max() <= 1e-14 * (1 + np.abs(x).max())
        wrong = rng.integers(-1, 2, n).astype(np.int8)
        check_eq(J, b, x0, lo, hi, solve_eq(J, b, x0, lo, hi, None, wrong), counts)
    assert counts["breakdown"] <= 0.005 * 2 * COUNT, counts
    assert counts["same"] >= 0.1 * COUNT and counts["infeasible"] >= 0.1 * COUNT, counts


@pytest.mark.parametrize(("n", "m"), SIZES)
def test_box_qp_agrees_with_daqp_and_kkt(n: int, m: int) -> None:
    rng = np.random.default_rng(200 * n + m)
    counts = tally()
    for _ in range(COUNT):
        P, c, lo, hi = random_box(rng, n, m)
        result = solve_box(P, c, lo, hi, rng.normal(size=n))
        check_box(P, c, lo, hi, result, counts)
        flag, it, x, _ = solve_box(P, c, lo, hi, result[2], result[3])  # warm: done at once
        assert flag == 1 and it == 1
        assert np.abs(x - result[2]).max() <= 1e-14 * (1 + np.abs(x).max())
        wrong = rng.integers(-1, 2, n).astype(np.int8)
        check_box(P, c, lo, hi, solve_box(P, c, lo, hi, rng.normal(size=n), wrong), counts)
    assert counts["breakdown"] == 0, counts


def test_units_do_not_matter(rng: np.random.Generator) -> None:
    """Problems scaled by 1e-3 … 1e3 (``J``) and 1e-4 … 1e2 (velocities), some boxes 1e4
    times wider: DAQP's verdict, the KKT conditions relative to the data, no breakdown."""
    for k in range(2000 if COMPILED else 300):
        n, m = SIZES[k % len(SIZES)]
        J, b, x0, lo, hi = random_eq(rng, n, m)
        sJ, sv = 10.0 ** rng.uniform(-3, 3), 10.0 ** rng.uniform(-4, 2)
        wide = 1e4 if rng.random() < 0.1 else 1.0
        J, b, x0, lo, hi = sJ * J, sJ * sv * b, sv * x0, sv * wide * lo, sv * wide * hi
        flag, _, x, active = solve_eq(J, b, x0, lo, hi)
        assert flag == (1 if daqp_qp(np.eye(n), -x0, J, b, lo, hi)[0] is not None else 0)
        size = 1 + np.abs(x).max() + np.abs(b).max() + np.abs(x0).max()
        assert flag == 0 or eq_kkt(J, b, x0, lo, hi, x, active) <= 1e-9 * size
        P = J.T @ J + 1e-6 * sJ**2 * np.eye(n)
        c = -J.T @ b - 1e-6 * sJ**2 * x0
        flag, _, x, _ = solve_box(P, c, lo, hi, sv * rng.normal(size=n))
        assert flag == 1
        size = 1 + np.abs(c).max() + np.abs(P).max() * np.abs(x).max()
        assert box_kkt(P, c, lo, hi, x) <= 1e-11 * size


def test_warm_starts_along_a_drifting_problem(rng: np.random.Generator) -> None:
    """A control loop's sequence: each QP a small change of the last, warm-started from
    its answer, equals the cold solve and takes fewer iterations in total."""
    J, b, x0, lo, hi = random_eq(rng, 7, 6)
    P, c, _, _ = random_box(rng, 7, 6)
    x, active, xb, ab = np.zeros(7), np.zeros(7, np.int8), np.zeros(7), np.zeros(7, np.int8)
    warm = cold = 0
    for _ in range(300 if COMPILED else 60):
        J = J + 1e-3 * rng.normal(size=J.shape)
        b, c = b + 1e-3 * rng.normal(size=6), c + 1e-3 * rng.normal(size=7)
        flag, it, x_new, a_new = solve_eq(J, b, x0, lo, hi, x, active)
        ref = solve_eq(J, b, x0, lo, hi)
        assert flag == ref[0]
        if flag == 1:
            x, active = x_new, a_new
            assert np.abs(x - ref[2]).max() <= 1e-10 * (1 + np.abs(x).max())
            warm, cold = warm + it, cold + ref[1]
        flag, it, xb_new, ab_new = solve_box(P, c, lo, hi, xb, ab)
        ref = solve_box(P, c, lo, hi)
        assert flag == 1 and np.abs(xb_new - ref[2]).max() <= 1e-10 * (1 + np.abs(xb_new).max())
        xb, ab, warm, cold = xb_new, ab_new, warm + it, cold + ref[1]
    assert warm < cold


def test_infeasible_verdicts_hold_a_farkas_certificate(rng: np.random.Generator) -> None:
    """Every "infeasible" is confirmed by HiGHS (an independent LP solver); every exact
    answer is feasible by HiGHS too."""
    verdicts = {0: 0, 1: 0}
    for _ in range(400 if COMPILED else 100):
        n, m = SIZES[int(rng.integers(len(SIZES)))]
        J, b, x0, lo, hi = random_eq(rng, n, m)
        flag = solve_eq(J, b, x0, lo, hi)[0]
        if flag >= 0:
            assert feasible(J, b, lo, hi) is not (flag == 0)
            verdicts[flag] += 1
    assert min(verdicts.values()) >= 20, verdicts


def test_proxqp_agrees(rng: np.random.Generator) -> None:
    """ProxQP (an augmented-Lagrangian solver; optimum to its tolerance, 1e-9 here)."""
    for _ in range(200 if COMPILED else 50):
        J, b, x0, lo, hi = random_eq(rng, 7, int(rng.integers(3, 7)))
        flag, _, x, _ = solve_eq(J, b, x0, lo, hi)
        other = qpsolvers.solve_qp(np.eye(7), -x0, None, None, J, b, lo, hi, solver="proxqp",
                                   eps_abs=1e-11, eps_rel=0.0)  # fmt: skip
        if flag == 1 and other is not None:
            assert np.abs(x - other).max() <= 1e-7 * (1 + np.abs(x).max())
        P, c, lo, hi = random_box(rng, 7, int(rng.integers(3, 7)))
        xb = solve_box(P, c, lo, hi)[2]
        other = qpsolvers.solve_qp(P, c, lb=lo, ub=hi, solver="proxqp", eps_abs=1e-11,
                                   eps_rel=0.0)  # fmt: skip
        assert 0.5 * xb @ P @ xb + c @ xb <= 0.5 * other @ P @ other + c @ other + 1e-10


# ------------------------------------------------------------------- degenerate cases


def test_degenerate_problems() -> None:
    rng = np.random.default_rng(5)
    J, b, x0, lo, hi = random_eq(rng, 7, 5)
    b = J @ (0.5 * (lo + hi))  # feasible
    cases = []
    fixed_lo, fixed_hi = lo.copy(), hi.copy()
    fixed_lo[2] = fixed_hi[2] = 0.3 * hi[2]  # lo == hi for a joint
    cases.append((J, J @ np.clip(0.5 * (lo + hi), fixed_lo, fixed_hi), x0, fixed_lo, fixed_hi))
    on = np.clip(x0, lo, hi)
    on[[0, 3]] = lo[0], hi[3]  # q̇0 exactly on bounds
    cases.append((J, b, on, lo, hi))
    cases.append((np.eye(7)[:5], on[:5], on, lo, hi))
    cases.append((J[:4], b[:4], np.clip(x0, lo, hi), lo, hi))
    for case in cases:
        flag, _, x, active = solve_eq(*case)
        xd, _ = daqp_qp(np.eye(7), -case[2], *case[:2], *case[3:])
        assert flag == 1 and xd is not None and np.abs(x - xd).max() <= 1e-12
        assert eq_kkt(*case, x, active) <= 1e-12
    # a zero row: ignored when its target is 0, a certified infeasibility when not
    Jz, bz = J.copy(), b.copy()
    Jz[1], bz[1] = 0.0, 0.0
    flag, _, x, _ = solve_eq(Jz, bz, x0, lo, hi)
    keep = [0, 2, 3, 4]
    assert flag == 1 and np.abs(x - solve_eq(Jz[keep], bz[keep], x0, lo, hi)[2]).max() == 0.0
    bz[1] = 1e-3
    assert solve_eq(Jz, bz, x0, lo, hi)[0] == 0
    # duplicated rows: the same, consistent or not
    Jd, bd = np.vstack([J, J[2]]), np.concatenate([b, b[2:3]])
    flag, _, x, _ = solve_eq(Jd, bd, x0, lo, hi)
    assert flag == 1 and np.abs(x - solve_eq(J, b, x0, lo, hi)[2]).max() <= 1e-14
    bd[-1] += 1e-6
    assert solve_eq(Jd, bd, x0, lo, hi)[0] == 0
    # m = n: a single point, in the box or not
    Js = rng.normal(size=(7, 7))
    inside = Js @ (0.5 * (lo + hi))
    flag, _, x, _ = solve_eq(Js, inside, x0, lo, hi)
    assert flag == 1 and np.abs(x - 0.5 * (lo + hi)).max() <= 1e-12
    assert solve_eq(Js, Js @ (hi + 0.1), x0, lo, hi)[0] == 0
    # box QP: lo == hi, and a start on the bounds
    P, c, blo, bhi = random_box(rng, 7, 6)
    blo[4] = bhi[4] = 0.0
    flag, _, x, _ = solve_box(P, c, blo, bhi, blo.copy(), np.full(7, -1, np.int8))
    xd = daqp_qp(P, c, np.zeros((0, 7)), np.zeros(0), blo, bhi)[0]
    assert flag == 1 and x[4] == 0.0 and np.abs(x - xd).max() <= 1e-10


def test_bad_inputs_break_down_instead_of_answering() -> None:
    J, b, x0 = np.eye(3)[:2], np.ones(2), np.zeros(3)
    lo, hi = -np.ones(3), np.ones(3)
    assert solve_eq(J, b, x0, np.array([1.0, -1, -1]), np.array([0.0, 1, 1]))[0] == -1
    work = np.zeros((2, 2))  # too small
    assert K.eq_box_qp(J, b, x0, lo, hi, np.zeros(3), work, np.zeros(3, np.int8))[0] == -1
    c = np.ones(3)
    assert K.box_qp(np.eye(3), c, lo, hi, np.zeros(3), work, np.zeros(3, np.int8))[0] == -1
    with np.errstate(all="ignore"):  # (the plain-Python twin computes with the NaN)
        for bad in (np.nan, np.inf):  # never an "optimal" answer with a NaN in it
            for k in range(3):
                args = [J.copy(), b.copy(), x0.copy()]
                args[k].flat[1] = bad
                assert solve_eq(*args, lo, hi)[0] != 1, (bad, k)
            for k in range(2):
                args = [np.eye(3), c.copy()]
                args[k].flat[1] = bad
                assert solve_box(*args, lo, hi)[0] == -1, (bad, k)
    nearly = np.array([[1.0, 0, 0], [1.0, 3e-7, 0]])  # nearly dependent rows, refused
    assert solve_eq(nearly, np.array([0.5, 0.5 + 1e-9]), x0, lo, hi)[0] == -1
    exactly = np.array([[1.0, 0, 0], [1.0, 1e-12, 0]])  # dependent to rounding, consistent
    assert solve_eq(exactly, np.array([0.5, 0.5]), x0, lo, hi)[:3:2][0] == 1


# ------------------------------------------------- every QP of the hard-limit test suite


class Recorder:
    """Every QP that ``QPScheme`` hands to DAQP (``WarmQP.solve``), as solved, by source."""

    def __init__(self) -> None:
        self.source = ""
        self.exact: dict[str, list[tuple[np.ndarray, ...]]] = {}
        self.box: dict[str, list[tuple[np.ndarray, ...]]] = {}

    def wrap(self, solve: Any) -> Any:
        def recording(qp: _solvers.WarmQP, H=None, f=None, A=None, bupper=None, blower=None):
            data = getattr(qp, "_seen", None) or dict(qp._data)
            new = {"H": H, "f": f, "A": A, "bupper": bupper, "blower": blower}
            data.update({k: np.array(v) for k, v in new.items() if v is not None})
            qp._seen = data  # type: ignore[attr-defined]
            P, c, G, bu, bl = (np.array(data[k]) for k in ("H", "f", "A", "bupper", "blower"))
            n, m = c.shape[0], G.shape[0]
            if m and np.all(data["sense"][n:] == 5) and np.array_equal(P, np.eye(n)):
                self.exact.setdefault(self.source, []).append((G, bu[n:], -c, bl[:n], bu[:n]))
            elif not m:
                self.box.setdefault(self.source, []).append((P, c, bl, bu))
            return solve(qp, H, f, A, bupper, blower)

        return recording


@pytest.fixture(scope="module")
def suite_qps() -> Iterator[Recorder]:
    recorder = Recorder()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_solvers.WarmQP, "solve", recorder.wrap(_solvers.WarmQP.solve))
        robot = rr.models.panda()
        recorder.source = "test_qp"
        states = random_limit_states(robot, np.random.default_rng(11), STATES)
        step_from_states(QPScheme(dt=1e-3), robot, states)
        recorder.source = "test_near_singular"
        for robot, q, J, xd in near_singular_tasks(18):
            QPScheme(1e-3).step(robot, q, J, xd)
    yield recorder


@pytest.mark.parametrize("source", ["test_qp", "test_near_singular"])
def test_every_qp_of_the_hard_limit_suite(suite_qps: Recorder, source: str) -> None:
    """Same verdict as DAQP; ``q̇`` to 1e-12 where the active sets agree, else 1e-10. A
    breakdown (the scheme then asks DAQP) only at a nearly singular ``J`` (σ_min/σ_max
    below 1e-6), and none on ``test_qp.py``'s states; the counts are printed."""
    exact, boxes = tally(), tally()
    for J, b, x0, lo, hi in suite_qps.exact[source]:
        before = exact["breakdown"]
        check_eq(J, b, x0, lo, hi, solve_eq(J, b, x0, lo, hi), exact)
        if exact["breakdown"] > before:
            s = np.linalg.svd(J, compute_uv=False)
            assert s[-1] < 1e-6 * s[0]
    for P, c, lo, hi in suite_qps.box[source]:
        check_box(P, c, lo, hi, solve_box(P, c, lo, hi, np.clip(np.zeros(len(c)), lo, hi)), boxes)
    total = len(suite_qps.exact[source]), len(suite_qps.box[source])
    print(f"\n{source}: exact QPs {total[0]} {exact}; box QPs {total[1]} {boxes}")
    assert boxes["breakdown"] == 0, boxes
    if source == "test_qp":
        assert total[0] >= STATES // 10 and total[1] >= STATES // 4
        assert exact["breakdown"] == 0, exact
