"""Which arms have the closed form of :mod:`redres.ik.analytic`, and its constants.

:func:`analytic_arm` reads the robot's serial chain to a frame and checks, to
:data:`STRUCTURE_TOL`, that it has 7 revolute joints, axes 1–3 meeting at one point ``S``
(a spherical shoulder), axes 5 and 6 meeting at a point ``W``, and an elbow (joint 4)
that changes ``|W − S|``; an arm without it raises :class:`NotAnalyticError` naming the
failed test. It then computes, once per robot and frame, everything the kernel needs
that depends on the arm alone (:func:`_constants`; the derivation is in
:mod:`redres.ik.analytic`), packed in the slots of :mod:`redres.ik._analytic_codes`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import numpy as np
from numpy.typing import NDArray

from .._validate import FloatArray
from ..errors import RedresError
from . import _analytic_codes as codes

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["STRUCTURE_TOL", "AnalyticArm", "NotAnalyticError", "analytic_arm"]

#: Tolerance of the structure tests, m for distances between axes, and for the sines
#: of angles between axes that must not be parallel.
STRUCTURE_TOL = 1e-9


class NotAnalyticError(RedresError, ValueError):
    """The arm lacks the structure of :mod:`redres.ik.analytic` (the message names the
    failed test); ``rr.ik`` solves it numerically."""


@dataclass(frozen=True)
class AnalyticArm:
    """The constants of the closed form of one arm (module docstring): build with
    :func:`analytic_arm`.

    Attributes:
        frame: the frame solved for.
        links, axes, kinds: the :attr:`~redres.robot.SerialChain.arrays` of its chain.
        bounds: joint limits, ``(2, 7)``, rad (``q_min``, ``q_max``).
        arm: the packed constants, slots named in :mod:`redres.ik._analytic_codes`.
        shoulder: the point ``S`` in the world, m.
        wrist: the point ``W`` in frame 6, m.
    """

    frame: str
    links: FloatArray
    axes: FloatArray
    kinds: NDArray[np.int64]
    bounds: FloatArray
    arm: FloatArray
    shoulder: FloatArray
    wrist: FloatArray


_ARMS: WeakKeyDictionary[Robot, dict[str | None, AnalyticArm]] = WeakKeyDictionary()


def analytic_arm(robot: Robot, frame: str | None = None) -> AnalyticArm:
    """The closed form's constants for ``robot``'s chain to ``frame`` (default: its tip),
    computed once per robot and frame.

    Raises:
        NotAnalyticError: not 7 revolute joints, axes 1-3 not meeting at one point, axes
            5 and 6 not meeting, or an elbow that does not change ``|W − S|`` (the
            message says which).
        FrameNotFoundError: unknown ``frame``.
    """
    per_robot = _ARMS.get(robot)
    if per_robot is None:
        per_robot = _ARMS[robot] = {}
    found = per_robot.get(frame)
    if found is None:
        found = per_robot[frame] = _build(robot, frame)
    return found


def _build(robot: Robot, frame: str | None) -> AnalyticArm:
    from ..robot import NotSerialChainError

    name = robot.model.frames[robot.frame_id(frame)].name
    where = f"{robot.name}, frame {name!r}"
    try:
        chain = robot.chain(name)
    except NotSerialChainError as exc:
        raise NotAnalyticError(f"{where}: {exc}") from None
    links, axes, kinds = chain.arrays
    if len(kinds) != 7 or robot.n != 7 or chain.prismatic.any():
        prismatic = int(chain.prismatic.sum())
        _refuse(
            where,
            "needs 7 revolute joints up to the frame and n = 7; got "
            f"{len(kinds)} joints ({prismatic} prismatic), n = {robot.n}",
        )
    R = [X[:, :3] for X in links]
    p = [X[:, 3] for X in links]
    s1, gap = _meet(np.zeros(3), axes[0], p[1], R[1] @ axes[1], where, "axes 1 and 2")
    if gap > STRUCTURE_TOL:
        _refuse(where, f"axes 1 and 2 do not meet (they pass {gap:.3g} m apart)")
    s2 = R[1].T @ (s1 - p[1])
    foot, gap = _foot(s2, p[2], R[2] @ axes[2])
    if gap > STRUCTURE_TOL:
        _refuse(where, f"axis 3 misses the point where axes 1 and 2 meet by {gap:.3g} m")
    if np.linalg.norm(np.cross(axes[1], R[2] @ axes[2])) < STRUCTURE_TOL:
        _refuse(where, "axes 2 and 3 are parallel (not a spherical shoulder)")
    s3 = R[2].T @ (foot - p[2])
    w5, gap = _meet(np.zeros(3), axes[4], p[5], R[5] @ axes[5], where, "axes 5 and 6")
    if gap > STRUCTURE_TOL:
        _refuse(where, f"axes 5 and 6 do not meet (they pass {gap:.3g} m apart)")
    w6 = R[5].T @ (w5 - p[5])
    w4 = R[4] @ w5 + p[4]
    s_prime = R[3].T @ (s3 - p[3])
    a = axes[3]
    P = float((a @ s_prime) * (a @ w4))
    K = float(w4 @ w4 + s_prime @ s_prime)
    A, B = float(s_prime @ w4) - P, float(s_prime @ np.cross(a, w4))
    if math.hypot(A, B) < STRUCTURE_TOL:
        _refuse(where, "joint 4 does not change the distance between the shoulder and the wrist")
    arm = _constants(R, p, axes, w6, w4, s_prime, (K, P, A, B))
    arm[codes.S : codes.S + 3] = links[0][:, :3] @ s1 + links[0][:, 3]
    arm[codes.LO : codes.LO + 7], arm[codes.HI : codes.HI + 7] = robot.q_min, robot.q_max
    bounds = np.ascontiguousarray(np.stack((robot.q_min, robot.q_max)), dtype=np.float64)
    for array in (arm, bounds):
        array.flags.writeable = False
    return AnalyticArm(name, links, axes, kinds, bounds, arm, arm[codes.S : codes.S + 3], w6)


def _constants(
    R: list[FloatArray],
    p: list[FloatArray],
    axes: FloatArray,
    w6: FloatArray,
    w4: FloatArray,
    s_prime: FloatArray,
    elbow: tuple[float, float, float, float],
) -> FloatArray:
    """The kernel's constants (slots of :mod:`._analytic_codes`, but ``S`` and the
    limits): ``R``, ``p`` the placements' rotations and origins, ``axes`` the joint
    axes, ``w6``, ``w4`` the wrist point in frames 6 and 4, ``s_prime`` the shoulder
    point in joint 4's placement frame, ``elbow`` ``(K, P, A, B)``."""
    arm = np.zeros(codes.N_ARM)

    def put(slot: int, value: Any) -> None:
        value = np.ravel(value)
        arm[slot : slot + len(value)] = value

    def turning(a: FloatArray, v: FloatArray, frame: FloatArray, slots: tuple[int, ...]) -> None:
        """``frame Rot(a, θ) v = c0 + cos θ cc + sin θ cs`` (Rodrigues) into ``slots``."""
        along = (a @ v) * a
        for slot, value in zip(slots, (along, v - along, np.cross(a, v))):
            put(slot, frame @ value)

    a7, a4, a5, a6 = axes[6], axes[3], axes[4], axes[5]
    outer = np.outer(a7, a7)
    put(codes.M0, R[7].T @ outer @ R[6].T)  # R(X7)ᵀ Rot(a7, −q7) R(X6)ᵀ
    put(codes.MC, R[7].T @ (np.eye(3) - outer) @ R[6].T)
    put(codes.MS, -R[7].T @ _skew(a7) @ R[6].T)
    put(codes.D7, -R[7].T @ p[7])
    put(codes.WE, w6 - p[6])
    put(codes.A6, a6)
    K, P, A, B = elbow
    H = math.hypot(A, B)
    put(codes.K_ELBOW, (K, P, 1.0 / H, math.atan2(B, A), A / H, B / H))
    turning(a4, w4, R[3], (codes.V0, codes.VC, codes.VS))
    arm[codes.V0 : codes.V0 + 3] -= R[3] @ s_prime
    turning(a4, R[4] @ a5, R[3], (codes.U0, codes.UC, codes.US))
    ba5 = R[5] @ a6  # the joint-6 axis in frame 5: q5 turns it onto (R4 R(X4))ᵀ z6
    turning(a4, R[4] @ np.cross(a5, ba5), R[3], (codes.P50, codes.P5C, codes.P5S))
    turning(a4, R[4] @ (ba5 - (a5 @ ba5) * a5), R[3], (codes.Q50, codes.Q5C, codes.Q5S))
    bta4 = R[5].T @ a5  # the joint-5 axis in frame 6: q6 turns R6ᵀ z5 onto it
    put(codes.P6, np.cross(bta4, a6))
    put(codes.Q6, bta4 - (a6 @ bta4) * a6)
    put(codes.COS_GAMMA, a5 @ ba5)
    C = R[1] @ R[2]
    k1, k2, k3 = axes[0], R[1] @ axes[1], C @ axes[2]
    m3 = _normal(k3)
    put(codes.X0, R[0])
    put(codes.A3, axes[2])
    put(codes.M3C, C.T @ m3)
    for slot, value in ((codes.K1, k1), (codes.K2, k2), (codes.K3, k3), (codes.M3, m3),
                        (codes.K1XK2, np.cross(k1, k2))):  # fmt: skip
        put(slot, value)
    put(codes.K12, (k1 @ k2, k2 @ k3))
    twin = abs(k1 @ k2) < codes.TWIN_TOL and np.linalg.norm(np.cross(k1, k3)) < codes.TWIN_TOL
    arm[codes.TWIN] = 1.0 if twin else 0.0
    return arm


