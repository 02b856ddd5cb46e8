"""Compiled dense QP solvers of the hard-limit step (internal): the two small QPs of
:class:`~redres.resolution.QPScheme` (formulas: :mod:`.qp`) solved inside numba, so that a
compiled step never returns to Python for DAQP.

Entry points (all arrays float64 C-contiguous but ``active``, int8; ``work`` of shape
:func:`work_shape` ``(n, m)`` or larger, preallocated by the caller):

* :func:`box_qp` ``(P, c, lo, hi, x, work, active) → (flag, iterations)``: the strictly
  convex box QP ``min ½ xᵀP x + cᵀx  s.t.  lo ≤ x ≤ hi`` (the least-violating QP, ``P =
  JᵀWJ + λ²I``), by a primal active-set method (Nocedal & Wright 2006, §16.5): on the
  working set (each joint free, at ``lo`` or at ``hi``) the Newton point of the free
  variables comes from a Cholesky factor of ``P_FF``; the step towards it stops at the
  first bound it hits, which joins the set; at the Newton point the bound with the most
  negative multiplier ``μ_k = ±(P x + c)_k`` leaves it. Warm start: ``x`` and ``active``
  on entry (the previous step's answer), clipped into the box.
  Calls :func:`_newton`.
* :func:`eq_box_qp` ``(J, b, x0, lo, hi, x, work, active) → (flag, iterations)``: the
  exact QP ``min ½‖x − x0‖²  s.t.  J x = b,  lo ≤ x ≤ hi``, by the dual active-set method
  of Goldfarb & Idnani (1983) with ``H = I``. The equalities are taken first
  (:func:`_independent_rows`: dependent rows are dropped when consistent); the start is
  the optimum on a working set of bounds whose multipliers are ≥ 0 (the previous step's
  ``active``, pruned; without it, none); then the most violated bound ``p`` (normal
  ``n_p = s e_p``, ``s = +1`` at ``lo``, ``−1`` at ``hi``) is added: with ``F`` the joints
  off the working set and ``w = (J_F J_Fᵀ)⁻¹ J e_p``, the primal step is ``z = s (e_p −
  J_Fᵀ w)`` on ``F`` (``zᵀn_p = 1 − e_pᵀJᵀw``), the working bounds' multipliers move by
  ``−t r_a``, ``r_a = −s_a s (J e_a)ᵀw``; the step ``t`` is the smaller of the full step
  (``p`` becomes active) and the first multiplier to reach zero (that bound leaves).
  Calls :func:`_independent_rows` (:func:`_distance2`), :func:`_start`, :func:`_factor`,
  :func:`_optimum`, :func:`_certified`.

Both finish with a clean solve on the final active set and one step of iterative
refinement, so that the answer equals any exact solver's (DAQP's) to rounding when the
active sets agree.

**Certificate of infeasibility.** ``eq_box_qp`` returns 0 only with a vector ``y`` that
proves ``{J x = b, lo ≤ x ≤ hi}`` empty by Farkas' lemma, ``yᵀb > max_{lo ≤ x ≤ hi} yᵀJ x =
Σ_k max(c_k lo_k, c_k hi_k)``, ``c = Jᵀy``, checked explicitly with a margin of 1e-12 of
the terms' size (:func:`_certified`). Two sources: a row of ``J`` that depends on the rows
before it with an inconsistent ``b`` (``y`` the dependency), and the Goldfarb–Idnani test
(``z = 0`` and no working bound with ``r_a > 0``: ``n_p = Jᵀr_E + Σ r_a n_a`` with all
``r_a ≤ 0``, whence ``y = −r_E``, ``r_E = s w``, gives ``yᵀb − max yᵀJx = b_p − n_pᵀx > 0``).

**Flags.** 1 optimal; 0 certified infeasible (``eq_box_qp``); −1 breakdown: iteration
limit (``4(n + m) + 10``), a working set whose ``J_F`` is nearly rank deficient (relative
pivot below 1e-6), a failed final check (bounds or multipliers off by more than 1e-9 of
their scale), an empty box or a bad ``work``: the caller then asks DAQP.

References:
    D. Goldfarb, A. Idnani, "A numerically stable dual method for solving strictly convex
    quadratic programs", Mathematical Programming 27 (1983) 1–33.
    J. Nocedal, S. J. Wright, *Numerical Optimization*, 2nd ed., Springer (2006), §16.5
    (active-set methods for convex QP) and §12.5 (Farkas' lemma).
"""

