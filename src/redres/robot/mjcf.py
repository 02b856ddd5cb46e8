"""MJCF specifics of loading a robot: what Pinocchio's MJCF parser leaves out.

Pinocchio's parser (3.x) drops the placement of a body directly under ``<worldbody>`` that
has no joint (a fixed base): a robot whose base body sits at ``pos="0 0 0.12"`` (the
UFactory xArm7 of the MuJoCo Menagerie) loads 0.12 m too low, while the placements of
every body below it, and of a root body with a joint, are kept.
:func:`keep_root_placements` puts them back, computed from the file as MuJoCo reads it
(``pos`` and one of ``quat``, ``axisangle``, ``euler``, ``xyaxes``, ``zaxis``, with the
compiler's ``angle`` and ``eulerseq``; MuJoCo's XML reference, "body").
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

from ..errors import URDFError

_AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]),
         "z": np.array([0.0, 0.0, 1.0])}  # fmt: skip


def keep_root_placements(model: pin.Model, root: ET.Element, label: str) -> None:
    """Give the joints and frames of each jointless body under ``<worldbody>`` (parsed by
    Pinocchio with that body at the origin) the body's placement from the file ``root``."""
    compiler = root.find("compiler")
    radian = compiler is not None and compiler.get("angle", "degree") == "radian"
    sequence = "xyz" if compiler is None else compiler.get("eulerseq", "xyz")
    for world in root.iter("worldbody"):
        for body in world.findall("body"):
            if body.find("joint") is not None or body.find("freejoint") is not None:
                continue  # Pinocchio keeps the placement of a body with a joint
            X = pin.SE3(_rotation(body, radian, sequence, label), _numbers(body, "pos", 3))
            if X.isIdentity():
                continue
            names = {e.get("name") for e in body.iter() if e.get("name") is not None}
            for j in range(1, model.njoints):
                if model.parents[j] == 0 and model.names[j] in names:
                    model.jointPlacements[j] = X * model.jointPlacements[j]
            for frame in model.frames:
                if frame.parentJoint == 0 and frame.name in names:
                    frame.placement = X * frame.placement


def _numbers(element: ET.Element, key: str, size: int, default: float = 0.0) -> np.ndarray:
    text = element.get(key)
    if text is None:
        return np.full(size, default)
    values = np.array([float(v) for v in text.split()])
    if values.shape != (size,):
        raise URDFError(f"<body name={element.get('name')!r}>: {key} needs {size} numbers")
    return values


def _rotation(body: ET.Element, radian: bool, sequence: str, label: str) -> np.ndarray:
    """The body's orientation (MuJoCo's alternatives; identity without one)."""
    scale = 1.0 if radian else math.pi / 180.0
    if body.get("quat") is not None:
        w, x, y, z = _numbers(body, "quat", 4)
        return np.asarray(pin.Quaternion(w, x, y, z).normalized().matrix())
    if body.get("axisangle") is not None:
        values = _numbers(body, "axisangle", 4)
        axis = values[:3] / np.linalg.norm(values[:3])
        return np.asarray(pin.exp3(axis * values[3] * scale))
    if body.get("euler") is not None:
        angles = _numbers(body, "euler", 3) * scale
        if len(sequence) != 3 or not (sequence.islower() or sequence.isupper()):
            raise URDFError(f"{label}: eulerseq {sequence!r} mixes fixed and moving axes")
        turns = [np.asarray(pin.exp3(_AXES[a.lower()] * t)) for a, t in zip(sequence, angles)]
        R = np.eye(3)
        for turn in turns if sequence.islower() else turns[::-1]:  # moving axes: R1 R2 R3
            R = R @ turn
        return R
    if body.get("xyaxes") is not None:
        values = _numbers(body, "xyaxes", 6)
        x = values[:3] / np.linalg.norm(values[:3])
        y = values[3:] - (values[3:] @ x) * x
        y /= np.linalg.norm(y)
        return np.column_stack([x, y, np.cross(x, y)])
    if body.get("zaxis") is not None:
        z = _numbers(body, "zaxis", 3)
        z = z / np.linalg.norm(z)
        axis = np.cross(_AXES["z"], z)
        s = float(np.linalg.norm(axis))
        if s < 1e-12:
            return np.eye(3) if z[2] > 0 else np.diag([1.0, -1.0, -1.0])
        return np.asarray(pin.exp3(axis / s * math.atan2(s, z[2])))
    return np.eye(3)
