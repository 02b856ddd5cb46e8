"""Compiled geometry both closed forms of :mod:`redres.ik.analytic` share (internal).

Vectors as scalar triples (numba keeps them in registers), no entry point of its own:
its kernels are compiled into the callers of :mod:`._q7_kernels` (offset-wrist arms at
``q7``) and :mod:`._arm_angle_kernels` (S-R-S arms at the arm angle).

Kernels::

    _unit, _perpendicular            a vector's direction and length; a normal to it
    _angle                           Paden–Kahan subproblem 1 (rotation about an axis)
    _rot, _apply                     Rodrigues' rotation; a 9-tuple matrix times a slot
    _wrap, _limit, _group            angles into [−π, π), then into a joint's limits
    _is_pose                         whether a 4x4 array is a homogeneous transform
"""

from __future__ import annotations

import math

from .._compile import kernel
from ._analytic_codes import (
    HI,
    HOMOGENEOUS_TOL,
    LIMIT_TOL,
    LO,
    ROTATION_TOL,
)

PI = math.pi
TWO_PI = 2.0 * math.pi
INV_TWO_PI = 1.0 / TWO_PI


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
def _apply(R, arm, i):
    """``R arm[i : i + 3]`` for ``R`` a 9-tuple, row by row."""
    x, y, z = arm[i], arm[i + 1], arm[i + 2]
    return (R[0] * x + R[1] * y + R[2] * z, R[3] * x + R[4] * y + R[5] * z,
            R[6] * x + R[7] * y + R[8] * z)  # fmt: skip


@kernel(inline=True)
def _wrap(x):
    """``x`` moved by a multiple of 2π into ``[−π, π)`` (to rounding at the ends; no
    branch: the angles wrapped are mostly inside already)."""
    return x - TWO_PI * math.floor(x * INV_TWO_PI + 0.5)


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
