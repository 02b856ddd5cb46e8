"""The compiled operational-space step of a serial chain (internal), through
:mod:`redres._compile`.

One call computes what :class:`redres.dynamics.OperationalSpaceController` takes from five
Pinocchio calls and NumPy (kinematics, ``J̇ q̇``, ``M``, ``b``, ``J̄``), on the arrays of
:class:`redres.robot.SerialChain` (``links``, ``axes``, ``kinds``: see
:mod:`redres.robot._chain_kernels`) and the chain's bodies: ``body[j]`` = mass (kg), centre of
mass in joint ``j``'s frame (m), rotational inertia about it in that frame (kg·m²:
``Ixx, Ixy, Ixz, Iyy, Iyz, Izz``), Pinocchio's ``model.inertias``, which already hold the
bodies fixed to the joint.

In world axes, with ``p_j``, ``z_j`` the origin and axis of joint ``j`` and ``d`` the step
from the parent joint's origin (Siciliano et al., *Robotics*, 2009, §7.5, recursive
Newton–Euler; Featherstone, *Rigid Body Dynamics Algorithms*, 2008, ch. 5–6):

* **Angular velocities, and accelerations at ``q̈ = 0``**: ``ω_j = ω + z_j q̇_j``,
  ``α_j = α + ω × z_j q̇_j``, ``a_j = a + α × d + ω × (ω × d)`` for the joint origin's
  linear acceleration (a prismatic joint keeps ``ω``, ``α`` and adds ``2 ω × z_j q̇_j`` to
  ``a_j``; the linear velocities enter only through these terms, so none is kept). The
  frame's ``[a; α]`` is ``J̇ q̇`` of its world-aligned Jacobian.
* **Bias** ``b = C q̇ + g`` (RNEA with ``q̈ = 0`` and the base accelerating at ``−g``): each
  body's force ``f = m a_c`` and moment ``I α + ω × I ω`` at its centre of mass, summed
  from the tip down; ``b_j = z_j · n_j`` (``z_j · f_j`` prismatic).
* **Mass matrix** (composite rigid bodies): the bodies from joint ``i`` on, as one rigid
  body of mass ``m``, first moment ``h`` and inertia ``I_O`` about the world origin, moved
  by joint ``j ≤ i`` alone at unit rate (``ω = z_j``, origin velocity ``p_j × z_j``) have
  momentum ``P = m v_O + ω × h`` and moment of momentum ``L_O = h × v_O + I_O ω``;
  ``M_ij = z_i · (L_O − p_i × P)`` (``z_i · P`` prismatic), plus the armature on the
  diagonal.

The operational-space torque then follows the module docstring of
:mod:`redres.dynamics.osc` with ``projector="dynamic"`` and ``compensation="joint"``: the
weighted inverse kernel of :mod:`redres.linalg._kernels` (``W = M``) gives the rank, the
singular values and the damping; the task and null-space torques come from Householder QR
of ``[J_sᵀ; λ I]`` (:mod:`redres.dynamics._consistent_kernels`, the formulas of
:mod:`redres.dynamics.consistent`), or from that kernel's ``J̄`` where the inverse is
truncated or selectively damped.

Entry points: :func:`chain_dynamics` (:func:`_forward`, :func:`_world_inertia`) and
:func:`osc_step` (``chain_dynamics``, ``inverse``, :func:`_consistent_torques`);
:func:`consistent_torques` (the operational-space torque's Pinocchio path). Both factor with
``_consistent_factor`` and apply ``_consistent_parts`` of
:mod:`redres.dynamics._consistent_kernels`.
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel
from ..linalg._codes import FULL, OK, Q_NONFINITE, SELECTIVE
from ..linalg._kernels import inverse
from ..robot._chain_codes import PRISMATIC
from ..robot._chain_kernels import rotation_error
from ._codes import OUT_ERROR, OUT_POSE, OUT_STATS, OUT_TARGET
from ._consistent_kernels import _consistent_factor, _consistent_parts

# Columns of the per-joint work array: world origin, axis, angular velocity, angular and
# linear acceleration at q̈ = 0, the rotation (row-major).
_P, _Z, _W, _AL, _A, _R = 0, 3, 6, 9, 12, 15
_WORK = 24


@kernel
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@kernel
def _forward(links, axes, kinds, q, qd, work, T):
    """Joint frames, angular velocities and accelerations at ``q̈ = 0`` into ``work``
    (k, 24), the frame's pose into ``T``. Returns whether ``q`` and ``qd`` are finite, and
    ``[a; α]`` of the frame origin (``J̇ q̇``) as a tuple."""
    finite = True  # math.isfinite, not x * 0: the plain-Python twin warns on inf * 0
    for x in q:
        finite = finite and math.isfinite(x)
    for x in qd:
        finite = finite and math.isfinite(x)
    if not finite:  # nothing to compute (the plain twin's math.cos would raise on inf)
        return False, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    k = kinds.shape[0]
    R = np.eye(3)
    p = np.zeros(3)
    w = np.zeros(3)
    al = np.zeros(3)
    a = np.zeros(3)
    p_new = np.empty(3)
    R_new = np.empty((3, 3))
    K = np.empty((3, 3))
    for j in range(k + 1):
        X = links[j]
        for i in range(3):
            p_new[i] = p[i] + R[i, 0] * X[0, 3] + R[i, 1] * X[1, 3] + R[i, 2] * X[2, 3]
            for col in range(3):
                R_new[i, col] = R[i, 0] * X[0, col] + R[i, 1] * X[1, col] + R[i, 2] * X[2, col]
        if j < k and kinds[j] == PRISMATIC:
            for i in range(3):
                z = R_new[i, 0] * axes[j, 0] + R_new[i, 1] * axes[j, 1] + R_new[i, 2] * axes[j, 2]
                p_new[i] += q[j] * z
        # the parent's motion carried to the new origin
        d0, d1, d2 = p_new[0] - p[0], p_new[1] - p[1], p_new[2] - p[2]
        c0, c1, c2 = _cross(w[0], w[1], w[2], d0, d1, d2)
        e0, e1, e2 = _cross(al[0], al[1], al[2], d0, d1, d2)
        f0, f1, f2 = _cross(w[0], w[1], w[2], c0, c1, c2)
        a[0] += e0 + f0
        a[1] += e1 + f1
        a[2] += e2 + f2
        p[:] = p_new
        if j == k:
            R[:] = R_new
            break
        ax, ay, az = axes[j, 0], axes[j, 1], axes[j, 2]
        if kinds[j] != PRISMATIC:  # R <- R · Rot(a, q_j), Rodrigues
            c, s = math.cos(q[j]), math.sin(q[j])
            u = 1.0 - c
            K[0, 0], K[0, 1], K[0, 2] = c + u * ax * ax, u * ax * ay - s * az, u * ax * az + s * ay
            K[1, 0], K[1, 1], K[1, 2] = u * ay * ax + s * az, c + u * ay * ay, u * ay * az - s * ax
            K[2, 0], K[2, 1], K[2, 2] = u * az * ax - s * ay, u * az * ay + s * ax, c + u * az * az
            for i in range(3):
                for col in range(3):
                    R[i, col] = (
                        R_new[i, 0] * K[0, col] + R_new[i, 1] * K[1, col] + R_new[i, 2] * K[2, col]
                    )
        else:
            R[:] = R_new
        z0 = R[0, 0] * ax + R[0, 1] * ay + R[0, 2] * az
        z1 = R[1, 0] * ax + R[1, 1] * ay + R[1, 2] * az
        z2 = R[2, 0] * ax + R[2, 1] * ay + R[2, 2] * az
        r = qd[j]
        g0, g1, g2 = _cross(w[0], w[1], w[2], z0 * r, z1 * r, z2 * r)
        if kinds[j] == PRISMATIC:
            a[0] += 2.0 * g0
            a[1] += 2.0 * g1
            a[2] += 2.0 * g2
        else:
            w[0] += z0 * r
            w[1] += z1 * r
            w[2] += z2 * r
            al[0] += g0
            al[1] += g1
            al[2] += g2
        row = work[j]
        for i in range(3):
            row[_P + i], row[_Z + i] = p[i], (z0, z1, z2)[i]
            row[_W + i] = w[i]
            row[_AL + i], row[_A + i] = al[i], a[i]
            for col in range(3):
                row[_R + 3 * i + col] = R[i, col]
    for i in range(3):
        for col in range(3):
            T[i, col] = R[i, col]
        T[i, 3] = p[i]
        T[3, i] = 0.0
    T[3, 3] = 1.0
    return True, (a[0], a[1], a[2], al[0], al[1], al[2])


@kernel
def _world_inertia(row, body, Iw, Ib, RI, r):
    """``Iw`` <- the body's inertia about its centre of mass in world axes, ``R I Rᵀ``;
    ``r`` <- the centre of mass's offset from the joint origin in world axes (``Ib``,
    ``RI``: scratch, 3x3)."""
    Ib[0, 0], Ib[0, 1], Ib[0, 2] = body[4], body[5], body[6]
    Ib[1, 0], Ib[1, 1], Ib[1, 2] = body[5], body[7], body[8]
    Ib[2, 0], Ib[2, 1], Ib[2, 2] = body[6], body[8], body[9]
    for i in range(3):
        for c in range(3):
            acc = 0.0
            for m in range(3):
                acc += row[_R + 3 * i + m] * Ib[m, c]
            RI[i, c] = acc
    for i in range(3):
        for c in range(3):
            acc = 0.0
            for m in range(3):
                acc += RI[i, m] * row[_R + 3 * c + m]
            Iw[i, c] = acc
    for i in range(3):
        r[i] = (
            row[_R + 3 * i] * body[1]
            + row[_R + 3 * i + 1] * body[2]
            + row[_R + 3 * i + 2] * body[3]
        )
    return r


@kernel
def chain_dynamics(links, axes, kinds, body, armature, gravity, q, qd, T, J, jdqd, M, b):
    """For a serial chain of all ``n`` joints of the model: ``T`` (4x4) the frame's pose,
    ``J`` (6 x n) its world-aligned Jacobian, ``jdqd`` (6) ``J̇ q̇``, ``M`` (n x n) the joint
    inertia with the armature, ``b`` (n) ``C q̇ + g`` (module docstring). Returns False
    when ``q`` or ``qd`` holds NaN or ±inf."""
    n = kinds.shape[0]
    work = np.empty((n, _WORK))
    finite, acc = _forward(links, axes, kinds, q, qd, work, T)
    if not finite:
        return False
    for i in range(6):
        jdqd[i] = acc[i]
    for j in range(n):  # the Jacobian
        row = work[j]
        if kinds[j] == PRISMATIC:
            for i in range(3):
                J[i, j], J[i + 3, j] = row[_Z + i], 0.0
        else:
            t = _cross(row[_Z], row[_Z + 1], row[_Z + 2],
                       T[0, 3] - row[_P], T[1, 3] - row[_P + 1], T[2, 3] - row[_P + 2])  # fmt: skip
            for i in range(3):
                J[i, j], J[i + 3, j] = t[i], row[_Z + i]
    # Composite bodies (about the world origin) and the RNEA's forces, tip first.
    mass = 0.0
    h = np.zeros(3)
    IO = np.zeros((3, 3))
    F = np.zeros(3)  # force of the bodies from j on
    N = np.zeros(3)  # their moment about the world origin
    Iw = np.empty((3, 3))
    Ib = np.empty((3, 3))
    RI = np.empty((3, 3))
    r = np.empty(3)
    L = np.empty(3)
    for j in range(n - 1, -1, -1):
        row = work[j]
        m = body[j, 0]
        _world_inertia(row, body[j], Iw, Ib, RI, r)
        c0, c1, c2 = row[_P] + r[0], row[_P + 1] + r[1], row[_P + 2] + r[2]
        w0, w1, w2 = row[_W], row[_W + 1], row[_W + 2]
        # composite: I_O += Iw + m (|c|² I − c cᵀ), h += m c
        cc = c0 * c0 + c1 * c1 + c2 * c2
        cv = (c0, c1, c2)
        for i in range(3):
            for k in range(3):
                IO[i, k] += Iw[i, k] + m * ((cc if i == k else 0.0) - cv[i] * cv[k])
        mass += m
        h[0] += m * c0
        h[1] += m * c1
        h[2] += m * c2
        # the body's acceleration at its centre of mass, the base at −g
        t0, t1, t2 = _cross(row[_AL], row[_AL + 1], row[_AL + 2], r[0], r[1], r[2])
        s0, s1, s2 = _cross(w0, w1, w2, r[0], r[1], r[2])
        u0, u1, u2 = _cross(w0, w1, w2, s0, s1, s2)
        f0 = m * (row[_A] - gravity[0] + t0 + u0)
        f1 = m * (row[_A + 1] - gravity[1] + t1 + u1)
        f2 = m * (row[_A + 2] - gravity[2] + t2 + u2)
        for i in range(3):
            L[i] = Iw[i, 0] * w0 + Iw[i, 1] * w1 + Iw[i, 2] * w2
        x0, x1, x2 = _cross(w0, w1, w2, L[0], L[1], L[2])
        y0, y1, y2 = _cross(c0, c1, c2, f0, f1, f2)
        for i in range(3):
            N[i] += (Iw[i, 0] * row[_AL] + Iw[i, 1] * row[_AL + 1] + Iw[i, 2] * row[_AL + 2]
                     + (x0, x1, x2)[i] + (y0, y1, y2)[i])  # fmt: skip
        F[0] += f0
        F[1] += f1
        F[2] += f2
        z0, z1, z2 = row[_Z], row[_Z + 1], row[_Z + 2]
        p0, p1, p2 = row[_P], row[_P + 1], row[_P + 2]
        if kinds[j] == PRISMATIC:
            b[j] = z0 * F[0] + z1 * F[1] + z2 * F[2]
        else:  # moment about p_j: N − p_j × F
            m0, m1, m2 = _cross(p0, p1, p2, F[0], F[1], F[2])
            b[j] = z0 * (N[0] - m0) + z1 * (N[1] - m1) + z2 * (N[2] - m2)
        # column j of M below the diagonal: the composite of bodies j.. moved by joint i ≤ j
        for i in range(j + 1):
            col = work[i]
            e0, e1, e2 = col[_Z], col[_Z + 1], col[_Z + 2]
            if kinds[i] == PRISMATIC:
                om0, om1, om2 = 0.0, 0.0, 0.0
                v0, v1, v2 = e0, e1, e2
            else:
                om0, om1, om2 = e0, e1, e2
                v0, v1, v2 = _cross(col[_P], col[_P + 1], col[_P + 2], e0, e1, e2)
            k0, k1, k2 = _cross(om0, om1, om2, h[0], h[1], h[2])
            P0, P1, P2 = mass * v0 + k0, mass * v1 + k1, mass * v2 + k2
            if kinds[j] == PRISMATIC:
                value = z0 * P0 + z1 * P1 + z2 * P2
            else:
                l0, l1, l2 = _cross(h[0], h[1], h[2], v0, v1, v2)
                l0 += IO[0, 0] * om0 + IO[0, 1] * om1 + IO[0, 2] * om2
                l1 += IO[1, 0] * om0 + IO[1, 1] * om1 + IO[1, 2] * om2
                l2 += IO[2, 0] * om0 + IO[2, 1] * om1 + IO[2, 2] * om2
                n0, n1, n2 = _cross(p0, p1, p2, P0, P1, P2)
                value = z0 * (l0 - n0) + z1 * (l1 - n1) + z2 * (l2 - n2)
            M[j, i] = value
            M[i, j] = value
        M[j, j] += armature[j]
    return True


@kernel
def osc_step(links, axes, kinds, body, armature, gravity, damp, q, qd, feed, target, gains,
             rows, quad, settings, out):  # fmt: skip
    """One operational-space torque (module docstring) into ``out`` (the layout of
    :mod:`redres.dynamics._codes`): the total ``τ``, the task part ``Jᵀ Λ (ẍ* − J̇ q̇)``,
    the null part ``(I − Jᵀ J̄ᵀ) τ₀`` and ``τ₀``, the compensation being ``b + d ∘ q̇``
    (``damp`` = d); then the frame's error against ``target`` (18: the rotation row-major,
    the position and the twist, :class:`redres.tasks.FrameTask`'s block), its pose, the
    target pose, and rank, σ_min, σ_max, damping of ``J M^{-1/2}``. ``feed`` (12): the
    reference twist and acceleration; ``gains`` (2 x m): ``K_p``, ``K_d`` of the ``rows``
    (m, int64); ``quad`` (2 x n): ``(a, r)`` of ``Σ wᵢ ∇Dᵢ = a ∘ (q − r)``; ``settings``:
    ``null_kp, null_kd, has_objectives, damping mode, λ, λ_max, ε, rcond``. Returns a status
    (:class:`redres.linalg._codes.Status`)."""
    n = kinds.shape[0]
    m = rows.shape[0]
    base = 4 * n
    J = np.empty((6, n))
    e = out[base + OUT_ERROR : base + OUT_POSE]
    T = out[base + OUT_POSE : base + OUT_TARGET].reshape(4, 4)
    goal = out[base + OUT_TARGET : base + OUT_STATS].reshape(4, 4)
    jdqd = np.empty(6)
    M = np.empty((n, n))
    b = np.empty(n)
    if not chain_dynamics(links, axes, kinds, body, armature, gravity, q, qd, T, J, jdqd, M, b):
        return Q_NONFINITE
    for i in range(3):
        for c in range(3):
            goal[i, c] = target[3 * i + c]
        goal[i, 3] = target[9 + i]
        goal[3, i] = 0.0
        e[i] = target[9 + i] - T[i, 3]
    goal[3, 3] = 1.0
    rotation_error(goal, T, e)
    Jm = np.empty((m, n))
    cmd = np.empty(m)
    for r in range(m):
        i = rows[r]
        acc = 0.0
        for c in range(n):
            Jm[r, c] = J[i, c]
            acc += J[i, c] * qd[c]
        cmd[r] = feed[6 + i] + gains[1, r] * (feed[i] - acc) + gains[0, r] * e[i] - jdqd[i]
    empty = np.empty((0, 0))
    mode = int(settings[3])
    status, rank, smin, smax, used = inverse(
        Jm, np.empty(0), M, empty, empty, empty, FULL, mode, settings[4], settings[5],
        settings[6], settings[7],
    )  # fmt: skip
    if status != OK:
        return status
    stats = base + OUT_STATS
    out[stats], out[stats + 1], out[stats + 2], out[stats + 3] = rank, smin, smax, used
    # q̈₀ = −k_d q̇ − k_p a ∘ (q − r), τ₀ = M q̈₀ (out[3n:4n])
    qdd0 = np.empty(n)
    for c in range(n):
        qdd0[c] = -settings[1] * qd[c]
        if settings[2] != 0.0 and settings[0] > 0.0:
            qdd0[c] -= settings[0] * quad[0, c] * (q[c] - quad[1, c])
    for a in range(n):
        tau0 = 0.0
        for c in range(n):
            tau0 += M[a, c] * qdd0[c]
        out[3 * n + a] = tau0
    if mode != SELECTIVE and (rank == m or used > 0.0):  # one inverse in every direction
        _consistent_torques(M, Jm, used, cmd, qdd0, out)
    else:  # truncated or selective: through J̄, τ_task = M J̄ cmd, τ_null = τ₀ − Jᵀ J̄ᵀ τ₀
        Jbar = np.empty((n, m))
        inverse(Jm, np.empty(0), M, Jbar, empty, empty, FULL, mode, settings[4], settings[5],
                settings[6], settings[7])  # fmt: skip
        x = np.empty(n)
        for c in range(n):
            acc = 0.0
            for r in range(m):
                acc += Jbar[c, r] * cmd[r]
            x[c] = acc
        for a in range(n):
            task = 0.0
            for c in range(n):
                task += M[a, c] * x[c]
            out[n + a] = task
        y = np.empty(m)  # J̄ᵀ τ₀
        for r in range(m):
            acc = 0.0
            for c in range(n):
                acc += Jbar[c, r] * out[3 * n + c]
            y[r] = acc
        for a in range(n):
            acc = 0.0
            for r in range(m):
                acc += Jm[r, a] * y[r]
            out[2 * n + a] = out[3 * n + a] - acc
    for a in range(n):
        out[a] = out[n + a] + b[a] + damp[a] * qd[a] + out[2 * n + a]
    return OK


@kernel
def _consistent_torques(M, Jm, lam, cmd, qdd0, out):
    """``out[n:2n] <- Jᵀ Λ cmd`` and ``out[2n:3n] <- τ₀ − Jᵀ J̄ᵀ τ₀`` with ``τ₀ = M q̈₀`` in
    ``out[3n:4n]`` (``L⁻¹ τ₀ = Lᵀ q̈₀``)."""
    n = Jm.shape[1]
    L, S, beta, rdiag, u = _consistent_factor(M, Jm, lam)
    for i in range(n):
        acc = 0.0
        for k in range(i, n):
            acc += L[k, i] * qdd0[k]
        u[i] = acc
    proj = np.empty(n)
    _consistent_parts(L, S, beta, rdiag, cmd, u, out[n : 2 * n], proj)
    for a in range(n):
        out[2 * n + a] = out[3 * n + a] - proj[a]


@kernel
def consistent_torques(M, J, lam, a, tau, task, proj):
    """``task <- Jᵀ Λ a`` and ``proj <- Jᵀ J̄ᵀ τ`` (``(n,)`` each) with ``Λ = (J M⁻¹ Jᵀ +
    λ² I)⁻¹``, by QR (:mod:`redres.dynamics.consistent`); ``M`` (n x n) positive definite,
    ``J`` (m x n) of full row rank unless ``λ > 0`` (the caller's inverse checked both)."""
    n = J.shape[1]
    L, S, beta, rdiag, u = _consistent_factor(M, J, lam)
    for i in range(n):  # L⁻¹ τ
        acc = tau[i]
        for k in range(i):
            acc -= L[i, k] * u[k]
        u[i] = acc / L[i, i]
    _consistent_parts(L, S, beta, rdiag, a, u, task, proj)
