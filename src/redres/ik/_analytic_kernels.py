"""Compiled analytic IK of 7R arms at a given ``q7`` (internal): every solution of one pose.

Entry points and their call tree::

    solve_pose(arm, T, q7, out) -> count + (flags << FLAG_SHIFT), or a negative status
        _is_pose, _frame6, _unit, _perpendicular, _angle, _limit, _shoulder -> _emit
    errors(links, axes, kinds, out, count)
        robot._chain_kernels.fk (each solution's own FK error against the pose in ``out``)
    solve_many(arm, links, axes, kinds, T, q7, out, summary, residuals)
        solve_pose, and errors when residuals, over a parallel range of poses (each pose
        independent: results do not depend on the thread count)

``arm`` holds the arm's constants (slots of :mod:`._analytic_codes`, derived in
:func:`redres.ik.structure.analytic_arm`); ``links, axes, kinds`` are
:attr:`redres.robot.SerialChain.arrays` of the 7 joints and the frame; ``T`` the frame's
pose ``(4, 4)``; ``out`` ``(N_ROWS, N_VALUES)`` receives the solutions (joints, FK
errors, branch, flags, within the limits) and, in its last row, the pose. The
derivation is in :mod:`redres.ik.analytic`; the steps, with ``Rot(a, θ)`` Rodrigues'
rotation:

1. ``R6 = R_T R(X7)ᵀ Rot(a7, −q7) R(X6)ᵀ``, a fixed combination of three constant
   matrices with ``cos q7``, ``sin q7``; the wrist point ``W``, the joint-6 axis ``z6``.
2. ``|W − S|² = K − 2P − 2H cos(q4 − δ)``: ``q4 = δ ± acos(x)``; ``cos q4``, ``sin q4`` by
   the sum formulas (no further trigonometry).
3. For each ``q4``, ``S → W`` in frame 3 (``v3``) and the joint-5 axis there (``u3``), each
   ``c0 + cos q4 cc + sin q4 cs``: ``R3 = v̂ ĥᵀ + f n3ᵀ + b m3ᵀ`` with ``f = cos φ n + sin φ m``,
   ``b = cos φ m − sin φ n`` (``[v̂, n, m]`` fixed by the pose, ``[ĥ, n3, m3]`` by ``q4``),
   and ``cos φ`` from the 5/6 condition, ``sin φ = ±√(1 − cos² φ)``.
4. ``q5``, ``q6`` (subproblem 1 each) as ``atan2`` of dot products that are linear in
   ``cos φ``, ``sin φ`` with coefficients computed once per pose or per ``q4``; the
   shoulder (subproblem 2 on the axis ``k3``, two signs; subproblem 1 for ``q3``) from
   ``t = R(X0)ᵀ R3 a3`` and ``R(X0)ᵀ R3 Cᵀ m3``, built the same way. When the shoulder's
   axes allow it (slot ``TWIN``) the second sign is the first turned,
   ``(q1 + π, −q2, q3 + π)``.
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel, parallel_range
from ..robot._chain_kernels import fk
from ._analytic_codes import (
    A3,
    A6,
    BAD_POSE,
    BAD_Q7,
    BRANCH,
    BRANCHES_MERGED,
    COS_DELTA,
    COS_GAMMA,
    D7,
    DELTA,
    ELBOW_STRETCHED,
    FLAG_SHIFT,
    FLAGS,
    HI,
    HOMOGENEOUS_TOL,
    INV_H,
    K1,
    K1XK2,
    K2,
    K3,
    K12,
    K23,
    K_ELBOW,
    LIMIT_TOL,
    LO,
    M0,
    M3,
    M3C,
    MAX_SOLUTIONS,
    MC,
    MERGE_TOL,
    MS,
    N_VALUES,
    P5C,
    P5S,
    P6,
    P50,
    P_ELBOW,
    POSE,
    POSITION_ERROR,
    Q5C,
    Q5S,
    Q6,
    Q50,
    REACH_TOL,
    ROTATION_ERROR,
    ROTATION_TOL,
    SELF_MOTION,
    SHOULDER_SINGULAR,
    SIN_DELTA,
    SINGULAR_TOL,
    SOLVED,
    SRS_A4,
    SRS_ELBOW_FRAME,
    SRS_ELBOW_POINT,
    SRS_INV_H,
    SRS_K,
    SRS_LEVER_TOL,
    SRS_LS,
    SRS_LW,
    SRS_OFFSET_TOL,
    SRS_P,
    SRS_PF,
    SRS_PL3,
    SRS_REACH_TOL,
    SRS_REFERENCE,
    SRS_RF,
    SRS_RL3,
    SRS_RS,
    SRS_RW,
    SRS_S,
    SRS_S3,
    SRS_SIGMA_S,
    SRS_SIGMA_W,
    SRS_STRAIGHT,
    SRS_W4,
    SRS_W7,
    TWIN,
    U0,
    UC,
    UNREACHABLE,
    US,
    V0,
    VC,
    VS,
    WE,
    WITHIN,
    X0,
    S,
)

prange = parallel_range()
PI = math.pi
TWO_PI = 2.0 * math.pi
INV_TWO_PI = 1.0 / TWO_PI


@kernel(inline=True)
def _dot(arm, i, x, y, z):
    """``arm[i : i + 3] · v``, for ``v = (x, y, z)``."""
    return arm[i] * x + arm[i + 1] * y + arm[i + 2] * z


@kernel(inline=True)
def _combo(arm, i0, ic, i_s, c, s):
    """``arm[i0:] + c arm[ic:] + s arm[i_s:]``, three entries from each slot."""
    return (arm[i0] + c * arm[ic] + s * arm[i_s], arm[i0 + 1] + c * arm[ic + 1] + s * arm[i_s + 1],
            arm[i0 + 2] + c * arm[ic + 2] + s * arm[i_s + 2])  # fmt: skip


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
def _angle(kx, ky, kz, ux, uy, uz, wx, wy, wz):
    """The rotation about the unit ``k`` that takes ``u`` to ``w`` (equal components
    along ``k``): Paden–Kahan subproblem 1, ``θ = atan2(k·(u × w), u·w − (k·u)(k·w))``.
    Returns ``(θ, cos θ, sin θ)`` (``(0, 1, 0)`` when a perpendicular part vanishes)."""
    cx, cy, cz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    along = (kx * ux + ky * uy + kz * uz) * (kx * wx + ky * wy + kz * wz)
    x = ux * wx + uy * wy + uz * wz - along
    y = kx * cx + ky * cy + kz * cz
    r = math.sqrt(x * x + y * y)
    if r == 0.0:
        return 0.0, 1.0, 0.0
    return math.atan2(y, x), x / r, y / r


@kernel
def _rot(ax, ay, az, c, s, x, y, z):
    """``Rot(a, θ) v`` (Rodrigues): ``v c + (a × v) s + a (a·v)(1 − c)``, ``c, s`` of θ."""
    d = (ax * x + ay * y + az * z) * (1.0 - c)
    return (
        x * c + (ay * z - az * y) * s + ax * d,
        y * c + (az * x - ax * z) * s + ay * d,
        z * c + (ax * y - ay * x) * s + az * d,
    )


@kernel(inline=True)
def _wrap(x):
    """``x`` moved by a multiple of 2π into ``[−π, π)`` (to rounding at the ends; no
    branch: the angles wrapped are mostly inside already)."""
    return x - TWO_PI * math.floor(x * INV_TWO_PI + 0.5)


@kernel
def _is_pose(T):
    """Whether ``T`` is 4x4, finite, its last row ``[0, 0, 0, 1]`` (to
    ``HOMOGENEOUS_TOL``) and its 3x3 block a proper rotation (to ``ROTATION_TOL``)."""
    if T.shape[0] != 4 or T.shape[1] != 4:
        return False
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
def _frame6(arm, T, c7, s7):
    """``R6 = R_T (M0 + c7 MC + s7 MS)``, row by row (9 values)."""
    m0, m1, m2 = _combo(arm, M0, MC, MS, c7, s7)
    m3, m4, m5 = _combo(arm, M0 + 3, MC + 3, MS + 3, c7, s7)
    m6, m7, m8 = _combo(arm, M0 + 6, MC + 6, MS + 6, c7, s7)
    return (
        T[0, 0] * m0 + T[0, 1] * m3 + T[0, 2] * m6,
        T[0, 0] * m1 + T[0, 1] * m4 + T[0, 2] * m7,
        T[0, 0] * m2 + T[0, 1] * m5 + T[0, 2] * m8,
        T[1, 0] * m0 + T[1, 1] * m3 + T[1, 2] * m6,
        T[1, 0] * m1 + T[1, 1] * m4 + T[1, 2] * m7,
        T[1, 0] * m2 + T[1, 1] * m5 + T[1, 2] * m8,
        T[2, 0] * m0 + T[2, 1] * m3 + T[2, 2] * m6,
        T[2, 0] * m1 + T[2, 1] * m4 + T[2, 2] * m7,
        T[2, 0] * m2 + T[2, 1] * m5 + T[2, 2] * m8,
    )


@kernel(inline=True)
def _apply(R, arm, i):
    """``R arm[i : i + 3]`` for ``R`` a 9-tuple, row by row."""
    x, y, z = arm[i], arm[i + 1], arm[i + 2]
    return (R[0] * x + R[1] * y + R[2] * z, R[3] * x + R[4] * y + R[5] * z,
            R[6] * x + R[7] * y + R[8] * z)  # fmt: skip


@kernel(inline=True)
def _base(arm, x, y, z):
    """``R(X0)ᵀ v``: a world vector in the placement frame of joint 1."""
    return (arm[X0] * x + arm[X0 + 3] * y + arm[X0 + 6] * z,
            arm[X0 + 1] * x + arm[X0 + 4] * y + arm[X0 + 7] * z,
            arm[X0 + 2] * x + arm[X0 + 5] * y + arm[X0 + 8] * z)  # fmt: skip


@kernel(nogil=False)  # called from Python, about a microsecond
def solve_pose(arm, T, q7, out):
    """Every solution of pose ``T`` at ``q7`` (module docstring) into ``out``; returns
    ``count + (flags << FLAG_SHIFT)``, or a negative status (``_analytic_codes``)."""
    if not _is_pose(T):
        return BAD_POSE
    if not math.isfinite(q7):
        return BAD_Q7
    for i in range(3):  # the pose, for the FK errors
        for j in range(4):
            out[POSE, 4 * i + j] = T[i, j]
    # 1. frame 6, the wrist point W, the joint-6 axis z6
    R6 = _frame6(arm, T, math.cos(q7), math.sin(q7))
    e0, e1, e2 = _apply(R6, arm, WE)
    wx = T[0, 3] + T[0, 0] * arm[D7] + T[0, 1] * arm[D7 + 1] + T[0, 2] * arm[D7 + 2] + e0
    wy = T[1, 3] + T[1, 0] * arm[D7] + T[1, 1] * arm[D7 + 1] + T[1, 2] * arm[D7 + 2] + e1
    wz = T[2, 3] + T[2, 0] * arm[D7] + T[2, 1] * arm[D7 + 1] + T[2, 2] * arm[D7 + 2] + e2
    z6x, z6y, z6z = _apply(R6, arm, A6)
    vx, vy, vz, dist = _unit(wx - arm[S], wy - arm[S + 1], wz - arm[S + 2])
    # 2. the elbow: cos(q4 − δ) = x
    x = ((arm[K_ELBOW] - dist * dist) / 2.0 - arm[P_ELBOW]) * arm[INV_H]
    if abs(x) > 1.0 + REACH_TOL:
        return UNREACHABLE << FLAG_SHIFT
    pose_flags = 0
    n4 = 2
    if 1.0 - abs(x) < MERGE_TOL:  # a double root: the two elbow solutions are one
        n4 = 1
        pose_flags |= ELBOW_STRETCHED
    x = min(1.0, max(-1.0, x))
    spread4 = math.acos(x)
    root4 = math.sqrt((1.0 - x) * (1.0 + x))  # sin of spread4
    if dist < SINGULAR_TOL:  # W at S: any direction maps onto it; pick one
        vx, vy, vz = 0.0, 0.0, 1.0
        pose_flags |= SELF_MOTION
    # the pose's frame [v̂, n, m] about S → W: n along the part of z6 normal to it
    z_along = z6x * vx + z6y * vy + z6z * vz
    nx, ny, nz, nzp = _unit(z6x - z_along * vx, z6y - z_along * vy, z6z - z_along * vz)
    if nzp < SINGULAR_TOL:
        nx, ny, nz = _perpendicular(vx, vy, vz)
    mx, my, mz = vy * nz - vz * ny, vz * nx - vx * nz, vx * ny - vy * nx
    zn, zm = z6x * nx + z6y * ny + z6z * nz, z6x * mx + z6y * my + z6z * mz
    # q6's two vectors (world) dotted with v̂, n, m
    p0, p1, p2 = _apply(R6, arm, P6)
    g0, g1, g2 = _apply(R6, arm, Q6)
    pv, pn, pm = (
        p0 * vx + p1 * vy + p2 * vz,
        p0 * nx + p1 * ny + p2 * nz,
        p0 * mx + p1 * my + p2 * mz,
    )
    gv, gn, gm = (
        g0 * vx + g1 * vy + g2 * vz,
        g0 * nx + g1 * ny + g2 * nz,
        g0 * mx + g1 * my + g2 * mz,
    )
    # v̂, n, m in the placement frame of joint 1 (the shoulder's)
    bvx, bvy, bvz = _base(arm, vx, vy, vz)
    bnx, bny, bnz = _base(arm, nx, ny, nz)
    bmx, bmy, bmz = _base(arm, mx, my, mz)
    ok7 = (arm[LO + 6] - LIMIT_TOL <= q7) & (q7 <= arm[HI + 6] + LIMIT_TOL)
    count = 0
    all_flags = 0
    for i4 in range(n4):
        sign4 = 1.0 if i4 == 0 else -1.0
        x4, ok4 = _limit(arm, 3, arm[DELTA] + sign4 * spread4)
        c4 = arm[COS_DELTA] * x - sign4 * arm[SIN_DELTA] * root4
        s4 = arm[SIN_DELTA] * x + sign4 * arm[COS_DELTA] * root4
        # 3. S → W (v3, direction ĥ) and the joint-5 axis (u3) in frame 3
        h0, h1, h2 = _combo(arm, V0, VC, VS, c4, s4)
        u0, u1, u2 = _combo(arm, U0, UC, US, c4, s4)
        hx, hy, hz, length3 = _unit(h0, h1, h2)
        if length3 < SINGULAR_TOL:
            hx, hy, hz = 0.0, 0.0, 1.0
        uh = u0 * hx + u1 * hy + u2 * hz
        n3x, n3y, n3z, nu = _unit(u0 - uh * hx, u1 - uh * hy, u2 - uh * hz)
        rhs = arm[COS_GAMMA] - z_along * uh
        flags4 = pose_flags
        n_phi = 2
        cp, sp = 1.0, 0.0
        if nu * nzp < SINGULAR_TOL:  # the condition does not involve φ
            if abs(rhs) > math.sqrt(SINGULAR_TOL):
                continue  # nor holds: no solution at this q4
            n_phi = 1
            flags4 |= SELF_MOTION
            if nu < SINGULAR_TOL:
                n3x, n3y, n3z = _perpendicular(hx, hy, hz)
        else:
            y = rhs / (nu * nzp)
            if abs(y) > 1.0 + REACH_TOL:
                continue
            if 1.0 - abs(y) < MERGE_TOL:
                n_phi = 1
                flags4 |= BRANCHES_MERGED
            cp = min(1.0, max(-1.0, y))
            sp = math.sqrt((1.0 - cp) * (1.0 + cp))
        m3x, m3y, m3z = hy * n3z - hz * n3y, hz * n3x - hx * n3z, hx * n3y - hy * n3x
        un, um = u0 * n3x + u1 * n3y + u2 * n3z, u0 * m3x + u1 * m3y + u2 * m3z
        # q5's two vectors in frame 3 (for this q4) dotted with ĥ, n3, m3
        a0, a1, a2 = _combo(arm, P50, P5C, P5S, c4, s4)
        b0, b1, b2 = _combo(arm, Q50, Q5C, Q5S, c4, s4)
        ah, an, am = (
            a0 * hx + a1 * hy + a2 * hz,
            a0 * n3x + a1 * n3y + a2 * n3z,
            a0 * m3x + a1 * m3y + a2 * m3z,
        )
        bh, bn, bm = (
            b0 * hx + b1 * hy + b2 * hz,
            b0 * n3x + b1 * n3y + b2 * n3z,
            b0 * m3x + b1 * m3y + b2 * m3z,
        )
        # the shoulder's two frame-3 vectors (a3, Cᵀ m3) dotted with ĥ, n3, m3
        th, tn, tm = (
            _dot(arm, A3, hx, hy, hz),
            _dot(arm, A3, n3x, n3y, n3z),
            _dot(arm, A3, m3x, m3y, m3z),
        )
        ch, cn, cm = (
            _dot(arm, M3C, hx, hy, hz),
            _dot(arm, M3C, n3x, n3y, n3z),
            _dot(arm, M3C, m3x, m3y, m3z),
        )
        for i_phi in range(n_phi):
            s = sp if i_phi == 0 else -sp
            # R3 = v̂ ĥᵀ + f n3ᵀ + b m3ᵀ, f = c n + s m, b = c m − s n (R3 ĥ = v̂)
            # q6: z5 = R3 u3 = uh v̂ + un f + um b
            pf, pb = cp * pn + s * pm, cp * pm - s * pn
            gf, gb = cp * gn + s * gm, cp * gm - s * gn
            q6 = math.atan2(uh * pv + un * pf + um * pb, uh * gv + un * gf + um * gb)
            # q5: R3ᵀ z6 = z_along ĥ + (f·z6) n3 + (b·z6) m3
            zf, zb = cp * zn + s * zm, cp * zm - s * zn
            q5 = math.atan2(z_along * ah + zf * an + zb * am, z_along * bh + zf * bn + zb * bm)
            # 4. the shoulder: t = R(X0)ᵀ R3 a3, w = R(X0)ᵀ R3 Cᵀ m3
            fx, fy, fz = cp * bnx + s * bmx, cp * bny + s * bmy, cp * bnz + s * bmz
            gx, gy, gz = cp * bmx - s * bnx, cp * bmy - s * bny, cp * bmz - s * bnz
            tx, ty, tz = (
                th * bvx + tn * fx + tm * gx,
                th * bvy + tn * fy + tm * gy,
                th * bvz + tn * fz + tm * gz,
            )
            kx, ky, kz = (
                ch * bvx + cn * fx + cm * gx,
                ch * bvy + cn * fy + cm * gy,
                ch * bvz + cn * fz + cm * gz,
            )
            branch = 4 * i4 + 2 * i_phi
            x5, ok5 = _limit(arm, 4, q5)
            x6, ok6 = _limit(arm, 5, q6)
            rest = (x4, x5, x6, q7, ok4 & ok5 & ok6 & ok7)
            count = _shoulder(arm, tx, ty, tz, kx, ky, kz, rest, branch, flags4, out, count)
    if count == 0:
        return UNREACHABLE << FLAG_SHIFT
    for r in range(count):
        all_flags |= int(out[r, FLAGS])
    return count | all_flags << FLAG_SHIFT


@kernel
def _shoulder(arm, tx, ty, tz, wx, wy, wz, rest, branch, flags, out, count):
    """The shoulder's solutions, ``Rot(k1, q1) Rot(k2, q2) Rot(k3, q3) k3 = t`` and
    ``… m3 = w`` (subproblem 2, two signs, then subproblem 1), emitted into ``out``
    from row ``count``; returns the new count."""
    k1x, k1y, k1z = arm[K1], arm[K1 + 1], arm[K1 + 2]
    k2x, k2y, k2z = arm[K2], arm[K2 + 1], arm[K2 + 2]
    k3x, k3y, k3z = arm[K3], arm[K3 + 1], arm[K3 + 2]
    # subproblem 2: o = x k1 + y k2 ± z (k1 × k2), with k1·o = k1·t, k2·o = k2·k3
    k12, b23 = arm[K12], arm[K23]
    b1t = k1x * tx + k1y * ty + k1z * tz
    den = 1.0 - k12 * k12
    xs, ys = (b1t - k12 * b23) / den, (b23 - k12 * b1t) / den
    z2 = (1.0 - xs * xs - ys * ys - 2.0 * xs * ys * k12) / den
    if z2 < -REACH_TOL:
        return count  # this shoulder cannot point axis 3 along t
    zs = math.sqrt(max(z2, 0.0))
    sx, sy, sz = k1y * tz - k1z * ty, k1z * tx - k1x * tz, k1x * ty - k1y * tx
    singular = math.sqrt(sx * sx + sy * sy + sz * sz) < SINGULAR_TOL
    q1 = q2 = q3 = 0.0
    ox = oy = oz = 0.0
    for i_sh in range(1 if singular else 2):
        if i_sh == 1 and arm[TWIN] == 1.0:  # the first solution turned (module docstring)
            q1, q2, q3 = q1 + PI, -q2, q3 + PI
        else:
            sign = zs if i_sh == 0 else -zs
            ox = xs * k1x + ys * k2x + sign * arm[K1XK2]
            oy = xs * k1y + ys * k2y + sign * arm[K1XK2 + 1]
            oz = xs * k1z + ys * k2z + sign * arm[K1XK2 + 2]
            q2, c2, s2 = _angle(k2x, k2y, k2z, k3x, k3y, k3z, ox, oy, oz)
            q1, c1, s1 = 0.0, 1.0, 0.0
            if not singular:
                q1, c1, s1 = _angle(k1x, k1y, k1z, ox, oy, oz, tx, ty, tz)
            # Rot(k3, q3) m3 = Rot(k2, −q2) Rot(k1, −q1) w
            r0, r1, r2 = _rot(k1x, k1y, k1z, c1, -s1, wx, wy, wz)
            r0, r1, r2 = _rot(k2x, k2y, k2z, c2, -s2, r0, r1, r2)
            q3 = _angle(k3x, k3y, k3z, arm[M3], arm[M3 + 1], arm[M3 + 2], r0, r1, r2)[0]
        f = flags
        a1, a3 = q1, q3
        if singular:  # only q1 + σ q3 is fixed (o = σ k1): split it evenly
            sigma = 1.0 if k1x * ox + k1y * oy + k1z * oz > 0.0 else -1.0
            a1, a3 = 0.5 * sigma * q3, 0.5 * q3
            f |= SHOULDER_SINGULAR
        _emit(arm, out[count], a1, q2, a3, rest, branch + i_sh, f)
        count += 1
    return count


@kernel(inline=True)
def _limit(arm, j, x):
    """Joint ``j`` at ``x``, wrapped into ``[−π, π)`` and moved by 2π into its limits
    where that fits; returns ``(x, whether it is within them)``."""
    lo, hi = arm[LO + j] - LIMIT_TOL, arm[HI + j] + LIMIT_TOL
    x = _wrap(x)
    if x + TWO_PI <= hi and x < lo:  # the first test is false for limits inside (−π, π)
        x += TWO_PI
    elif x - TWO_PI >= lo and x > hi:
        x -= TWO_PI
    return x, (lo <= x) & (x <= hi)


@kernel
def _group(arm, j, t1, t2, t3):
    """:func:`_limit` of joints ``j … j + 2``: ``(x1, x2, x3, all within)``."""
    x1, ok1 = _limit(arm, j, t1)
    x2, ok2 = _limit(arm, j + 1, t2)
    x3, ok3 = _limit(arm, j + 2, t3)
    return x1, x2, x3, ok1 & ok2 & ok3


@kernel
def _emit(arm, row, q1, q2, q3, rest, branch, flags):
    """One solution into ``row``: joints 1-3 (limited here), ``rest``: ``(q4, q5, q6, q7,
    whether they are within the limits)`` (limited once for the solutions sharing them),
    branch, flags, within the limits."""
    x1, ok1 = _limit(arm, 0, q1)
    x2, ok2 = _limit(arm, 1, q2)
    x3, ok3 = _limit(arm, 2, q3)
    row[0], row[1], row[2] = x1, x2, x3
    row[3], row[4], row[5], row[6] = rest[0], rest[1], rest[2], rest[3]
    row[BRANCH] = branch
    row[FLAGS] = flags
    row[WITHIN] = 1.0 if ok1 & ok2 & ok3 & rest[4] else 0.0


@kernel(nogil=False)  # called from Python, under a microsecond per solution
def errors(links, axes, kinds, out, count):
    """The FK errors of solutions ``0 … count − 1`` of ``out`` against its pose row:
    position (m) and rotation angle (rad) into their columns (the chain's own FK)."""
    F = np.empty((4, 4))
    P = out[POSE]
    for r in range(count):
        row = out[r]
        fk(links, axes, kinds, row, F)
        dx, dy, dz = F[0, 3] - P[3], F[1, 3] - P[7], F[2, 3] - P[11]
        row[POSITION_ERROR] = math.sqrt(dx * dx + dy * dy + dz * dz)
        # the angle of E = R_Tᵀ R: atan2(|vee(E − Eᵀ)| / 2, (tr E − 1) / 2), accurate at
        # every angle
        wx = _pose_dot(P, F, 2, 1) - _pose_dot(P, F, 1, 2)
        wy = _pose_dot(P, F, 0, 2) - _pose_dot(P, F, 2, 0)
        wz = _pose_dot(P, F, 1, 0) - _pose_dot(P, F, 0, 1)
        trace = _pose_dot(P, F, 0, 0) + _pose_dot(P, F, 1, 1) + _pose_dot(P, F, 2, 2)
        half_sine = 0.5 * math.sqrt(wx * wx + wy * wy + wz * wz)
        row[ROTATION_ERROR] = math.atan2(half_sine, 0.5 * (trace - 1.0))


@kernel(inline=True)
def _pose_dot(P, F, i, j):
    """Column ``i`` of the pose row's rotation (``P``: ``T[:3, :4]`` row by row) dotted
    with column ``j`` of ``F[:3, :3]``: ``(R_Tᵀ R_F)[i, j]``."""
    return P[i] * F[0, j] + P[4 + i] * F[1, j] + P[8 + i] * F[2, j]


@kernel(parallel=True)
def solve_many(arm, links, axes, kinds, T, q7, out, summary, residuals):
    """:func:`solve_pose` for poses ``T[i]`` ``(N, 4, 4)`` at ``q7[i]`` into ``out[i]``,
    and :func:`errors` when ``residuals`` (else the FK errors are NaN), rows past the
    count padded (zeros, branch −1); ``summary[i]`` <- ``(status, count, flags)``."""
    for i in prange(T.shape[0]):
        code = solve_pose(arm, T[i], q7[i], out[i])
        count, flags, status = 0, 0, code
        if code >= 0:
            count, flags, status = code & ((1 << FLAG_SHIFT) - 1), code >> FLAG_SHIFT, SOLVED
            if residuals:
                errors(links, axes, kinds, out[i], count)
            else:
                for r in range(count):
                    out[i, r, POSITION_ERROR] = math.nan
                    out[i, r, ROTATION_ERROR] = math.nan
        for r in range(count, MAX_SOLUTIONS):
            for j in range(N_VALUES):
                out[i, r, j] = 0.0
            out[i, r, BRANCH] = -1.0
        summary[i, 0] = status
        summary[i, 1] = count
        summary[i, 2] = flags


# ---------------------------------------------------------------------- arm angle
# The S-R-S closed form of :mod:`redres.ik.srs` at one arm angle (its module docstring,
# steps 1-3): ``R3 = Rot(ŵ, φ) R3⁰``; the shoulder's ``M = Lᵀ R3 Rʳ`` and the wrist's
# ``M = Lᵀ (R3 Q4)ᵀ R7 Rʳ`` give three joints each, ``θ₁ = atan2(g M₁₂, g M₀₂)``,
# ``θ₂ = g acos M₂₂``, ``θ₃ = σ atan2(g M₂₁, −g M₂₀)`` (0-based entries); ``g = −1`` turns
# both atan2 by π.


@kernel(inline=True)
def _matrix(arm, i):
    """The 3x3 matrix in slots ``i … i + 8``, row by row, as a 9-tuple."""
    return (arm[i], arm[i + 1], arm[i + 2], arm[i + 3], arm[i + 4], arm[i + 5], arm[i + 6],
            arm[i + 7], arm[i + 8])  # fmt: skip


@kernel(inline=True)
def _tr(A):
    """The transpose of a 9-tuple matrix."""
    return (A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8])


