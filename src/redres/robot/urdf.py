"""Loading a URDF into a Pinocchio model of one base-to-tip chain.

Nothing in the file is executed: the XML is checked with the standard library parser
first (for a message with a line number), then handed to Pinocchio's URDF parser.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pinocchio as pin

from .._validate import MAX_LENGTH, MAX_MASS
from ..errors import ModelFileNotFoundError, URDFError, describe_os_error, shown_path
from .dh import MAX_JOINTS

# Pinocchio's unbounded revolute joints (nq = 2: cos, sin) and their bounded twins.
_BOUNDED = {
    "JointModelRUBX": pin.JointModelRX,
    "JointModelRUBY": pin.JointModelRY,
    "JointModelRUBZ": pin.JointModelRZ,
}


def build_urdf_model(
    path: str | Path,
    tip: str | None,
    locked: Mapping[str, float] | None,
    continuous_limits: tuple[float, float],
) -> tuple[pin.Model, str]:
    """Parse ``path`` and reduce it to the chain ending at ``tip``; returns (model, tip)."""
    file = Path(path)
    try:
        found = file.is_file()
    except OSError as exc:  # a name too long, a loop of links
        raise URDFError(f"cannot read the URDF file: {describe_os_error(exc)}") from None
    if not found:
        raise ModelFileNotFoundError(f"URDF file not found: {shown_path(file)}")
    try:
        root = ET.parse(file).getroot()
    except ET.ParseError as exc:
        raise URDFError(f"{file}: not well-formed XML ({exc})") from None
    except OSError as exc:
        raise URDFError(f"cannot read the URDF file: {describe_os_error(exc)}") from None
    if root.tag != "robot":
        raise URDFError(f"{file}: the root element is <{root.tag}>, expected <robot>")
    if root.find("link") is None:
        raise URDFError(f"{file}: the URDF has no <link> element")
    _check_physical(root, file)
    try:
        full = pin.buildModelFromUrdf(str(file))
    except (RuntimeError, ValueError) as exc:
        raise URDFError(f"{file}: Pinocchio cannot build a model: {exc}") from None
    if full.nv == 0:
        raise URDFError(f"{file}: the URDF has no movable joint")

    tip_name = tip if tip is not None else _default_tip(full, file)
    if not full.existFrame(tip_name):
        names = [str(f.name) for f in full.frames][1:]
        raise URDFError(f"{file}: no frame named {tip_name!r}; frames: {', '.join(names)}")
    chain = set(full.supports[full.frames[full.getFrameId(tip_name)].parentJoint])
    to_lock = [j for j in range(1, full.njoints) if j not in chain]
    model = full
    if to_lock:
        q_ref = _locked_configuration(full, locked or {}, file)
        model = pin.buildReducedModel(full, to_lock, q_ref)
    elif locked:
        raise URDFError(f"{file}: cannot lock {sorted(locked)}: every joint is on the chain")
    if model.nv == 0:
        links = [str(f.name) for f in full.frames if f.type == pin.FrameType.BODY]
        raise URDFError(
            f"{file}: no movable joint between the root and tip {tip_name!r} (the root link or "
            f"fixed to it); choose a link further out: {', '.join(links[1:])}"
        )
    if model.nq != model.nv:
        model = _bound_continuous_joints(model, continuous_limits, file)
    return model, tip_name


#: The numeric attributes of a URDF's elements, and how many numbers each holds.
_NUMERIC = {
    "mass": {"value": 1},
    "inertia": dict.fromkeys(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 1),
    "origin": {"xyz": 3, "rpy": 3},
    "axis": {"xyz": 3},
    "limit": dict.fromkeys(("lower", "upper", "velocity", "effort"), 1),
}


def _check_physical(root: ET.Element, file: Path) -> None:
    """Refuse, by name, what Pinocchio would build into a wrong model (a negative or NaN
    mass, a zero joint axis, NaN placements or limits) and chains too long to build."""
    movable = [j for j in root.iter("joint") if j.get("type", "fixed") != "fixed"]
    if len(movable) > MAX_JOINTS:
        raise URDFError(
            f"{file}: {len(movable)} movable joints; redres models chains of at most "
            f"{MAX_JOINTS} joints (docs/models.md)"
        )
    for owner in root:
        where = f"{file}: {owner.tag} {owner.get('name')!r}"
        for element in owner.iter():
            for key, count in _NUMERIC.get(element.tag, {}).items():
                text = element.get(key)
                if text is None:
                    continue
                tag = f"<{element.tag} {key}={text!r}>"
                try:
                    values = [float(v) for v in text.split()]
                except ValueError:
                    values = []
                if len(values) != count or not all(map(math.isfinite, values)):
                    raise URDFError(f"{where}: {tag} must be {count} finite number(s)")
                if element.tag == "mass" and not 0.0 <= values[0] <= MAX_MASS:
                    raise URDFError(f"{where}: {tag} must be from 0 to {MAX_MASS:g} kg")
                if key == "xyz" and element.tag == "origin" and max(map(abs, values)) > MAX_LENGTH:
                    raise URDFError(f"{where}: {tag} must lie within ±{MAX_LENGTH:g} m")
                if element.tag == "axis" and math.hypot(*values) < 1e-9:
                    raise URDFError(f'{where}: {tag} is no direction; give one, e.g. "0 0 1"')


def _default_tip(model: pin.Model, file: Path) -> str:
    leaves = [j for j in range(1, model.njoints) if len(model.children[j]) == 0]
    if len(leaves) != 1:
        bodies = [str(f.name) for f in model.frames if f.type == pin.FrameType.BODY]
        raise URDFError(
            f"{file}: the kinematic tree branches; pass tip= one of its links: {', '.join(bodies)}"
        )
    leaf = leaves[0]
    # The deepest body attached to that joint (fixed links after it included).
    candidates = [
        i
        for i, f in enumerate(model.frames)
        if f.parentJoint == leaf and f.type == pin.FrameType.BODY
    ]
    return str(model.frames[candidates[-1]].name)


def _locked_configuration(model: pin.Model, locked: Mapping[str, float], file: Path) -> np.ndarray:
    q = pin.neutral(model)
    for name, value in locked.items():
        if not model.existJointName(name):
            names = [str(s) for s in model.names][1:]
            raise URDFError(
                f"{file}: cannot lock unknown joint {name!r}; joints: {', '.join(names)}"
            )
        joint = model.joints[model.getJointId(name)]
        if joint.nq != 1 or not math.isfinite(float(value)):
            raise URDFError(f"{file}: joint {name!r} must be locked at one finite value")
        q[joint.idx_q] = float(value)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    finite = np.isfinite(lo) & np.isfinite(hi) & (lo <= hi)
    q[finite] = np.clip(q[finite], lo[finite], hi[finite])
    return q


def _bound_continuous_joints(
    model: pin.Model, limits: tuple[float, float], file: Path
) -> pin.Model:
    """Copy ``model`` with each continuous joint replaced by a revolute joint in ``limits``."""
    lo, hi = float(limits[0]), float(limits[1])
    if not (lo < hi):
        raise URDFError(f"continuous_limits must satisfy low < high; got {limits}")
    out = pin.Model()
    out.name = model.name
    for j in range(1, model.njoints):
        joint = model.joints[j]
        kind = joint.shortname()
        if kind in _BOUNDED:
            new_joint = _BOUNDED[kind]()
            q_lo, q_hi = np.array([lo]), np.array([hi])
        elif joint.nq == joint.nv == 1:
            new_joint = joint
            q_lo = model.lowerPositionLimit[joint.idx_q : joint.idx_q + 1]
            q_hi = model.upperPositionLimit[joint.idx_q : joint.idx_q + 1]
        else:
            raise URDFError(
                f"{file}: joint {model.names[j]!r} ({kind}) has {joint.nv} degrees of freedom; "
                "only one-DOF joints are supported"
            )
        v = slice(joint.idx_v, joint.idx_v + 1)
        jid = out.addJoint(
            model.parents[j],
            new_joint,
            model.jointPlacements[j],
            model.names[j],
            np.array(model.upperEffortLimit[v]),
            np.array(model.upperVelocityLimit[v]),
            np.array(q_lo),
            np.array(q_hi),
        )
        out.appendBodyToJoint(jid, model.inertias[j], pin.SE3.Identity())
    for f in list(model.frames)[1:]:
        out.addFrame(pin.Frame(f), False)
    out.armature = np.array(model.armature)
    out.gravity = model.gravity
    return out
