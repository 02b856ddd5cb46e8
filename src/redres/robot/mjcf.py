"""MJCF specifics of loading a robot: what Pinocchio's MJCF parser leaves out.

Pinocchio's parser (3.x) drops the placement of a body directly under ``<worldbody>`` that
has no joint (a fixed base): a robot whose base body sits at ``pos="0 0 0.12"`` (the
UFactory xArm7 of the MuJoCo Menagerie) loads 0.12 m too low, while the placements of
every body below it, and of a root body with a joint, are kept.
:func:`keep_root_placements` puts them back, computed from the file as MuJoCo reads it
(``pos`` and one of ``quat``, ``axisangle``, ``euler``, ``xyaxes``, ``zaxis``, with the
compiler's ``angle`` and ``eulerseq``; MuJoCo's XML reference, "body").

Pinocchio's parser does not check the numbers it reads: ``pos="0.3 0"`` (too few),
``pos="a b c"`` or ``range="nan 1"`` build a model from whatever memory held, ``axis="0 0 0"``
a joint without a direction, ``mass="-1"`` a massless link. :func:`check_numbers` reads
every numeric attribute of the bodies, joints, geoms, sites, inertials, cameras and lights
(and of the default classes that hold them) first, with MuJoCo's counts, and refuses, naming the
element and attribute, what is not finite, has the wrong count, is a zero direction or
quaternion, or is a negative mass, inertia or size.

Pinocchio's parser reads a joint's ``actuatorfrcrange`` (not always through the right
default class) but not the ``forcerange`` of the actuators that drive it, which is where
most Menagerie arms keep their torque limits (``<general joint="joint1"
forcerange="-87 87"/>``, often through a default class).
:func:`torque_limits` reads both, resolving default classes as MuJoCo does (an element's
``class``, else the ``childclass`` of its nearest body, else ``main``; a class inherits
every attribute its own element does not set from its parent class; an actuator's default
is shared by every actuator type). An actuator's force acts on its joint through ``gear``,
so the joint's limit is ``|gear| · max(|lo|, |hi|)``, summed over the actuators on the
joint and capped by the joint's own ``actuatorfrcrange``; a joint without either has
none (``inf``). A file that includes another (``<include>``) is read as written: the
included file's actuators are not seen.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

from .._validate import MAX_LENGTH, MAX_MASS
from ..errors import MJCFError

#: The actuator elements of ``<actuator>`` and of a default class (MuJoCo's XML reference,
#: "actuator"); the defaults of each are the one actuator default of their class.
_ACTUATORS = ("general", "motor", "position", "velocity", "intvelocity", "damper",
              "cylinder", "muscle", "adhesion")  # fmt: skip

_AXES = {"x": np.array([1.0, 0.0, 0.0]), "y": np.array([0.0, 1.0, 0.0]),
         "z": np.array([0.0, 0.0, 1.0])}  # fmt: skip


#: Numeric attributes by element, with the numbers each may hold (MuJoCo's XML reference).
_ORIENTATION = {"quat": (4,), "axisangle": (4,), "euler": (3,), "xyaxes": (6,), "zaxis": (3,)}
_NUMERIC: dict[str, dict[str, tuple[int, ...]]] = {
    "body": {"pos": (3,), **_ORIENTATION},
    "inertial": {"pos": (3,), "mass": (1,), "diaginertia": (3,), "fullinertia": (6,),
                 **_ORIENTATION},
    "joint": {"pos": (3,), "axis": (3,), "range": (2,), "ref": (1,), "springref": (1,),
              "damping": (1,), "stiffness": (1,), "armature": (1,), "frictionloss": (1,),
              "actuatorfrcrange": (2,)},
    "geom": {"pos": (3,), "size": (1, 2, 3), "fromto": (6,), "mass": (1,), "density": (1,),
             **_ORIENTATION},
    "site": {"pos": (3,), "size": (1, 2, 3), "fromto": (6,), **_ORIENTATION},
    "camera": {"pos": (3,), **_ORIENTATION},
    "light": {"pos": (3,), "dir": (3,)},
}  # fmt: skip
#: Attributes that must not be negative (sizes, masses, inertias, joint dynamics).
_NONNEGATIVE = {"mass", "density", "diaginertia", "size", "damping", "stiffness", "armature",
                "frictionloss"}  # fmt: skip
#: Attributes that are a direction (or contain one first): not zero.
_DIRECTIONS = {"axis": 3, "quat": 4, "axisangle": 3, "zaxis": 3, "dir": 3}


def check_numbers(root: ET.Element, label: str) -> None:
    """Refuse, naming the element and attribute, a numeric attribute that Pinocchio would
    build into a wrong model (module docstring): every element of :data:`_NUMERIC`, in the
    bodies and in the default classes.

    Raises:
        MJCFError: not a number, not finite, the wrong count, a zero direction or
            quaternion, a negative size, mass or inertia, an offset beyond ±MAX_LENGTH, a
            mass above MAX_MASS, a joint range with its low end above its high end.
    """
    for element in root.iter():
        for key, counts in _NUMERIC.get(element.tag, {}).items():
            text = element.get(key)
            if text is None:
                continue
            name = element.get("name") or element.get("class")
            where = f"{label}: <{element.tag}{f' name={name!r}' if name else ''} {key}={text!r}>"
            try:
                values = [float(v) for v in text.split()]
            except ValueError:
                values = []
            if len(values) not in counts or not all(map(math.isfinite, values)):
                many = " or ".join(str(c) for c in counts)
                raise MJCFError(f"{where}: needs {many} finite number(s)")
            if key in _NONNEGATIVE and min(values) < 0.0:
                raise MJCFError(f"{where}: must not be negative")
            if key in _DIRECTIONS and math.hypot(*values[: _DIRECTIONS[key]]) < 1e-9:
                what = "rotation" if key == "quat" else "direction"
                raise MJCFError(f"{where}: is all zero, no {what}")
            if key == "pos" and max(map(abs, values)) > MAX_LENGTH:
                raise MJCFError(f"{where}: must lie within ±{MAX_LENGTH:g} m")
            if key == "mass" and values[0] > MAX_MASS:
                raise MJCFError(f"{where}: must be at most {MAX_MASS:g} kg")
            if key == "range" and values[0] > values[1]:
                raise MJCFError(f"{where}: the low end is above the high end")
            if key == "xyaxes" and np.linalg.norm(np.cross(values[:3], values[3:])) < 1e-9:
                raise MJCFError(f"{where}: the two axes are parallel or zero")
            if key == "size" and element.tag == "geom":
                _check_geom_size(element, values, where)


#: The sizes a geom of each type needs: (without ``fromto``, with it) (MuJoCo's reference).
_GEOM_SIZES = {"sphere": (1, 1), "capsule": (2, 1), "cylinder": (2, 1), "box": (3, 2),
               "ellipsoid": (3, 3)}  # fmt: skip


def _check_geom_size(geom: ET.Element, values: list[float], where: str) -> None:
    """A geom whose own ``type`` needs more numbers than its ``size`` holds, or a zero
    where MuJoCo needs a positive size (a type set by a default class is not checked)."""
    kind = geom.get("type")
    if kind not in _GEOM_SIZES:
        return
    need = _GEOM_SIZES[kind][geom.get("fromto") is not None]
    if len(values) < need or min(values[:need]) <= 0.0:
        raise MJCFError(f"{where}: a {kind} needs {need} positive size number(s)")


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
        raise MJCFError(f"<body name={element.get('name')!r}>: {key} needs {size} numbers")
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
            raise MJCFError(f"{label}: eulerseq {sequence!r} mixes fixed and moving axes")
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


def torque_limits(root: ET.Element, label: str) -> dict[str, float]:
    """Each joint's torque limit from the MJCF ``root`` (module docstring), N·m, for the
    joints that have one (by joint name)."""
    classes = _default_classes(root)
    joint_cap: dict[str, float] = {}
    for cls, joint in _with_class(root.find("worldbody"), "main"):
        name = joint.get("name")
        limited = _attribute(joint, "actuatorfrclimited", cls, classes, "joint", "auto")
        text = _attribute(joint, "actuatorfrcrange", cls, classes, "joint")
        if name is not None and text is not None and limited != "false":
            joint_cap[name] = _bound(text, f"joint {name!r} actuatorfrcrange", label)
    driven: dict[str, float] = {}
    for section in root.iter("actuator"):
        for actuator in section:
            target = actuator.get("joint")
            if actuator.tag not in _ACTUATORS or target is None:
                continue  # a tendon, site or body actuator: no single joint to limit
            cls = actuator.get("class", "main")
            limited = _attribute(actuator, "forcelimited", cls, classes, "actuator", "auto")
            text = _attribute(actuator, "forcerange", cls, classes, "actuator")
            if text is None or limited == "false":
                continue
            what = f"actuator on joint {target!r} forcerange"
            gear = (_attribute(actuator, "gear", cls, classes, "actuator") or "1").split()
            ratio = abs(float(gear[0])) if gear else 1.0
            driven[target] = driven.get(target, 0.0) + ratio * _bound(text, what, label)
    limits = dict(driven)
    for name, cap in joint_cap.items():
        limits[name] = min(cap, limits.get(name, math.inf))
    return limits


def _bound(text: str, what: str, label: str) -> float:
    values = [float(v) for v in text.split()]
    if len(values) != 2 or not all(math.isfinite(v) for v in values):
        raise MJCFError(f"{label}: {what} needs two finite numbers; got {text!r}")
    return max(abs(values[0]), abs(values[1]))


def _default_classes(root: ET.Element) -> dict[str, tuple[ET.Element, str | None]]:
    """Every ``<default>`` by class name (the top one is ``main``), with its parent's."""
    classes: dict[str, tuple[ET.Element, str | None]] = {}

    def visit(default: ET.Element, parent: str | None) -> None:
        name = default.get("class", "main" if parent is None else None)
        if name is None:
            return  # a nested default without a class is an error in MuJoCo; skip it
        classes[name] = (default, parent)
        for child in default.findall("default"):
            visit(child, name)

    for top in root.findall("default"):
        visit(top, None)
    return classes


def _with_class(body: ET.Element | None, inherited: str) -> list[tuple[str, ET.Element]]:
    """Every ``<joint>`` under ``body`` with the class it takes when it names none."""
    if body is None:
        return []
    found = []
    childclass = body.get("childclass", inherited)
    for child in body:
        if child.tag == "joint":
            found.append((childclass, child))
        elif child.tag == "body":
            found.extend(_with_class(child, childclass))
    return found


def _attribute(
    element: ET.Element,
    key: str,
    inherited: str,
    classes: dict[str, tuple[ET.Element, str | None]],
    kind: str,
    default: str | None = None,
) -> str | None:
    """``key`` of ``element``, else of its class's defaults (its own ``class``, else
    ``inherited``) and their parents'. ``kind``: ``"joint"`` or ``"actuator"``."""
    value = element.get(key)
    if value is not None:
        return value
    name: str | None = element.get("class", inherited)
    tags = ("joint",) if kind == "joint" else _ACTUATORS
    while name is not None and name in classes:
        table, parent = classes[name]
        for child in table:
            if child.tag in tags and child.get(key) is not None:
                return child.get(key)
        name = parent
    return default
