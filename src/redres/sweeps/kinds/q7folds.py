"""The folds of the Panda's branches along ``q7`` (step 2 of :mod:`redres.sweeps.kinds.q7arcs`):
where two branches of the closed form meet and the self-motion turns back in ``q7``.

A branch of code ``b = 4 i4 + 2 iφ + is`` exists where both of its roots do: the elbow's
(``|x| ≤ 1``, step 2 of :mod:`redres.ik.analytic`) and the joint-5/6 condition's
(``|y| ≤ 1``, step 3); the kernel returns both arguments
(``roots`` of :class:`redres.ik.analytic.IKSolutionsBatch`). Two kinds of folds are found:

* **Between grid values** where a branch appears or vanishes (:func:`folds`): it is paired
  with the branch whose root merges with its own there (``b ^ 2``: step 3; ``b ^ 4``: the
  elbow), and the fold is found by the secant method on the squared joint-space distance
  ``d²`` between them (linear in ``q7`` near the fold: ``d ∝ √|q7 − q7*|``); for the
  elbow's pair on ``h = 1 − |x|`` instead (``d²`` to first order there), so that a
  branch that vanishes and comes back on the way does not stop the search.
* **Hidden between two samples** (:func:`hidden`), from the margin ``e = 1 − |y|`` of
  elbow root ``i4``'s condition at every ``q7`` evaluated so far: where ``e`` changes
  sign between two neighbouring values and no fold was found there (a search for
  another fold stepped over a hole of the pair), and where it has the same sign at
  three neighbouring values and an extreme toward 0 between them. That extreme is
  found by successive parabolic interpolation, and where ``e`` changes sign there, the
  pair ``(b, b ^ 2)`` lives on an *island* between two values where it does not (``e``
  rises above 0), or has a *hole* between two values where it does (``e`` dips below
  0). Each end is a fold, found as above from the side where the pair exists, and a
  sample without a branch is put just past it (it ends the run of samples there). An
  island or hole of the elbow's root (``x``) is not looked for: ``|W − S|²`` is a
  sinusoid in ``q7`` on these arms, so ``|x| ≤ 1`` holds on at most two arcs of the
  circle, each seen by the grid unless narrower than its step.

At each fold both branches are sampled where they are closer than :data:`FOLD_GAP`
(joint space), with their twins of the other shoulder sign (``b ^ 1``, folding at the
same ``q7``); the samples of the two sides of fold ``f`` are tagged ``2f`` and ``2f + 1``
(:mod:`.q7arcs` joins the runs there).
"""

from __future__ import annotations

import numpy as np

from .q7samples import (
    BranchSolver,
    Samples,
    distance2,
    narrowed,
    parabola_vertex,
    turns,
)

__all__ = ["FOLD_GAP", "Evaluated", "folds", "hidden"]

FOLD_GAP = 1e-4  #: rad: the two sides of a fold, apart in joint space (2-norm)
_FOLD_TOL = 1e-12  # rad: a bracket in q7 narrower than this: not a fold of the pair
_ELBOW_TOL = 1e-10  # 1 − |x| at an elbow's fold: the pair there ~1e-5 rad apart
_MERGE = 1e-12  # 1 − |x| below which the kernel returns one elbow root (MERGE_TOL)
_EXTRA = 3  # samples between a fold and the value its search started from
_HIDDEN_RANGE = 0.5  # an extreme of e this near 0 (from the samples) is looked into
_HIDDEN_ROUNDS = 16  # rounds of successive parabolic interpolation at most
_HIDDEN_TOL = 1e-7  # rad: a step of q7 below which the extreme is found


