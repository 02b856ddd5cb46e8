"""Closed-form joint angles of an S-R-S arm as functions of its arm angle, and the arm
angles reachable within the joint limits.

Shimizu, Kakuya, Yoon, Kitagaki, Kosuge, "Analytical inverse kinematic computation for
7-DOF redundant manipulators with joint limits and its application to redundancy
resolution", IEEE T-RO 24(5), 2008. An S-R-S arm has three shoulder axes meeting at a
point ``S``, an elbow joint, and three wrist axes meeting at ``W``. For a pose ``T`` of
the frame:

1. **Wrist centre and elbow.** ``W`` is fixed in the last link, so ``W = T ∘ w₇``. The
   distance ``|W − S|`` depends on the elbow joint alone: with ``s'`` the shoulder point
   in the elbow joint's parent frame and ``w₄`` the wrist centre in its own frame,
   ``|W − S|² = K − 2(P + A cos θ₄ + B sin θ₄)`` (Rodrigues' formula about the elbow
   axis), so ``θ₄ = δ + g₄·acos(−x)`` with ``x = ((K − |W − S|²)/2 − P)/√(A² + B²)``,
   ``δ`` the stretched elbow, ``g₄ = ±1``.
2. **The shoulder by the arm angle.** For that ``θ₄`` every orientation ``R₃`` of the
   third link that puts ``W`` at its place is one rotation about ``ŵ = (W − S)/|W − S|``
   of another; rotating the upper arm about ``ŵ`` by ``β`` adds ``β`` to the library's
   arm angle ``φ`` (:class:`redres.tasks.ArmAngleTask`). With ``R₃⁰`` the one of arm angle 0
   (the elbow's offset along ``l = (w × v) × w``), ``R₃(φ) = Rot(ŵ, φ) R₃⁰
   = A_s sin φ + B_s cos φ + C_s``, ``A_s = [ŵ]ₓR₃⁰``, ``B_s = −[ŵ]ₓ²R₃⁰``,
   ``C_s = ŵŵᵀR₃⁰`` (Shimizu et al.'s form, there about their own reference
   plane; here about the library's, so the map is in the angle the augmented scheme
   controls).
3. **Joint angles.** The shoulder's three rotations, brought to one frame, are
   ``Rz(θ₁) Ry(θ₂) Rz(σθ₃)`` of ``M = Lᵀ R₃ Rʳ`` (constant ``L``, ``Rʳ`` from the joint
   placements; ``σ = ±1``), so with ``g₂ = ±1``: ``θ₂ = g₂ acos M₃₃``,
   ``θ₁ = atan2(g₂M₂₃, g₂M₁₃)``, ``θ₃ = σ atan2(g₂M₃₂, −g₂M₃₁)``; every entry of ``M``
   is ``a sin φ + b cos φ + c``. The wrist likewise from ``R₄ᵀ R₇`` with ``g₆``.
   ``(g₂, g₄, g₆)`` is the global configuration (Shimizu's GC₂, GC₄, GC₆: the signs of
   ``θ₂``, ``θ₄`` from the stretched elbow, ``θ₆``): eight branches, each a circle of
   arm angles.
4. **Limits in closed form.** ``θ₁ = t`` (or ``θ₃``) where ``M₂₃ cos t − M₁₃ sin t = 0``,
   ``θ₂ = t`` where ``M₃₃ = cos t``: each ``α sin φ + β cos φ + γ = 0``, solved as
   ``φ = atan2(α, β) ± acos(−γ/√(α² + β²))``. With the singular points ``M₃₃ = ±1``
   (where ``θ₁`` and ``θ₃`` may jump) they cut the circle into arcs on which no joint
   meets a limit; an arc is feasible when its midpoint is within the limits, and
   feasible neighbours join. Interval endpoints are thus exact roots.

Covered: 7 revolute joints, ``S`` and ``W`` where the library's ``shoulder`` and
``wrist`` frames are (checked), proper-Euler shoulder and wrist (first and third axes
parallel at the zero configuration, the second perpendicular to both, as the iiwa14 and
srs7), joint limits inside ``(−π, π)``, and all eight branches. Not defined: poses with
the elbow stretched or the wrist centre on the reference line through ``S`` (the arm
angle is undefined there: such a pose is reported with no arm angle).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import RedresError
from . import _analytic_codes as codes
from .arcs import Arc, from_arcs, linear_cuts, runs

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["BRANCHES", "NotSRSError", "SRSArm", "SRSPoses"]

#: The eight global configurations ``(g₂, g₄, g₆)``, row ``b = 4 i₂ + 2 i₄ + i₆`` with
#: ``g = 1 − 2i``.
BRANCHES = np.array([[1 - 2 * (b >> 2), 1 - 2 * ((b >> 1) & 1), 1 - 2 * (b & 1)]
                     for b in range(8)], dtype=np.int64)  # fmt: skip
_TOL = 1e-9  # m, rad: the structure checks


class NotSRSError(RedresError, ValueError):
    """The robot is not an S-R-S arm of the form :class:`SRSArm` covers."""


def _rot(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotations about the unit ``axis`` (3,) by ``angle`` (...), ``(..., 3, 3)``."""
    K = _skew(np.broadcast_to(axis, (*np.shape(angle), 3)))
    s, c = np.sin(angle)[..., None, None], np.cos(angle)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def _skew(v: np.ndarray) -> np.ndarray:
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    norm = np.linalg.norm(v, axis=-1)
    return v / np.maximum(norm, 1e-300)[..., None], norm