from __future__ import annotations

import math

from ..._compile import kernel
from ...linalg._dense_kernels import _cholesky, _cholesky_solve, _solve_lower_transposed

OPTIMAL, INFEASIBLE, BREAKDOWN = 1, 0, -1
# Pivots of the Gram matrix J_F J_Fᵀ are squared: rounding alone leaves ~1e-16 of a diagonal
# entry in an exactly dependent one, hence thresholds well above it.
_NEAR = 1e-12  # squared relative pivot below which a working set is refused (J_F: 1e-6)
_DEPENDENT = 1e-20  # squared relative distance at or below which a row of J is dependent
_SPD = 1e-15  # relative pivot of P_FF below which the box QP's P is not numerically definite
_ZERO_STEP = 1e-12  # ‖z‖² at or below which the added bound depends on the working set
_MAYBE_ZERO = 1e-9  # ‖z‖² below which a Farkas certificate is tried first (rounding in ‖z‖²)
_CHECK = 1e-9  # final check: bounds, multipliers and dropped rows, relative


def work_shape(n: int, m: int = 0) -> tuple[int, int]:
    """The smallest ``work`` (rows, columns) of :func:`box_qp` (``m = 0``) and
    :func:`eq_box_qp` for ``n`` variables and ``m`` equality rows."""
    return max(2 * n, 3 * m) + 8, max(n, m, 1)


# --------------------------------------------------------------------------- box QP


@kernel
def box_qp(P, c, lo, hi, x, work, active):
    """``argmin ½ xᵀP x + cᵀx  s.t.  lo ≤ x ≤ hi``, ``P`` (n, n) symmetric positive definite,
    ``c``, ``lo``, ``hi``, ``x`` (n,), ``active`` (n,) int8 (module docstring); ``x`` and
    ``active``: the warm start on entry, the optimum and its active set on exit. A joint
    with ``lo = hi`` stays at ``lo``. Returns ``(flag, iterations)``."""
    n = x.shape[0]
    if work.shape[0] < 2 * n + 8 or work.shape[1] < n:
        return BREAKDOWN, 0
    for k in range(n):
        if not lo[k] <= hi[k]:  # empty box or NaN bound
            return BREAKDOWN, 0
        if lo[k] == hi[k] or active[k] < 0:
            active[k], x[k] = -1, lo[k]
        elif active[k] > 0:
            active[k], x[k] = 1, hi[k]
        else:
            x[k] = min(max(x[k], lo[k]), hi[k]) if x[k] == x[k] else lo[k]
    v = work[2 * n]
    cap = 4 * n + 10
    for it in range(1, cap + 1):
        if not _newton(P, c, x, active, work, v, False):
            return BREAKDOWN, it
        alpha, block = 1.0, -1
        for k in range(n):
            if active[k] == 0:
                step = v[k] - x[k]
                if step < 0.0 and lo[k] - x[k] > alpha * step:
                    alpha, block = (lo[k] - x[k]) / step, k
                elif step > 0.0 and hi[k] - x[k] < alpha * step:
                    alpha, block = (hi[k] - x[k]) / step, k
        for k in range(n):
            if active[k] == 0:
                x[k] = v[k] if block < 0 else x[k] + alpha * (v[k] - x[k])
        if block >= 0:  # the first bound hit joins the working set
            active[block] = -1 if v[block] < x[block] else 1
            x[block] = lo[block] if active[block] < 0 else hi[block]
            continue
        release, worst = -1, 0.0
        for k in range(n):
            if active[k] != 0 and lo[k] < hi[k]:
                g, size = c[k], abs(c[k])
                for j in range(n):
                    g += P[k, j] * x[j]
                    size += abs(P[k, j] * x[j])
                mu = g if active[k] < 0 else -g
                if mu < -1e-12 * size and mu < worst:  # beyond the rounding of g: release
                    release, worst = k, mu
        if release < 0:  # optimal: one step of iterative refinement on the same factor
            _newton(P, c, x, active, work, v, True)
            for k in range(n):
                if not abs(x[k]) < math.inf:  # a NaN or infinite input got through
                    return BREAKDOWN, it
            return OPTIMAL, it
        active[release] = 0
    return BREAKDOWN, cap


