"""Compiled dynamic programming over the nodes of a path's grid (internal).

Entry points and their call tree::

    sort_samples(q, start, delta, order, keys, key)
        per sample, the joint that separates its nodes best (``key``), and its nodes in
        order of that joint (``order``, ``keys``)
    forward(q, start, order, keys, key, delta, active, value, bottleneck, edge_weight,
            best, parent, reached, counts)
        _successors (_window, _allowed): the DP recursion (redres.plan.dp docstring)
    backward(q, start, order, keys, key, delta, active, ends)
        _successors: which nodes lead to the last sample
    components(q, start, order, keys, key, delta, on, root) -> count
        _successors, _find: union-find over the transitions between ``on`` nodes
    edge_list(q, start, order, keys, key, delta, active) -> (first, source, target, tested)
        _successors: the transitions as edges, grouped by their first node
    edge_forward(q, first, source, target, accel, active, opening, value, bottleneck,
                 edge_weight, best, parent, reached, counts)
        _steady, _distance: the DP over edges (acceleration limits)
    edge_backward(q, first, source, target, accel, active, last, ends)
        _steady: which edges lead to the last sample

The nodes of sample ``k`` are the rows ``start[k]:start[k + 1]`` of ``q`` ``(M, n)``.
A transition from node ``i`` (sample ``k``) to node ``j`` (sample ``k + 1``) is allowed
when ``|q[j] − q[i]| ≤ delta`` joint by joint. Pruning, exact: every allowed ``j`` has
``|q[j, s] − q[i, s]| ≤ delta[s]`` for the joint ``s = key[k + 1]``, so the nodes of
sample ``k + 1``, sorted by that joint, are searched in that window only (a binary search,
then a scan); ``s`` is the joint whose spread over the sample's nodes is the largest
multiple of its ``delta`` (the fewest candidates when the nodes spread evenly).
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel


@kernel
def sort_samples(q, start, delta, order, keys, key):
    """Fill ``key`` ``(K,)`` (the joint each sample is sorted by), ``order`` ``(M,)`` (node
    rows, sample by sample, in increasing value of that joint) and ``keys`` ``(M,)``
    (those values)."""
    n = q.shape[1]
    for k in range(len(start) - 1):
        a, b = start[k], start[k + 1]
        best, score = 0, -1.0
        if b > a:
            for j in range(n):
                lo, hi = q[a, j], q[a, j]
                for i in range(a + 1, b):
                    lo = min(lo, q[i, j])
                    hi = max(hi, q[i, j])
                # delta 0: any spread separates perfectly; delta inf: nothing does
                s = (hi - lo) / delta[j] if delta[j] > 0.0 else math.inf
                if s > score:
                    best, score = j, s
        key[k] = best
        idx = np.argsort(q[a:b, best], kind="mergesort")
        for i in range(b - a):
            order[a + i] = a + idx[i]
            keys[a + i] = q[a + idx[i], best]


@kernel(inline=True)
def _allowed(q, i, j, delta):
    """Whether ``|q[j] − q[i]| ≤ delta`` for every joint."""
    for c in range(q.shape[1]):
        if abs(q[j, c] - q[i, c]) > delta[c]:
            return False
    return True


@kernel(inline=True)
def _window(keys, a, b, x, d):
    """Rows ``[lo, hi)`` of the sorted ``keys[a:b]`` within ``[x − d, x + d]``."""
    lo = a + np.searchsorted(keys[a:b], x - d, side="left")
    hi = a + np.searchsorted(keys[a:b], x + d, side="right")
    return lo, hi


@kernel(inline=True)
def _successors(q, start, order, keys, key, delta, on, k, i, out):
    """The ``on`` nodes of sample ``k + 1`` that node ``i`` (of sample ``k``) may move to,
    in window order, into ``out``; returns ``(tested, allowed)``: the ``on`` nodes inside
    the window and how many of them are allowed (the first ``allowed`` rows of ``out``)."""
    s = key[k + 1]
    lo, hi = _window(keys, start[k + 1], start[k + 2], q[i, s], delta[s])
    tested = 0
    allowed = 0
    for p in range(lo, hi):
        j = order[p]
        if on[j]:
            tested += 1
            if _allowed(q, i, j, delta):
                out[allowed] = j
                allowed += 1
    return tested, allowed


@kernel
def forward(q, start, order, keys, key, delta, active, value, bottleneck, edge_weight,
            best, parent, reached, counts):  # fmt: skip
    """The DP from the first sample to the last over the ``active`` nodes.

    ``bottleneck``: ``best[j] = max over allowed i of min(best[i], value[j])`` (the
    largest smallest ``value`` of a path ending at ``j``); else ``best[j] = min over
    allowed i of (best[i] + edge_weight·‖q[j] − q[i]‖) + value[j]``. A tie keeps the
    first predecessor in row order. ``parent[j]``: that predecessor (−1 on the first
    sample or where ``j`` is not ``reached``). ``counts``: pairs inside the windows,
    allowed transitions among them.
    """
    K = len(start) - 1
    for m in range(q.shape[0]):
        parent[m] = -1
        reached[m] = False
        best[m] = -math.inf if bottleneck else math.inf
    for i in range(start[0], start[1]):
        if active[i]:
            reached[i] = True
            best[i] = value[i]
    out = np.empty(q.shape[0], dtype=np.int64)
    for k in range(K - 1):
        for i in range(start[k], start[k + 1]):
            if not reached[i]:
                continue
            tested, allowed = _successors(q, start, order, keys, key, delta, active, k, i, out)
            counts[0] += tested
            counts[1] += allowed
            for t in range(allowed):
                j = out[t]
                if bottleneck:
                    cand = min(best[i], value[j])
                    if cand > best[j] or not reached[j]:
                        best[j], parent[j], reached[j] = cand, i, True
                else:
                    step = 0.0
                    if edge_weight != 0.0:
                        ss = 0.0
                        for c in range(q.shape[1]):
                            d = q[j, c] - q[i, c]
                            ss += d * d
                        step = edge_weight * math.sqrt(ss)
                    cand = (best[i] + step) + value[j]
                    if cand < best[j] or not reached[j]:
                        best[j], parent[j], reached[j] = cand, i, True


@kernel
def backward(q, start, order, keys, key, delta, active, ends):
    """``ends[i]``: an allowed path through ``active`` nodes leads from ``i`` to the last
    sample."""
    K = len(start) - 1
    for m in range(q.shape[0]):
        ends[m] = False
    for i in range(start[K - 1], start[K]):
        ends[i] = active[i]
    out = np.empty(q.shape[0], dtype=np.int64)
    for k in range(K - 2, -1, -1):
        for i in range(start[k], start[k + 1]):
            if active[i]:
                ends[i] = _successors(q, start, order, keys, key, delta, ends, k, i, out)[1] > 0


@kernel(inline=True)
def _find(root, a):
    """The representative of ``a`` (path halving)."""
    while root[a] != a:
        root[a] = root[root[a]]
        a = root[a]
    return a


@kernel
def components(q, start, order, keys, key, delta, on, root):
    """The connected components of the graph of the ``on`` nodes and the allowed
    transitions between them (edges taken both ways): ``root[m]`` the representative of
    node ``m``'s component; returns how many components meet the first sample."""
    K = len(start) - 1
    M = q.shape[0]
    for m in range(M):
        root[m] = m
    out = np.empty(M, dtype=np.int64)
    for k in range(K - 1):
        for i in range(start[k], start[k + 1]):
            if not on[i]:
                continue
            allowed = _successors(q, start, order, keys, key, delta, on, k, i, out)[1]
            for t in range(allowed):
                ri, rj = _find(root, i), _find(root, out[t])
                if ri != rj:
                    root[max(ri, rj)] = min(ri, rj)
    for m in range(M):
        root[m] = _find(root, m)
    seen = np.zeros(M, dtype=np.bool_)
    count = 0
    for i in range(start[0], start[1]):
        if on[i] and not seen[root[i]]:
            seen[root[i]] = True
            count += 1
    return count


