"""Compiled analytic IK of S-R-S arms at one arm angle (internal): every solution of one
pose (iiwa14, srs7, file arms detected as S-R-S).

Entry point and its call tree::

    solve_arm_angle(srs, T, phi, out) -> count, or a negative status
        _is_pose, _srs_joints (-> _euler, _mul), _limit, _group, _flip
        (the shared geometry in :mod:`._geometry_kernels`)

The S-R-S closed form of :mod:`redres.ik.srs` at one arm angle (its module docstring,
steps 1-3): ``R3 = Rot(ŵ, φ) R3⁰``; the shoulder's ``M = Lᵀ R3 Rʳ`` and the wrist's
``M = Lᵀ (R3 Q4)ᵀ R7 Rʳ`` give three joints each, ``θ₁ = atan2(g M₁₂, g M₀₂)``,
``θ₂ = g acos M₂₂``, ``θ₃ = σ atan2(g M₂₁, −g M₂₀)`` (0-based entries); ``g = −1`` turns
both atan2 by π. ``srs`` holds the arm's constants (slots ``SRS_*`` of
:mod:`._analytic_codes`, from :meth:`redres.ik.srs.SRSArm.constants`); ``out`` as for
:func:`._q7_kernels.solve_pose`.
"""

from __future__ import annotations

import math

from .._compile import kernel
from ._analytic_codes import (
    BAD_POSE,
    BAD_Q7,
    BRANCH,
    FLAG_SHIFT,
    FLAGS,
    POSE,
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
    UNREACHABLE,
    WITHIN,
)
from ._geometry_kernels import PI, TWO_PI, _apply, _group, _is_pose, _limit, _rot, _unit


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