@kernel
def _newton(P, c, x, active, work, v, refine):
    """The free variables' Newton point ``P_FF v_F = −(c_F + P_FA x_A)`` into ``v`` (F: joints
    with ``active = 0``), factoring ``P_FF`` into ``work[n:2n]``; with ``refine`` the factor
    is already there and ``x_F`` gets one refinement step ``P_FF d = −(P x + c)_F``.
    Returns False when ``P_FF`` is not numerically positive definite."""
    n = x.shape[0]
    G, L, r = work[:n], work[n : 2 * n], work[2 * n + 1]
    f = 0
    for k in range(n):
        if active[k] == 0:
            acc = -c[k]
            for j in range(n):
                if active[j] != 0 or refine:
                    acc -= P[k, j] * x[j]
            r[f] = acc
            if not refine:
                g = 0
                for j in range(k + 1):
                    if active[j] == 0:
                        G[f, g] = P[k, j]
                        g += 1
            f += 1
    if not refine:
        if not _cholesky(G, L, f, 0.0):
            return False
        for i in range(f):
            if L[i, i] * L[i, i] < _SPD * G[i, i]:
                return False
    _cholesky_solve(L, r, f)
    f = 0
    for k in range(n):
        if active[k] == 0:
            if refine:
                x[k] += r[f]
            else:
                v[k] = r[f]
            f += 1
    return True


# --------------------------------------------------------------------------- exact QP


