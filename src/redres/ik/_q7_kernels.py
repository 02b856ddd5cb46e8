"""Compiled analytic IK of 7R arms at a given ``q7`` (internal): every solution of one pose
(Panda, FR3: offset elbow and wrist; also S-R-S arms).

Entry points and their call tree::

    solve_pose(arm, T, q7, out) -> count + (flags << FLAG_SHIFT), or a negative status
        _is_pose, _frame6, _unit, _perpendicular, _in_frame, _mix, _angle, _limit,
        _shoulder -> _emit
        (the shared geometry in :mod:`._geometry_kernels`)
    solve_many(arm, links, axes, kinds, T, q7, out, summary, residuals)
        solve_pose, and :func:`._residual_kernels.errors` when residuals, over a parallel
        range of poses (each pose independent: results do not depend on the thread count)

``arm`` holds the arm's constants (slots of :mod:`._analytic_codes`, derived in
:func:`redres.ik.structure.analytic_arm`); ``links, axes, kinds`` are
:attr:`redres.robot.SerialChain.arrays` of the 7 joints and the frame; ``T`` the frame's
pose ``(4, 4)``; ``out`` ``(N_ROWS, N_VALUES)`` receives the solutions (joints, FK
errors, branch, flags, within the limits), then the pose and the arguments of the
``acos`` of steps 2 and 3 (rows ``POSE``, ``ROOTS``). The
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

from .._compile import kernel, parallel_range
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
    ROOTS,
    ROTATION_ERROR,
    SELF_MOTION,
    SHOULDER_SINGULAR,
    SIN_DELTA,
    SINGULAR_TOL,
    SOLVED,
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
from ._geometry_kernels import (
    PI,
    _angle,
    _apply,
    _is_pose,
    _limit,
    _perpendicular,
    _rot,
    _unit,
)
from ._residual_kernels import errors

prange = parallel_range()


@kernel(inline=True)
def _in_frame(x, y, z, ax, ay, az, bx, by, bz, cx, cy, cz):
    """``(v·a, v·b, v·c)`` for ``v = (x, y, z)``: ``v``'s components along the axes
    ``a, b, c`` of a frame."""
    return (x * ax + y * ay + z * az, x * bx + y * by + z * bz,
            x * cx + y * cy + z * cz)  # fmt: skip


@kernel(inline=True)
def _mix(s0, s1, s2, ax, ay, az, bx, by, bz, cx, cy, cz):
    """``s0 a + s1 b + s2 c``: a vector from its components along the axes ``a, b, c``."""
    return (s0 * ax + s1 * bx + s2 * cx, s0 * ay + s1 * by + s2 * cy,
            s0 * az + s1 * bz + s2 * cz)  # fmt: skip


@kernel(inline=True)
def _combo(arm, i0, ic, i_s, c, s):
    """``arm[i0:] + c arm[ic:] + s arm[i_s:]``, three entries from each slot."""
    return (arm[i0] + c * arm[ic] + s * arm[i_s], arm[i0 + 1] + c * arm[ic + 1] + s * arm[i_s + 1],
            arm[i0 + 2] + c * arm[ic + 2] + s * arm[i_s + 2])  # fmt: skip


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
    for j in range(N_VALUES):  # the roots' arguments, filled as they are reached
        out[ROOTS, j] = math.nan
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
    out[ROOTS, 0] = x
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
    pv, pn, pm = _in_frame(p0, p1, p2, vx, vy, vz, nx, ny, nz, mx, my, mz)
    gv, gn, gm = _in_frame(g0, g1, g2, vx, vy, vz, nx, ny, nz, mx, my, mz)
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
            out[ROOTS, 1 + i4] = y
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
        ah, an, am = _in_frame(a0, a1, a2, hx, hy, hz, n3x, n3y, n3z, m3x, m3y, m3z)
        bh, bn, bm = _in_frame(b0, b1, b2, hx, hy, hz, n3x, n3y, n3z, m3x, m3y, m3z)
        # the shoulder's two frame-3 vectors (a3, Cᵀ m3) dotted with ĥ, n3, m3
        th, tn, tm = _in_frame(arm[A3], arm[A3 + 1], arm[A3 + 2],
                               hx, hy, hz, n3x, n3y, n3z, m3x, m3y, m3z)  # fmt: skip
        ch, cn, cm = _in_frame(arm[M3C], arm[M3C + 1], arm[M3C + 2],
                               hx, hy, hz, n3x, n3y, n3z, m3x, m3y, m3z)  # fmt: skip
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
            tx, ty, tz = _mix(th, tn, tm, bvx, bvy, bvz, fx, fy, fz, gx, gy, gz)
            kx, ky, kz = _mix(ch, cn, cm, bvx, bvy, bvz, fx, fy, fz, gx, gy, gz)
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
