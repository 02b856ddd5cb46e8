"""The robot of a sweep, as workers receive it: a built-in model name, a MuJoCo Menagerie
arm's name, or the text of a URDF or MJCF file, with the limits the spec sets.

Workers (other processes, other machines) rebuild the :class:`~redres.robot.Robot` from
this description and keep it for the process (:meth:`RobotSource.build`), so a job
carries a few kilobytes instead of a pickled model, and each worker owns its data.
:meth:`RobotSource.identity` is what the manifest records: the built-in or Menagerie
name or the file's SHA-256, the limits the spec sets, and a digest of the kinematic
model the solver sees (the joint placements, axes and limits of the chain), so that a
sweep never resumes on a robot that differs from the one it began with.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ModelFileError

if TYPE_CHECKING:
    from .._toml import Reader
    from ..robot import Robot

__all__ = ["RobotSource", "model_digest"]

_BUILT: dict[RobotSource, Robot] = {}  # per process: the robot of each source


@dataclass(frozen=True)
class RobotSource:
    """A robot to rebuild in a worker.

    Attributes:
        model: a built-in name (:func:`redres.models.names`), or None.
        menagerie: a MuJoCo Menagerie arm (:func:`redres.models.menagerie`), or None.
        urdf: the URDF text, or None.
        mjcf: the MJCF text, or None (exactly one of the four is given). A file's meshes
            stay behind: a sweep's file robot has its kinematics, limits and inertias.
        tip: the chain's tip frame of a file or Menagerie robot (None: its only end).
        frame: the frame the sweep places (None: the robot's tip).
        label: how people name it (the model name or the file name).
        limits: the limits the spec sets (``qd_max``, ...; :data:`redres._toml.LIMIT_KEYS`),
            as ``(key, values)`` pairs for :meth:`redres.Robot.with_limits`.
    """

    model: str | None = None
    urdf: str | None = None
    tip: str | None = None
    frame: str | None = None
    label: str = ""
    mjcf: str | None = None
    menagerie: str | None = None
    limits: tuple[tuple[str, tuple[float, ...]], ...] = ()

    @classmethod
    def from_table(cls, r: Reader, base: Path) -> RobotSource:
        """The ``[robot]`` table of a spec: ``model = "panda"``, ``menagerie = "fr3"``,
        ``urdf = "arm.urdf"`` or ``mjcf = "arm.xml"`` (a path relative to the spec's
        folder) with ``tip``; optional ``frame`` and limits (``qd_max = 2.0``, ...)."""
        from .. import models

        key, value = r.robot_source()
        tip, frame = r.get("tip", "string", None), r.get("frame", "string", None)
        if key == "model":
            if value not in models.names():
                raise r.fail("model", f"unknown robot {value!r}; built-in robots: "
                             f"{', '.join(models.names())}")  # fmt: skip
            if tip is not None:
                raise r.fail("tip", "tip applies to a file robot; use frame = ... for a built-in")
            source = cls(model=value, frame=frame, label=value)
        elif key == "menagerie":
            source = cls(menagerie=value, tip=tip, frame=frame, label=value)
        else:
            text = r.file_text(key, base / value)
            source = cls(urdf=text if key == "urdf" else None, mjcf=text if key == "mjcf" else None,
                         tip=tip, frame=frame, label=Path(value).name)  # fmt: skip
        with r.blame(key):
            robot = source.build()
        limits = r.joint_limits(robot.n)
        r.done()
        if limits:
            pairs = tuple((k, tuple(float(x) for x in v)) for k, v in limits.items())
            source = dataclasses.replace(source, limits=pairs)
            with r.blame(None):  # the message names the limit
                robot = source.build()
        with r.blame("frame" if frame else key):
            robot.frame_id(frame)
            robot.chain(frame)  # a sweep needs the compiled serial-chain kinematics
        return source

    def build(self) -> Robot:
        """The robot, built once per process (file text through a temporary file, parsed
        without executing anything: :meth:`redres.Robot.from_urdf`,
        :meth:`~redres.Robot.from_mjcf`), under the spec's limits."""
        found = _BUILT.get(self)
        if found is not None:
            return found
        from .. import models
        from ..robot import Robot

        if self.model is not None:
            robot = models.load(self.model)
        elif self.menagerie is not None:
            robot = models.menagerie(self.menagerie, tip=self.tip)
        else:
            text, suffix = (self.urdf, ".urdf") if self.urdf is not None else (self.mjcf, ".xml")
            assert text is not None
            load = Robot.from_urdf if self.urdf is not None else Robot.from_mjcf
            handle, name = tempfile.mkstemp(suffix=suffix, prefix="redres-sweep-")
            try:
                with os.fdopen(handle, "w", encoding="utf-8") as f:
                    f.write(text)
                robot = load(name, tip=self.tip, name=Path(self.label).stem)
            except ModelFileError as exc:  # named after the user's file, not the copy
                raise type(exc)(str(exc).replace(name, self.label)) from None
            finally:
                os.unlink(name)
        if self.limits:
            limits: dict[str, Any] = {k: np.array(v) for k, v in self.limits}
            robot = robot.with_limits(**limits)
        _BUILT[self] = robot
        return robot

    def identity(self) -> dict[str, Any]:
        """What the manifest records of the robot (module docstring)."""
        out: dict[str, Any] = {"label": self.label, "frame": self.frame}
        if self.model is not None:
            out["model"] = self.model
        elif self.menagerie is not None:
            out["menagerie"] = self.menagerie
            out["tip"] = self.tip
        else:
            key = "urdf" if self.urdf is not None else "mjcf"
            text = self.urdf if self.urdf is not None else self.mjcf
            assert text is not None
            out[f"{key}_sha256"] = hashlib.sha256(text.encode()).hexdigest()
            out["tip"] = self.tip
        if self.limits:
            out["limits"] = {k: list(v) for k, v in self.limits}
        out["model_sha256"] = model_digest(self.build(), self.frame)
        return out


def model_digest(robot: Robot, frame: str | None = None) -> str:
    """SHA-256 of what the compiled solver sees of ``robot`` up to ``frame``: the chain's
    placements, axes and joint kinds, and the joint limits."""
    digest = hashlib.sha256()
    for array in (*robot.chain(frame).arrays, robot.q_min, robot.q_max):
        a = np.ascontiguousarray(array)
        digest.update(f"{a.dtype.str}{a.shape}".encode())
        digest.update(a.tobytes())
    return digest.hexdigest()
