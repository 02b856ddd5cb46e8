"""Denavit–Hartenberg records and their translation into a Pinocchio model.

Standard (distal) convention, joint ``i`` moving about ``z_{i-1}``::

    T_{i-1,i} = Rz(θ_i + q_i) Tz(d_i) Tx(a_i) Rx(α_i)          (revolute)
    T_{i-1,i} = Rz(θ_i) Tz(d_i + q_i) Tx(a_i) Rx(α_i)          (prismatic)

Modified (proximal, Craig 1989) convention, joint ``i`` moving about ``z_i``; the record of
joint ``i`` carries ``a_{i-1}`` and ``α_{i-1}``::

    T_{i-1,i} = Rx(α_{i-1}) Tx(a_{i-1}) Rz(θ_i + q_i) Tz(d_i)   (revolute)

Pinocchio needs each joint's frame to carry the joint axis as its z axis. In the modified
convention the DH frame ``i`` is that frame. In the standard convention the joint frame of
joint ``i`` is DH frame ``i-1`` turned by ``q_i``, and DH frame ``i`` hangs on joint ``i`` at
``Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i)`` (Rz(q) commutes with Rz(θ) and Tz(d)).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any, Literal

import numpy as np
import pinocchio as pin

from .._validate import MAX_LENGTH, MAX_MASS, FloatArray, as_transform
from ..errors import DHParameterError, JointLimitError, NotPositiveDefiniteError

JointType = Literal["revolute", "prismatic"]

#: The longest chain redres builds (docs/models.md): real arms have up to a dozen joints,
#: while Pinocchio's memory and build time grow steeply with the joint count (500 joints:
#: 4.2 GB and 15 s), so a longer chain is refused before it is built.
MAX_JOINTS = 100


@dataclass(frozen=True)
class DHLink:
    """One joint and the link it moves, in Denavit–Hartenberg form.

    Attributes:
        a: link length, m (``a_i`` standard; ``a_{i-1}`` modified).
        alpha: link twist, rad (``α_i`` standard; ``α_{i-1}`` modified).
        d: link offset, m (for a prismatic joint: the offset at ``q = 0``).
        theta: joint angle offset, rad (for a revolute joint: the angle at ``q = 0``).
        joint: ``"revolute"`` or ``"prismatic"``.
        q_min, q_max: position limits, rad or m (default ±π for revolute joints, ±inf,
            unbounded, for prismatic ones; ``±inf`` may be given for either).
        qd_max: velocity limit, rad/s or m/s (default: unknown, ``inf``).
        qdd_max: acceleration limit, rad/s² or m/s² (default ``inf``).
        qddd_max: jerk limit, rad/s³ or m/s³ (default ``inf``).
        tau_max: torque or force limit, N·m or N (default ``inf``).
        mass: link mass, kg (default 0: a massless link).
        com: centre of mass in the link's DH frame, m, 3 values.
        inertia: 3x3 inertia about the centre of mass, axes of the link's DH frame, kg·m².
        armature: reflected rotor inertia, kg·m², added to the mass-matrix diagonal.
        name: joint name (default ``joint<i>``).
    """

    a: float
    alpha: float
    d: float
    theta: float = 0.0
    joint: JointType = "revolute"
    q_min: float | None = None
    q_max: float | None = None
    qd_max: float | None = None
    qdd_max: float | None = None
    qddd_max: float | None = None
    tau_max: float | None = None
    mass: float = 0.0
    com: tuple[float, float, float] | Sequence[float] | None = None
    inertia: Sequence[Sequence[float]] | FloatArray | None = None
    armature: float = 0.0
    name: str | None = None

    @classmethod
    def from_record(cls, record: DHLink | Mapping[str, Any], index: int = 0) -> DHLink:
        """Validate a record (a :class:`DHLink` or a dict with its keys) into a DHLink."""
        if isinstance(record, DHLink):
            rec: dict[str, Any] = {f.name: getattr(record, f.name) for f in fields(cls)}
        elif isinstance(record, Mapping):
            rec = dict(record)
        else:
            raise DHParameterError(
                f"DH record {index} must be a DHLink or a dict; got {type(record).__name__}"
            )
        valid = [f.name for f in fields(cls)]
        unknown = sorted(set(rec) - set(valid))
        if unknown:
            raise DHParameterError(
                f"DH record {index}: unknown key(s) {unknown}; valid keys: {', '.join(valid)}"
            )
        missing = [k for k in ("a", "alpha", "d") if k not in rec]
        if missing:
            raise DHParameterError(f"DH record {index}: missing required key(s) {missing}")
        joint = rec.get("joint", "revolute")
        if joint not in ("revolute", "prismatic"):
            raise DHParameterError(
                f"DH record {index}: joint must be 'revolute' or 'prismatic'; got {joint!r}"
            )
        for key in ("a", "alpha", "d", "theta", "mass", "armature"):
            if key in rec:
                rec[key] = _finite(rec[key], index, key)
        for key, bound in (("a", MAX_LENGTH), ("d", MAX_LENGTH), ("mass", MAX_MASS)):
            if abs(rec.get(key, 0.0)) > bound:
                raise DHParameterError(
                    f"DH record {index}: |{key}| must be <= {bound:g} (SI units); got {rec[key]}"
                )
        for key in ("q_min", "q_max", "qd_max", "qdd_max", "qddd_max", "tau_max"):
            if rec.get(key) is not None:
                rec[key] = _number(rec[key], index, key)
        if rec.get("name") is not None and not isinstance(rec["name"], str):
            raise DHParameterError(f"DH record {index}: name must be a string; got {rec['name']!r}")
        if rec.get("mass", 0.0) < 0.0 or rec.get("armature", 0.0) < 0.0:
            raise DHParameterError(f"DH record {index}: mass and armature must be >= 0")
        for key in ("qd_max", "qdd_max", "qddd_max", "tau_max"):
            if rec.get(key) is not None and not rec[key] > 0.0:
                raise DHParameterError(
                    f"DH record {index}: {key} must be > 0 (leave it out, or inf, for no "
                    f"limit); got {rec[key]}"
                )
        return cls(**rec)

    def limits(self, index: int) -> tuple[float, float]:
        """Position limits with defaults applied (±π revolute, ±inf prismatic); checks
        ``q_min <= q_max``."""
        default = math.pi if self.joint == "revolute" else math.inf
        lo = -default if self.q_min is None else self.q_min
        hi = default if self.q_max is None else self.q_max
        if lo > hi:
            raise JointLimitError(f"DH record {index}: q_min = {lo} > q_max = {hi}")
        return lo, hi

    def spatial_inertia(self, index: int) -> pin.Inertia:
        """The link's spatial inertia in its DH frame."""
        try:
            com = np.zeros(3) if self.com is None else np.asarray(self.com, dtype=float)
            inertia = np.zeros((3, 3)) if self.inertia is None else np.asarray(self.inertia, float)
        except (TypeError, ValueError, OverflowError) as exc:
            raise DHParameterError(
                f"DH record {index}: com and inertia must be numbers ({exc})"
            ) from None
        if com.shape != (3,) or not np.isfinite(com).all() or np.abs(com).max() > MAX_LENGTH:
            raise DHParameterError(
                f"DH record {index}: com must be 3 finite numbers within ±{MAX_LENGTH:g} m; "
                f"got {com}"
            )
        if inertia.shape != (3, 3) or not np.isfinite(inertia).all():
            raise DHParameterError(
                f"DH record {index}: inertia must be a finite 3x3 matrix; got shape {inertia.shape}"
            )
        if not np.allclose(inertia, inertia.T, atol=1e-12):
            raise NotPositiveDefiniteError(f"DH record {index}: inertia is not symmetric")
        if np.linalg.eigvalsh(inertia).min() < -1e-12:
            raise NotPositiveDefiniteError(
                f"DH record {index}: inertia is not positive semi-definite"
            )
        return pin.Inertia(float(self.mass), com, inertia)