# ------------------------------------------------------- acceleration limits: a DP over edges


@kernel
def edge_list(q, start, order, keys, key, delta, active):
    """The allowed transitions between ``active`` nodes as edges, grouped by their first
    node in row order: returns ``(first (M + 1,), source (E,), target (E,), tested)``, the
    edges of node ``i`` being ``first[i]:first[i + 1]`` and ``tested`` the node pairs the
    window search ran the test on."""
    K = len(start) - 1
    M = q.shape[0]
    first = np.zeros(M + 1, dtype=np.int64)
    tested = 0
    out = np.empty(M, dtype=np.int64)
    for k in range(K - 1):  # count
        for i in range(start[k], start[k + 1]):
            if active[i]:
                t, a = _successors(q, start, order, keys, key, delta, active, k, i, out)
                tested += t
                first[i + 1] += a
    for m in range(M):
        first[m + 1] += first[m]
    source = np.empty(first[M], dtype=np.int64)
    target = np.empty(first[M], dtype=np.int64)
    for k in range(K - 1):  # fill
        for i in range(start[k], start[k + 1]):
            if active[i]:
                a = _successors(q, start, order, keys, key, delta, active, k, i, out)[1]
                for t in range(a):
                    source[first[i] + t], target[first[i] + t] = i, out[t]
    return first, source, target, tested