def _skew(v: FloatArray) -> FloatArray:
    """``[v]×``: ``[v]× x = v × x``."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _refuse(where: str, why: str) -> None:
    raise NotAnalyticError(
        f"{where}: no closed form: {why}; analytic IK needs axes 1-3 meeting at one point "
        f"and axes 5-6 meeting (tolerance {STRUCTURE_TOL:g}); use rr.ik (numerical) instead"
    )


def _meet(
    p1: FloatArray, d1: FloatArray, p2: FloatArray, d2: FloatArray, where: str, what: str
) -> tuple[FloatArray, float]:
    """The midpoint of the closest points of lines ``p1 + t d1`` and ``p2 + s d2`` (unit
    directions), and their distance."""
    b = float(d1 @ d2)
    if 1.0 - b * b < STRUCTURE_TOL**2:
        _refuse(where, f"{what} are parallel")
    w = p1 - p2
    d, e = float(d1 @ w), float(d2 @ w)
    t, s = (b * e - d) / (1.0 - b * b), (e - b * d) / (1.0 - b * b)
    c1, c2 = p1 + t * d1, p2 + s * d2
    return (c1 + c2) / 2.0, float(np.linalg.norm(c1 - c2))


def _foot(x: FloatArray, p: FloatArray, d: FloatArray) -> tuple[FloatArray, float]:
    """The foot of ``x`` on the line ``p + t d`` (unit ``d``) and the distance to it."""
    foot = p + float((x - p) @ d) * d
    return foot, float(np.linalg.norm(x - foot))


def _normal(v: FloatArray) -> FloatArray:
    """A unit vector normal to the unit ``v``."""
    e = np.zeros(3)
    e[int(np.argmin(np.abs(v)))] = 1.0
    n = np.cross(v, e)
    return np.asarray(n / np.linalg.norm(n))
