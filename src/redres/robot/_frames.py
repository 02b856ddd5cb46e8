"""Operational frames on a Pinocchio model (internal): the one place frames are added."""

from __future__ import annotations

from typing import Any

import pinocchio as pin

from .._validate import as_transform
from ..errors import FrameNotFoundError, InvalidParameterError


def add_frame(model: pin.Model, name: str, parent: str, T_parent_frame: Any) -> int:
    """Add an operational frame to a Pinocchio model; returns its index."""
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