def _euler_basis(
    links: np.ndarray, axes: np.ndarray, first: int
) -> tuple[np.ndarray, np.ndarray, float]:
    """``(L, Rʳ, σ)`` of three joints from ``first``: ``Lᵀ R_in⁻¹ R_out Rʳ =
    Rz(θ₁) Ry(θ₂) Rz(σθ₃)`` where ``R_out = R_in P₁ Rot(a₁) P₂ Rot(a₂) P₃ Rot(a₃)``."""
    P = [links[first + i][:, :3] for i in range(3)]
    u1 = (P[1] @ P[2]).T @ axes[first]
    u2 = P[2].T @ axes[first + 1]
    u3 = axes[first + 2]
    sigma = float(u1 @ u3)
    if abs(u1 @ u2) > _TOL or abs(u2 @ u3) > _TOL or abs(abs(sigma) - 1.0) > _TOL:
        raise NotSRSError(
            f"joints {first + 1}-{first + 3} are not a proper-Euler spherical group (first "
            "and third axes parallel, second perpendicular)"
        )
    basis = np.column_stack((np.cross(u2, u1), u2, u1))
    return P[0] @ P[1] @ P[2] @ basis, basis, math.copysign(1.0, sigma)


@dataclass(frozen=True)
class SRSArm:
    """The constants of the closed form of one S-R-S arm (module docstring).

    Build with :meth:`from_robot`; the attributes are its fixed vectors (m) and
    matrices, in the joint frames of the chain (frame ``j`` after joint ``j``, 1-based).
    """

    links: np.ndarray
    axes: np.ndarray
    q_min: np.ndarray
    q_max: np.ndarray
    reference: np.ndarray
    shoulder: np.ndarray
    s3: np.ndarray
    w4: np.ndarray
    w7: np.ndarray
    elbow_frame: int
    elbow_local: np.ndarray
    shoulder_euler: tuple[np.ndarray, np.ndarray, float]
    wrist_euler: tuple[np.ndarray, np.ndarray, float]
    elbow_law: tuple[float, float, float, float]

    @classmethod
    def from_robot(
        cls,
        robot: Robot,
        frame: str | None = None,
        points: tuple[str, str, str] = ("shoulder", "elbow", "wrist"),
        reference: np.ndarray | None = None,
    ) -> SRSArm:
        """The closed form of ``robot``'s chain to ``frame`` (default: tip), with the
        arm angle of the ``points`` frames about ``reference`` (default world z).

        Raises:
            NotSRSError: the chain is not an S-R-S arm of the covered form (the message
                says which test failed).
        """
        links, axes, kinds = robot.chain(frame).arrays
        if len(kinds) != 7 or robot.n != 7 or robot.chain(frame).prismatic.any():
            raise NotSRSError(f"{robot.name}: an S-R-S arm has 7 revolute joints up to the frame")
        located = []
        for name in points:
            chain = robot.chain(name)
            located.append((len(chain.joints), chain.arrays[0][-1][:, 3].copy()))
            if chain.joints != robot.chain(frame).joints[: len(chain.joints)]:
                raise NotSRSError(f"{robot.name}: frame {name!r} is not on the arm's chain")
        (ks, ls), (ke, le), (kw, lw) = located
        if ke not in (3, 4):
            raise NotSRSError(f"{robot.name}: the elbow point must be on link 3 or 4")
        rng = np.random.default_rng(0)
        samples = [np.zeros(7)] + [rng.uniform(robot.q_min, robot.q_max) for _ in range(5)]
        seen: dict[str, list[np.ndarray]] = {k: [] for k in ("S", "s3", "w4", "w7")}
        for q in samples:
            F = _joint_frames(links, axes, q)
            S = _apply(F[ks - 1], ls) if ks else ls
            W = _apply(F[kw - 1], lw)
            seen["S"].append(S)
            seen["s3"].append(_apply_inv(F[2], S))
            seen["w4"].append(_apply_inv(F[3], W))
            seen["w7"].append(_apply_inv(F[6], W))
        for key, what in (("S", "the shoulder point is not fixed (not on axes 1-2)"),
                          ("s3", "the shoulder point is not on axis 3"),
                          ("w4", "the wrist point is not on axes 5-6"),
                          ("w7", "the wrist point is not on axis 7")):  # fmt: skip
            if np.ptp(np.array(seen[key]), axis=0).max() > _TOL:
                raise NotSRSError(f"{robot.name}: {what}")
        if (robot.q_min <= -math.pi).any() or (robot.q_max >= math.pi).any():
            raise NotSRSError(f"{robot.name}: the closed form needs joint limits inside (-pi, pi)")
        s3, w4 = seen["s3"][0], seen["w4"][0]
        a, L3 = axes[3], links[3]
        s_prime = L3[:, :3].T @ (s3 - L3[:, 3])
        P = float((a @ s_prime) * (a @ w4))
        elbow = (float(w4 @ w4 + s_prime @ s_prime), P, float(s_prime @ w4) - P,
                 float(s_prime @ np.cross(a, w4)))  # fmt: skip
        v = np.array([0.0, 0.0, 1.0]) if reference is None else np.asarray(reference, float)
        return cls(
            links.copy(), axes.copy(), robot.q_min.copy(), robot.q_max.copy(),
            v / np.linalg.norm(v), seen["S"][0], s3, w4, seen["w7"][0], ke - 1, le,
            _euler_basis(links, axes, 0), _euler_basis(links, axes, 4), elbow,
        )  # fmt: skip

    @functools.cached_property
    def constants(self) -> np.ndarray:
        """The packed constants of the compiled form (``solve_arm_angle`` of
        :mod:`redres.ik._arm_angle_kernels`; slots ``SRS_*`` of
        :mod:`redres.ik._analytic_codes`), read-only."""
        out = np.zeros(codes.N_ARM)
        K, P, A, B = self.elbow_law
        Lf, L3 = self.links[7], self.links[3]
        for slot, value in (
            (codes.SRS_RF, Lf[:, :3]), (codes.SRS_PF, Lf[:, 3]), (codes.SRS_W7, self.w7),
            (codes.SRS_S, self.shoulder),
            (codes.SRS_K, (K, P, 1.0 / math.hypot(A, B), math.atan2(B, A) + math.pi)),
            (codes.SRS_RL3, L3[:, :3]), (codes.SRS_PL3, L3[:, 3]), (codes.SRS_A4, self.axes[3]),
            (codes.SRS_W4, self.w4), (codes.SRS_S3, self.s3),
            (codes.SRS_ELBOW_POINT, self.elbow_local),
            (codes.SRS_ELBOW_FRAME, 1.0 if self.elbow_frame == 3 else 0.0),
            (codes.SRS_REFERENCE, self.reference),
            (codes.SRS_LS, self.shoulder_euler[0]), (codes.SRS_RS, self.shoulder_euler[1]),
            (codes.SRS_SIGMA_S, self.shoulder_euler[2]),
            (codes.SRS_LW, self.wrist_euler[0]), (codes.SRS_RW, self.wrist_euler[1]),
            (codes.SRS_SIGMA_W, self.wrist_euler[2]),
            (codes.LO, self.q_min), (codes.HI, self.q_max),
        ):  # fmt: skip
            flat = np.ravel(value)
            out[slot : slot + len(flat)] = flat
        out.flags.writeable = False
        return out

    def poses(self, T: np.ndarray) -> SRSPoses:
        """The closed form's coefficients for poses ``T`` ``(N, 4, 4)`` of the frame."""
        return SRSPoses.build(self, np.asarray(T, dtype=np.float64))