@kernel
def eq_box_qp(J, b, x0, lo, hi, x, work, active):
    """``argmin ½‖x − x0‖²  s.t.  J x = b,  lo ≤ x ≤ hi``: ``J`` (m, n), ``b`` (m,), ``x0``,
    ``lo``, ``hi``, ``x`` (n,), ``active`` (n,) int8 (on entry the previous active set, a
    hint; on exit the optimum's). Goldfarb–Idnani, module docstring. Returns ``(flag,
    iterations)``: 1 optimal (``x`` written), 0 certified infeasible, −1 breakdown."""
    m, n = J.shape
    if work.shape[0] < max(2 * n, 3 * m) + 8 or work.shape[1] < max(n, m):
        return BREAKDOWN, 0
    for k in range(n):
        if not lo[k] <= hi[k]:
            return BREAKDOWN, 0
        if lo[k] == hi[k]:  # a fixed joint leaves the problem
            active[k], x[k] = -1, lo[k]
    Jk, base = work[2 * m : 3 * m], 3 * m
    bk, w, u, y = work[base], work[base + 1], work[base + 2], work[base + 3]
    mk, flag = _independent_rows(J, b, lo, hi, active, work, bk, work[base + 4], y)
    if flag != OPTIMAL:
        return flag, 0
    cap = 4 * (n + m) + 10
    it = _start(Jk, mk, bk, x0, lo, hi, active, work, x, y, u, cap)
    if it < 0:  # the previous active set is no start here: from no bound at all
        for k in range(n):
            if lo[k] < hi[k]:
                active[k] = 0
        it = _start(Jk, mk, bk, x0, lo, hi, active, work, x, y, u, cap)
        if it < 0:
            return BREAKDOWN, 0
    while True:  # add the most violated bound p
        p, most = -1, 0.0
        for k in range(n):
            if active[k] == 0:
                gap = max(lo[k] - x[k], x[k] - hi[k])
                if gap > 1e-13 * (1.0 + abs(x[k])) and gap > most:
                    p, most = k, gap
        if p < 0:
            break
        s = 1.0 if x[p] < lo[p] else -1.0
        up = 0.0
        while True:
            it += 1
            if it > cap:
                return BREAKDOWN, it
            L = work[m : 2 * m]
            for i in range(mk):
                w[i] = Jk[i, p]
            _cholesky_solve(L, w, mk)
            znp, free = 1.0, 0
            for i in range(mk):
                znp -= Jk[i, p] * w[i]
            for k in range(n):
                free += active[k] == 0
            if free <= mk:  # J_F square: e_p is in its row space, z = 0 exactly
                znp = 0.0
            t1, block = math.inf, -1
            for a in range(n):
                if active[a] != 0 and lo[a] < hi[a]:
                    acc = 0.0
                    for i in range(mk):
                        acc += Jk[i, a] * w[i]
                    y[a] = (1.0 if active[a] > 0 else -1.0) * s * acc  # r_a
                    if y[a] > 0.0 and u[a] < t1 * y[a]:
                        t1, block = u[a] / y[a], a
            if znp <= _MAYBE_ZERO and block < 0:  # n_p in the span of the working set?
                cert = work[base + 5]
                for i in range(mk):
                    cert[i] = -s * w[i]  # y = −r_E on the kept rows
                flag = _certified(J, b, lo, hi, cert, mk, work[base + 4])
                if flag == INFEASIBLE or znp <= _ZERO_STEP:
                    return flag, it
            t = t1
            if znp > _ZERO_STEP:
                t = min(t1, s * ((lo[p] if s > 0 else hi[p]) - x[p]) / znp)  # full step
                for k in range(n):
                    if active[k] == 0:
                        acc = 1.0 if k == p else 0.0
                        for i in range(mk):
                            acc -= Jk[i, k] * w[i]
                        x[k] += t * s * acc
            for a in range(n):
                if active[a] != 0 and lo[a] < hi[a]:
                    u[a] -= t * y[a]
            up += t
            if block < 0 or t < t1:  # full step: p joins the working set
                active[p] = -1 if s > 0 else 1
                x[p], u[p] = (lo[p] if s > 0 else hi[p]), up
                if not _factor(Jk, mk, active, work):
                    return BREAKDOWN, it
                break
            active[block], u[block] = 0, 0.0  # partial step: the blocking bound leaves
            if not _factor(Jk, mk, active, work):
                return BREAKDOWN, it
    # the clean solve on the final active set, refined once, and its check
    _optimum(Jk, mk, bk, x0, lo, hi, active, work, x, y, u, True)
    for k in range(n):
        size = _CHECK * (1.0 + abs(x[k]) + abs(x0[k]))
        if not size < math.inf:  # a NaN or infinite input got through
            return BREAKDOWN, it
        if active[k] == 0 and (x[k] < lo[k] - size or x[k] > hi[k] + size):
            return BREAKDOWN, it
        if active[k] != 0 and lo[k] < hi[k] and u[k] < -size:
            return BREAKDOWN, it
    for i in range(m):  # every row, the dropped ones too
        acc, size = b[i], abs(b[i])
        for k in range(n):
            acc -= J[i, k] * x[k]
            size += abs(J[i, k] * x[k])
        if not abs(acc) <= _CHECK * (size + 1e-300):  # (NaN included)
            return BREAKDOWN, it
    return OPTIMAL, it


