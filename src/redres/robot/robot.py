"""`Robot`: kinematics and dynamics of one serial chain, on Pinocchio.

Conventions (docs/conventions.md): spatial vectors are ``[linear; angular]``; the default
Jacobian reference ``"world"`` is the geometric Jacobian of the frame origin with
world-aligned axes (Pinocchio ``LOCAL_WORLD_ALIGNED``); ``"local"`` uses the frame's own
axes (Pinocchio ``LOCAL``). Angles in radians, lengths in metres, SI everywhere.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np
import pinocchio as pin

from .._validate import FloatArray, as_rng, as_scalar, as_vector, real_array
from ..errors import FrameNotFoundError, InvalidParameterError, JointLimitError, ShapeError
from ._frames import Reference, add_frame
from .derivatives import revolute_jacobian_derivatives
from .files import RobotFiles

if TYPE_CHECKING:
    from .capsules import Capsule
    from .chain import SerialChain
    from .dh import DHLink


_REFERENCE = {"world": pin.LOCAL_WORLD_ALIGNED, "local": pin.LOCAL}


class _CopiedArray(property):
    """A read-only array property of :class:`Robot` whose value is a copy of the private
    array ``_<name>``: changing what a caller gets leaves the robot as it was."""

    def __init__(self, doc: str) -> None:
        super().__init__(self._copy)
        self.__doc__ = doc  # (Python 3.11 drops property(doc=...) in a subclass)

    def __set_name__(self, owner: type, name: str) -> None:
        self._name, self._private = name, f"_{name}"

    def _copy(self, robot: object) -> FloatArray:
        return np.array(getattr(robot, self._private), dtype=float)

    def __set__(self, robot: object, value: object) -> None:
        raise AttributeError(
            f"Robot.{self._name} is read-only; Robot.with_limits gives a robot with other "
            "velocity, acceleration, jerk or torque limits"
        )

    @overload
    def __get__(self, robot: None, owner: type | None = None) -> _CopiedArray: ...
    @overload
    def __get__(self, robot: object, owner: type | None = None) -> FloatArray: ...
    def __get__(self, robot: object, owner: type | None = None) -> Any:
        return super().__get__(robot, owner)


class Robot(RobotFiles):
    """A serial manipulator with ``n`` one-degree-of-freedom joints.

    Build one with :meth:`from_dh`, :meth:`from_urdf`, :meth:`from_urdf_string`,
    :meth:`from_mjcf` or a function of :mod:`redres.models`; the constructor takes a ready
    Pinocchio model. :meth:`with_limits` derives one with tighter limits.

    Args:
        model: Pinocchio model whose joints are all one-DOF (revolute or prismatic), with
            position, velocity and effort limits filled in.
        tip: name of the default frame of :meth:`fk` and :meth:`jacobian`.
        name: a short name for tables and reports.
        home: what :meth:`neutral` returns, shape ``(n,)``; default: zero clipped to the limits.
        qdd_max: joint acceleration limits, shape ``(n,)``, rad/s² or m/s²; ``inf`` where
            unknown.
        qddd_max: joint jerk limits, shape ``(n,)``, rad/s³ or m/s³; ``inf`` where unknown.

    Attributes:
        model: the Pinocchio model (read it, do not resize it).

    Threads may share a ``Robot``: :attr:`data` is each calling thread's own Pinocchio
    data. Add frames (:meth:`add_frame`) before sharing it.
    """

    def __init__(
        self,
        model: pin.Model,
        *,
        tip: str,
        name: str = "robot",
        home: Sequence[float] | FloatArray | None = None,
        qdd_max: Sequence[float] | FloatArray | None = None,
        qddd_max: Sequence[float] | FloatArray | None = None,
    ) -> None:
        """Wrap a Pinocchio ``model`` of one-DOF joints; ``help(Robot)`` lists the arguments."""
        if model.nq != model.nv:
            raise InvalidParameterError(
                f"Robot needs one-DOF joints (nq == nv); model {model.name!r} has "
                f"nq={model.nq}, nv={model.nv}. Load URDFs with Robot.from_urdf, which "
                "converts continuous joints."
            )
        self.model = model
        self._local = threading.local()  # per-thread Pinocchio data (the ``data`` property)
        self._model_version = 0
        self.name = name
        n = model.nv
        q_min = np.array(model.lowerPositionLimit, dtype=float)
        q_max = np.array(model.upperPositionLimit, dtype=float)
        bad = np.flatnonzero(~(q_min <= q_max))
        if bad.size:
            j = int(bad[0])
            raise JointLimitError(
                f"joint {self.joint_names[j]!r}: q_min = {q_min[j]} > q_max = {q_max[j]}; "
                "swap the limits or fix the model"
            )
        self._q_min = q_min
        self._q_max = q_max
        self._qd_max = np.abs(np.array(model.upperVelocityLimit, dtype=float))
        self._tau_max = np.abs(np.array(model.upperEffortLimit, dtype=float))
        self._qdd_max = _limit_vector(qdd_max, n, "qdd_max")
        self._qddd_max = _limit_vector(qddd_max, n, "qddd_max")
        self._frame_ids: dict[str, int] = {}
        self._chains: dict[int, SerialChain] = {}
        self._refresh_frames()
        self._all_revolute = all(
            j.shortname()
            in ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")
            for j in list(model.joints)[1:]
        )
        self._tip_id = self.frame_id(tip)
        self._tip = tip
        self._lower = np.tril_indices(n, -1)
        if home is None:
            home_q = np.clip(np.zeros(n), q_min, q_max)
        else:
            home_q = as_vector(home, "home", n).copy()
            self._check_within_limits(home_q, "home")
        self._home = home_q
        #: Capsules approximating the links, for obstacle distances (built-in arms set them).
        self.capsules: list[Capsule] = []

    @property
    def data(self) -> pin.Data:
        """The Pinocchio data this robot computes into: the calling thread's own."""
        local = self._local
        if getattr(local, "version", -1) != self._model_version:
            local.data, local.version = self.model.createData(), self._model_version
        return local.data

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k != "_local"}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._local = threading.local()

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dh(
        cls,
        links: Sequence[DHLink | Mapping[str, Any]],
        convention: Literal["standard", "modified"] = "standard",
        base: Any = None,
        tool: Any = None,
        *,
        name: str = "dh_robot",
        tip: str = "tool",
        tool_name: str = "tool",
        frames: Mapping[str, tuple[str, Any]] | None = None,
        home: Sequence[float] | FloatArray | None = None,
    ) -> Robot:
        """Build a robot from Denavit–Hartenberg parameters.

        Args:
            links: one record per joint (:class:`DHLink` or a dict with the same keys:
                ``a``, ``alpha``, ``d``, ``theta`` (offset), ``joint`` ("revolute" or
                "prismatic"), optional ``q_min``, ``q_max``, ``qd_max``, ``qdd_max``,
                ``qddd_max``, ``tau_max``, ``mass``, ``com``, ``inertia``, ``armature``, ``name``).
            convention: ``"standard"`` (distal: ``Rz(θ) Tz(d) Tx(a) Rx(α)``, joint ``i``
                moves about ``z_{i-1}``) or ``"modified"`` (Craig's proximal convention:
                ``Rx(α_{i-1}) Tx(a_{i-1}) Rz(θ_i) Tz(d_i)``, the record of joint ``i``
                carries ``a_{i-1}`` and ``α_{i-1}``).
            base: 4x4 pose of DH frame 0 in the world (default identity).
            tool: 4x4 pose of the tool frame in the last DH frame (default identity).
            name: robot name.
            tip: default frame of :meth:`fk` and :meth:`jacobian`.
            tool_name: name of the tool frame.
            frames: extra frames, ``{name: (parent frame, 4x4 pose in the parent)}``, added
                in order (a later one may hang on an earlier one).
            home: configuration returned by :meth:`neutral`.

        The frames are ``base``, ``link1`` … ``link<n>`` (the DH frames), the tool frame
        and the extra ``frames``.
        Inertial parameters (``com``, ``inertia`` about the centre of mass) are expressed
        in the link's own DH frame.
        """
        from .dh import build_dh_model

        model, (qdd_max, qddd_max) = build_dh_model(links, convention, base, tool, name,
                                                     tool_name)  # fmt: skip
        for frame_name, (parent, T) in (frames or {}).items():
            add_frame(model, frame_name, parent, T)
        return cls(model, tip=tip, name=name, home=home, qdd_max=qdd_max, qddd_max=qddd_max)

    # ------------------------------------------------------------------ description
    @property
    def n(self) -> int:
        """Number of joints (degrees of freedom)."""
        return int(self.model.nv)

    q_min = _CopiedArray("Lower position limits, shape ``(n,)``, rad or m.")
    q_max = _CopiedArray("Upper position limits, shape ``(n,)``, rad or m.")
    qd_max = _CopiedArray(
        "Velocity limits (symmetric), shape ``(n,)``, rad/s or m/s; ``inf`` if unknown."
    )
    qdd_max = _CopiedArray(
        "Acceleration limits (symmetric), shape ``(n,)``, rad/s²; ``inf`` if unknown."
    )
    qddd_max = _CopiedArray("Jerk limits (symmetric), shape ``(n,)``, rad/s³; ``inf`` if unknown.")

    @property
    def joint_damping(self) -> FloatArray:
        """Viscous joint damping ``d`` (torque ``−d q̇``), shape ``(n,)``, N·m·s/rad; zero
        unless the model's file gives it (an MJCF's ``damping``)."""
        return np.array(self.model.damping, dtype=float)

    tau_max = _CopiedArray(
        "Torque (force) limits (symmetric), shape ``(n,)``, N·m or N; ``inf`` if unknown."
    )

    @property
    def tip(self) -> str:
        """Name of the default frame."""
        return self._tip

    @property
    def joint_names(self) -> list[str]:
        """Joint names, in configuration order."""
        return [str(s) for s in list(self.model.names)[1:]]

    def frames(self, *, include_joint_frames: bool = True) -> list[str]:
        """Names of the frames usable with :meth:`fk` and :meth:`jacobian`.

        Args:
            include_joint_frames: also list the frames a URDF puts at each (fixed) joint.
        """
        if include_joint_frames:
            return list(self._frame_ids)
        joints = (pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT)
        return [f for f, i in self._frame_ids.items() if self.model.frames[i].type not in joints]

    def neutral(self) -> FloatArray:
        """A comfortable configuration inside the limits (the model's home pose)."""
        return self._home.copy()

    def random_configuration(
        self, rng: np.random.Generator | int | None = None, *, margin: float = 0.0
    ) -> FloatArray:
        """A configuration drawn uniformly within the limits (every limit must be finite).

        Args:
            rng: a NumPy generator or a seed; ``None`` draws a fresh seed.
            margin: keep this distance (rad or m, >= 0) from every limit.

        Raises:
            InvalidParameterError: a bad ``rng``, or ``margin`` < 0 or over a joint range.
            JointLimitError: a joint without finite limits (no uniform draw exists).
        """
        gen = as_rng(rng)
        margin = as_scalar(margin, "margin", minimum=0.0)
        unbounded = np.flatnonzero(~(np.isfinite(self._q_min) & np.isfinite(self._q_max)))
        if unbounded.size:
            j = int(unbounded[0])
            raise JointLimitError(
                f"random_configuration draws within finite limits; joint "
                f"{self.joint_names[j]!r} has [{self._q_min[j]}, {self._q_max[j]}]: give it "
                "q_min and q_max, or draw that joint yourself"
            )
        lo, hi = self._q_min + margin, self._q_max - margin
        if np.any(lo > hi):
            raise InvalidParameterError(f"margin={margin} is wider than a joint range")
        return gen.uniform(lo, hi)

    def joint_limit_margin(self, q: Any) -> FloatArray:
        """Signed distance of each joint to its nearer limit, shape ``(n,)``; < 0 outside."""
        qv = self._q(q)
        return np.minimum(qv - self._q_min, self._q_max - qv)

    def within_limits(self, q: Any, tol: float = 0.0) -> bool:
        """Whether ``q`` is inside the position limits, up to ``tol``."""
        return bool(np.all(self.joint_limit_margin(q) >= -as_scalar(tol, "tol")))

    def frame_id(self, frame: str | None) -> int:
        """Pinocchio index of ``frame`` (``None``: the tip)."""
        if frame is None:
            return self._tip_id
        try:
            return self._frame_ids[frame]
        except (KeyError, TypeError):
            raise FrameNotFoundError(
                f"unknown frame {frame!r} on robot {self.name!r}; valid frames: "
                f"{', '.join(self._frame_ids)}"
            ) from None

    def chain(self, frame: str | None = None) -> SerialChain:
        """Compiled kinematics of the chain from the base to ``frame`` (default: tip):
        pose, Jacobians and pose error without Pinocchio calls, equal to :meth:`fk` and
        :meth:`jacobian` (:mod:`redres.robot.chain`). Built on first use, then cached.

        Raises:
            NotSerialChainError: the model is not a serial chain of revolute and
                prismatic joints up to ``frame`` (use :meth:`fk` and :meth:`jacobian`).
        """
        fid = self.frame_id(frame)
        found = self._chains.get(fid)
        if found is None:
            from .chain import SerialChain

            found = self._chains[fid] = SerialChain(self.model, fid)
        return found

    def add_frame(self, name: str, parent: str, T_parent_frame: Any) -> None:
        """Add a frame rigidly attached to ``parent`` at pose ``T_parent_frame`` (4x4)."""
        add_frame(self.model, name, parent, T_parent_frame)
        self._model_version += 1  # every thread's data is rebuilt for the new model
        self._refresh_frames()

    def __repr__(self) -> str:
        return f"Robot(name={self.name!r}, n={self.n}, tip={self._tip!r})"

    # ------------------------------------------------------------------ kinematics
    def fk(self, q: Any, frame: str | None = None) -> FloatArray:
        """Pose of ``frame`` (default: tip) in the world, a 4x4 homogeneous transform."""
        fid = self.frame_id(frame)
        pin.framesForwardKinematics(self.model, self.data, self._q(q))
        return np.array(self.data.oMf[fid].homogeneous)

    def jacobian(
        self, q: Any, frame: str | None = None, reference: Reference = "world"
    ) -> FloatArray:
        """Geometric Jacobian of ``frame``, shape ``(6, n)``, rows ``[v; w]``.

        ``reference="world"``: velocity of the frame origin and angular velocity, in
        world-aligned axes. ``reference="local"``: the same twist in the frame's axes.
        """
        rf = self._reference(reference)
        J = pin.computeFrameJacobian(self.model, self.data, self._q(q), self.frame_id(frame), rf)
        return np.asarray(J).reshape(6, self.n)

    def kinematics(
        self, q: Any, frame: str | None = None, reference: Reference = "world"
    ) -> tuple[FloatArray, FloatArray]:
        """Pose (4x4) and Jacobian (6 x n) of ``frame`` from one forward pass."""
        placement, J = self.placement_jacobian(self._q(q), self.frame_id(frame), reference)
        return placement.homogeneous, J

    def placement_jacobian(
        self, q: FloatArray, frame_id: int, reference: Reference = "world"
    ) -> tuple[pin.SE3, FloatArray]:
        """Hot-path form of :meth:`kinematics`: Pinocchio ``SE3`` placement and Jacobian.

        ``q`` must already be a valid float64 vector of shape ``(n,)`` (not checked) and
        ``frame_id`` a value of :meth:`frame_id`.
        """
        model, data = self.model, self.data
        if reference == "world":
            # One forward pass fills the joint placements and this frame's Jacobian (faster
            # than computeJointJacobians + getFrameJacobian, which fill every joint's
            # columns). Not for "local": Pinocchio computes that one by a backward pass
            # that leaves the joint placements untouched.
            J = pin.computeFrameJacobian(model, data, q, frame_id, pin.LOCAL_WORLD_ALIGNED)
            placement = pin.updateFramePlacement(model, data, frame_id)
        else:
            pin.computeJointJacobians(model, data, q)
            placement = pin.updateFramePlacement(model, data, frame_id)
            J = pin.getFrameJacobian(model, data, frame_id, _REFERENCE[reference])
        return placement, J if J.ndim == 2 else J.reshape(6, self.n)

    def point_jacobians(self, q: Any, frames: Sequence[str]) -> tuple[FloatArray, FloatArray]:
        """Origins of several frames and their position Jacobians from one forward pass.

        Returns:
            ``(points, jacobians)``: shapes ``(k, 3)`` (m, world) and ``(k, 3, n)``
            (world-aligned linear rows of :meth:`jacobian`).
        """
        ids = [self.frame_id(f) for f in frames]
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, self._q(q))
        points = np.empty((len(ids), 3))
        jacobians = np.empty((len(ids), 3, self.n))
        for k, fid in enumerate(ids):
            pin.updateFramePlacement(model, data, fid)
            points[k] = data.oMf[fid].translation
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            jacobians[k] = np.asarray(J).reshape(6, self.n)[:3]
        return points, jacobians

    def jacobian_derivatives(self, q: Any, frame: str | None = None) -> FloatArray:
        """Partial derivatives ``∂J/∂qᵢ`` of the world-aligned Jacobian, shape ``(n, 6, n)``.

        For revolute chains all from one Jacobian (:mod:`redres.robot.derivatives`); chains
        with prismatic joints fall back to ``n`` calls of :meth:`jacobian_dot`.
        """
        qv = self._q(q)
        if not self._all_revolute:
            eye = np.eye(self.n)
            return np.stack([self.jacobian_dot(qv, eye[i], frame) for i in range(self.n)])
        return revolute_jacobian_derivatives(self.jacobian(qv, frame))

    def jacobian_dot(
        self, q: Any, qd: Any, frame: str | None = None, reference: Reference = "world"
    ) -> FloatArray:
        """Time derivative of :meth:`jacobian` along the joint velocity ``qd``, ``(6, n)``.

        With it the classical acceleration of the frame origin is ``J qdd + J̇ qd``.
        """
        fid = self.frame_id(frame)
        rf = self._reference(reference)
        pin.computeJointJacobiansTimeVariation(self.model, self.data, self._q(q), self._qd(qd))
        pin.updateFramePlacement(self.model, self.data, fid)
        dJ = pin.getFrameJacobianTimeVariation(self.model, self.data, fid, rf)
        return np.asarray(dJ).reshape(6, self.n)

    # ------------------------------------------------------------------ dynamics
    def mass_matrix(self, q: Any) -> FloatArray:
        """Joint-space inertia matrix M(q), shape ``(n, n)``, symmetric positive definite.

        Includes the rotor armature on its diagonal.
        """
        M = np.array(pin.crba(self.model, self.data, self._q(q)))  # upper triangle filled
        lower = self._lower
        M[lower] = M.T[lower]
        return M

    def bias(self, q: Any, qd: Any) -> FloatArray:
        """Coriolis, centrifugal and gravity torques C(q, qd) qd + g(q), shape ``(n,)``."""
        return np.array(pin.nonLinearEffects(self.model, self.data, self._q(q), self._qd(qd)))

    def gravity(self, q: Any) -> FloatArray:
        """Gravity torques g(q), shape ``(n,)``, N·m (gravity -9.81 m/s² along world z)."""
        return np.array(pin.computeGeneralizedGravity(self.model, self.data, self._q(q)))

    def inverse_dynamics(self, q: Any, qd: Any, qdd: Any) -> FloatArray:
        """Torques ``M(q) qdd + C(q, qd) qd + g(q)`` by RNEA, shape ``(n,)``."""
        qdd_v = as_vector(qdd, "qdd", self.n)
        return np.array(pin.rnea(self.model, self.data, self._q(q), self._qd(qd), qdd_v))

    def forward_dynamics(self, q: Any, qd: Any, tau: Any) -> FloatArray:
        """Joint accelerations ``M⁻¹(tau - C qd - g)`` by ABA, shape ``(n,)``."""
        tau_v = as_vector(tau, "tau", self.n)
        return np.array(pin.aba(self.model, self.data, self._q(q), self._qd(qd), tau_v))

    # ------------------------------------------------------------------ internals
    def _q(self, q: Any) -> FloatArray:
        return as_vector(q, "q", self.n)

    def _qd(self, qd: Any) -> FloatArray:
        return as_vector(qd, "qd", self.n)

    @staticmethod
    def _reference(reference: str) -> Any:
        try:
            return _REFERENCE[reference]
        except KeyError:
            raise InvalidParameterError(
                f"reference must be 'world' or 'local'; got {reference!r}"
            ) from None

    def _refresh_frames(self) -> None:
        ids: dict[str, int] = {}
        for i, f in enumerate(self.model.frames):
            if i == 0 or f.name in ids:  # skip 'universe'; first definition wins
                continue
            ids[str(f.name)] = i
        self._frame_ids = ids

    def _check_within_limits(self, q: FloatArray, name: str) -> None:
        outside = np.flatnonzero((q < self._q_min) | (q > self._q_max))
        if outside.size:
            j = int(outside[0])
            raise JointLimitError(
                f"{name}[{j}] = {q[j]} is outside the limits of joint "
                f"{self.joint_names[j]!r}: [{self._q_min[j]}, {self._q_max[j]}]"
            )


def _limit_vector(value: Any, n: int, name: str) -> FloatArray:
    """Acceleration or jerk limits ``name``: positive numbers, ``inf`` (unknown) allowed and
    the default."""
    if value is None:
        return np.full(n, np.inf)
    arr = np.array(real_array(value, name), dtype=float)
    if arr.shape != (n,):
        raise ShapeError(f"{name} must have shape ({n},); got shape {arr.shape}")
    if np.isnan(arr).any() or np.any(arr <= 0):
        raise InvalidParameterError(f"{name} must be positive (inf: unknown); got {arr}")
    return arr
