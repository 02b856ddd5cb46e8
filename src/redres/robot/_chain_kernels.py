"""Compiled kinematics of a serial chain (internal), through :mod:`redres._compile`.

The chain is the arrays :class:`redres.robot.chain.SerialChain` extracts once from a
Pinocchio model, for ``k`` joints from the base to a frame:

- ``links`` ``(k + 1, 3, 4)``: ``[R | p]`` of joint ``j`` in its parent joint
  (Pinocchio ``model.jointPlacements``), then, last, the frame's fixed placement in the
  last joint (``T_tool``);
- ``axes`` ``(k, 3)``: the joint axis in the joint's own frame (unit vector);
- ``kinds`` ``(k,)``: :data:`REVOLUTE_X` … :data:`PRISMATIC`.

Forward kinematics is the product of the homogeneous transforms along the chain
(Siciliano, Sciavicco, Villani, Oriolo, *Robotics*, 2009, ch. 2, direct kinematics), in
the form Pinocchio composes them (``oMi = oMparent · jointPlacement · M_joint(q)``;
Carpentier et al., "The Pinocchio C++ library", 2019)::

    T_0f = (Π_{j<k} X_j · exp(q_j [a_j])) · T_tool,    X_j = links[j],  T_tool = links[k],
    exp(θ [a]) = Rot(a, θ) (revolute)  or  Trans(a θ) (prismatic)

with ``Rot(a, θ) = I cos θ + sin θ [a]× + (1 − cos θ) a aᵀ`` (Rodrigues); when ``a``
is a coordinate axis only two columns of the running rotation change.

The geometric Jacobian of the frame origin ``p`` (Siciliano et al. 2009, §3.1.3),
world-aligned, column ``j`` with world axis ``z_j = R_0j a_j`` and joint origin ``p_j``::

    revolute:  [z_j × (p − p_j); z_j]        prismatic:  [z_j; 0]

is Pinocchio's ``LOCAL_WORLD_ALIGNED`` frame Jacobian; the frame's own axes (``LOCAL``)
are ``blkdiag(Rᵀ, Rᵀ)`` times it. One pass down the chain stores ``p_j`` and ``z_j`` in
the Jacobian's columns, a second over the columns forms the cross products: no scratch
memory, so the kernels allocate nothing and a batch kernel can call them on slices.

The pose error of a frame task (docs/conventions.md) is ``e = [p_d − p; log(R_d Rᵀ)]``
with the SO(3) logarithm of :func:`log3`.
"""

from __future__ import annotations

import math

from .._compile import kernel
from ._chain_codes import PRISMATIC, REVOLUTE, REVOLUTE_X, REVOLUTE_Y, REVOLUTE_Z

__all__ = ["PRISMATIC", "REVOLUTE", "REVOLUTE_X", "REVOLUTE_Y", "REVOLUTE_Z"]


@kernel
def _rotation_log(m00, m01, m02, m10, m11, m12, m20, m21, m22):
    """The rotation vector ``θ u = log(M)`` of a rotation matrix ``M`` (entries ``mij``).

    Sola, Deray, Atchuthan, "A micro Lie theory for state estimation in robotics", 2018,
    the logarithmic map of SO(3): with ``w = vee(M − Mᵀ) = 2 sin θ u`` and ``cos θ = (tr M − 1)/2``,
    ``θ = atan2(|w|/2, cos θ)`` is accurate at every angle, and ``log M = θ/(2 sin θ) w``.
    The axis from ``w`` has an absolute error of about ``ε / sin θ``; the symmetric part
    ``(M + Mᵀ)/2 = cos θ I + (1 − cos θ) u uᵀ`` gives it with an error of about
    ``ε / (1 − cos θ)`` (its largest diagonal entry ``u_k²`` is at least 1/3). The two
    bounds cross at ``θ = π/2``: the skew part is used below, the symmetric part above,
    with the sign of ``u`` taken from ``w`` (at ``θ = π`` both signs are logarithms).
    Near 0, ``θ / sin θ = 1 + θ²/6 + O(θ⁴)``.
    """
    wx = m21 - m12
    wy = m02 - m20
    wz = m10 - m01
    s = 0.5 * math.sqrt(wx * wx + wy * wy + wz * wz)
    c = 0.5 * (m00 + m11 + m22 - 1.0)
    theta = math.atan2(s, c)
    if c >= 0.0:
        half = 0.5 + theta * theta / 12.0 if theta < 1e-5 else 0.5 * theta / s
        return half * wx, half * wy, half * wz
    one_minus_c = 1.0 - c
    k = 0
    if m11 > m00:
        k = 1
    if (m22 > m11) if k == 1 else (m22 > m00):
        k = 2
    if k == 0:
        ux = math.sqrt(max(m00 - c, 0.0) / one_minus_c)
        scale = 0.5 / (one_minus_c * ux)
        uy, uz = (m01 + m10) * scale, (m02 + m20) * scale
    elif k == 1:
        uy = math.sqrt(max(m11 - c, 0.0) / one_minus_c)
        scale = 0.5 / (one_minus_c * uy)
        ux, uz = (m01 + m10) * scale, (m12 + m21) * scale
    else:
        uz = math.sqrt(max(m22 - c, 0.0) / one_minus_c)
        scale = 0.5 / (one_minus_c * uz)
        ux, uy = (m02 + m20) * scale, (m12 + m21) * scale
    if ux * wx + uy * wy + uz * wz < 0.0:
        theta = -theta
    return theta * ux, theta * uy, theta * uz


