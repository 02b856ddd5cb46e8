"""The robot of a sweep, as workers receive it: a built-in model name or URDF text.

Workers (other processes, other machines) rebuild the :class:`~redres.robot.Robot` from
this description and keep it for the process (:meth:`RobotSource.build`), so a job
carries a few kilobytes instead of a pickled model, and each worker owns its data.
:meth:`RobotSource.identity` is what the manifest records: the built-in name or the
URDF's SHA-256, and a digest of the kinematic model the solver sees (the joint
placements, axes and limits of the chain), so that a sweep never resumes on a robot
that differs from the one it began with.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import describe_os_error, shown_path

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
        urdf: the URDF text, or None (exactly one of ``model`` and ``urdf``).
        tip: the chain's tip frame of a URDF (None: its only end).
        frame: the frame the sweep places (None: the robot's tip).
        label: how people name it (the model name or the URDF file name).
    """

    model: str | None = None
    urdf: str | None = None
    tip: str | None = None
    frame: str | None = None
    label: str = ""

    @classmethod
    def from_table(cls, r: Reader, base: Path) -> RobotSource:
        """The ``[robot]`` table of a spec: ``model = "panda"`` or ``urdf = "arm.urdf"``
        (relative to the spec's folder) with ``tip``; optional ``frame``."""
        from .. import models

        model = r.get("model", "string", None)
        path = r.get("urdf", "string", None)
        tip, frame = r.get("tip", "string", None), r.get("frame", "string", None)
        r.done()
        if (model is None) == (path is None):
            raise r.fail(
                "model", 'give exactly one of model = "<built-in name>" or urdf = "<path>"'
            )
        if model is not None:
            if model not in models.names():
                raise r.fail("model", f"unknown robot {model!r}; built-in robots: "
                             f"{', '.join(models.names())}")  # fmt: skip
            if tip is not None:
                raise r.fail("tip", "tip applies to a urdf; use frame = ... for a built-in")
            source = cls(model=model, frame=frame, label=model)
        else:
            file = base / path
            try:
                text = file.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                why = describe_os_error(exc) if isinstance(exc, OSError) else "not UTF-8 text"
                raise r.fail("urdf", f"cannot read {shown_path(file)}: {why}") from None
            source = cls(urdf=text, tip=tip, frame=frame, label=file.name)
        with r.blame("frame" if frame else ("model" if model else "urdf")):
            robot = source.build()
            robot.frame_id(frame)
            robot.chain(frame)  # a sweep needs the compiled serial-chain kinematics
        return source

    def build(self) -> Robot:
        """The robot, built once per process (URDF text through a temporary file, parsed
        without executing anything: :meth:`redres.Robot.from_urdf`)."""
        found = _BUILT.get(self)
        if found is not None:
            return found
        from .. import models
        from ..robot import Robot

        if self.model is not None:
            robot = models.load(self.model)
        else:
            assert self.urdf is not None
            handle, name = tempfile.mkstemp(suffix=".urdf", prefix="redres-sweep-")
            try:
                with os.fdopen(handle, "w", encoding="utf-8") as f:
                    f.write(self.urdf)
                robot = Robot.from_urdf(name, tip=self.tip, name=Path(self.label).stem)
            finally:
                os.unlink(name)
        _BUILT[self] = robot
        return robot

    def identity(self) -> dict[str, Any]:
        """What the manifest records of the robot (module docstring)."""
        out: dict[str, Any] = {"label": self.label, "frame": self.frame}
        if self.model is not None:
            out["model"] = self.model
        else:
            assert self.urdf is not None
            out["urdf_sha256"] = hashlib.sha256(self.urdf.encode()).hexdigest()
            out["tip"] = self.tip
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