@dataclass(frozen=True)
class SRSPoses:
    """The closed form for ``N`` poses, both elbow signs (axis 1: ``g₄ = +1, −1``).

    Attributes:
        arm: the arm.
        q4: elbow angles, ``(N, 2)``, rad.
        valid: the elbow reaches and the arm angle is defined, ``(N, 2)``.
        shoulder, wrist: ``(N, 2, 3, 3, 3)``: the ``sin φ``, ``cos φ`` and constant
            coefficients (axis 2) of the matrices ``M`` of the shoulder and the wrist.
    """

    arm: SRSArm
    q4: np.ndarray
    valid: np.ndarray
    shoulder: np.ndarray
    wrist: np.ndarray

    @classmethod
    def build(cls, arm: SRSArm, T: np.ndarray) -> SRSPoses:
        """The coefficients (module docstring, steps 1-3)."""
        Lf = arm.links[7]
        R7 = T[:, :3, :3] @ Lf[:, :3].T
        p7 = T[:, :3, 3] - R7 @ Lf[:, 3]
        wv = p7 + R7 @ arm.w7 - arm.shoulder
        wh, d = _unit(wv)
        K, P, A, B = arm.elbow_law
        x = ((K - d * d) / 2.0 - P) / math.hypot(A, B)
        reach = np.abs(x) <= 1.0 + 1e-12
        bend = np.arccos(np.clip(-x, -1.0, 1.0))
        straight = math.atan2(B, A) + math.pi
        q4 = np.pi - np.mod(np.pi - (straight + np.stack((bend, -bend), axis=1)), 2 * np.pi)
        L3 = arm.links[3]
        Q4 = L3[:, :3] @ _rot(arm.axes[3], q4)  # (N, 2, 3, 3)
        u3 = Q4 @ arm.w4 + L3[:, 3] - arm.s3
        e_local = Q4 @ arm.elbow_local + L3[:, 3] if arm.elbow_frame == 3 else arm.elbow_local
        e3 = e_local - arm.s3
        x_loc, _ = _unit(u3)
        y_loc, offset = _unit(e3 - np.sum(e3 * x_loc, axis=-1)[..., None] * x_loc)
        world_y, lever = _unit(np.cross(np.cross(wv, arm.reference), wv))
        world = np.stack((wh, world_y, np.cross(wh, world_y)), axis=-1)[:, None]
        local = np.stack((x_loc, y_loc, np.cross(x_loc, y_loc)), axis=-1)
        R0 = world @ np.swapaxes(local, -1, -2)
        Kw = _skew(wh)[:, None]
        coeff = np.stack(
            (Kw @ R0, -(Kw @ Kw) @ R0, (wh[:, :, None] * wh[:, None, :])[:, None] @ R0), axis=2
        )  # fmt: skip  (N, 2, 3, 3, 3): R3 = sum_k coeff[k] * basis_k
        Ls, Rs, _ = arm.shoulder_euler
        Lw, Rw, _ = arm.wrist_euler
        shoulder = Ls.T @ coeff @ Rs
        wrist = Lw.T @ np.swapaxes(Q4, -1, -2)[:, :, None] @ np.swapaxes(coeff, -1, -2)
        wrist = wrist @ R7[:, None, None] @ Rw
        valid = reach[:, None] & (offset > 1e-9) & (lever > 1e-9 * d * d)[:, None]
        return cls(arm, q4, valid, shoulder, wrist)

    def joints(self, phi: np.ndarray, branch: int) -> np.ndarray:
        """Joint angles ``(N, M, 7)`` (rad) at arm angles ``phi`` ``(N, M)`` on
        :data:`BRANCHES` row ``branch`` (NaN where not :attr:`valid`)."""
        g2, g4, g6 = BRANCHES[branch]
        e = 0 if g4 > 0 else 1
        sin, cos = np.sin(phi), np.cos(phi)
        q = np.empty((*np.shape(phi), 7))
        for M, sigma, g, first in ((self.shoulder, self.arm.shoulder_euler[2], g2, 0),
                                   (self.wrist, self.arm.wrist_euler[2], g6, 4)):  # fmt: skip

            def entry(r: int, c: int, M: np.ndarray = M) -> np.ndarray:
                k = M[:, e, :, r, c]  # (N, 3): sin, cos, constant coefficients
                return np.asarray(sin * k[:, 0, None] + cos * k[:, 1, None] + k[:, 2, None])

            q[..., first] = np.arctan2(g * entry(1, 2), g * entry(0, 2))
            q[..., first + 1] = g * np.arccos(np.clip(entry(2, 2), -1.0, 1.0))
            q[..., first + 2] = sigma * np.arctan2(g * entry(2, 1), -g * entry(2, 0))
        q[..., 3] = self.q4[:, e, None]
        q[~self.valid[:, e]] = np.nan
        return q

    def cuts(self) -> np.ndarray:
        """Arm angles where a joint meets a limit or a spherical group is singular,
        ``(N, 2, 32)`` in ``[-π, π)``, NaN-padded, per elbow sign (step 4)."""
        arm = self.arm
        rows = []
        for M, first, sigma in ((self.shoulder, 0, arm.shoulder_euler[2]),
                                (self.wrist, 4, arm.wrist_euler[2])):  # fmt: skip
            for limit in (arm.q_min, arm.q_max):
                t1, t2, t3 = limit[first], limit[first + 1], sigma * limit[first + 2]
                rows.append(M[..., 1, 2] * math.cos(t1) - M[..., 0, 2] * math.sin(t1))
                rows.append(M[..., 2, 1] * math.cos(t3) + M[..., 2, 0] * math.sin(t3))
                rows.append(M[..., 2, 2] - np.array([0.0, 0.0, math.cos(t2)]))
            for pole in (1.0, -1.0):
                rows.append(M[..., 2, 2] - np.array([0.0, 0.0, pole]))
        coeff = np.stack(rows, axis=2)  # (N, 2, 16, 3): alpha sin + beta cos + gamma = 0
        alpha, beta, gamma = coeff[..., 0], coeff[..., 1], coeff[..., 2]
        r = np.hypot(alpha, beta)
        x = -gamma / np.maximum(r, 1e-300)
        ok = (r > 1e-12) & (np.abs(x) <= 1.0 + 1e-12)
        centre, spread = np.arctan2(alpha, beta), np.arccos(np.clip(x, -1.0, 1.0))
        roots = np.concatenate((centre - spread, centre + spread), axis=2)
        roots = np.where(np.concatenate((ok, ok), axis=2), roots, np.nan)
        return -np.pi + np.mod(roots + np.pi, 2 * np.pi)

    def arcs(self) -> list[list[list[Arc]]]:
        """Per pose and :data:`BRANCHES` row, the arcs of arm angles within the joint
        limits (:func:`redres.ik.arcs.from_arcs`)."""
        count = len(self.q4)
        cuts = np.sort(self.cuts(), axis=2)
        slots = cuts.shape[2] + 1
        padded = np.full((count, 2, slots), np.nan)
        mids = np.full((count, 2, slots), np.nan)
        kept = np.zeros((count, 2), dtype=np.int64)
        for i in range(count):
            for e in range(2):
                c = cuts[i, e][np.isfinite(cuts[i, e])]
                c = c[np.concatenate(([True], np.diff(c) > 1e-12))] if len(c) else c
                if len(c) > 1 and c[0] + 2 * np.pi - c[-1] <= 1e-12:
                    c = c[:-1]
                c = c if len(c) else np.array([-np.pi])
                kept[i, e] = len(c)
                padded[i, e, : len(c)] = c
                ends = np.append(c[1:], c[0] + 2 * np.pi)
                mids[i, e, : len(c)] = (c + ends) / 2.0
        out: list[list[list[Arc]]] = [[[] for _ in range(8)] for _ in range(count)]
        lo, hi = self.arm.q_min, self.arm.q_max
        for b in range(8):
            e = 0 if BRANCHES[b, 1] > 0 else 1
            q = self.joints(np.nan_to_num(mids[:, e]), b)
            inside = np.all((q >= lo) & (q <= hi), axis=-1)
            for i in range(count):
                if self.valid[i, e]:
                    k = kept[i, e]
                    out[i][b] = from_arcs(padded[i, e, :k], inside[i, :k])
        return out

    def intervals(self, slots: int) -> dict[str, np.ndarray]:
        """What a redundancy map stores, on arrays (the same pieces as :meth:`arcs`,
        there per pose in Python): per branch ``intervals`` ``(N, 8, slots, 2)``,
        ``count``, ``width``, and over the branches ``union`` ``(N, slots, 2)``,
        ``union_count``, ``total_width`` (:mod:`redres.ik.arcs`)."""
        cuts = self.cuts()
        out: dict[str, np.ndarray] = {}
        s_e, t_e, _ = linear_cuts(cuts)  # (N, 2, A): per elbow sign
        s_u, t_u, _ = linear_cuts(cuts.reshape(len(cuts), -1))  # the union: both elbows' cuts
        lo, hi = self.arm.q_min, self.arm.q_max
        flags = []
        for b in range(8):
            e = 0 if BRANCHES[b, 1] > 0 else 1
            q = self.joints(np.nan_to_num((s_e[:, e] + t_e[:, e]) / 2.0), b)
            inside = np.all((q >= lo) & (q <= hi), axis=-1) & np.isfinite(s_e[:, e])
            flags.append(inside & self.valid[:, e, None])
        # each arc of the union lies in one arc of each elbow's cuts (a subset of its cuts)
        union = np.zeros(s_u.shape, dtype=bool)
        mid_u = np.nan_to_num((s_u + t_u) / 2.0)
        for e in range(2):  # the arc of elbow e's cuts holding each union arc's midpoint
            local = (s_e[:, e, None, :] <= mid_u[:, :, None]).sum(axis=2) - 1  # NaN: False
            for branch in np.flatnonzero(BRANCHES[:, 1] == (1 if e == 0 else -1)):
                union |= np.take_along_axis(flags[int(branch)], local, axis=1)
        union &= np.isfinite(s_u)
        starts = np.stack([s_e[:, 0 if g4 > 0 else 1] for g4 in BRANCHES[:, 1]], axis=1)
        stops = np.stack([t_e[:, 0 if g4 > 0 else 1] for g4 in BRANCHES[:, 1]], axis=1)
        out["intervals"], out["count"], out["width"] = runs(starts, stops, np.stack(flags, 1),
                                                            slots)  # fmt: skip
        out["union"], out["union_count"], out["total_width"] = runs(s_u, t_u, union, slots)
        return out


def _joint_frames(links: np.ndarray, axes: np.ndarray, q: np.ndarray) -> list[np.ndarray]:
    """World poses ``(4, 4)`` of the frames after each joint (the chain's convention)."""
    T = np.eye(4)
    out = []
    for j in range(len(axes)):
        step = np.eye(4)
        step[:3] = links[j]
        spin = np.eye(4)
        spin[:3, :3] = _rot(axes[j], np.array(q[j]))
        T = T @ step @ spin
        out.append(T)
    return out


def _apply(T: np.ndarray, p: np.ndarray) -> np.ndarray:
    return np.asarray(T[:3, :3] @ p + T[:3, 3])


def _apply_inv(T: np.ndarray, p: np.ndarray) -> np.ndarray:
    return np.asarray(T[:3, :3].T @ (p - T[:3, 3]))
