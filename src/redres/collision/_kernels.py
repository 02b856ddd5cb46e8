"""Compiled distances of collision pairs and their Jacobian rows (internal).

Plain Python written for numba, compiled through :mod:`redres._compile` (kernel group
``collision``, :mod:`redres.collision.distances`). Entry point:

- :func:`pair_distances` — every pair at one ``q`` from the capsule frames' poses and
  world-aligned Jacobians; calls :func:`_capsule_obstacle` (→ :func:`_segment_segment`,
  :func:`_segment_box`, :func:`_segment_plane`) or :func:`_segment_segment` for a self
  pair, then :func:`_add_row`.
- :func:`chain_frames` — those poses and that Jacobian of a serial chain without
  Pinocchio: :func:`redres.robot._chain_kernels._chain_pass` per capsule joint.
- :func:`damper_rows` — :func:`chain_frames` (for a serial chain), :func:`pair_distances`,
  then each pair's damper bound (the rows of :mod:`redres.collision.constraint`, one per
  pair at a fixed position), in one call from ``q``.

Every pair gives the signed surface distance ``d`` (< 0: penetration), the witness points
``p_a`` on the first capsule's centre line and ``p_b`` on the other shape, and the unit
normal ``n̂`` pointing from the other shape towards the capsule. For a capsule the witness
is taken on the centre line: the surface point ``p_a − r n̂`` moves with the link like it
up to ``ω × r n̂``, which has no component along ``n̂``, so both give the same ``ḋ``.

``∂d/∂q = n̂ᵀ (J_a − J_b)`` (Faverjon & Tournassoud 1987; Kanoun, Lamiraux, Wieber 2011),
``J_p`` column ``k``: ``v_k + ω_k × p`` from Pinocchio's ``WORLD`` joint Jacobian
``[v; ω]`` (``v`` the velocity of the point at the world origin; Featherstone's spatial
velocity), the columns of the joints that move the link; ``J_b = 0`` for an obstacle.
Where the closest points are unique it is the exact derivative: their sliding along the
surfaces changes ``d`` only to second order.

Closest points of segments: Ericson, *Real-Time Collision Detection*, 2005, §5.1.9 (the
parallel case clamps ``s = 0`` and projects). Segment–box: ``f(t) = dist²(a + t(b − a),
box)`` is a convex piecewise quadratic of ``t`` whose pieces change where a coordinate
crosses a face plane (at most six breakpoints), minimised exactly piece by piece; when
the segment meets the box (``min f = 0``) the signed distance, convex in ``t``, is
minimised by golden-section search (Kiefer 1953) to round-off.
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel
from ..robot._chain_kernels import _chain_pass, point_columns

_TINY = 1e-30  # squared lengths below this are points / coincident witnesses
_GOLDEN = 0.6180339887498949  # (√5 − 1)/2
_SPHERE, _CAPSULE, _BOX, _PLANE = 0, 1, 2, 3  # redres.collision.shapes' kind codes


@kernel(inline=True)
def _mul(R, x):
    """``R x`` for a 3x3 ``R``."""
    out = np.empty(3)
    for i in range(3):
        out[i] = R[i, 0] * x[0] + R[i, 1] * x[1] + R[i, 2] * x[2]
    return out


@kernel(inline=True)
def _mul_t(R, x):
    """``Rᵀ x`` for a 3x3 ``R``."""
    out = np.empty(3)
    for i in range(3):
        out[i] = R[0, i] * x[0] + R[1, i] * x[1] + R[2, i] * x[2]
    return out


@kernel(inline=True)
def _gap(p, x, y, z):
    """``‖p − (x, y, z)‖``."""
    return math.sqrt((p[0] - x) ** 2 + (p[1] - y) ** 2 + (p[2] - z) ** 2)


@kernel(inline=True)
def _clamp01(x):
    return 0.0 if x < 0.0 else 1.0 if x > 1.0 else x


@kernel(inline=True)
def _segment_params(r0, r1, r2, u0, u1, u2, v0, v1, v2):
    """Parameters ``(s, t)`` of the closest points ``p1 + s u``, ``p2 + t v`` of two
    segments, ``r = p1 − p2`` (Ericson)."""
    a = u0 * u0 + u1 * u1 + u2 * u2
    e = v0 * v0 + v1 * v1 + v2 * v2
    f = v0 * r0 + v1 * r1 + v2 * r2
    if a <= _TINY and e <= _TINY:
        return 0.0, 0.0
    if a <= _TINY:
        return 0.0, _clamp01(f / e)
    c = u0 * r0 + u1 * r1 + u2 * r2
    if e <= _TINY:
        return _clamp01(-c / a), 0.0
    b = u0 * v0 + u1 * v1 + u2 * v2
    denom = a * e - b * b
    s = _clamp01((b * f - c * e) / denom) if denom > 1e-14 * a * e else 0.0  # parallel: s = 0
    t = (b * s + f) / e
    if t < 0.0:
        return _clamp01(-c / a), 0.0
    if t > 1.0:
        return _clamp01((b - c) / a), 1.0
    return s, t


@kernel(inline=True)
def _unit_or_perpendicular(g0, g1, g2, u0, u1, u2, v0, v1, v2, n):
    """``n = g/‖g‖``; when the witnesses coincide (centre lines cross) a unit vector normal
    to both directions ``u``, ``v`` (else to ``u``): the direction is undefined there.
    Returns ‖g‖."""
    size = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
    if size * size > _TINY:
        n[0], n[1], n[2] = g0 / size, g1 / size, g2 / size
        return size
    c0, c1, c2 = u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0
    if c0 * c0 + c1 * c1 + c2 * c2 <= _TINY:  # parallel or a point: any normal to u
        e0, e1 = (1.0, 0.0) if abs(u0) <= abs(u1) and abs(u0) <= abs(u2) else (0.0, 1.0)
        c0, c1, c2 = -u2 * e1, u2 * e0, u0 * e1 - u1 * e0
        if c0 * c0 + c1 * c1 + c2 * c2 <= _TINY:
            c0, c1, c2 = 0.0, 0.0, 1.0
    size_c = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    n[0], n[1], n[2] = c0 / size_c, c1 / size_c, c2 / size_c
    return size


@kernel(inline=True)
def _segment_segment(a, b, p, q, pa, pb, n):
    """Closest points of ``[a, b]`` and ``[p, q]`` into ``pa``, ``pb``; normal from the
    second to the first into ``n``; returns their distance."""
    u0, u1, u2 = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    v0, v1, v2 = q[0] - p[0], q[1] - p[1], q[2] - p[2]
    s, t = _segment_params(a[0] - p[0], a[1] - p[1], a[2] - p[2], u0, u1, u2, v0, v1, v2)
    pa[0], pa[1], pa[2] = a[0] + s * u0, a[1] + s * u1, a[2] + s * u2
    pb[0], pb[1], pb[2] = p[0] + t * v0, p[1] + t * v1, p[2] + t * v2
    return _unit_or_perpendicular(pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2],
                                  u0, u1, u2, v0, v1, v2, n)  # fmt: skip


@kernel(inline=True)
def _box_sq(x, h):
    """Squared distance of the point ``x`` (box coordinates) to the box ``|x_i| ≤ h_i``."""
    acc = 0.0
    for i in range(3):
        over = abs(x[i]) - h[i]
        if over > 0.0:
            acc += over * over
    return acc


@kernel(inline=True)
def _box_signed(x, h):
    """Signed distance of ``x`` to the box when inside or on it: ``max_i (|x_i| − h_i)``."""
    best = -np.inf
    for i in range(3):
        best = max(best, abs(x[i]) - h[i])
    return best


@kernel
def _segment_box(a, b, c, h, R, pa, pb, n):
    """Signed distance of segment ``[a, b]`` to the box (centre ``c``, half extents ``h``,
    axes the columns of ``R``), world coordinates; witnesses and normal as
    :func:`_segment_segment` (module docstring for the method)."""
    A = _mul_t(R, a - c)
    D = _mul_t(R, b - a)
    cuts = np.empty(8)
    cuts[0], cuts[1] = 0.0, 1.0
    k = 2
    for i in range(3):
        if abs(D[i]) > 1e-300:
            for sign in (-1.0, 1.0):
                t = (sign * h[i] - A[i]) / D[i]
                if 0.0 < t < 1.0:
                    cuts[k] = t
                    k += 1
    cuts = np.sort(cuts[:k])
    best_t, best_f = 0.0, np.inf
    for j in range(k - 1):
        t0, t1 = cuts[j], cuts[j + 1]
        mid = A + (0.5 * (t0 + t1)) * D
        num, den = 0.0, 0.0
        for i in range(3):
            if mid[i] > h[i]:
                num += (A[i] - h[i]) * D[i]
                den += D[i] * D[i]
            elif mid[i] < -h[i]:
                num += (A[i] + h[i]) * D[i]
                den += D[i] * D[i]
        t = t0 if den <= 0.0 else min(max(-num / den, t0), t1)
        f = _box_sq(A + t * D, h)
        if f < best_f:
            best_f, best_t = f, t
    for t in (0.0, 1.0):  # the ends themselves (pieces of zero length are skipped above)
        f = _box_sq(A + t * D, h)
        if f < best_f:
            best_f, best_t = f, t
    if best_f > 0.0:
        x = A + best_t * D
        y = np.minimum(np.maximum(x, -h), h)
        g = _mul(R, x - y)
        size = math.sqrt(best_f)
        for i in range(3):
            n[i] = g[i] / size
        dist = size
    else:  # the segment meets the box: most penetrating point (convex in t)
        lo, hi = 0.0, 1.0
        u = hi - _GOLDEN * (hi - lo)
        v = lo + _GOLDEN * (hi - lo)
        fu, fv = _box_signed(A + u * D, h), _box_signed(A + v * D, h)
        for _ in range(120):
            if fu <= fv:
                hi, v, fv = v, u, fu
                u = hi - _GOLDEN * (hi - lo)
                fu = _box_signed(A + u * D, h)
            else:
                lo, u, fu = u, v, fv
                v = lo + _GOLDEN * (hi - lo)
                fv = _box_signed(A + v * D, h)
        best_t = 0.5 * (lo + hi)
        for t in (0.0, 1.0):
            if _box_signed(A + t * D, h) < _box_signed(A + best_t * D, h):
                best_t = t
        x = A + best_t * D
        axis, dist = 0, -np.inf
        for i in range(3):
            if abs(x[i]) - h[i] > dist:
                axis, dist = i, abs(x[i]) - h[i]
        y = x.copy()
        y[axis] = h[axis] if x[axis] >= 0.0 else -h[axis]
        for i in range(3):
            n[i] = R[i, axis] * (1.0 if x[axis] >= 0.0 else -1.0)
    wa = _mul(R, x) + c
    wb = _mul(R, y) + c
    for i in range(3):
        pa[i], pb[i] = wa[i], wb[i]
    return dist


@kernel(inline=True)
def _segment_plane(a, b, normal, offset, pa, pb, n):
    """Signed distance of segment ``[a, b]`` to the half-space ``normal·x ≤ offset``: its
    lower end (the midpoint when both ends are level within round-off)."""
    sa = normal[0] * a[0] + normal[1] * a[1] + normal[2] * a[2] - offset
    sb = normal[0] * b[0] + normal[1] * b[1] + normal[2] * b[2] - offset
    scale = 1e-12 * (1.0 + abs(sa) + abs(sb))
    s = 0.5 if abs(sa - sb) <= scale else 0.0 if sa < sb else 1.0
    dist = (1.0 - s) * sa + s * sb
    for i in range(3):
        pa[i] = a[i] + s * (b[i] - a[i])
        pb[i] = pa[i] - dist * normal[i]
        n[i] = normal[i]
    return dist


@kernel
def _capsule_obstacle(a, b, kind, row, pa, pb, n):
    """Signed surface distance of the capsule centre line ``[a, b]`` to an obstacle row
    (:mod:`redres.collision.shapes`), radius of the capsule not subtracted."""
    if kind == _SPHERE:
        c = row[0:3]
        return _segment_segment(a, b, c, c, pa, pb, n) - row[3]
    if kind == _CAPSULE:
        return _segment_segment(a, b, row[0:3], row[3:6], pa, pb, n) - row[6]
    if kind == _BOX:
        R = row[6:15].copy().reshape(3, 3)
        return _segment_box(a, b, row[0:3], row[3:6], R, pa, pb, n)
    return _segment_plane(a, b, row[0:3], row[3], pa, pb, n)


@kernel(inline=True)
def _add_row(J, cols, p, n, sign, out):
    """``out[:cols] += sign · n̂ᵀ J_p``, ``J_p`` column ``k``: ``v_k + ω_k × p`` from
    Pinocchio's ``WORLD`` joint Jacobian ``[v; ω]`` (``v``: the velocity of the point at
    the world origin); columns from ``cols`` on do not move the link."""
    for k in range(cols):
        w0, w1, w2 = J[3, k], J[4, k], J[5, k]
        v0 = J[0, k] + w1 * p[2] - w2 * p[1]
        v1 = J[1, k] + w2 * p[0] - w0 * p[2]
        v2 = J[2, k] + w0 * p[1] - w1 * p[0]
        out[k] += sign * (n[0] * v0 + n[1] * v1 + n[2] * v2)


@kernel
def pair_distances(R, t, J, cap_frame, cap_cols, cap_a, cap_b, cap_r, kinds, rows, pairs,
                   cutoff, dist, pa, pb, normal, grad):  # fmt: skip
    """Every pair's signed distance, witnesses, normal and ``∂d/∂q`` row.

    Args:
        R, t: the capsules' joints' rotations ``(F, 3, 3)`` and origins ``(F, 3)``.
        J: Pinocchio's ``WORLD`` Jacobian of the joints ``(6, n)`` (``data.J``).
        cap_frame, cap_cols, cap_a, cap_b, cap_r: capsule ``i``'s joint index into ``R``
            ``(C,)``, the number of leading columns of ``J`` that move it ``(C,)``, its
            segment ends in its joint's frame ``(C, 3)`` and radius ``(C,)``.
        kinds, rows: the packed obstacles ``(O,)``, ``(O, 16)``.
        pairs: ``(P, 3)``: ``(0, capsule, obstacle)`` or ``(1, capsule, capsule)``.
        cutoff: pairs whose bounding spheres are farther apart than this (m) are not
            resolved: their ``dist`` is that lower bound and their row zero.
        dist, pa, pb, normal, grad: outputs ``(P,)``, ``(P, 3)`` ×3, ``(P, n)``.

    Returns:
        The number of pairs resolved (within ``cutoff`` of each other).
    """
    C = cap_a.shape[0]
    work = np.empty((C, 10))  # one allocation: ends, midpoint, bounding radius
    wa, wb, mid, reach = work[:, 0:3], work[:, 3:6], work[:, 6:9], work[:, 9]
    for i in range(C):
        f = cap_frame[i]
        for r in range(3):
            wa[i, r] = (R[f, r, 0] * cap_a[i, 0] + R[f, r, 1] * cap_a[i, 1]
                        + R[f, r, 2] * cap_a[i, 2] + t[f, r])  # fmt: skip
            wb[i, r] = (R[f, r, 0] * cap_b[i, 0] + R[f, r, 1] * cap_b[i, 1]
                        + R[f, r, 2] * cap_b[i, 2] + t[f, r])  # fmt: skip
            mid[i, r] = 0.5 * (wa[i, r] + wb[i, r])
        reach[i] = 0.5 * _gap(wa[i], wb[i, 0], wb[i, 1], wb[i, 2]) + cap_r[i]
    resolved = 0
    for k in range(pairs.shape[0]):
        kind, i, j = pairs[k, 0], pairs[k, 1], pairs[k, 2]
        grad[k, :] = 0.0
        if kind == 0:  # broad phase: bounding spheres (none for a plane)
            o = kinds[j]
            bound = -np.inf
            row = rows[j]
            if o == _SPHERE:
                bound = _gap(mid[i], row[0], row[1], row[2]) - reach[i] - row[3]
            elif o == _CAPSULE:
                e0, e1, e2 = row[3] - row[0], row[4] - row[1], row[5] - row[2]
                c = _gap(mid[i], row[0] + 0.5 * e0, row[1] + 0.5 * e1, row[2] + 0.5 * e2)
                bound = c - reach[i] - 0.5 * math.sqrt(e0 * e0 + e1 * e1 + e2 * e2) - row[6]
            elif o == _BOX:
                h = math.sqrt(row[3] * row[3] + row[4] * row[4] + row[5] * row[5])
                bound = _gap(mid[i], row[0], row[1], row[2]) - reach[i] - h
        else:
            bound = _gap(mid[i], mid[j, 0], mid[j, 1], mid[j, 2]) - reach[i] - reach[j]
        if bound > cutoff:
            dist[k] = bound
            pa[k, :] = mid[i]
            pb[k, :] = mid[i]
            normal[k, :] = 0.0
            continue
        resolved += 1
        if kind == 0:
            d = _capsule_obstacle(wa[i], wb[i], kinds[j], rows[j], pa[k], pb[k], normal[k])
        else:
            d = _segment_segment(wa[i], wb[i], wa[j], wb[j], pa[k], pb[k], normal[k])
            d -= cap_r[j]
        dist[k] = d - cap_r[i]
        _add_row(J, cap_cols[i], pa[k], normal[k], 1.0, grad[k])
        if kind != 0:
            _add_row(J, cap_cols[j], pb[k], normal[k], -1.0, grad[k])
    return resolved


@kernel
def chain_frames(links, axes, kinds, depth, q, T, R, t, J):
    """The capsules' joints' poses and Pinocchio's ``WORLD`` joint Jacobian of a serial
    chain (joints ``1 … k`` of the model, :class:`redres.robot.chain.SerialChain`), the
    inputs of :func:`pair_distances`, without Pinocchio.

    Args:
        links: ``(F, k + 1, 3, 4)``: row ``f`` holds the chain's first ``depth[f]`` joint
            placements, then the identity (the joint's own frame as the chain's tool).
        axes, kinds: the chain's joint axes ``(k, 3)`` and kinds ``(k,)``.
        depth: ``(F,)``: how many joints move frame ``f`` (0: fixed to the base).
        q: ``(n,)``, rad or m.
        T: scratch ``(4, 4)``.
        R, t: outputs ``(F, 3, 3)``, ``(F, 3)``: ``oMi`` of each capsule's joint.
        J: output ``(6, n)``: columns ``[v; ω]``, ``v = p_j × z_j`` the velocity of the point
            at the world origin for a revolute joint about ``z_j`` through ``p_j``, ``[z_j; 0]``
            for a prismatic one; zero past the deepest capsule joint.
    """
    deepest = 0
    for f in range(depth.shape[0]):
        if depth[f] > depth[deepest]:
            deepest = f
    for f in range(depth.shape[0]):
        k = depth[f]
        _chain_pass(links[f, : k + 1], axes[:k], kinds[:k], q, T, J, f == deepest)
        for i in range(3):
            t[f, i] = T[i, 3]
            for c in range(3):
                R[f, i, c] = T[i, c]
    point_columns(kinds[: depth[deepest]], 0.0, 0.0, 0.0, J)  # Pinocchio's WORLD columns


@kernel
def damper_rows(links, axes, chain_kinds, depth, q, T, R, t, J, cap_frame, cap_cols, cap_a,
                cap_b, cap_r, kinds, rows, pairs, influence, safety, rate, dist, pa, pb,
                normal, grad, lower):  # fmt: skip
    """:func:`chain_frames` (its arguments first; skipped when ``depth`` is empty: ``R``,
    ``t``, ``J`` then come from Pinocchio), :func:`pair_distances` with ``cutoff =
    influence`` (``grad`` is then the rows ``∂d/∂q``), and ``lower[k] = rate · (d_k −
    safety)`` for a pair closer than ``influence``, ``−1e30`` (no bound: DAQP's infinity)
    for the others. ``rate`` is ``−ξ/(d_i − d_s)`` (1/s). Returns ``(#resolved,
    #active)``."""
    if depth.shape[0] > 0:
        chain_frames(links, axes, chain_kinds, depth, q, T, R, t, J)
    resolved = pair_distances(R, t, J, cap_frame, cap_cols, cap_a, cap_b, cap_r, kinds,
                              rows, pairs, influence, dist, pa, pb, normal, grad)  # fmt: skip
    active = 0
    for k in range(dist.shape[0]):
        if dist[k] < influence:
            lower[k] = rate * (dist[k] - safety)
            active += 1
        else:
            lower[k] = -1e30
    return resolved, active