@kernel
def log3(R, out):
    """``out[:3] <- log(R)``, the rotation vector of the 3x3 rotation matrix ``R``; returns
    whether it is finite (False when ``R`` holds NaN or ±inf: all three entries are NaN)."""
    x, y, z = _rotation_log(
        R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2]
    )
    out[0] = x
    out[1] = y
    out[2] = z
    return math.isfinite(x + y + z)


@kernel
def _chain_pass(links, axes, kinds, q, T, J, columns):
    """``T`` (4x4) <- the frame's pose; when ``columns``, ``J[:, j]`` <- ``[p_j; z_j]``
    for a revolute and ``[z_j; 0]`` for a prismatic joint ``j`` (module docstring).
    Returns whether every entry of ``q`` is finite (``x · 0`` is 0 but for NaN and ±inf).

    One body without calls (a call per joint, or choosing between two arrays, costs more
    than the arithmetic): ``T[:3] <- T[:3] · links[j]``, then the joint's motion, which
    for a coordinate axis turns two columns ``(u, v)`` of R into ``(c u + s v, c v − s u)``.
    """
    nonfinite = 0.0
    for x in q:
        nonfinite += x * 0.0
    for i in range(4):
        for col in range(4):
            T[i, col] = 1.0 if i == col else 0.0
    k = kinds.shape[0]
    for j in range(k + 1):
        X = links[j]
        for i in range(3):
            r0, r1, r2 = T[i, 0], T[i, 1], T[i, 2]
            T[i, 3] += r0 * X[0, 3] + r1 * X[1, 3] + r2 * X[2, 3]
            T[i, 0] = r0 * X[0, 0] + r1 * X[1, 0] + r2 * X[2, 0]
            T[i, 1] = r0 * X[0, 1] + r1 * X[1, 1] + r2 * X[2, 1]
            T[i, 2] = r0 * X[0, 2] + r1 * X[1, 2] + r2 * X[2, 2]
        if j == k:
            break
        kind, x = kinds[j], q[j]
        ax, ay, az = axes[j, 0], axes[j, 1], axes[j, 2]
        if kind == PRISMATIC:
            for i in range(3):
                T[i, 3] += x * (T[i, 0] * ax + T[i, 1] * ay + T[i, 2] * az)
        else:
            c, s = math.cos(x), math.sin(x)
            if kind == REVOLUTE_Z:
                for i in range(3):
                    u, w = T[i, 0], T[i, 1]
                    T[i, 0] = c * u + s * w
                    T[i, 1] = c * w - s * u
            elif kind == REVOLUTE_X:
                for i in range(3):
                    u, w = T[i, 1], T[i, 2]
                    T[i, 1] = c * u + s * w
                    T[i, 2] = c * w - s * u
            elif kind == REVOLUTE_Y:
                for i in range(3):
                    u, w = T[i, 2], T[i, 0]
                    T[i, 2] = c * u + s * w
                    T[i, 0] = c * w - s * u
            else:  # R <- R · Rot(a, x), Rodrigues
                v = 1.0 - c
                k00, k01, k02 = c + v * ax * ax, v * ax * ay - s * az, v * ax * az + s * ay
                k10, k11, k12 = v * ay * ax + s * az, c + v * ay * ay, v * ay * az - s * ax
                k20, k21, k22 = v * az * ax - s * ay, v * az * ay + s * ax, c + v * az * az
                for i in range(3):
                    r0, r1, r2 = T[i, 0], T[i, 1], T[i, 2]
                    T[i, 0] = r0 * k00 + r1 * k10 + r2 * k20
                    T[i, 1] = r0 * k01 + r1 * k11 + r2 * k21
                    T[i, 2] = r0 * k02 + r1 * k12 + r2 * k22
        if columns:
            for i in range(3):
                z = T[i, 0] * ax + T[i, 1] * ay + T[i, 2] * az
                if kind == PRISMATIC:
                    J[i, j] = z
                    J[i + 3, j] = 0.0
                else:
                    J[i, j] = T[i, 3]  # the joint origin, until the frame origin is known
                    J[i + 3, j] = z
    return nonfinite == 0.0


