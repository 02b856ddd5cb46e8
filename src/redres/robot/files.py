"""Robots from the files users bring, and robots derived from others (a mixin of
:class:`~redres.robot.Robot`, kept here so that ``robot.py`` stays the kinematics).

- :meth:`RobotFiles.from_urdf`, :meth:`~RobotFiles.from_urdf_string` and
  :meth:`~RobotFiles.from_mjcf` load a description through Pinocchio's parsers, keep the
  base-to-tip chain (:mod:`redres.robot.urdf`), fit link capsules to the collision
  geometry (:mod:`redres.robot.fitting`) so that obstacle objectives work on the robot,
  and keep its visual meshes for the report and the viewer (:mod:`redres.robot.meshes`).
- The neutral pose of a file robot is the file's reference configuration when it names
  one (an MJCF keyframe ``home``), else the middle of each joint's range (zero for a joint
  without finite limits): zero clipped into the limits is, for many arms, a stretched
  singular pose on a limit.
- :meth:`~RobotFiles.with_limits` gives the same robot under tighter velocity,
  acceleration or torque limits than its file says; every scheme and controller reads
  the limits from the robot, so they all honour them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np
import pinocchio as pin

from .._validate import (
    FloatArray,
    as_scalar,
    checked_keywords,
    real_array,
    short_repr,
    unknown_keyword,
)
from ..errors import InvalidParameterError, ShapeError

if TYPE_CHECKING:
    from typing import Self, Unpack  # Python 3.11; only read by type checkers

    from .meshes import LinkMesh

from .urdf import ModelSource

_PI = float(np.pi)


class LoadOptions(TypedDict, total=False):
    """Keyword options of the file loaders :meth:`Robot.from_urdf`,
    :meth:`Robot.from_urdf_string` and :meth:`Robot.from_mjcf`.

    Attributes:
        locked: positions of the joints off the base-to-tip chain, joint name -> rad or m
            (default: zero clipped into their limits).
        name: robot name (default: the file's robot name).
        continuous_limits: position limits given to continuous joints, rad (default
            ``(-π, π)``).
        capsules: fit link capsules to the collision geometry (default True; False skips
            reading the collision meshes, 0.5–1 s for a real URDF).
    """

    locked: Mapping[str, float] | None
    name: str | None
    continuous_limits: tuple[float, float]
    capsules: bool


def file_neutral(model: pin.Model, reference: np.ndarray | None) -> FloatArray:
    """The neutral pose of a file robot (module docstring)."""
    lo = np.array(model.lowerPositionLimit, dtype=float)
    hi = np.array(model.upperPositionLimit, dtype=float)
    if reference is not None and reference.shape == lo.shape:
        if np.all((reference >= lo) & (reference <= hi)):
            return reference.copy()
    finite = np.isfinite(lo) & np.isfinite(hi)
    return np.where(finite, 0.5 * (lo + hi), np.clip(0.0, lo, hi))


def _positive_limits(value: Any, n: int, name: str, current: FloatArray) -> FloatArray:
    arr = real_array(value, name, "a number or a vector").copy()
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ShapeError(f"{name} must be a number or have shape ({n},); got shape {arr.shape}")
    if np.isnan(arr).any() or np.any(arr <= 0):
        raise InvalidParameterError(f"{name} must be positive (inf: unknown); got {arr}")
    if np.any(arr > current):
        j = int(np.argmax(arr - current))
        raise InvalidParameterError(
            f"{name}[{j}] = {arr[j]:g} exceeds the robot's own limit {current[j]:g}; "
            "with_limits tightens limits, it cannot raise them"
        )
    return arr


def _checked_options(
    tip: Any, options: LoadOptions
) -> tuple[str | None, dict[str, float] | None, str | None, tuple[float, float], bool]:
    """The loaders' ``tip`` and :class:`LoadOptions`, each checked by name."""
    if tip is not None and not isinstance(tip, str):
        raise InvalidParameterError(f"tip must be a frame name (a string); got {short_repr(tip)}")
    name = options.get("name")
    if name is not None and not isinstance(name, str):
        raise InvalidParameterError(f"name must be a string; got {short_repr(name)}")
    locked = options.get("locked")
    if locked is not None:
        if not isinstance(locked, Mapping) or not all(isinstance(k, str) for k in locked):
            raise InvalidParameterError(
                f"locked must map joint names to positions, e.g. {{'finger_joint1': 0.0}}; "
                f"got {short_repr(locked)}"
            )
        locked = {k: as_scalar(v, f"locked[{k!r}]") for k, v in locked.items()}
    limits = options.get("continuous_limits", (-_PI, _PI))
    pair = real_array(limits, "continuous_limits", "a pair (low, high)")
    if pair.shape != (2,) or not np.isfinite(pair).all() or not pair[0] < pair[1]:
        raise InvalidParameterError(
            "continuous_limits must be two finite numbers low < high, rad; got "
            f"{short_repr(limits)}"
        )
    capsules = options.get("capsules", True)
    if not isinstance(capsules, (bool, np.bool_)):
        raise InvalidParameterError(f"capsules must be True or False; got {short_repr(capsules)}")
    return tip, locked, name, (float(pair[0]), float(pair[1])), bool(capsules)


@dataclass(frozen=True)
class _VisualSource:
    """Where a file robot's visual meshes are read from when first asked for."""

    source: ModelSource
    tip: str
    locked: Mapping[str, float] | None
    continuous_limits: tuple[float, float]


class RobotFiles:
    """Loaders and derived robots for :class:`~redres.robot.Robot` (module docstring)."""

    @property
    def visuals(self) -> tuple[LinkMesh, ...]:
        """Visual meshes of a file robot, in its links' frames (empty for the built-ins):
        read from the file on first use (the report and the viewer ask), then kept."""
        state = self.__dict__
        found = state.get("_visuals")
        if found is None:
            where: _VisualSource | None = state.get("_visual_source")
            found = () if where is None else _read_visuals(where)
            state["_visuals"] = found
        return found  # type: ignore[no-any-return]

    @visuals.setter
    def visuals(self, value: Sequence[LinkMesh]) -> None:
        self.__dict__["_visuals"] = tuple(value)

    @classmethod
    def _load(cls, source: ModelSource, tip: str | None, options: LoadOptions, loader: str) -> Self:
        from . import fitting
        from .urdf import load_model

        unknown = set(options) - set(LoadOptions.__annotations__)
        if unknown:
            names = ["tip", *LoadOptions.__annotations__]
            if loader == "from_urdf_string":
                names.insert(1, "mesh_dir")
            raise unknown_keyword(f"Robot.{loader}", names, dict(options))
        tip, locked, name, continuous_limits, capsules = _checked_options(tip, options)
        geometry = ("collision",) if capsules else ()
        loaded = load_model(source, tip, locked, continuous_limits, geometry=geometry)
        model = loaded.model
        home = file_neutral(model, loaded.reference)
        robot: Any = cls(model, tip=loaded.tip, name=name or str(model.name), home=home)  # type: ignore[call-arg]
        if capsules and loaded.collision is not None:
            robot.capsules = fitting.link_capsules(model, loaded.collision)
        robot.__dict__["_visual_source"] = _VisualSource(
            source, loaded.tip, locked, continuous_limits
        )
        return robot

    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        tip: str | None = None,
        **options: Unpack[LoadOptions],
    ) -> Self:
        """Load a robot from a URDF file, keeping only the base-to-``tip`` chain.

        Joints off that chain (gripper fingers, a second arm) are locked at the value given
        in ``locked`` (joint name -> position), else at zero clipped into their limits.
        Continuous joints become revolute joints limited to ``continuous_limits``.
        Link capsules are fitted to the collision geometry (``robot.capsules``), visual
        meshes kept (``robot.visuals``); a mesh that cannot be read leaves them out.

        Args:
            path: URDF file (XML text: :meth:`from_urdf_string`).
            tip: frame (link) name at the end of the chain; may be omitted when the URDF
                is an unbranched chain, links fixed after the last joint included (a hand
                with fixed fingers branches: give the tip).
            options: ``locked``, ``name``, ``continuous_limits``, ``capsules``
                (:class:`LoadOptions`).

        Raises:
            ModelFileNotFoundError: the file does not exist.
            URDFError: the file cannot be parsed, or ``tip`` is missing or ambiguous.
        """
        from .urdf import urdf_source

        return cls._load(urdf_source(path), tip, options, "from_urdf")

    @classmethod
    def from_urdf_string(
        cls,
        xml: str,
        tip: str | None = None,
        *,
        mesh_dir: str | Path | None = None,
        **options: Unpack[LoadOptions],
    ) -> Self:
        """:meth:`from_urdf` on URDF text (e.g. the output of xacro or a ROS parameter).

        Args:
            xml: the URDF document.
            mesh_dir: where relative mesh paths (and ``package://`` roots) are found
                (default: the current folder).
            tip, options: as for :meth:`from_urdf`.
        """
        if not isinstance(xml, str):
            raise InvalidParameterError(f"xml must be a str; got {type(xml).__name__}")
        source = ModelSource("<URDF string>", "urdf", text=xml)
        if mesh_dir is not None:
            source.mesh_dir = Path(mesh_dir)
        return cls._load(source, tip, options, "from_urdf_string")

    @classmethod
    def from_mjcf(
        cls,
        path: str | Path,
        tip: str | None = None,
        **options: Unpack[LoadOptions],
    ) -> Self:
        """Load a robot from an MJCF file (MuJoCo's format; the MuJoCo Menagerie's models)
        through Pinocchio's MJCF parser, with the tip and locking rules of
        :meth:`from_urdf`. A keyframe named ``home`` becomes :meth:`neutral`.

        Torque limits are read as MuJoCo reads them: each joint's actuators' ``forcerange``
        times their ``gear``, capped by the joint's ``actuatorfrcrange``, through default
        classes (:mod:`redres.robot.mjcf`); a hinge without a range gets
        ``continuous_limits``. MJCF has no joint velocity limits: ``qd_max`` is ``inf``
        until set with :meth:`with_limits` (or ``qd_max =`` in a scenario's or sweep's
        ``[robot]``).

        Raises:
            ModelFileNotFoundError: the file does not exist.
            MJCFError: the file cannot be parsed (a malformed number is named by element and
                attribute), or ``tip`` is missing or ambiguous.
        """
        from .urdf import mjcf_source

        return cls._load(mjcf_source(path), tip, options, "from_mjcf")

    @checked_keywords
    def with_limits(
        self,
        *,
        qd_max: float | Sequence[float] | FloatArray | None = None,
        qdd_max: float | Sequence[float] | FloatArray | None = None,
        qddd_max: float | Sequence[float] | FloatArray | None = None,
        tau_max: float | Sequence[float] | FloatArray | None = None,
        name: str | None = None,
    ) -> Self:
        """The same robot under tighter limits: a new :class:`Robot` (this one is
        unchanged) whose ``qd_max``, ``qdd_max``, ``qddd_max`` or ``tau_max`` are the
        given values (a number for every joint, or shape ``(n,)``; rad/s, rad/s², rad/s³,
        N·m). Every scheme, :class:`~redres.control.Controller` path, command shaper and
        :func:`~redres.run` reads them.

        Raises:
            InvalidParameterError: a value that is not positive, or above the robot's own
                limit (this tightens limits; a model with a wrong limit is fixed in its
                file).
            ShapeError: a vector of the wrong length.
        """
        robot: Any = self  # a Robot: this class is its mixin (robot.py imports this module)
        n = robot.n
        model = pin.Model(robot.model)
        if qd_max is not None:
            vel = _positive_limits(qd_max, n, "qd_max", robot.qd_max)
            model.upperVelocityLimit, model.lowerVelocityLimit = vel, -vel
        if tau_max is not None:
            tau = _positive_limits(tau_max, n, "tau_max", robot.tau_max)
            model.upperEffortLimit, model.lowerEffortLimit = tau, -tau
        rates = {"qdd_max": qdd_max, "qddd_max": qddd_max}
        changed = {k: _positive_limits(v, n, k, getattr(robot, k)) for k, v in rates.items()
                   if v is not None}  # fmt: skip
        return self.derived(model, name=name or robot.name, **changed)

    def derived(self, model: Any = None, **changes: Any) -> Self:
        """This robot built again (``model``: a changed copy of its Pinocchio model, same
        joints), with ``changes`` to the constructor's keywords (``tip``, ``name``,
        ``home``, ``qdd_max``, ``qddd_max``); its capsules and meshes are kept. What
        :meth:`with_limits` and :func:`redres.dynamics.with_payload` build on."""
        robot: Any = self
        keep = {"tip": robot.tip, "name": robot.name, "home": robot.neutral(),
                "qdd_max": robot.qdd_max, "qddd_max": robot.qddd_max}  # fmt: skip
        out: Any = type(robot)(robot.model if model is None else model, **(keep | changes))
        out.capsules = list(robot.capsules)
        for key in ("_visual_source", "_visuals"):  # the same meshes, read once
            if key in robot.__dict__:
                out.__dict__[key] = robot.__dict__[key]
        return out  # type: ignore[no-any-return]


def _read_visuals(where: _VisualSource) -> tuple[LinkMesh, ...]:
    from .meshes import link_meshes
    from .urdf import load_model

    loaded = load_model(where.source, where.tip, where.locked, where.continuous_limits,
                        geometry=("visual",))  # fmt: skip
    return () if loaded.visual is None else link_meshes(loaded.model, loaded.visual)