@kernel(inline=True)
def _steady(q, h, i, j, accel):
    """Whether ``|q[j] − 2 q[i] + q[h]| ≤ accel`` for every joint (the central second
    difference of three consecutive samples, times ``dt²``)."""
    for c in range(q.shape[1]):
        if abs(q[j, c] - 2.0 * q[i, c] + q[h, c]) > accel[c]:
            return False
    return True


@kernel
def edge_forward(q, first, source, target, accel, active, opening, value, bottleneck,
                 edge_weight, best, parent, reached, counts):  # fmt: skip
    """The DP of :func:`forward` with an edge ``h → i`` as the state, so that a step
    ``i → j`` is allowed only when ``|q[j] − 2 q[i] + q[h]| ≤ accel`` as well; over the
    edges whose two nodes are ``active``; the nodes of the first sample are the rows
    before ``opening``. ``best[e]``, ``parent[e]`` (the previous edge, −1
    on the first samples' edges), ``reached[e]`` per edge; ``counts``: edge pairs tested,
    allowed. The edges of the first sample start the recursion (its velocity is free)."""
    E = len(target)
    for e in range(E):
        parent[e] = -1
        reached[e] = False
        best[e] = -math.inf if bottleneck else math.inf
    for e in range(first[opening]):  # the first sample's edges
        i, j = source[e], target[e]
        if not (active[i] and active[j]):
            continue
        reached[e] = True
        if bottleneck:
            best[e] = min(value[i], value[j])
        else:
            best[e] = (value[i] + edge_weight * _distance(q, i, j)) + value[j]
    for e in range(E):  # edges in the order of their first node: sample by sample
        if not reached[e]:
            continue
        h, i = source[e], target[e]
        for f in range(first[i], first[i + 1]):
            j = target[f]
            if not active[j]:
                continue
            counts[0] += 1
            if not _steady(q, h, i, j, accel):
                continue
            counts[1] += 1
            if bottleneck:
                cand = min(best[e], value[j])
                if cand > best[f] or not reached[f]:
                    best[f], parent[f], reached[f] = cand, e, True
            else:
                cand = (best[e] + edge_weight * _distance(q, i, j)) + value[j]
                if cand < best[f] or not reached[f]:
                    best[f], parent[f], reached[f] = cand, e, True


@kernel
def edge_backward(q, first, source, target, accel, active, last, ends):
    """``ends[e]``: an allowed path through ``active`` nodes continues edge ``e`` to the
    last sample (whose nodes are the rows from ``last`` on)."""
    for e in range(len(target) - 1, -1, -1):
        i, j = source[e], target[e]
        ends[e] = False
        if not (active[i] and active[j]):
            continue
        if j >= last:
            ends[e] = True
            continue
        for f in range(first[j], first[j + 1]):
            if ends[f] and _steady(q, i, j, target[f], accel):
                ends[e] = True
                break


@kernel(inline=True)
def _distance(q, i, j):
    """``‖q[j] − q[i]‖``, summed joint by joint in order."""
    ss = 0.0
    for c in range(q.shape[1]):
        d = q[j, c] - q[i, c]
        ss += d * d
    return math.sqrt(ss)
