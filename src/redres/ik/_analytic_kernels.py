"""Compiled analytic IK of 7R arms at a given ``q7`` (internal): every solution of one pose.

Entry points and their call tree::

    solve_pose(links, axes, kinds, bounds, arm, T, q7, out, codes) -> (status, count, flags)
        _is_pose, _frame6, _rot, _angle, _unit, _perpendicular, _wrist, _to_base, _emit
        _emit -> _wrap, _column_dot, robot._chain_kernels.fk (the solution's own FK error)
    solve_many(links, axes, kinds, bounds, arm, T, q7, out, codes, summary)
        solve_pose over a parallel range of poses (each pose independent: results do not
        depend on the thread count)

``links, axes, kinds`` are :attr:`redres.robot.SerialChain.arrays` of the 7 joints and
the frame; ``bounds`` ``(2, 7)`` the joint limits; ``arm`` the constants of
:mod:`._analytic_codes` (slots ``S``, ``W6`` …); ``T`` the frame's pose ``(4, 4)``;
``out`` ``(8, N_VALUES)`` and ``codes`` ``(8, N_CODES)`` int64 receive the solutions
(joints, FK errors; branch, flags, within the limits). The derivation is in
:mod:`redres.ik.analytic`; the steps, with ``Rot(a, θ)`` Rodrigues' rotation:

1. ``F6 = T · links[7]⁻¹ · Rot(a7, q7)ᵀ · links[6]⁻¹``; the wrist point
   ``W = F6 ∘ w6`` and the joint-6 axis ``z6 = R6 a6``.
2. ``|W − S|² = K − 2 (P + A cos q4 + B sin q4)``: ``q4 = atan2(B, A) ± acos(x)``.
3. For each ``q4``, ``S → W`` in frame 3 (``v3``) and the joint-5 axis there (``u3``):
   ``R3 = Rot(ŵ, φ) R3⁰`` with ``R3⁰ v̂3 = ŵ`` and ``R3⁰ u3⊥ ∥ z6⊥`` (the parts normal
   to the line), so that ``z5 · z6 = (z6·ŵ)(u3·v̂3) + |u3⊥||z6⊥| cos φ = cos γ``:
   ``φ = ± acos(...)``.
4. For each ``R3``, the shoulder ``Rot(k1, q1) Rot(k2, q2) Rot(k3, q3) = R_X0ᵀ R3 Cᵀ``
   (Paden–Kahan subproblem 2 on the axis ``k3``, two signs; subproblem 1 for ``q3``),
   then ``q5``, ``q6`` (subproblem 1 each, unique).
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel, parallel_range
from ..robot._chain_kernels import fk
from ._analytic_codes import (
    BA5,
    BAD_POSE,
    BAD_Q7,
    BRANCH,
    BRANCHES_MERGED,
    BTA4,
    COS_GAMMA,
    ELBOW,
    ELBOW_STRETCHED,
    FLAGS,
    HOMOGENEOUS_TOL,
    K1,
    K2,
    K3,
    LIMIT_TOL,
    M3,
    M3C,
    MERGE_TOL,
    N_JOINTS,
    POSITION_ERROR,
    REACH_TOL,
    ROTATION_ERROR,
    ROTATION_TOL,
    SELF_MOTION,
    SHOULDER_SINGULAR,
    SINGULAR_TOL,
    SOLVED,
    SP,
    UNREACHABLE,
    W4,
    W6,
    WITHIN,
    Z5,
    S,
)

prange = parallel_range()
TWO_PI = 2.0 * math.pi


@kernel(inline=True)
def _mv(M, x, y, z):
    """``M[:3, :3] v``, for ``v = (x, y, z)``."""
    return (M[0, 0] * x + M[0, 1] * y + M[0, 2] * z, M[1, 0] * x + M[1, 1] * y + M[1, 2] * z,
            M[2, 0] * x + M[2, 1] * y + M[2, 2] * z)  # fmt: skip


@kernel(inline=True)
def _mtv(M, x, y, z):
    """``M[:3, :3]ᵀ v``, for ``v = (x, y, z)``."""
    return (M[0, 0] * x + M[1, 0] * y + M[2, 0] * z, M[0, 1] * x + M[1, 1] * y + M[2, 1] * z,
            M[0, 2] * x + M[1, 2] * y + M[2, 2] * z)  # fmt: skip


@kernel
def _rot(ax, ay, az, c, s, x, y, z):
    """``Rot(a, θ) v`` (Rodrigues): ``v c + (a × v) s + a (a·v)(1 − c)``, ``c, s`` of θ."""
    d = (ax * x + ay * y + az * z) * (1.0 - c)
    return (
        x * c + (ay * z - az * y) * s + ax * d,
        y * c + (az * x - ax * z) * s + ay * d,
        z * c + (ax * y - ay * x) * s + az * d,
    )


@kernel
def _angle(kx, ky, kz, ux, uy, uz, wx, wy, wz):
    """The angle of the rotation about the unit ``k`` that takes ``u`` to ``w`` (equal
    components along ``k``): Paden–Kahan subproblem 1, ``atan2(k·(u × w), u·w − (k·u)(k·w))``
    (finite always: 0 when a perpendicular part vanishes)."""
    cx, cy, cz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    along = (kx * ux + ky * uy + kz * uz) * (kx * wx + ky * wy + kz * wz)
    dot = ux * wx + uy * wy + uz * wz - along
    return math.atan2(kx * cx + ky * cy + kz * cz, dot)


@kernel
def _unit(x, y, z):
    """``(v / |v|, |v|)``; ``v`` itself when ``|v|`` is 0."""
    n = math.sqrt(x * x + y * y + z * z)
    if n == 0.0:
        return x, y, z, 0.0
    return x / n, y / n, z / n, n


@kernel
def _perpendicular(x, y, z):
    """A unit vector perpendicular to the unit ``v`` (the cross product with the
    coordinate axis ``v`` is least aligned with)."""
    if abs(x) <= abs(y) and abs(x) <= abs(z):
        px, py, pz = 0.0, -z, y  # e_x × v
    elif abs(y) <= abs(z):
        px, py, pz = z, 0.0, -x  # e_y × v
    else:
        px, py, pz = -y, x, 0.0  # e_z × v
    ux, uy, uz, _ = _unit(px, py, pz)
    return ux, uy, uz


@kernel
def _wrap(x):
    """``x`` moved by a multiple of 2π into ``[−π, π)``."""
    return x - TWO_PI * math.floor((x + math.pi) / TWO_PI)


@kernel
def _is_pose(T):
    """Whether ``T`` is finite, its last row ``[0, 0, 0, 1]`` (to ``HOMOGENEOUS_TOL``) and
    its 3x3 block a proper rotation (to ``ROTATION_TOL``)."""
    total = 0.0
    for i in range(4):
        for j in range(4):
            total += T[i, j] * 0.0
    if total != 0.0:  # NaN or ±inf somewhere (x · 0 is 0 for finite x only)
        return False
    if abs(T[3, 0]) + abs(T[3, 1]) + abs(T[3, 2]) + abs(T[3, 3] - 1.0) > HOMOGENEOUS_TOL:
        return False
    for i in range(3):
        for j in range(3):
            g = T[0, i] * T[0, j] + T[1, i] * T[1, j] + T[2, i] * T[2, j]
            if abs(g - (1.0 if i == j else 0.0)) > ROTATION_TOL:
                return False
    det = (
        T[0, 0] * (T[1, 1] * T[2, 2] - T[1, 2] * T[2, 1])
        - T[0, 1] * (T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0])
        + T[0, 2] * (T[1, 0] * T[2, 1] - T[1, 1] * T[2, 0])
    )
    return det > 0.0


@kernel
def _frame6(links, axes, T, q7, R6):
    """``R6`` (3x3) <- the orientation of frame 6, and returns its origin: ``F7 = T ·
    links[7]⁻¹``, ``F6 = F7 · Rot(a7, q7)ᵀ · links[6]⁻¹``."""
    X6, X7 = links[6], links[7]
    ax, ay, az = axes[6, 0], axes[6, 1], axes[6, 2]
    c, s = math.cos(q7), math.sin(q7)
    p7x, p7y, p7z = T[0, 3], T[1, 3], T[2, 3]
    for i in range(3):  # row i of R7 = R_T R_X7ᵀ, then of R7 Rot(a7, q7)ᵀ = (Rot r_i)ᵀ
        r0 = T[i, 0] * X7[0, 0] + T[i, 1] * X7[0, 1] + T[i, 2] * X7[0, 2]
        r1 = T[i, 0] * X7[1, 0] + T[i, 1] * X7[1, 1] + T[i, 2] * X7[1, 2]
        r2 = T[i, 0] * X7[2, 0] + T[i, 1] * X7[2, 1] + T[i, 2] * X7[2, 2]
        shift = r0 * X7[0, 3] + r1 * X7[1, 3] + r2 * X7[2, 3]
        if i == 0:
            p7x -= shift
        elif i == 1:
            p7y -= shift
        else:
            p7z -= shift
        y0, y1, y2 = _rot(ax, ay, az, c, s, r0, r1, r2)
        for j in range(3):  # R6 = Y R_X6ᵀ
            R6[i, j] = y0 * X6[j, 0] + y1 * X6[j, 1] + y2 * X6[j, 2]
    px = p7x - (R6[0, 0] * X6[0, 3] + R6[0, 1] * X6[1, 3] + R6[0, 2] * X6[2, 3])
    py = p7y - (R6[1, 0] * X6[0, 3] + R6[1, 1] * X6[1, 3] + R6[1, 2] * X6[2, 3])
    pz = p7z - (R6[2, 0] * X6[0, 3] + R6[2, 1] * X6[1, 3] + R6[2, 2] * X6[2, 3])
    return px, py, pz


@kernel
def _emit(links, axes, kinds, bounds, T, q7, q1, q2, q3, q4, q5, q6, branch, flags, row, code,
          scratch):  # fmt: skip
    """Solution ``q1 … q6`` and ``q7`` into ``row`` (each joint moved by 2π into its
    limits where that fits), its FK error, branch, flags and limit test into ``code``."""
    within = 1
    for j in range(N_JOINTS):
        lo, hi = bounds[0, j] - LIMIT_TOL, bounds[1, j] + LIMIT_TOL
        if j == N_JOINTS - 1:
            x = q7
        else:
            x = _wrap(q1 if j == 0 else q2 if j == 1 else q3 if j == 2 else q4 if j == 3
                      else q5 if j == 4 else q6)  # fmt: skip
            if x < lo and x + TWO_PI <= hi:
                x += TWO_PI
            elif x > hi and x - TWO_PI >= lo:
                x -= TWO_PI
        if not lo <= x <= hi:
            within = 0
        row[j] = x
    fk(links, axes, kinds, row, scratch)
    dx, dy, dz = scratch[0, 3] - T[0, 3], scratch[1, 3] - T[1, 3], scratch[2, 3] - T[2, 3]
    row[POSITION_ERROR] = math.sqrt(dx * dx + dy * dy + dz * dz)
    # angle of E = R_Tᵀ R: atan2(|vee(E − Eᵀ)| / 2, (tr E − 1) / 2), accurate at every angle
    wx = _column_dot(T, scratch, 2, 1) - _column_dot(T, scratch, 1, 2)
    wy = _column_dot(T, scratch, 0, 2) - _column_dot(T, scratch, 2, 0)
    wz = _column_dot(T, scratch, 1, 0) - _column_dot(T, scratch, 0, 1)
    trace = _column_dot(T, scratch, 0, 0) + _column_dot(T, scratch, 1, 1)
    trace += _column_dot(T, scratch, 2, 2)
    half_sine = 0.5 * math.sqrt(wx * wx + wy * wy + wz * wz)
    row[ROTATION_ERROR] = math.atan2(half_sine, 0.5 * (trace - 1.0))
    code[BRANCH] = branch
    code[FLAGS] = flags
    code[WITHIN] = within


@kernel(inline=True)
def _column_dot(A, B, i, j):
    """Column ``i`` of ``A[:3, :3]`` dotted with column ``j`` of ``B[:3, :3]``: ``(AᵀB)[i, j]``."""
    return A[0, i] * B[0, j] + A[1, i] * B[1, j] + A[2, i] * B[2, j]


@kernel
def solve_pose(links, axes, kinds, bounds, arm, T, q7, out, codes):
    """Every solution of pose ``T`` at ``q7`` (module docstring) into ``out`` and
    ``codes``; returns ``(status, count, flags)`` (``_analytic_codes``)."""
    if not _is_pose(T):
        return BAD_POSE, 0, 0
    if not math.isfinite(q7):
        return BAD_Q7, 0, 0
    work = np.empty((3, 4, 4))  # one allocation: the FK's pose, R6, R3 (3x3 blocks)
    scratch, R6, R3 = work[0], work[1], work[2]
    # 1. frame 6, the wrist point W, the joint-6 axis z6
    fx, fy, fz = _frame6(links, axes, T, q7, R6)
    w0, w1, w2 = arm[W6], arm[W6 + 1], arm[W6 + 2]
    wx = fx + R6[0, 0] * w0 + R6[0, 1] * w1 + R6[0, 2] * w2
    wy = fy + R6[1, 0] * w0 + R6[1, 1] * w1 + R6[1, 2] * w2
    wz = fz + R6[2, 0] * w0 + R6[2, 1] * w1 + R6[2, 2] * w2
    a0, a1, a2 = axes[5, 0], axes[5, 1], axes[5, 2]
    z6x, z6y, z6z = _mv(R6, a0, a1, a2)
    vx, vy, vz, dist = _unit(wx - arm[S], wy - arm[S + 1], wz - arm[S + 2])
    # 2. the elbow: A cos q4 + B sin q4 = (K − d²)/2 − P
    K, P, A, B = arm[ELBOW], arm[ELBOW + 1], arm[ELBOW + 2], arm[ELBOW + 3]
    x = ((K - dist * dist) / 2.0 - P) / math.hypot(A, B)
    if abs(x) > 1.0 + REACH_TOL:
        return SOLVED, 0, UNREACHABLE
    pose_flags = 0
    n4 = 2
    if 1.0 - abs(x) < MERGE_TOL:  # a double root: the two elbow solutions are one
        n4 = 1
        pose_flags |= ELBOW_STRETCHED
    spread4 = math.acos(min(1.0, max(-1.0, x)))
    centre4 = math.atan2(B, A)
    if dist < SINGULAR_TOL:  # W at S: any direction maps onto it; pick one
        vx, vy, vz = 0.0, 0.0, 1.0
        pose_flags |= SELF_MOTION
    X3, X0 = links[3], links[0]
    e0, e1, e2 = axes[3, 0], axes[3, 1], axes[3, 2]
    count = 0
    all_flags = 0
    for i4 in range(n4):
        q4 = _wrap(centre4 + spread4 if i4 == 0 else centre4 - spread4)
        c4, s4 = math.cos(q4), math.sin(q4)
        # 3. S → W (v3) and the joint-5 axis (u3) in frame 3
        p0, p1, p2 = _rot(e0, e1, e2, c4, s4, arm[W4], arm[W4 + 1], arm[W4 + 2])
        p0, p1, p2 = p0 - arm[SP], p1 - arm[SP + 1], p2 - arm[SP + 2]
        g0, g1, g2 = _rot(e0, e1, e2, c4, s4, arm[Z5], arm[Z5 + 1], arm[Z5 + 2])
        v3x, v3y, v3z = _mv(X3, p0, p1, p2)
        u3x, u3y, u3z = _mv(X3, g0, g1, g2)
        hx, hy, hz, length3 = _unit(v3x, v3y, v3z)
        if length3 < SINGULAR_TOL:
            hx, hy, hz = 0.0, 0.0, 1.0
        # parts of u3 and z6 along the line S → W and normal to it
        u_along = u3x * hx + u3y * hy + u3z * hz
        n3x, n3y, n3z, nu = _unit(u3x - u_along * hx, u3y - u_along * hy, u3z - u_along * hz)
        z_along = z6x * vx + z6y * vy + z6z * vz
        nx, ny, nz, nzp = _unit(z6x - z_along * vx, z6y - z_along * vy, z6z - z_along * vz)
        rhs = arm[COS_GAMMA] - z_along * u_along
        flags4 = pose_flags
        n_phi = 2
        spread = 0.0
        if nu * nzp < SINGULAR_TOL:  # the condition does not involve φ
            if abs(rhs) > math.sqrt(SINGULAR_TOL):
                continue  # nor holds: no solution at this q4
            n_phi = 1
            flags4 |= SELF_MOTION
            if nu < SINGULAR_TOL:
                n3x, n3y, n3z = _perpendicular(hx, hy, hz)
            if nzp < SINGULAR_TOL:
                nx, ny, nz = _perpendicular(vx, vy, vz)
        else:
            y = rhs / (nu * nzp)
            if abs(y) > 1.0 + REACH_TOL:
                continue
            if 1.0 - abs(y) < MERGE_TOL:
                n_phi = 1
                flags4 |= BRANCHES_MERGED
            spread = math.acos(min(1.0, max(-1.0, y)))
        # right-handed frames [ĥ, n3, m3] (frame 3) and [v̂, n, m] (world)
        m3x, m3y, m3z = hy * n3z - hz * n3y, hz * n3x - hx * n3z, hx * n3y - hy * n3x
        mx, my, mz = vy * nz - vz * ny, vz * nx - vx * nz, vx * ny - vy * nx
        for i_phi in range(n_phi):
            phi = spread if i_phi == 0 else -spread
            cp, sp = math.cos(phi), math.sin(phi)
            # R3 = v̂ ĥᵀ + (c n + s m) n3ᵀ + (c m − s n) m3ᵀ  (R3 ĥ = v̂, Rot(v̂, φ) on n)
            f0, f1, f2 = cp * nx + sp * mx, cp * ny + sp * my, cp * nz + sp * mz
            b0, b1, b2 = cp * mx - sp * nx, cp * my - sp * ny, cp * mz - sp * nz
            for i in range(3):
                vi = vx if i == 0 else (vy if i == 1 else vz)
                fi = f0 if i == 0 else (f1 if i == 1 else f2)
                bi = b0 if i == 0 else (b1 if i == 1 else b2)
                R3[i, 0] = vi * hx + fi * n3x + bi * m3x
                R3[i, 1] = vi * hy + fi * n3y + bi * m3y
                R3[i, 2] = vi * hz + fi * n3z + bi * m3z
            q5, q6 = _wrist(X3, links[4], axes, arm, R3, R6, c4, s4, u3x, u3y, u3z, z6x, z6y, z6z)
            # 4. the shoulder: t = R_X0ᵀ R3 a3 (axis 3), h = R_X0ᵀ R3 Cᵀ m
            tx, ty, tz = _to_base(X0, R3, axes[2, 0], axes[2, 1], axes[2, 2])
            hmx, hmy, hmz = _to_base(X0, R3, arm[M3C], arm[M3C + 1], arm[M3C + 2])
            k1x, k1y, k1z = arm[K1], arm[K1 + 1], arm[K1 + 2]
            k2x, k2y, k2z = arm[K2], arm[K2 + 1], arm[K2 + 2]
            k3x, k3y, k3z = arm[K3], arm[K3 + 1], arm[K3 + 2]
            # subproblem 2: c = x k1 + y k2 ± z (k1 × k2), with k1·c = k1·t, k2·c = k2·k3
            k12 = k1x * k2x + k1y * k2y + k1z * k2z
            b23 = k2x * k3x + k2y * k3y + k2z * k3z
            b1t = k1x * tx + k1y * ty + k1z * tz
            den = 1.0 - k12 * k12
            xs, ys = (b1t - k12 * b23) / den, (b23 - k12 * b1t) / den
            z2 = (1.0 - xs * xs - ys * ys - 2.0 * xs * ys * k12) / den
            if z2 < -REACH_TOL:
                continue  # this shoulder cannot point axis 3 along t
            zs = math.sqrt(max(z2, 0.0))
            cx, cy, cz = k1y * k2z - k1z * k2y, k1z * k2x - k1x * k2z, k1x * k2y - k1y * k2x
            sx, sy, sz = k1y * tz - k1z * ty, k1z * tx - k1x * tz, k1x * ty - k1y * tx
            singular = math.sqrt(sx * sx + sy * sy + sz * sz) < SINGULAR_TOL
            for i_sh in range(1 if singular else 2):
                sign = zs if i_sh == 0 else -zs
                ox = xs * k1x + ys * k2x + sign * cx
                oy = xs * k1y + ys * k2y + sign * cy
                oz = xs * k1z + ys * k2z + sign * cz
                q2 = _angle(k2x, k2y, k2z, k3x, k3y, k3z, ox, oy, oz)
                q1 = 0.0 if singular else _angle(k1x, k1y, k1z, ox, oy, oz, tx, ty, tz)
                # Rot(k3, q3) m = Rot(k2, −q2) Rot(k1, −q1) h
                r0, r1, r2 = _rot(k1x, k1y, k1z, math.cos(q1), -math.sin(q1), hmx, hmy, hmz)
                r0, r1, r2 = _rot(k2x, k2y, k2z, math.cos(q2), -math.sin(q2), r0, r1, r2)
                q3 = _angle(k3x, k3y, k3z, arm[M3], arm[M3 + 1], arm[M3 + 2], r0, r1, r2)
                flags = flags4
                if singular:  # only q1 + σ q3 is fixed (c = σ k1): split it evenly
                    sigma = 1.0 if k1x * ox + k1y * oy + k1z * oz > 0.0 else -1.0
                    q1, q3 = 0.5 * sigma * q3, 0.5 * q3
                    flags |= SHOULDER_SINGULAR
                branch = 4 * i4 + 2 * i_phi + i_sh
                _emit(links, axes, kinds, bounds, T, q7, q1, q2, q3, q4, q5, q6, branch, flags,
                      out[count], codes[count], scratch)  # fmt: skip
                all_flags |= flags
                count += 1
    if count == 0:
        all_flags |= UNREACHABLE
    return SOLVED, count, all_flags


@kernel(parallel=True)
def solve_many(links, axes, kinds, bounds, arm, T, q7, out, codes, summary):
    """:func:`solve_pose` for poses ``T[i]`` ``(N, 4, 4)`` at ``q7[i]`` into ``out[i]``,
    ``codes[i]``; ``summary[i]`` <- ``(status, count, flags)``."""
    for i in prange(T.shape[0]):
        status, count, flags = solve_pose(links, axes, kinds, bounds, arm, T[i], q7[i], out[i],
                                          codes[i])  # fmt: skip
        summary[i, 0] = status
        summary[i, 1] = count
        summary[i, 2] = flags


@kernel
def _to_base(X0, R3, x, y, z):
    """``R_X0ᵀ R3 v``: a vector of frame 3 in the placement frame of joint 1."""
    w0, w1, w2 = _mv(R3, x, y, z)
    return _mtv(X0, w0, w1, w2)


@kernel
def _wrist(X3, X4, axes, arm, R3, R6, c4, s4, u3x, u3y, u3z, z6x, z6y, z6z):
    """``(q5, q6)`` (subproblem 1 each): ``q6`` turns
    ``R6ᵀ z5`` into ``R_X5ᵀ a5`` about ``a6``; ``q5`` turns ``R_X5 a6`` into
    ``(R4 R_X4)ᵀ z6`` about ``a5`` (joint axes 1-based here)."""
    z5x, z5y, z5z = _mv(R3, u3x, u3y, u3z)
    l0, l1, l2 = _mtv(R6, z5x, z5y, z5z)
    q6 = _angle(axes[5, 0], axes[5, 1], axes[5, 2], l0, l1, l2,
                       arm[BTA4], arm[BTA4 + 1], arm[BTA4 + 2])  # fmt: skip
    # (R4 R_X4)ᵀ z6 = R_X4ᵀ Rot(a4, −q4) R_X3ᵀ R3ᵀ z6
    g0, g1, g2 = _mtv(R3, z6x, z6y, z6z)
    h0, h1, h2 = _mtv(X3, g0, g1, g2)
    h0, h1, h2 = _rot(axes[3, 0], axes[3, 1], axes[3, 2], c4, -s4, h0, h1, h2)
    m0, m1, m2 = _mtv(X4, h0, h1, h2)
    q5 = _angle(axes[4, 0], axes[4, 1], axes[4, 2], arm[BA5], arm[BA5 + 1], arm[BA5 + 2],
                m0, m1, m2)  # fmt: skip
    return q5, q6
