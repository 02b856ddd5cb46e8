"""Every pair's distance and ``∂d/∂q`` at one configuration, in one compiled call.

:class:`CollisionModel` fixes a robot's link capsules, the obstacles and the pairs
(:mod:`redres.collision.pairs`) once; :meth:`CollisionModel.compute` then takes the
joints' poses and ``WORLD`` Jacobian, from the compiled serial chain
(:func:`redres.collision._kernels.chain_frames`, :class:`redres.robot.chain.SerialChain`'s
arrays) or, for a model that is not one, from one Pinocchio pass
(``computeJointJacobians``), and hands them to the kernel
:func:`redres.collision._kernels.pair_distances` (formulas there).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from .. import _compile
from .._validate import FloatArray, as_vector
from ..errors import InvalidParameterError
from .pairs import Pair, allowed_set, candidate_self_pairs, is_allowed
from .shapes import pack_obstacles

if TYPE_CHECKING:
    from ..robot import Capsule, Robot

#: The distance kernels. Cold: 66 s measured at load 8 on 2 cores (about 20 s quiet, estimated).
KERNELS = _compile.KernelGroup("collision", ("redres.collision._kernels",), cold_seconds=20.0)


def _kernels() -> Any:
    return KERNELS.required("collision distances")


def _entry(name: str, args: tuple[Any, ...]) -> tuple[Any, bool]:
    """The kernel ``name`` for ``args``' types, and whether it is compiled (a plain twin
    answers while it compiles behind: the caller asks again later)."""
    module = _kernels()
    return _compile.entry_point(getattr(module, name), args), _compile.is_compiled(module)


@dataclass(slots=True)
class PairDistances:
    """Distances of a :class:`CollisionModel`'s pairs at one ``q`` (arrays owned by the
    model: copy what must outlive the next :meth:`~CollisionModel.compute`).

    Attributes:
        pairs: the pairs, shape ``P``.
        distance: signed surface distances ``(P,)``, m (< 0: penetration); for a pair
            beyond the call's ``cutoff`` a lower bound of it.
        point_a: witness on the first capsule's centre line ``(P, 3)``, m.
        point_b: witness on the other shape ``(P, 3)``: on its centre line or centre for a
            capsule or a sphere, on its surface for a box or a half-space.
        normal: unit normal from the other shape towards the first capsule ``(P, 3)``.
        gradient: ``∂d/∂q = n̂ᵀ(J_a − J_b)`` ``(P, n)``, m/rad (zero beyond ``cutoff``).
        resolved: how many pairs were within ``cutoff`` (computed exactly).
    """

    pairs: list[Pair]
    distance: FloatArray
    point_a: FloatArray
    point_b: FloatArray
    normal: FloatArray
    gradient: FloatArray
    resolved: int

    def closest(self, self_pairs: bool | None = None) -> tuple[Pair, float] | None:
        """The closest pair and its distance (``self_pairs``: only self pairs when
        True, only environment pairs when False); None when there is none."""
        keep = [k for k, p in enumerate(self.pairs)
                if self_pairs is None or p.self_pair == self_pairs]  # fmt: skip
        if not keep:
            return None
        k = keep[int(np.argmin(self.distance[keep]))]
        return self.pairs[k], float(self.distance[k])


class CollisionModel:
    """A robot's link capsules, the obstacles and the pairs between them.

    Args:
        robot: the robot (its Pinocchio model; a private Pinocchio data is made).
        obstacles: :mod:`redres.collision.shapes` obstacles, world coordinates.
        capsules: link capsules (default ``robot.capsules``).
        self_collision: also pair the capsules with each other.
        allowed: pairs of names (capsule, frame or obstacle names) never checked.
        srdf: an SRDF (path or XML text) whose ``disable_collisions`` are allowed too.
        safety: pairs within this distance at the neutral pose are left out (in contact
            there: a table under the base, links the model makes touch), m.
        neutral: which pairs that rule applies to: ``"all"``, or ``"self"`` (every
            environment pair kept, as the soft objective wants).

    Raises:
        InvalidParameterError: no capsules, or an obstacle of an unknown type.
    """

    def __init__(
        self,
        robot: Robot,
        obstacles: Sequence[Any] = (),
        *,
        capsules: Sequence[Capsule] | None = None,
        self_collision: bool = True,
        allowed: Sequence[Sequence[str]] = (),
        srdf: str | Path | None = None,
        safety: float = 0.0,
        neutral: Literal["all", "self"] = "all",
    ) -> None:
        """The arguments are described in ``help(CollisionModel)``."""
        caps = list(robot.capsules if capsules is None else capsules)
        if not caps:
            raise InvalidParameterError(
                f"robot {robot.name!r} has no link capsules: its file has no collision "
                "geometry (add <collision> shapes to its links and they are fitted), or pass "
                "capsules=[Capsule(...)] (redres.robot.capsule_between)"
            )
        self.robot, self.capsules, self.obstacles = robot, caps, list(obstacles)
        self._kinds, self._rows = pack_obstacles(self.obstacles)
        model = robot.model
        frames = [model.frames[robot.frame_id(c.frame)] for c in caps]
        joints = sorted({f.parentJoint for f in frames})
        self._joints = joints
        self._cap_frame = np.array([joints.index(f.parentJoint) for f in frames], np.int64)
        # the columns of the joints supporting each link (a serial chain: a prefix)
        self._cap_cols = np.array(
            [max([model.joints[j].idx_v + model.joints[j].nv for j in model.supports[f.parentJoint]
                  if j > 0], default=0) for f in frames], np.int64)  # fmt: skip
        # segment ends moved from the capsule's frame into its joint's frame
        self._cap_a = np.ascontiguousarray([f.placement.act(np.asarray(c.a, float))
                                            for f, c in zip(frames, caps)])  # fmt: skip
        self._cap_b = np.ascontiguousarray([f.placement.act(np.asarray(c.b, float))
                                            for f, c in zip(frames, caps)])  # fmt: skip
        self._cap_r = np.array([float(c.radius) for c in caps])
        self._data = model.createData()
        self._calls: dict[str, Any] = {}  # kernel entry points, compiled ones kept
        F = len(joints)
        self._T = np.zeros((F, 4, 4))
        self._R, self._t = self._T[:, :3, :3], self._T[:, :3, 3]  # views the kernel reads
        self._T4, self._J, self._resolved = np.zeros((4, 4)), np.zeros((6, robot.n)), 0
        self._chain = self._chain_arrays(robot, joints, [c.frame for c in caps])
        self._no_chain = (np.zeros((0, 1, 3, 4)), np.zeros((0, 3)), np.zeros(0, np.int64),
                          np.zeros(0, np.int64))  # fmt: skip
        self._q0 = np.zeros(robot.n)
        permitted = allowed_set(allowed, srdf)
        candidates = [(0, i, j) for i, cap in enumerate(caps)
                      for j, obs in enumerate(self.obstacles)
                      if not is_allowed(permitted, (cap.name, cap.frame), (obs.name,))]  # fmt: skip
        if self_collision:
            candidates += [(1, i, j) for i, j in candidate_self_pairs(robot, caps, permitted)]
        #: Pairs left out for contact at the neutral pose: ``(first, second, reason)``.
        self.excluded: list[tuple[str, str, str]] = []
        self._set_pairs(candidates, [])
        at_neutral = self._run(robot.neutral(), np.inf)[0]
        rows, pairs = [], []
        for (kind, i, j), d in zip(candidates, at_neutral):
            second = caps[j].name if kind else self.obstacles[j].name
            if d <= safety and (kind or neutral == "all"):
                self.excluded.append((caps[i].name, second, "in contact at the neutral pose"))
            else:
                rows.append((kind, i, j))
                pairs.append(Pair(caps[i].name, second, bool(kind)))
        self._set_pairs(rows, pairs)

    def _set_pairs(self, rows: list[tuple[int, int, int]], pairs: list[Pair]) -> None:
        P, n = len(rows), self.robot.n
        self.pairs = pairs
        self._pairs = np.array(rows, np.int64).reshape(P, 3)
        self._d, self._gradient = np.zeros(P), np.zeros((P, n))
        self._pa, self._pb, self._n = np.zeros((P, 3)), np.zeros((P, 3)), np.zeros((P, 3))

    @staticmethod
    def _chain_arrays(robot: Robot, joints: list[int], frames: list[str]) -> tuple[Any, ...] | None:
        """The arguments of :func:`~redres.collision._kernels.chain_frames` before ``q``:
        the serial chain to the deepest capsule joint, one row of placements per capsule
        joint; None when the model is not a serial chain there (Pinocchio answers)."""
        from ..robot import NotSerialChainError

        model = robot.model
        deepest = max(joints)
        frame = max(frames, key=lambda name: model.frames[robot.frame_id(name)].parentJoint)
        try:
            links, axes, kinds = robot.chain(frame).arrays
        except NotSerialChainError:
            return None
        if deepest == 0 or len(kinds) != deepest:
            return None
        packed = np.zeros((len(joints), len(kinds) + 1, 3, 4))
        for f, j in enumerate(joints):  # joints 1 … k of a serial chain: joint j is depth j
            packed[f, :j] = links[:j]
            packed[f, j, :, :3] = np.eye(3)
        depth = np.array(joints, np.int64)
        return packed, np.ascontiguousarray(axes), np.ascontiguousarray(kinds), depth

    def _call(self, name: str, args: tuple[Any, ...]) -> Any:
        """Kernel ``name`` on ``args`` (its entry point found on first call, kept once
        compiled)."""
        call = self._calls.get(name)
        if call is None:
            call, compiled = _entry(name, args)
            if compiled:
                self._calls[name] = call
        return call(*args)

    def _kinematics(self, q: FloatArray) -> None:
        if self._chain is not None:  # q as the typed entry point wants it (a no-op on a step's q)
            q = np.ascontiguousarray(q, dtype=np.float64)
            self._call("chain_frames", (*self._chain, q, self._T4, self._R, self._t, self._J))
            return
        model, data = self.robot.model, self._data
        # one pass: poses and data.J, copied (C order: the kernels' entry points are typed)
        self._J[:] = pin.computeJointJacobians(model, data, q)
        oMi, T = data.oMi, self._T
        for k, j in enumerate(self._joints):
            T[k] = oMi[j].homogeneous  # one conversion per joint

    def _geometry(self) -> tuple[Any, ...]:
        return (self._R, self._t, self._J, self._cap_frame, self._cap_cols, self._cap_a,
                self._cap_b, self._cap_r, self._kinds, self._rows, self._pairs)  # fmt: skip

    def _run(self, q: FloatArray, cutoff: float) -> tuple[FloatArray, int]:
        self._kinematics(q)
        args = (*self._geometry(), float(cutoff), self._d, self._pa, self._pb, self._n,
                self._gradient)  # fmt: skip
        return self._d, int(self._call("pair_distances", args))

    def damper(
        self, q: FloatArray, influence: float, safety: float, rate: float, G: FloatArray,
        lower: FloatArray,
    ) -> int:  # fmt: skip
        """The velocity-damper rows of every pair at ``q`` (a checked float vector ``(n,)``)
        in one compiled call (:func:`~redres.collision._kernels.damper_rows`): ``G``
        ``(P, n)`` ← ``∂d/∂q``, ``lower`` ``(P,)`` ← ``rate · (d − safety)`` for the pairs
        closer than ``influence`` (m) and ``−1e30`` for the others (``rate`` in 1/s).
        The distances and witnesses go to the model's arrays (:meth:`last`). Returns how
        many pairs are closer than ``influence``."""
        if self._chain is None:
            self._kinematics(q)
            q = self._q0  # (the chain arrays are empty: the kernel skips the chain)
        else:
            q = np.ascontiguousarray(q, dtype=np.float64)
        args = (*(self._chain or self._no_chain), q, self._T4, *self._geometry(),
                float(influence), float(safety), float(rate), self._d, self._pa, self._pb,
                self._n, G, lower)  # fmt: skip
        resolved, active = self._call("damper_rows", args)
        self._resolved = int(resolved)
        return int(active)

    def last(self, gradient: FloatArray) -> PairDistances:
        """The :class:`PairDistances` of the last :meth:`damper` call (``gradient``: its
        ``G``)."""
        return PairDistances(self.pairs, self._d, self._pa, self._pb, self._n, gradient,
                             self._resolved)  # fmt: skip

    def compute(self, q: Any, cutoff: float = np.inf, *, checked: bool = False) -> PairDistances:
        """Every pair at ``q`` (shape ``(n,)``, rad); pairs whose bounding spheres are
        farther apart than ``cutoff`` (m; the broad phase) are not resolved exactly.
        ``checked``: ``q`` is already a finite float vector of size ``n`` (a scheme's
        step checked it)."""
        if not checked:
            q = as_vector(q, "q", self.robot.n)
        _, resolved = self._run(q, cutoff)
        return PairDistances(self.pairs, self._d, self._pa, self._pb, self._n, self._gradient,
                             resolved)  # fmt: skip

    def distances(self, q: Any) -> FloatArray:
        """Exact signed distances of every pair at ``q``, ``(P,)``, m (a copy)."""
        return self.compute(q).distance.copy()

    def self_mask(self) -> NDArray[np.bool_]:
        """Which pairs are self pairs, ``(P,)``."""
        return np.array([p.self_pair for p in self.pairs], bool)
