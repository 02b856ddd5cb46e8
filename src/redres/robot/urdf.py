"""Loading a URDF (file or XML text) or an MJCF file into a Pinocchio model of one
base-to-tip chain.

Nothing in the file is executed: the XML is checked with the standard library parser
first (for a message with a line number), then handed to Pinocchio's URDF or MJCF parser
(Pinocchio 3+ reads MJCF: ``pin.buildModelFromMJCF``). Both go through the same reduction
to the chain ending at the tip (:func:`reduce_to_chain`), whose geometry models follow.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pinocchio as pin

from .._validate import MAX_LENGTH, MAX_MASS, short_repr
from ..errors import (
    MJCFError,
    ModelFileNotFoundError,
    URDFError,
    describe_os_error,
    shown_path,
)
from .dh import MAX_JOINTS
from .mjcf import check_numbers, keep_root_placements, torque_limits

# Pinocchio's unbounded revolute joints (nq = 2: cos, sin) and their bounded twins.
_BOUNDED = {
    "JointModelRUBX": pin.JointModelRX,
    "JointModelRUBY": pin.JointModelRY,
    "JointModelRUBZ": pin.JointModelRZ,
}

Format = Literal["urdf", "mjcf"]


@dataclass
class ModelSource:
    """A robot description: its label in messages, its format, and the file or the text.

    Attributes:
        label: what messages call it (the file, or ``<URDF string>``).
        kind: ``"urdf"`` or ``"mjcf"``.
        file: the file (``None`` for text); ``text`` the XML when given as a string.
    """

    label: str
    kind: Format
    file: Path | None = None
    text: str | None = None
    mesh_dir: Path | None = None

    @property
    def folder(self) -> Path:
        """Where relative mesh paths (and ``package://`` roots) are looked up."""
        if self.mesh_dir is not None:
            return self.mesh_dir
        return self.file.parent if self.file is not None else Path()


@dataclass
class LoadedModel:
    """The reduced model, its tip, and the geometry models that came with it."""

    model: pin.Model
    tip: str
    collision: Any = None  # pin.GeometryModel, or None when the file has none
    visual: Any = None
    reference: np.ndarray | None = None  # a configuration the file names (MJCF keyframe)


def urdf_source(path: str | Path) -> ModelSource:
    """A URDF file, checked to exist."""
    return _file_source(path, "urdf")


def mjcf_source(path: str | Path) -> ModelSource:
    """An MJCF file, checked to exist."""
    return _file_source(path, "mjcf")


def _file_source(path: str | Path, kind: Format) -> ModelSource:
    name = kind.upper()
    if isinstance(path, str) and path.lstrip().startswith("<"):
        hint = "Robot.from_urdf_string(xml)" if kind == "urdf" else "a file name"
        raise URDFError(f"{short_repr(path, 60)} is {name} text, not a file name; use {hint}")
    file = Path(path)
    try:
        found = file.is_file()
    except OSError as exc:  # a name too long, a loop of links
        hint = " (pass XML text to Robot.from_urdf_string)" if kind == "urdf" else ""
        raise URDFError(f"cannot read the {name} file: {describe_os_error(exc)}{hint}") from None
    if not found:
        raise ModelFileNotFoundError(f"{name} file not found: {shown_path(file)}")
    return ModelSource(str(file), kind, file=file)


def _root(source: ModelSource) -> ET.Element:
    label, name = source.label, source.kind.upper()
    try:
        if source.file is not None:
            root = ET.parse(source.file).getroot()
        else:
            root = ET.fromstring(source.text or "")
    except ET.ParseError as exc:
        raise URDFError(f"{label}: not well-formed XML ({exc})") from None
    except OSError as exc:
        raise URDFError(f"cannot read the {name} file: {describe_os_error(exc)}") from None
    expected = "robot" if source.kind == "urdf" else "mujoco"
    if root.tag != expected:
        raise URDFError(f"{label}: the root element is <{root.tag}>, expected <{expected}>")
    return root


def _as_utf8(source: ModelSource, root: ET.Element) -> ModelSource:
    """Pinocchio reads names as UTF-8: a URDF file in another encoding (ISO-8859-1 with an
    'é' in a name, declared in its XML header) is handed over as UTF-8 text, its meshes
    still found beside the file; an MJCF must be UTF-8 (MuJoCo's own rule)."""
    if source.file is None:
        return source
    try:
        source.file.read_bytes().decode("utf-8")
        return source
    except UnicodeDecodeError:
        pass
    if source.kind == "mjcf":
        raise URDFError(f"{source.label}: not UTF-8 text; MuJoCo reads MJCF as UTF-8: save it so")
    text = ET.tostring(root, encoding="unicode")
    return ModelSource(source.label, "urdf", text=text, mesh_dir=source.folder)


def _full_model(
    source: ModelSource, geometry: tuple[str, ...], root: ET.Element
) -> tuple[pin.Model, Any, Any]:
    """Pinocchio's model of the whole file (``root``, its XML) and the geometry models
    named in ``geometry`` (``"collision"``, ``"visual"``; ``None`` where one cannot be
    built, e.g. a missing mesh). An MJCF's root bodies keep their placement
    (:func:`.mjcf.keep_root_placements`)."""
    label = source.label
    try:
        if source.kind == "mjcf":
            full = pin.buildModelFromMJCF(str(source.file))
        elif source.file is not None:
            full = pin.buildModelFromUrdf(str(source.file))
        else:
            full = pin.buildModelFromXML(source.text)
    except (RuntimeError, ValueError) as exc:
        raise URDFError(f"{label}: Pinocchio cannot build a model: {exc}") from None
    if source.kind == "mjcf":
        keep_root_placements(full, root, label)
    kinds = {"collision": pin.COLLISION, "visual": pin.VISUAL}
    geoms = [_geometry(full, source, kinds[k]) if k in geometry else None for k in kinds]
    return full, geoms[0], geoms[1]


def _geometry(model: pin.Model, source: ModelSource, kind: Any) -> Any:
    # package://NAME/... is looked up as NAME under each of these: the file's folder and
    # its ancestors (a ROS-like layout: share/NAME/robots/x.urdf), besides ROS_PACKAGE_PATH
    # that Pinocchio reads itself.
    folder = source.folder.resolve()
    dirs = [str(p) for p in (folder, *folder.parents)][:8]
    try:
        if source.kind == "mjcf":
            return pin.buildGeomFromMJCF(model, str(source.file), kind)
        if source.file is not None:
            return pin.buildGeomFromUrdf(model, str(source.file), kind, package_dirs=dirs)
        return pin.buildGeomFromUrdfString(model, source.text, kind, package_dirs=dirs)
    except (RuntimeError, ValueError, OSError):  # a mesh that cannot be found or read
        return None


def load_model(
    source: ModelSource,
    tip: str | None,
    locked: Mapping[str, float] | None,
    continuous_limits: tuple[float, float],
    *,
    geometry: tuple[str, ...] = ("collision", "visual"),
) -> LoadedModel:
    """Parse ``source``, reduce it to the chain ending at ``tip``, with the geometry
    models named in ``geometry``.

    Raises:
        URDFError, MJCFError: by the file's format (the checks shared by both formats raise
            :class:`URDFError`; here an MJCF's become :class:`MJCFError`).
    """
    try:
        return _load_model(source, tip, locked, continuous_limits, geometry)
    except URDFError as exc:
        if source.kind == "mjcf":
            raise MJCFError(str(exc)) from None
        raise


def _load_model(
    source: ModelSource,
    tip: str | None,
    locked: Mapping[str, float] | None,
    continuous_limits: tuple[float, float],
    geometry: tuple[str, ...],
) -> LoadedModel:
    root = _root(source)
    source = _as_utf8(source, root)
    label = source.label
    if source.kind == "urdf":
        if root.find("link") is None:
            raise URDFError(f"{label}: the URDF has no <link> element")
        _check_physical(root, label)
    elif root.find("worldbody") is None:
        raise URDFError(f"{label}: the MJCF has no <worldbody> element")
    else:
        check_numbers(root, label)
    full, collision, visual = _full_model(source, geometry, root)
    if full.nv == 0:
        raise URDFError(f"{label}: the {source.kind.upper()} has no movable joint")
    if source.kind == "mjcf":
        _file_limits(full, torque_limits(root, label), continuous_limits)
    return reduce_to_chain(full, tip, locked, continuous_limits, label, collision, visual)


def reduce_to_chain(
    full: pin.Model,
    tip: str | None,
    locked: Mapping[str, float] | None,
    continuous_limits: tuple[float, float],
    file: str,
    collision: Any = None,
    visual: Any = None,
) -> LoadedModel:
    """The base-to-``tip`` chain of ``full``: every other joint locked (at ``locked``,
    else zero clipped into its limits), continuous joints bounded to
    ``continuous_limits``; the geometry models reduced with it."""
    tip_name = tip if tip is not None else _default_tip(full, file)
    if not full.existFrame(tip_name):
        names = [str(f.name) for f in full.frames][1:]
        raise URDFError(f"{file}: no frame named {tip_name!r}; frames: {', '.join(names)}")
    chain = set(full.supports[full.frames[full.getFrameId(tip_name)].parentJoint])
    to_lock = [j for j in range(1, full.njoints) if j not in chain]
    model = full
    reference = _reference(full)
    if to_lock:
        q_ref = _locked_configuration(full, locked or {}, file)
        geoms = [g for g in (collision, visual) if g is not None]
        if geoms:
            model, reduced = pin.buildReducedModel(full, geoms, to_lock, q_ref)
            it = iter(reduced)
            collision = next(it) if collision is not None else None
            visual = next(it) if visual is not None else None
        else:
            model = pin.buildReducedModel(full, to_lock, q_ref)
        if reference is not None:
            keep = [full.joints[j].idx_q for j in range(1, full.njoints) if j in chain]
            reference = reference[keep]
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
        reference = None  # cos/sin coordinates: not a configuration of the bounded model
    return LoadedModel(model, tip_name, collision, visual, reference)


def _file_limits(
    model: pin.Model, torques: Mapping[str, float], continuous_limits: tuple[float, float]
) -> None:
    """An MJCF's limits as MuJoCo reads them, put into ``model``: the torque limits of its
    actuators (:func:`.mjcf.torque_limits`, in place of Pinocchio's), and ``continuous_limits`` for
    a hinge without a range (MuJoCo's unlimited joint; Pinocchio leaves it at ±inf)."""
    lo, hi = _continuous(continuous_limits)
    q_lo, q_hi = np.array(model.lowerPositionLimit), np.array(model.upperPositionLimit)
    effort = np.array(model.effortLimit)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nq != 1 or joint.nv != 1:
            continue
        i, v = joint.idx_q, joint.idx_v
        revolute = joint.shortname().startswith(("JointModelR", "JointModelRevolute"))
        if revolute and not (np.isfinite(q_lo[i]) or np.isfinite(q_hi[i])):
            q_lo[i], q_hi[i] = lo, hi
        effort[v] = torques.get(str(model.names[j]), math.inf)
    model.lowerPositionLimit, model.upperPositionLimit = q_lo, q_hi
    model.effortLimit = effort


def _continuous(limits: tuple[float, float]) -> tuple[float, float]:
    """``continuous_limits`` as two floats, checked ``low < high``."""
    lo, hi = float(limits[0]), float(limits[1])
    if not (lo < hi):
        raise URDFError(f"continuous_limits must satisfy low < high; got {limits}")
    return lo, hi


def _reference(model: pin.Model) -> np.ndarray | None:
    """The configuration an MJCF keyframe named ``home`` gives, if any."""
    refs = model.referenceConfigurations
    return np.array(refs["home"], dtype=float) if "home" in refs else None


#: The numeric attributes of a URDF's elements, and how many numbers each holds.
_NUMERIC = {
    "mass": {"value": 1},
    "inertia": dict.fromkeys(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), 1),
    "origin": {"xyz": 3, "rpy": 3},
    "axis": {"xyz": 3},
    "limit": dict.fromkeys(("lower", "upper", "velocity", "effort"), 1),
}