@kernel
def _mul(A, B):
    """``A B`` of 9-tuple matrices (row by row)."""
    return (
        A[0] * B[0] + A[1] * B[3] + A[2] * B[6],
        A[0] * B[1] + A[1] * B[4] + A[2] * B[7],
        A[0] * B[2] + A[1] * B[5] + A[2] * B[8],
        A[3] * B[0] + A[4] * B[3] + A[5] * B[6],
        A[3] * B[1] + A[4] * B[4] + A[5] * B[7],
        A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
        A[6] * B[0] + A[7] * B[3] + A[8] * B[6],
        A[6] * B[1] + A[7] * B[4] + A[8] * B[7],
        A[6] * B[2] + A[7] * B[5] + A[8] * B[8],
    )


@kernel
def _euler(M, sigma):
    """``(θ₁, θ₂, θ₃)`` of ``M`` for ``g = +1`` (the ``g = −1`` angles: the first and third
    turned by π, the second negated)."""
    t1 = math.atan2(M[5], M[2])
    t2 = math.acos(min(1.0, max(-1.0, M[8])))
    t3 = sigma * math.atan2(M[7], -M[6])
    return t1, t2, t3


@kernel
def _srs_joints(srs, q4, R7, h, f, g):
    """``(valid, θ₁, θ₂, θ₃, θ₅, θ₆, θ₇)`` (``g = +1``) at elbow angle ``q4``, with
    ``R3 = ŵ x_locᵀ + f y_locᵀ + g z_locᵀ`` (``h = ŵ``); not valid when the elbow point is
    on the line ``S → W`` (the arm angle is not defined)."""
    c4, s4 = math.cos(q4), math.sin(q4)
    # Q4 = R(L3) Rot(a4, q4), column by column from Rodrigues
    a0, a1, a2 = srs[SRS_A4], srs[SRS_A4 + 1], srs[SRS_A4 + 2]
    e0 = _rot(a0, a1, a2, c4, s4, 1.0, 0.0, 0.0)
    e1 = _rot(a0, a1, a2, c4, s4, 0.0, 1.0, 0.0)
    e2 = _rot(a0, a1, a2, c4, s4, 0.0, 0.0, 1.0)
    Q4 = _mul(
        _matrix(srs, SRS_RL3), (e0[0], e1[0], e2[0], e0[1], e1[1], e2[1], e0[2], e1[2], e2[2])
    )
    u0, u1, u2 = _apply(Q4, srs, SRS_W4)
    u0 += srs[SRS_PL3] - srs[SRS_S3]
    u1 += srs[SRS_PL3 + 1] - srs[SRS_S3 + 1]
    u2 += srs[SRS_PL3 + 2] - srs[SRS_S3 + 2]
    if srs[SRS_ELBOW_FRAME] == 1.0:
        p0, p1, p2 = _apply(Q4, srs, SRS_ELBOW_POINT)
        p0, p1, p2 = p0 + srs[SRS_PL3], p1 + srs[SRS_PL3 + 1], p2 + srs[SRS_PL3 + 2]
    else:
        p0, p1, p2 = srs[SRS_ELBOW_POINT], srs[SRS_ELBOW_POINT + 1], srs[SRS_ELBOW_POINT + 2]
    p0, p1, p2 = p0 - srs[SRS_S3], p1 - srs[SRS_S3 + 1], p2 - srs[SRS_S3 + 2]
    lx, ly, lz, _ = _unit(u0, u1, u2)
    along = p0 * lx + p1 * ly + p2 * lz
    mx, my, mz, offset = _unit(p0 - along * lx, p1 - along * ly, p2 - along * lz)
    if not offset > SRS_OFFSET_TOL:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    nx, ny, nz = ly * mz - lz * my, lz * mx - lx * mz, lx * my - ly * mx
    R3 = (h[0] * lx + f[0] * mx + g[0] * nx, h[0] * ly + f[0] * my + g[0] * ny,
          h[0] * lz + f[0] * mz + g[0] * nz, h[1] * lx + f[1] * mx + g[1] * nx,
          h[1] * ly + f[1] * my + g[1] * ny, h[1] * lz + f[1] * mz + g[1] * nz,
          h[2] * lx + f[2] * mx + g[2] * nx, h[2] * ly + f[2] * my + g[2] * ny,
          h[2] * lz + f[2] * mz + g[2] * nz)  # fmt: skip
    shoulder = _mul(_mul(_tr(_matrix(srs, SRS_LS)), R3), _matrix(srs, SRS_RS))
    wrist = _mul(_tr(_mul(R3, Q4)), _mul(R7, _matrix(srs, SRS_RW)))
    wrist = _mul(_tr(_matrix(srs, SRS_LW)), wrist)
    t1, t2, t3 = _euler(shoulder, srs[SRS_SIGMA_S])
    t5, t6, t7 = _euler(wrist, srs[SRS_SIGMA_W])
    return True, t1, t2, t3, t5, t6, t7