@kernel
def _start(Jk, mk, bk, x0, lo, hi, active, work, x, nu, u, cap):
    """A dual feasible start: the optimum on the working set ``active`` (the previous
    step's), its bound with the most negative multiplier released until none is.
    Returns the number of releases, or −1 when a working set is nearly rank deficient."""
    n = x.shape[0]
    for k in range(n):
        if lo[k] < hi[k] and active[k] != 0:
            active[k] = -1 if active[k] < 0 else 1
    it = 0
    while it <= cap and _factor(Jk, mk, active, work):
        _optimum(Jk, mk, bk, x0, lo, hi, active, work, x, nu, u, False)
        drop, worst = -1, 0.0
        for k in range(n):
            if active[k] != 0 and lo[k] < hi[k] and u[k] < worst:
                drop, worst = k, u[k]
        if drop < 0:
            return it
        it += 1
        active[drop] = 0
    return -1


@kernel
def _independent_rows(J, b, lo, hi, active, work, bk, orig, y):
    """The rows of ``J`` that are independent on the joints that are not fixed (``lo <
    hi``), into ``Jk = work[2m:3m]`` with ``bk = b − J_fixed lo_fixed`` and their original
    index in ``orig``; the lower Cholesky factor of their Gram matrix in ``work[m:2m]``.
    A row dependent on the rows kept before it (relative distance ≤ 1e-10, computed
    directly: :func:`_distance2`) is dropped when
    ``b`` agrees; else the dependency proves the QP infeasible (:func:`_certified`).
    Returns ``(#kept, flag)``: OPTIMAL, INFEASIBLE, or BREAKDOWN for a nearly dependent
    row."""
    m, n = J.shape
    L, Jk, ell = work[m : 2 * m], work[2 * m : 3 * m], work[3 * m + 5]
    mk = 0
    for i in range(m):
        gii, bi = 0.0, b[i]
        for k in range(n):
            if lo[k] < hi[k]:
                gii += J[i, k] * J[i, k]
            else:
                bi -= J[i, k] * lo[k]
        d = gii
        for j in range(mk):
            acc = 0.0
            for k in range(n):
                if lo[k] < hi[k]:
                    acc += J[i, k] * Jk[j, k]
            for q in range(j):
                acc -= ell[q] * L[j, q]
            ell[j] = acc / L[j, j]
            d -= ell[j] * ell[j]
        if d > _NEAR * gii and gii > 0.0:
            for j in range(mk):
                L[mk, j], L[j, mk] = ell[j], 0.0
            L[mk, mk] = math.sqrt(d)
            for k in range(n):
                Jk[mk, k] = J[i, k] if lo[k] < hi[k] else 0.0
            bk[mk], orig[mk] = bi, i
            mk += 1
            continue
        _solve_lower_transposed(L, ell, mk)  # the dependency J_i ≈ Σ α_j J_kept_j: Lᵀα = ℓ
        if _distance2(J, i, lo, hi, Jk, L, mk, ell, work[3 * m + 1], work[3 * m + 2]) > (
            _DEPENDENT * gii
        ):
            return mk, BREAKDOWN  # nearly dependent: neither kept nor dropped safely
        e, size = bi, abs(bi)
        for j in range(mk):
            e -= ell[j] * bk[j]
            size += abs(ell[j] * bk[j])
        if abs(e) <= 1e-12 * size:  # consistent: J_i x = b_i follows from the kept rows
            continue
        sign = 1.0 if e > 0.0 else -1.0
        for j in range(mk):
            y[j] = -sign * ell[j]
        y[mk], orig[mk] = sign, i
        return mk, _certified(J, b, lo, hi, y, mk + 1, orig)
    return mk, OPTIMAL


@kernel
def _distance2(J, i, lo, hi, Jk, L, mk, alpha, r, t):
    """``‖r‖²``, ``r = J_i − Σ_j α_j Jk_j`` on the joints that are not fixed, computed
    directly and refined once (``α += G⁻¹ Jk r``, ``G = LLᵀ``; the Gram pivot alone carries
    the rounding of ``‖J_i‖²``, twice as many digits lost as here); ``α`` updated."""
    n = J.shape[1]
    total = 0.0
    for sweep in range(2):
        for k in range(n):
            acc = J[i, k] if lo[k] < hi[k] else 0.0
            for j in range(mk):
                acc -= alpha[j] * Jk[j, k]
            r[k] = acc
        if sweep == 1:
            break
        for j in range(mk):
            acc = 0.0
            for k in range(n):
                acc += Jk[j, k] * r[k]
            t[j] = acc
        _cholesky_solve(L, t, mk)
        for j in range(mk):
            alpha[j] += t[j]
    for k in range(n):
        total += r[k] * r[k]
    return total