@kernel
def fk(links, axes, kinds, q, T):
    """``T`` (4x4) <- pose of the frame in the world at configuration ``q`` (module
    docstring); ``q`` holds at least ``k`` values, one per joint in chain order. Returns
    False when ``q`` holds NaN or ±inf (then ``T`` is meaningless)."""
    return _chain_pass(links, axes, kinds, q, T, T, False)


@kernel
def point_columns(kinds, px, py, pz, J):
    """The columns ``[p_j; z_j]`` (revolute) and ``[z_j; 0]`` (prismatic) that
    :func:`_chain_pass` leaves for the chain's ``k`` joints become the world-aligned
    Jacobian of the point ``(px, py, pz)``: ``[z_j × (p − p_j); z_j]`` (module docstring);
    columns past ``k`` are zeroed. At the world origin that is Pinocchio's ``WORLD`` joint
    Jacobian (``v_j = p_j × z_j``, the velocity of the point at the origin)."""
    k = kinds.shape[0]
    for j in range(k):
        if kinds[j] != PRISMATIC:
            dx, dy, dz = px - J[0, j], py - J[1, j], pz - J[2, j]
            zx, zy, zz = J[3, j], J[4, j], J[5, j]
            J[0, j] = zy * dz - zz * dy
            J[1, j] = zz * dx - zx * dz
            J[2, j] = zx * dy - zy * dx
    for j in range(k, J.shape[1]):
        for i in range(6):
            J[i, j] = 0.0


@kernel
def jacobian(links, axes, kinds, q, local, T, J):
    """``T`` (4x4) <- the frame's pose and ``J`` (6 x n, n >= k) <- its geometric
    Jacobian, rows ``[v; ω]``: world-aligned, or in the frame's own axes when ``local``
    (module docstring). Columns past the chain's ``k`` joints are zero. Returns False
    when ``q`` holds NaN or ±inf."""
    finite = _chain_pass(links, axes, kinds, q, T, J, True)
    k = kinds.shape[0]
    point_columns(kinds, T[0, 3], T[1, 3], T[2, 3], J)
    if local:
        for j in range(k):
            for half in (0, 3):
                x, y, z = J[half, j], J[half + 1, j], J[half + 2, j]
                for i in range(3):
                    J[half + i, j] = T[0, i] * x + T[1, i] * y + T[2, i] * z
    return finite


@kernel
def pose_error(links, axes, kinds, q, target, T, J, e):
    """:func:`jacobian` (world-aligned) and ``e`` (6) <- the frame task's error
    ``[p_d − p; log(R_d Rᵀ)]`` against the pose ``target`` (4x4, or its 3x4 block).
    Returns False when ``q`` holds NaN or ±inf."""
    finite = jacobian(links, axes, kinds, q, False, T, J)
    for i in range(3):
        e[i] = target[i, 3] - T[i, 3]
    rotation_error(target, T, e)
    return finite


@kernel
def rotation_error(Rd, R, e):
    """``e[3:6] <- log(R_d Rᵀ)``, the orientation error of a frame task, from the 3x3
    blocks of ``Rd`` and ``R`` (each 3x3 or 4x4)."""
    # M = R_d Rᵀ, entry (i, j) = row i of R_d · row j of R.
    x, y, z = _rotation_log(
        _row_dot(Rd, R, 0, 0),
        _row_dot(Rd, R, 0, 1),
        _row_dot(Rd, R, 0, 2),
        _row_dot(Rd, R, 1, 0),
        _row_dot(Rd, R, 1, 1),
        _row_dot(Rd, R, 1, 2),
        _row_dot(Rd, R, 2, 0),
        _row_dot(Rd, R, 2, 1),
        _row_dot(Rd, R, 2, 2),
    )
    e[3] = x
    e[4] = y
    e[5] = z


@kernel(inline=True)
def _row_dot(A, B, i, j):
    """Row ``i`` of ``A[:3, :3]`` dotted with row ``j`` of ``B[:3, :3]``: ``(A Bᵀ)[i, j]``
    (inlined: called with nine literal ``i, j``, it would compile nine specialisations)."""
    return A[i, 0] * B[j, 0] + A[i, 1] * B[j, 1] + A[i, 2] * B[j, 2]