def _check_physical(root: ET.Element, file: str) -> None:
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
        fixed = owner.tag == "joint" and owner.get("type", "fixed") == "fixed"
        for element in owner.iter():
            if fixed and element.tag == "axis":
                continue  # a fixed joint's axis is not used
            if element.tag == "axis" and element.get("xyz") is None:
                raise URDFError(f'{where}: <axis> has no xyz; give a direction, e.g. "0 0 1"')
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


def _default_tip(model: pin.Model, file: str) -> str:
    """The last link of an unbranched tree: of the joint tree *and* of the links fixed
    after its last joint (fixed fingers make the link tree branch while the joint tree
    does not; then, as for any branch, the caller must choose)."""
    bodies = [str(f.name) for f in model.frames if f.type == pin.FrameType.BODY]
    sites = [str(f.name) for f in model.frames if f.type == pin.FrameType.OP_FRAME]
    choices = f"one of its links: {', '.join(bodies)}"
    if sites:  # an MJCF's sites (a TCP, an attachment site) are tips as good as links
        choices += f"; or of its sites: {', '.join(sites)}"
    leaves = [j for j in range(1, model.njoints) if len(model.children[j]) == 0]
    if len(leaves) != 1:
        raise URDFError(f"{file}: the kinematic tree branches; pass tip= {choices}")
    leaf = leaves[0]
    on_leaf = [i for i, f in enumerate(model.frames)
               if f.parentJoint == leaf and f.type == pin.FrameType.BODY]  # fmt: skip
    # A body on the leaf joint is an end of the link tree when no other body of that joint
    # hangs from it (through the fixed joints' frames).
    hangs = set()
    for i in on_leaf:
        parent = model.frames[i].parentFrame
        while parent > 0 and model.frames[parent].parentJoint == leaf:
            if model.frames[parent].type == pin.FrameType.BODY:
                hangs.add(parent)
            parent = model.frames[parent].parentFrame
    ends = [i for i in on_leaf if i not in hangs]
    if len(ends) > 1:
        names = ", ".join(str(model.frames[i].name) for i in ends)
        raise URDFError(
            f"{file}: the links fixed after joint {model.names[leaf]!r} branch ({names}); "
            f"pass tip= {choices}"
        )
    return str(model.frames[ends[-1]].name)


def _locked_configuration(model: pin.Model, locked: Mapping[str, float], file: str) -> np.ndarray:
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


def _bound_continuous_joints(model: pin.Model, limits: tuple[float, float], file: str) -> pin.Model:
    """Copy ``model`` with each continuous joint replaced by a revolute joint in ``limits``."""
    lo, hi = _continuous(limits)
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