@kernel
def _factor(Jk, mk, active, work):
    """Cholesky factor of ``G = J_F J_Fᵀ`` (kept rows, ``F`` the joints with ``active = 0``)
    into ``work[m:2m]`` (``G`` itself in ``work[:m]``); False when ``J_F`` is nearly rank
    deficient (a relative pivot below 1e-6)."""
    m = Jk.shape[0]
    G, L = work[:m], work[m : 2 * m]
    n = active.shape[0]
    for i in range(mk):
        for j in range(i + 1):
            acc = 0.0
            for k in range(n):
                if active[k] == 0:
                    acc += Jk[i, k] * Jk[j, k]
            G[i, j] = acc
    if not _cholesky(G, L, mk, 0.0):
        return False
    for i in range(mk):
        if L[i, i] * L[i, i] < _NEAR * G[i, i]:
            return False
    return True


@kernel
def _optimum(Jk, mk, bk, x0, lo, hi, active, work, x, nu, u, refine):
    """The optimum on the working set (bounds with ``active ≠ 0`` held, ``Jk x = bk``):
    ``x_F = x0_F + J_Fᵀν``, ``(J_F J_Fᵀ) ν = bk − J_A x_A − J_F x0_F`` on the factor of
    :func:`_factor`, with one refinement step when ``refine``; the bounds' multipliers
    ``u_a = s_a (x_a − x0_a − (Jᵀν)_a)`` (``s_a = +1`` at ``lo``, ``−1`` at ``hi``)."""
    n = x.shape[0]
    L = work[Jk.shape[0] : 2 * Jk.shape[0]]
    for k in range(n):
        x[k] = x0[k] if active[k] == 0 else (lo[k] if active[k] < 0 else hi[k])
    for k in range(mk):
        nu[k] = 0.0
    for _ in range(2 if refine else 1):
        r = work[3 * Jk.shape[0] + 6]
        for i in range(mk):
            acc = bk[i]
            for k in range(n):
                acc -= Jk[i, k] * x[k]
            r[i] = acc
        _cholesky_solve(L, r, mk)
        for i in range(mk):
            nu[i] += r[i]
        for k in range(n):
            if active[k] == 0:
                for i in range(mk):
                    x[k] += Jk[i, k] * r[i]
    for k in range(n):
        if active[k] != 0:
            acc = x[k] - x0[k]
            for i in range(mk):
                acc -= Jk[i, k] * nu[i]
            u[k] = acc if active[k] < 0 else -acc


@kernel
def _certified(J, b, lo, hi, yk, count, orig):
    """INFEASIBLE when ``y`` (``yk[j]`` on row ``orig[j]`` of ``J``, ``j < count``) proves
    ``{J x = b, lo ≤ x ≤ hi}`` empty by Farkas' lemma, ``yᵀb > Σ_k max(c_k lo_k, c_k
    hi_k)``, ``c = Jᵀy``, beyond 1e-12 of the terms' size; else BREAKDOWN."""
    n = J.shape[1]
    gap, size = 0.0, 0.0
    for j in range(count):
        term = yk[j] * b[int(orig[j])]
        gap += term
        size += abs(term)
    for k in range(n):
        ck = 0.0
        for j in range(count):
            ck += J[int(orig[j]), k] * yk[j]
        if ck != 0.0:
            bound = max(ck * lo[k], ck * hi[k])
            gap -= bound
            size += abs(bound)
    return INFEASIBLE if gap > 1e-12 * size and gap > 0.0 else BREAKDOWN