class Evaluated:
    """The roots' arguments at every ``(pose, q7)`` evaluated (:meth:`add`), for
    :func:`hidden`."""

    def __init__(self) -> None:
        self._parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        #: the folds of step 3's roots found, as keys ``2 pose + i4 + 1j q7``
        self.found: list[np.ndarray] = []

    def add(self, pose: np.ndarray, x: np.ndarray, roots: np.ndarray) -> None:
        self._parts.append((pose, x, roots))

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(pose (P,), q7 (P,), roots (P, 3))``."""
        if not self._parts:
            return np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3))
        return tuple(np.concatenate(p) for p in zip(*self._parts))  # type: ignore[return-value]


def folds(solver: BranchSolver, T: np.ndarray, g: np.ndarray, grid: tuple[np.ndarray, ...],
          s: Samples, seen: Evaluated) -> int:  # fmt: skip
    """Find the folds between grid values ``g`` (``grid``: configurations ``q``
    ``(N, 8, G, 7)``, whether within the limits ``(N, 8, G)``, the elbow's ``x``
    ``(N, G)``; module docstring) and sample both branches there and on the way to it.
    Returns how many folds (tags ``0`` to ``2 folds − 1``)."""
    q, inside, x = grid
    exists = np.isfinite(q[..., 0])
    change = exists[..., :-1] != exists[..., 1:]
    n, b, k = np.nonzero(change)
    side = np.where(exists[n, b, k], k, k + 1)  # where both exist

    def mate(x: np.ndarray) -> np.ndarray:  # a partner that vanishes there too
        return change[n, x, k] & exists[n, x, side]

    # the elbow's mate first when it vanishes too (every root ends: out of reach), else
    # the mate of step 3; then the other one where the first is no fold
    elbow = mate(b ^ 4)
    first, second = np.where(elbow, b ^ 4, b ^ 2), np.where(elbow, b ^ 2, b ^ 4)
    lead = (b & 1) == 0  # the shoulder's other sign (code b ^ 1) folds at the same q7
    done = np.zeros(change.shape, dtype=bool)
    tags = 0
    for partner in (first, second):
        fits = mate(partner) & (partner > b) & lead & ~done[n, b, k] & ~done[n, partner, k]
        fn, fb, fk, fs, fp = n[fits], b[fits], k[fits], side[fits], partner[fits]
        four = (fb, fp, fb ^ 1, fp ^ 1)  # the pair, and its twin of the other shoulder
        back = np.clip(2 * fs - (2 * fk + 1 - fs), 0, len(g) - 1)  # one grid value further
        qa = np.stack([q[fn, x, fs] for x in four], axis=1)
        ina = np.stack([inside[fn, x, fs] for x in four], axis=1)
        p, dp = g[back], distance2(q[fn, fb, back], q[fn, fp, back])  # NaN: either missing
        a, z = g[fs], g[2 * fk + 1 - fs]
        at_elbow = fp == fb ^ 4
        dp[at_elbow] = 1.0 - np.abs(x[fn, back])[at_elbow]
        ha = 1.0 - np.abs(x[fn, fs])
        ok = _secant(solver, T, fn, four, (a, z, p, dp, ha), qa, ina, seen, at_elbow)
        done[fn[ok], fb[ok], fk[ok]] = done[fn[ok], fp[ok], fk[ok]] = True
        phi = ok & ~at_elbow  # a fold of step 3's roots: the sign change of 1 − |y| found
        seen.found.append(2 * fn[phi] + (fb[phi] >> 2) + 1j * a[phi])
        tags = _add(solver, T, s, fn[ok], (fb[ok], fp[ok]), a[ok], qa[ok], ina[ok], g[fs][ok],
                    tags)  # fmt: skip
    return tags


def hidden(solver: BranchSolver, T: np.ndarray, s: Samples, seen: Evaluated, tags: int) -> int:
    """Find the islands and holes of the pairs ``(b, b ^ 2)`` between the values of ``q7``
    evaluated so far (module docstring), sample their folds, and return the new count of
    folds (their tags follow ``tags``)."""
    pose, x, roots = seen.arrays()
    key = np.concatenate((2 * pose, 2 * pose + 1))  # (pose, elbow root i4)
    xs = np.concatenate((x, x))
    e = 1.0 - np.abs(np.concatenate((roots[:, 1], roots[:, 2])))
    keep = np.isfinite(e)
    key, xs, e = key[keep], xs[keep], e[keep]
    order = np.argsort(key + 1j * xs)
    key, xs, e = key[order], xs[order], e[order]
    # a sign change between neighbouring values that no fold found explains (where a
    # search for another fold stepped over a hole)
    step = np.flatnonzero((key[1:] == key[:-1]) & ((e[1:] >= 0.0) != (e[:-1] >= 0.0)))
    up = e[step] >= 0.0  # the pair exists at the lower value
    a_x, z_x = np.where(up, xs[step], xs[step + 1]), np.where(up, xs[step + 1], xs[step])
    known = np.concatenate(seen.found) if seen.found else np.zeros(0, complex)
    new = ~np.isin(key[step] + 1j * a_x, known)
    change = (key[step][new] // 2, key[step][new] % 2, a_x[new], z_x[new])
    mid = np.flatnonzero((key[1:-1] == key[:-2]) & (key[1:-1] == key[2:])) + 1
    px = np.stack((xs[mid - 1], xs[mid], xs[mid + 1]), axis=1)
    sign = np.sign(e[mid])
    pe = np.stack((e[mid - 1], e[mid], e[mid + 1]), axis=1) * sign[:, None]  # > 0: same sign
    x3, e3 = tuple(px.T), tuple(pe.T)
    low = parabola_vertex(x3, e3)[1] < pe[:, 1]  # a minimum of sign · e: toward 0
    pick = ((pe > 0.0).all(axis=1) & (pe[:, 1] < _HIDDEN_RANGE) & (px[:, 0] < px[:, 1])
            & (px[:, 1] < px[:, 2]) & turns(x3, e3) & low)  # fmt: skip
    px, pe, sign = px[pick], pe[pick], sign[pick]
    n, i4 = key[mid[pick]] // 2, key[mid[pick]] % 2
    at = np.full(len(n), np.nan)  # where e changes sign: q7
    bracket = np.full((len(n), 2), np.nan)
    active = np.arange(len(n))
    for _ in range(_HIDDEN_ROUNDS):
        if not len(active):
            break
        lo, mid_x, hi = px[active, 0], px[active, 1], px[active, 2]
        v = parabola_vertex(tuple(px[active].T), tuple(pe[active].T))[0]
        wider = np.where(mid_x - lo > hi - mid_x, 0.5 * (lo + mid_x), 0.5 * (mid_x + hi))
        fits = np.isfinite(v) & (v > lo) & (v < hi)
        done = fits & (np.abs(v - mid_x) < _HIDDEN_TOL)
        v = np.where(fits & ~done, v, wider)
        every, _, found = solver.evaluate(T[n[active]], v)
        seen.add(n[active], v, found)
        ev = (1.0 - np.abs(found[np.arange(len(v)), 1 + i4[active]])) * sign[active]
        flipped = ~(ev > 0.0)  # NaN (the elbow out of reach): no longer the same sign
        at[active[flipped]], bracket[active[flipped]] = v[flipped], px[active[flipped]][:, ::2]
        px[active], pe[active] = narrowed(px[active], pe[active], v, ev, np.zeros(len(v), bool))
        active = active[~flipped & ~done & (px[active, 2] - px[active, 0] > _HIDDEN_TOL)]
    hit = np.flatnonzero(np.isfinite(at))
    n, i4, at, bracket, island = n[hit], i4[hit], at[hit], bracket[hit], sign[hit] < 0
    _sample(solver, T, n[island], at[island], s)  # the island's inside, where it was seen
    # each end: from where the pair exists (the island's inside, the hole's outside)
    # toward where it does not; then the sign changes between neighbouring values
    a = np.concatenate([np.where(island, at, bracket[:, j]) for j in (0, 1)] + [change[2]])
    z = np.concatenate([np.where(island, bracket[:, j], at) for j in (0, 1)] + [change[3]])
    n2 = np.concatenate((n, n, change[0]))
    b2 = 4 * np.concatenate((i4, i4, change[1]))
    if not len(a):
        return tags
    four = (b2, b2 ^ 2, b2 ^ 1, b2 ^ 3)
    every, within, found = solver.evaluate(T[n2], a)
    seen.add(n2, a, found)
    pick = np.arange(len(a))
    qa = np.stack([every[pick, x] for x in four], axis=1)
    ina = np.stack([within[pick, x] for x in four], axis=1)
    there = np.isfinite(qa[:, :2, 0]).all(axis=1)  # (an end at a merge: no pair to follow)
    n2, a, z, qa, ina = n2[there], a[there], z[there], qa[there], ina[there]
    four = tuple(x[there] for x in four)
    start = a.copy()
    nan = np.full(len(a), np.nan)
    ok = _secant(solver, T, n2, four, (a, z, nan, nan), qa, ina, seen)
    rows = np.stack([n2 * 8 + x for x in four], axis=1)[ok].ravel()
    empty = np.full((len(rows), 7), np.nan)  # no branch just past each fold: its run ends
    s.add(rows, np.repeat(z[ok], 4), empty, np.zeros(len(rows), dtype=bool))
    return _add(solver, T, s, n2[ok], (four[0][ok], four[1][ok]), a[ok], qa[ok], ina[ok],
                start[ok], tags)  # fmt: skip


def _add(solver: BranchSolver, T: np.ndarray, s: Samples, n: np.ndarray,
         pair: tuple[np.ndarray, np.ndarray], a: np.ndarray, qa: np.ndarray, ina: np.ndarray,
         start: np.ndarray, tags: int) -> int:  # fmt: skip
    """Add the samples of the folds of poses ``n`` at ``q7 = a`` (the pair and its twin,
    ``qa`` ``(F, 4, 7)``, tagged from ``tags``) and :data:`_EXTRA` samples between each
    fold and ``start``; returns the new count of folds."""
    four = (pair[0], pair[1], pair[0] ^ 1, pair[1] ^ 1)
    for j, branch in enumerate(four):
        has = np.isfinite(qa[:, j, 0])
        tag = 2 * (tags + 2 * np.arange(len(n)) + (j >= 2)) + j % 2  # fold, side
        s.add((n * 8 + branch)[has], a[has], qa[has, j], ina[has, j], tag[has])
    # samples evenly spaced in the curve's length from the start to the fold (q7 moves as
    # its square there): a joint may leave its limits and come back
    t = (np.arange(1, _EXTRA + 1) / (_EXTRA + 1)) ** 2
    _sample(solver, T, np.repeat(n, _EXTRA), (a[:, None] + (start - a)[:, None] * t).ravel(), s)
    return tags + 2 * len(n)


def _sample(
    solver: BranchSolver, T: np.ndarray, pose: np.ndarray, x: np.ndarray, s: Samples
) -> None:
    """Add every branch that exists at poses ``pose`` and ``q7`` values ``x``."""
    every, within = solver.all_branches(T[pose], x)
    i, b = np.nonzero(np.isfinite(every[..., 0]))
    s.add(pose[i] * 8 + b, x[i], every[i, b], within[i, b])


def _secant(solver: BranchSolver, T: np.ndarray, n: np.ndarray, four: tuple[np.ndarray, ...],
            start: tuple[np.ndarray, ...], qa: np.ndarray, ina: np.ndarray, seen: Evaluated,
            elbow: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
    """The secant on ``d²`` of the pairs ``four[:2]`` of poses ``n`` from ``a`` (where both
    exist), bracketed by ``z`` (where they do not), ``start = (a, z, p, dp)`` with ``p`` a
    previous point and ``dp`` its ``d²`` (NaN: none). Where ``elbow``, the pair meets
    at the elbow's fold: the secant is on ``h = 1 − |x|`` (``dp`` is ``h`` at ``p``),
    which is ``d²`` to first order there, and ``a`` is where the elbow reaches (``h``
    above the kernel's merge tolerance, the pair there or not: one of them may vanish
    before the fold and come back). Updates ``a``, ``z``, the configurations ``qa``
    ``(F, 4, 7)`` at ``a`` of the pair and its twin (``four[2:]``; NaN where there is
    none) and ``ina``, whether each is within the limits, in place; returns whether the
    pair met (``d <`` :data:`FOLD_GAP`, or ``h <`` :data:`_ELBOW_TOL` with the pair there)."""
    a, z, p, dp = start[:4]
    elbow = np.zeros(len(a), dtype=bool) if elbow is None else elbow
    da = np.where(elbow, start[4] if len(start) > 4 else np.nan, 0.0)
    da[~elbow] = distance2(qa[~elbow, 0], qa[~elbow, 1])
    tol = np.where(elbow, _ELBOW_TOL, FOLD_GAP**2)
    missed = np.zeros(len(a), dtype=bool)
    busy = (np.abs(z - a) > _FOLD_TOL) & (da > tol)
    while busy.any():
        act = np.flatnonzero(busy)
        with np.errstate(divide="ignore", invalid="ignore"):
            c = a[act] - da[act] * (a[act] - p[act]) / (da[act] - dp[act])
        # past the bracket (the secant's root is just past the fold): most of the way
        # to its end, or half-way after such a step missed
        secant = np.isfinite(c) & ((c - a[act]) * (z[act] - c) > 0.0)
        c = np.where(secant, c, a[act] + np.where(missed[act], 0.5, 0.9) * (z[act] - a[act]))
        every, within, roots = solver.evaluate(T[n[act]], c)
        seen.add(n[act], c, roots)
        pick = np.arange(len(act))
        pair = np.stack([every[pick, x[act]] for x in four], axis=1)
        h = 1.0 - np.abs(roots[:, 0])
        both = np.where(elbow[act], h >= _MERGE, np.isfinite(pair[:, :2, 0]).all(axis=1))
        hit, miss = act[both], act[~both]
        p[hit], dp[hit] = a[hit], da[hit]
        a[hit] = c[both]
        da[hit] = np.where(elbow[hit], h[both], distance2(pair[both, 0], pair[both, 1]))
        qa[hit] = pair[both]
        ina[hit] = np.stack([within[pick, x[act]] for x in four], axis=1)[both]
        z[miss] = c[~both]
        missed[act] = ~both & ~secant
        busy[act] = (np.abs(z[act] - a[act]) > _FOLD_TOL) & (da[act] > tol[act])
    return (da <= tol) & np.isfinite(qa[:, :2, 0]).all(axis=1)
