"""Frames (internal): the one place operational frames are added to a Pinocchio model,
and the axes a Jacobian is expressed in (:data:`Reference`)."""

from __future__ import annotations

from typing import Any, Literal

import pinocchio as pin

from .._validate import as_transform
from ..errors import FrameNotFoundError, InvalidParameterError

#: A Jacobian's axes: world-aligned (``"world"``, Pinocchio's LOCAL_WORLD_ALIGNED) or the
#: frame's own (``"local"``).
Reference = Literal["world", "local"]


def add_frame(model: pin.Model, name: str, parent: str, T_parent_frame: Any) -> int:
    """Add an operational frame to a Pinocchio model; returns its index."""
    if not isinstance(name, str) or not isinstance(parent, str):
        raise InvalidParameterError(f"frame names are strings; got {name!r} on {parent!r}")
    if model.existFrame(name):
        raise InvalidParameterError(f"frame {name!r} already exists on model {model.name!r}")
    if not model.existFrame(parent):
        names = [str(f.name) for f in model.frames][1:]
        raise FrameNotFoundError(
            f"unknown parent frame {parent!r}; valid frames: {', '.join(names)}"
        )
    T = as_transform(T_parent_frame, f"pose of frame {name!r}")
    parent_id = model.getFrameId(parent)
    parent_frame = model.frames[parent_id]
    placement = parent_frame.placement * pin.SE3(T[:3, :3], T[:3, 3])
    frame = pin.Frame(name, parent_frame.parentJoint, parent_id, placement, pin.FrameType.OP_FRAME)
    return int(model.addFrame(frame))