@kernel(inline=True)
def _flip(t):
    """``atan2(−y, −x)`` from ``t = atan2(y, x)``."""
    return t - math.copysign(PI, t)


@kernel(nogil=False)  # called from Python, under a microsecond
def solve_arm_angle(srs, T, phi, out):
    """Every solution of pose ``T`` at arm angle ``phi`` (rad) of an S-R-S arm (constants
    ``srs``, slots ``SRS_*``) into ``out``, in branch order ``4 i₂ + 2 i₄ + i₆``
    (:data:`redres.ik.srs.BRANCHES`); returns as :func:`solve_pose`."""
    if not _is_pose(T):
        return BAD_POSE
    if not math.isfinite(phi):
        return BAD_Q7
    for i in range(3):
        for j in range(4):
            out[POSE, 4 * i + j] = T[i, j]
    RT = (T[0, 0], T[0, 1], T[0, 2], T[1, 0], T[1, 1], T[1, 2], T[2, 0], T[2, 1], T[2, 2])
    R7 = _mul(RT, _tr(_matrix(srs, SRS_RF)))
    f0, f1, f2 = _apply(R7, srs, SRS_PF)
    w0, w1, w2 = _apply(R7, srs, SRS_W7)
    wvx = T[0, 3] - f0 + w0 - srs[SRS_S]
    wvy = T[1, 3] - f1 + w1 - srs[SRS_S + 1]
    wvz = T[2, 3] - f2 + w2 - srs[SRS_S + 2]
    hx, hy, hz, d = _unit(wvx, wvy, wvz)
    x = ((srs[SRS_K] - d * d) / 2.0 - srs[SRS_P]) * srs[SRS_INV_H]
    if abs(x) > 1.0 + SRS_REACH_TOL:
        return UNREACHABLE << FLAG_SHIFT
    bend = math.acos(min(1.0, max(-1.0, -x)))
    # the world frame of the arm angle: ŵ, the reference's lever (ŵ × r) × ŵ, their cross
    rx, ry, rz = srs[SRS_REFERENCE], srs[SRS_REFERENCE + 1], srs[SRS_REFERENCE + 2]
    ax, ay, az = wvy * rz - wvz * ry, wvz * rx - wvx * rz, wvx * ry - wvy * rx
    yx, yy, yz, lever = _unit(ay * wvz - az * wvy, az * wvx - ax * wvz, ax * wvy - ay * wvx)
    if not lever > SRS_LEVER_TOL * d * d:
        return UNREACHABLE << FLAG_SHIFT
    zx, zy, zz = hy * yz - hz * yy, hz * yx - hx * yz, hx * yy - hy * yx
    c, s = math.cos(phi), math.sin(phi)
    # R3 = Rot(ŵ, φ) R3⁰ = ŵ x_locᵀ + (c y + s z) y_locᵀ + (c z − s y) z_locᵀ
    fx, fy, fz = c * yx + s * zx, c * yy + s * zy, c * yz + s * zz
    gx, gy, gz = c * zx - s * yx, c * zy - s * yy, c * zz - s * yz
    h, f, g = (hx, hy, hz), (fx, fy, fz), (gx, gy, gz)
    q4a = PI - ((PI - (srs[SRS_STRAIGHT] + bend)) % TWO_PI)
    q4b = PI - ((PI - (srs[SRS_STRAIGHT] - bend)) % TWO_PI)
    ok_a, a1, a2, a3, a5, a6, a7 = _srs_joints(srs, q4a, R7, h, f, g)
    ok_b, b1, b2, b3, b5, b6, b7 = _srs_joints(srs, q4b, R7, h, f, g)
    # each group of three joints limited once (g = ±1), then combined into branches
    ga = (_limit(srs, 3, q4a), _group(srs, 0, a1, a2, a3),
          _group(srs, 0, _flip(a1), -a2, _flip(a3)), _group(srs, 4, a5, a6, a7),
          _group(srs, 4, _flip(a5), -a6, _flip(a7)))  # fmt: skip
    gb = (_limit(srs, 3, q4b), _group(srs, 0, b1, b2, b3),
          _group(srs, 0, _flip(b1), -b2, _flip(b3)), _group(srs, 4, b5, b6, b7),
          _group(srs, 4, _flip(b5), -b6, _flip(b7)))  # fmt: skip
    count = 0
    for b in range(8):
        i2, e, i6 = b >> 2, (b >> 1) & 1, b & 1
        if not (ok_a if e == 0 else ok_b):
            continue
        G = ga if e == 0 else gb
        S = G[1] if i2 == 0 else G[2]
        W = G[3] if i6 == 0 else G[4]
        row = out[count]
        row[0], row[1], row[2], row[3] = S[0], S[1], S[2], G[0][0]
        row[4], row[5], row[6] = W[0], W[1], W[2]
        row[BRANCH] = b
        row[FLAGS] = 0.0
        row[WITHIN] = 1.0 if S[3] and G[0][1] and W[3] else 0.0
        count += 1
    if count == 0:
        return UNREACHABLE << FLAG_SHIFT
    return count