def _finite(value: Any, index: int, key: str) -> float:
    x = _number(value, index, key)
    if not math.isfinite(x):
        raise DHParameterError(f"DH record {index}: {key} must be finite; got {x}")
    return x


def _number(value: Any, index: int, key: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise DHParameterError(
            f"DH record {index}: {key} must be a number; got {value!r}"
        ) from None
    if math.isnan(x):
        raise DHParameterError(f"DH record {index}: {key} is NaN")
    return x


def _se3(T: FloatArray) -> pin.SE3:
    return pin.SE3(np.array(T[:3, :3]), np.array(T[:3, 3]))


def _rot_x(angle: float) -> pin.SE3:
    return pin.SE3(pin.utils.rotate("x", angle), np.zeros(3))


def _rot_z(angle: float) -> pin.SE3:
    return pin.SE3(pin.utils.rotate("z", angle), np.zeros(3))


def _trans(x: float, y: float, z: float) -> pin.SE3:
    return pin.SE3(np.eye(3), np.array([x, y, z]))


def build_dh_model(
    links: Sequence[DHLink | Mapping[str, Any]],
    convention: str,
    base: Any,
    tool: Any,
    name: str,
    tool_name: str = "tool",
) -> tuple[pin.Model, FloatArray]:
    """Pinocchio model and the acceleration and jerk limits, ``(2, n)``, of a DH chain (see
    module docstring)."""
    if convention not in ("standard", "modified"):
        raise DHParameterError(f"convention must be 'standard' or 'modified'; got {convention!r}")
    if isinstance(links, (str, bytes)) or not isinstance(links, Sequence) or len(links) == 0:
        raise DHParameterError("links must be a non-empty sequence of DH records")
    if len(links) > MAX_JOINTS:
        raise DHParameterError(
            f"{len(links)} DH records; redres models chains of at most {MAX_JOINTS} joints "
            "(docs/models.md)"
        )
    records = [DHLink.from_record(rec, i) for i, rec in enumerate(links)]
    names = [link.name or f"joint{i + 1}" for i, link in enumerate(records)]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise DHParameterError(f"joint names must be unique; repeated: {', '.join(repeated)}")
    T_base = _se3(as_transform(np.eye(4) if base is None else base, "base"))
    T_tool = _se3(as_transform(np.eye(4) if tool is None else tool, "tool"))

    model = pin.Model()
    model.name = name
    model.addFrame(pin.Frame("base", 0, 0, T_base, pin.FrameType.OP_FRAME))
    parent_joint = 0
    placement = T_base  # pose of the next joint frame in the parent joint frame
    last_frame = 0
    for i, link in enumerate(records):
        lo, hi = link.limits(i)
        if convention == "standard":
            link_in_joint = _rot_z(link.theta) * _trans(0, 0, link.d)
            link_in_joint = link_in_joint * _trans(link.a, 0, 0) * _rot_x(link.alpha)
            joint_in_parent = placement
        else:
            joint_in_parent = placement * _rot_x(link.alpha) * _trans(link.a, 0, 0)
            joint_in_parent = joint_in_parent * _rot_z(link.theta) * _trans(0, 0, link.d)
            link_in_joint = pin.SE3.Identity()
        jmodel = pin.JointModelRZ() if link.joint == "revolute" else pin.JointModelPZ()
        jid = model.addJoint(
            parent_joint,
            jmodel,
            joint_in_parent,
            link.name or f"joint{i + 1}",
            np.array([np.inf if link.tau_max is None else link.tau_max]),
            np.array([np.inf if link.qd_max is None else link.qd_max]),
            np.array([lo]),
            np.array([hi]),
        )
        model.appendBodyToJoint(jid, link.spatial_inertia(i), link_in_joint)
        last_frame = model.addFrame(
            pin.Frame(f"link{i + 1}", jid, last_frame, link_in_joint, pin.FrameType.BODY)
        )
        parent_joint = jid
        placement = link_in_joint
    model.armature = np.array([rec.armature for rec in records])
    model.addFrame(
        pin.Frame(tool_name, parent_joint, last_frame, placement * T_tool, pin.FrameType.OP_FRAME)
    )
    rates = [[np.inf if x is None else x for x in (r.qdd_max, r.qddd_max)] for r in records]
    return model, np.array(rates).T
