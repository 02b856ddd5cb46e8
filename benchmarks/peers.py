"""The same Panda for every peer library, built from the same published parameters.

Each ``make_*`` returns ``None`` with a note when the peer is not installed, so a missing
peer is skipped, never a failure. KDL comes from Debian's ``python3-pykdl`` and is reached
through the system site-packages.
"""

from __future__ import annotations

import ctypes
import os
import re
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

import redres as rr
from redres.models.panda import DH, FLANGE_D, TCP_D

ROOT = Path(__file__).resolve().parents[1]
PANDA_URDF = ROOT / "tests" / "fixtures" / "panda_description.urdf"
SYSTEM_SITE = "/usr/lib/python3/dist-packages"


def note(message: str) -> None:
    print(f"  note: {message}", file=sys.stderr)


@contextmanager
def native_output_to_stderr() -> Iterator[None]:
    """Send what native code prints on standard output (file descriptor 1) to standard
    error while the block runs: a peer's C++ parser warns there (kdl_parser: "The root
    link ... has an inertia specified in the URDF ..."), and a benchmark's standard
    output is its table, which run_all.py copies into docs/benchmarks.md."""
    sys.stdout.flush()
    saved = os.dup(1)
    os.dup2(2, 1)
    try:
        yield
    finally:
        try:
            ctypes.CDLL(None).fflush(None)  # C stdio's buffer, written before fd 1 returns
        except (OSError, AttributeError):  # pragma: no cover - no C library to flush
            pass
        os.dup2(saved, 1)
        os.close(saved)


def panda_urdf_without_fingers() -> str:
    """The test fixture's Panda (arm, hand, TCP) with the two finger joints removed."""
    text = PANDA_URDF.read_text()
    text = re.sub(r"<joint name=\"panda_finger_joint\d\".*?</joint>\s*", "", text, flags=re.S)
    text = re.sub(r"<link name=\"panda_finger\d\">.*?</link>\s*", "", text, flags=re.S)
    return text


def import_pink() -> Any:
    try:
        import pink
        from pink import tasks
    except ImportError:
        note("pink (pip install pin-pink) is not installed: skipped")
        return None
    return pink, tasks


def import_mink() -> Any:
    try:
        import mink
        import mujoco
    except ImportError:
        note("mink/mujoco (pip install mink mujoco) are not installed: skipped")
        return None
    return mink, mujoco


def mujoco_panda(mujoco: Any) -> Any:
    """MuJoCo model of the fingerless Panda URDF, fixed links kept as bodies."""
    urdf = panda_urdf_without_fingers().replace(
        '<robot name="panda_fixture">',
        '<robot name="panda_fixture"><mujoco><compiler fusestatic="false" '
        'discardvisual="true"/></mujoco>',
    )
    return mujoco.MjModel.from_xml_string(urdf)


def import_kdl() -> Any:
    try:
        import PyKDL
    except ImportError:
        if SYSTEM_SITE not in sys.path:
            sys.path.append(SYSTEM_SITE)
        try:
            import PyKDL
        except ImportError:
            note("KDL (Debian package python3-pykdl) is not installed: skipped")
            return None
    return PyKDL


def kdl_panda(kdl: Any) -> Any:
    """KDL chain of the Panda to its TCP from the same modified DH table."""
    # A KDL segment turns its joint first, then applies its tip frame: with modified DH,
    # joint i's placement Rx(α)Tx(a)Tz(d) is the tip frame of the segment before it.
    chain = kdl.Chain()
    placements = [kdl.Frame.DH_Craig1989(a, alpha, d, 0.0) for a, d, alpha in DH]
    tool = kdl.Frame(kdl.Rotation.RotZ(-np.pi / 4), kdl.Vector(0.0, 0.0, FLANGE_D + TCP_D))
    chain.addSegment(kdl.Segment(kdl.Joint(kdl.Joint.Fixed), placements[0]))
    for tip in [*placements[1:], tool]:
        chain.addSegment(kdl.Segment(kdl.Joint(kdl.Joint.RotZ), tip))
    return chain


def check_same_panda(q: np.ndarray) -> None:
    """Fail loudly if a peer's Panda differs from redres' (same TCP pose)."""
    robot = rr.models.panda()
    kdl = import_kdl()
    if kdl is not None:
        chain = kdl_panda(kdl)
        frame = kdl.Frame()
        jnt = kdl.JntArray(7)
        for i, v in enumerate(q):
            jnt[i] = v
        kdl.ChainFkSolverPos_recursive(chain).JntToCart(jnt, frame)
        p = np.array([frame.p[i] for i in range(3)])
        if not np.allclose(p, robot.fk(q)[:3, 3], atol=1e-9):
            raise AssertionError(f"KDL Panda TCP {p} != redres {robot.fk(q)[:3, 3]}")


# --- Both arms (Panda and iiwa 14) for every peer: differential.py, ik_compare.py, quality.py

IIWA_URDF = ROOT / "src" / "redres" / "models" / "data" / "iiwa14.urdf"
ARMS = ("panda", "iiwa14")
#: The controlled frame: a URDF link of each arm, and redres' tip frame of the same pose.
TIP_LINK = {"panda": "panda_hand_tcp", "iiwa14": "flange"}
TIP_FRAME = {"panda": "tcp", "iiwa14": "flange"}
_MUJOCO_TAG = '<mujoco><compiler fusestatic="false" discardvisual="true"/></mujoco>'


def arm_urdf(name: str) -> str:
    """URDF text of an arm without meshes: the fingerless Panda, or redres' iiwa 14."""
    if name == "panda":
        return panda_urdf_without_fingers()
    if name == "iiwa14":
        return IIWA_URDF.read_text()
    raise KeyError(f"unknown arm {name!r}; expected one of {ARMS}")


def write_urdf(name: str, directory: Path) -> Path:
    """The arm's URDF written to ``directory`` (rtb and ikpy read files)."""
    path = Path(directory) / f"{name}.urdf"
    path.write_text(arm_urdf(name))
    return path


def mujoco_model(mujoco: Any, name: str) -> Any:
    """MuJoCo model of the arm's URDF, fixed links kept as bodies, visuals discarded."""
    text = arm_urdf(name)
    text = re.sub(r"(<robot name=\"[^\"]*\">)", r"\1" + _MUJOCO_TAG, text, count=1)
    return mujoco.MjModel.from_xml_string(text)


def _origin(joint: Any) -> np.ndarray:
    """4x4 placement of a URDF joint in its parent link (xyz, then fixed-axis rpy)."""
    element = joint.find("origin")
    attributes = element.attrib if element is not None else {}
    xyz = [float(v) for v in attributes.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in attributes.get("rpy", "0 0 0").split()]
    cr, cp, cy = np.cos(rpy)
    sr, sp, sy = np.sin(rpy)
    T = np.eye(4)
    T[:3, :3] = [  # Rz(yaw) Ry(pitch) Rx(roll), the URDF convention
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    T[:3, 3] = xyz
    return T


def urdf_joints(text: str, tip: str) -> list[tuple[str, bool, np.ndarray]]:
    """Joints from the root to ``tip``: (name, revolute about z, placement), parsed only."""
    import xml.etree.ElementTree as ET

    by_child = {j.find("child").get("link"): j for j in ET.fromstring(text).iter("joint")}
    chain, link = [], tip
    while link in by_child:
        joint = by_child[link]
        revolute = joint.get("type") in ("revolute", "continuous")
        axis = joint.find("axis")
        if revolute and (axis is None or axis.get("xyz", "").split() != ["0", "0", "1"]):
            raise ValueError(f"joint {joint.get('name')}: only z axes are supported here")
        chain.append((joint.get("name"), revolute, _origin(joint)))
        link = joint.find("parent").get("link")
    return chain[::-1]


def kdl_chain(kdl: Any, name: str) -> Any:
    """KDL chain of an arm to its tip: the Panda from its DH table, the iiwa from its URDF."""
    if name == "panda":
        return kdl_panda(kdl)
    chain, moving = kdl.Chain(), False
    # A KDL segment turns its joint, then applies its tip frame: the tip frame of each
    # segment is the placement of the next URDF joint.
    for _, revolute, T in urdf_joints(arm_urdf(name), TIP_LINK[name]):
        rotation = kdl.Rotation(*T[:3, :3].ravel().tolist())
        tip = kdl.Frame(rotation, kdl.Vector(*T[:3, 3].tolist()))
        joint = kdl.Joint(kdl.Joint.RotZ) if moving else kdl.Joint(kdl.Joint.Fixed)
        chain.addSegment(kdl.Segment(joint, tip))
        moving = revolute
    if moving:
        chain.addSegment(kdl.Segment(kdl.Joint(kdl.Joint.RotZ), kdl.Frame()))
    return chain


def import_rtb() -> Any:
    try:
        import roboticstoolbox
    except ImportError:
        note("robotics-toolbox (pip install roboticstoolbox-python) is not installed: skipped")
        return None
    return roboticstoolbox


def rtb_robot(rtb: Any, path: Path) -> Any:
    """robotics-toolbox robot read from a URDF file (its own parser, ETS kinematics)."""
    from roboticstoolbox.models.URDF.URDFRobot import URDF_file

    links, name, _ = URDF_file(str(path))
    return rtb.Robot(links, name=name)


def import_ikpy() -> Any:
    try:
        import ikpy.chain
    except ImportError:
        note("ikpy (pip install ikpy) is not installed: skipped")
        return None
    return ikpy.chain


def ikpy_chain(ikpy_chain_module: Any, name: str, path: Path) -> tuple[Any, np.ndarray]:
    """ikpy chain from the URDF file, with only the revolute joints active; and that mask."""
    base = "panda_link0" if name == "panda" else "link0"
    kinds = [revolute for _, revolute, _ in urdf_joints(arm_urdf(name), TIP_LINK[name])]
    mask = np.array([False, *kinds])  # ikpy adds a fixed "Base link" in front
    chain = ikpy_chain_module.Chain.from_urdf_file(
        str(path), base_elements=[base], active_links_mask=mask.tolist(), symbolic=False
    )
    if len(chain.links) != len(mask):
        raise AssertionError(f"ikpy's {name} chain: {len(chain.links)} links, not {len(mask)}")
    return chain, mask


def _kdl_fk(kdl: Any, name: str) -> Any:
    chain = kdl_chain(kdl, name)
    fk = kdl.ChainFkSolverPos_recursive(chain)

    def kdl_fk(q: np.ndarray) -> np.ndarray:
        jnt, frame = kdl.JntArray(len(q)), kdl.Frame()
        for i, v in enumerate(q):
            jnt[i] = float(v)
        fk.JntToCart(jnt, frame)
        _ = chain  # KDL solvers hold a bare reference: keep the chain alive
        return kdl_matrix(frame)

    return kdl_fk


def kdl_matrix(frame: Any) -> np.ndarray:
    """4x4 of a KDL frame."""
    T = np.eye(4)
    T[:3, :3] = [[frame.M[i, j] for j in range(3)] for i in range(3)]
    T[:3, 3] = [frame.p[i] for i in range(3)]
    return T


def _mujoco_fk(mujoco: Any, name: str) -> Any:
    model = mujoco_model(mujoco, name)
    data = mujoco.MjData(model)
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, TIP_LINK[name])

    def mujoco_fk(q: np.ndarray) -> np.ndarray:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        T = np.eye(4)
        T[:3, :3] = data.xmat[body].reshape(3, 3)
        T[:3, 3] = data.xpos[body]
        return T

    return mujoco_fk


def _ikpy_fk(ikpy: Any, name: str, directory: Path) -> Any:
    chain, mask = ikpy_chain(ikpy, name, write_urdf(name, directory))

    def ikpy_fk(q: np.ndarray) -> np.ndarray:
        full = np.zeros(len(mask))
        full[mask] = q
        return np.asarray(chain.forward_kinematics(full))

    return ikpy_fk


def peer_fk(name: str, directory: Path) -> dict[str, Any]:
    """Forward kinematics of the tip, ``q -> 4x4``, for every installed peer."""
    out: dict[str, Any] = {}
    kdl = import_kdl()
    if kdl is not None:
        out["KDL"] = _kdl_fk(kdl, name)
    found = import_mink()
    if found is not None:
        out["mink"] = _mujoco_fk(found[1], name)
    rtb = import_rtb()
    if rtb is not None:
        arm = rtb_robot(rtb, write_urdf(name, directory))
        out["robotics-toolbox"] = lambda q: np.asarray(arm.fkine(q, end=TIP_LINK[name]).A)
    ikpy = import_ikpy()
    if ikpy is not None:
        out["ikpy"] = _ikpy_fk(ikpy, name, directory)
    return out


def check_same_robot(name: str, directory: Path, count: int = 5, seed: int = 0) -> list[str]:
    """Abort loudly unless every peer's tip pose equals redres' at random configurations."""
    robot = rr.models.load(name)
    rng = np.random.default_rng(seed)
    configurations = [robot.random_configuration(rng) for _ in range(count)]
    fks = peer_fk(name, directory)
    for peer, fk in fks.items():
        for q in configurations:
            gap = float(np.abs(fk(q) - robot.fk(q, TIP_FRAME[name])).max())
            if not gap < 1e-9:
                raise AssertionError(
                    f"{peer}'s {name} is not redres' {name}: tip poses differ by {gap:.3g} at "
                    f"q = {np.round(q, 4).tolist()}; fix benchmarks/peers.py before comparing"
                )
    return list(fks)


# --- Collision geometry for mink: redres' link capsules and obstacles as MuJoCo geoms


def mujoco_capsule_arm(mujoco: Any, robot: Any, obstacles: Any, name: str = "panda") -> Any:
    """MuJoCo model of ``arm_urdf(name)`` whose only geoms are ``robot``'s link capsules
    (``<geom type="capsule" fromto=... size=radius>`` on the body its joint moves, named
    after the capsule) and ``obstacles`` (redres shapes) as geoms named after them:
    spheres, boxes and capsules on a mocap body (mink leaves out pairs of bodies welded
    to each other or parent and child, so a world geom would never be paired with the
    first link), a half-space as a world plane (its solid side below).

    The capsules are placed from their world ends at the neutral pose and checked at random
    configurations against redres' (``capsule_gap``); joint ranges are set to redres'.
    """
    from redres.collision import BoxObstacle, CapsuleObstacle, PlaneObstacle, SphereObstacle

    text = re.sub(r"(<robot name=\"[^\"]*\">)", r"\1" + _MUJOCO_TAG, arm_urdf(name), count=1)
    spec = mujoco.MjSpec.from_string(text)
    bare = spec.compile()
    data = mujoco.MjData(bare)
    q = robot.neutral()
    data.qpos[:] = q
    mujoco.mj_kinematics(bare, data)
    kind = mujoco.mjtGeom
    for cap in robot.capsules:
        joint = robot.model.frames[robot.frame_id(cap.frame)].parentJoint  # Pinocchio, 1-based
        body = int(bare.jnt_bodyid[joint - 1])
        T = robot.fk(q, cap.frame)
        R_b, x_b = data.xmat[body].reshape(3, 3), data.xpos[body]
        ends = [R_b.T @ (T[:3, :3] @ p + T[:3, 3] - x_b) for p in (cap.a, cap.b)]
        spec.body(bare.body(body).name).add_geom(
            name=cap.name, type=kind.mjGEOM_CAPSULE, fromto=np.concatenate(ends),
            size=[cap.radius, 0.0, 0.0],
        )  # fmt: skip
    world = spec.worldbody
    holder = world.add_body(name="obstacles", mocap=True)
    for obs in obstacles:
        if isinstance(obs, SphereObstacle):
            holder.add_geom(name=obs.name, type=kind.mjGEOM_SPHERE, pos=obs.center,
                            size=[max(obs.radius, 1e-9), 0.0, 0.0])  # fmt: skip
        elif isinstance(obs, CapsuleObstacle):
            holder.add_geom(name=obs.name, type=kind.mjGEOM_CAPSULE, size=[obs.radius, 0.0, 0.0],
                            fromto=np.concatenate([obs.a, obs.b]))  # fmt: skip
        elif isinstance(obs, BoxObstacle):
            quat = np.empty(4)
            mujoco.mju_mat2Quat(quat, np.ascontiguousarray(obs.rotation).ravel())
            holder.add_geom(name=obs.name, type=kind.mjGEOM_BOX, pos=obs.center, quat=quat,
                            size=obs.half_extents)  # fmt: skip
        elif isinstance(obs, PlaneObstacle):
            quat = np.empty(4)  # the plane's z axis along the normal: solid below
            mujoco.mju_quatZ2Vec(quat, obs.normal)
            world.add_geom(name=obs.name, type=kind.mjGEOM_PLANE, pos=obs.offset * obs.normal,
                           quat=quat, size=[0.0, 0.0, 1.0])  # fmt: skip
        else:
            raise TypeError(f"no MuJoCo geom for {type(obs).__name__}")
    model = spec.compile()
    model.jnt_range[: robot.n] = np.column_stack([robot.q_min, robot.q_max])
    return model


def capsule_gap(mujoco: Any, model: Any, robot: Any, count: int = 5, seed: int = 0) -> float:
    """Largest distance (m) between a capsule's ends in ``model`` (MuJoCo) and in redres
    at random configurations: 0 up to round-off when both place the same capsules."""
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(count):
        q = robot.random_configuration(rng)
        data.qpos[: robot.n] = q
        mujoco.mj_kinematics(model, data)
        for cap in robot.capsules:
            g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, cap.name)
            axis = data.geom_xmat[g].reshape(3, 3)[:, 2] * model.geom_size[g, 1]
            T = robot.fk(q, cap.frame)
            a, b = (T[:3, :3] @ p + T[:3, 3] for p in (cap.a, cap.b))
            ours = np.concatenate([a, b])
            theirs = np.concatenate([data.geom_xpos[g] - axis, data.geom_xpos[g] + axis])
            flipped = np.concatenate([theirs[3:], theirs[:3]])
            worst = max(worst, min(np.abs(ours - theirs).max(), np.abs(ours - flipped).max()))
    return worst


# --- PlaCo, in its own interpreter (step.py, differential.py, quality.py)

PLACO_WORKER = Path(__file__).with_name("placo_peer.py")


def placo_python() -> str | None:
    """The Python that imports ``placo``: ``$PLACO_PYTHON``, else this one if it has it.

    PlaCo 0.10.2 pins ``pin==3.8.0`` (through cmeel), which cannot be installed beside
    redres' Pinocchio 4: install it in its own environment (``python -m venv ...; pip
    install placo``) and name that environment's ``python`` in ``PLACO_PYTHON``."""
    path = os.environ.get("PLACO_PYTHON")
    if path:
        return path
    import importlib.util

    if importlib.util.find_spec("placo") is not None:
        return sys.executable
    note("PlaCo (pip install placo, in its own venv: it pins pin 3.8) not found: set "
         "PLACO_PYTHON to that venv's python; skipped")  # fmt: skip
    return None


def placo_job(name: str, kind: str, directory: Path, **fields: Any) -> dict[str, Any]:
    """A job for ``placo_peer.py`` on arm ``name``: its URDF written to ``directory``, the
    tip link, the joints, redres' limits of that arm (those every peer uses), and
    ``fields`` (``dt``, ``q``, ``target``, ``setups``, ... as the worker reads them)."""
    robot = rr.models.load(name)
    joints = [j for j, revolute, _ in urdf_joints(arm_urdf(name), TIP_LINK[name]) if revolute]
    rng = np.random.default_rng(5)
    check = [robot.random_configuration(rng).tolist() for _ in range(3)]
    job: dict[str, Any] = {
        "kind": kind, "urdf": str(write_urdf(name, directory)), "tip": TIP_LINK[name],
        "joints": joints, "q_min": robot.q_min.tolist(), "q_max": robot.q_max.tolist(),
        "qd_max": robot.qd_max.tolist(), "check_q": check,
    }  # fmt: skip
    job.update({k: np.asarray(v).tolist() if isinstance(v, np.ndarray) else v
                for k, v in fields.items()})  # fmt: skip
    return job


def _check_placo_poses(name: str, job: dict[str, Any], poses: list[list[float]]) -> None:
    robot = rr.models.load(name)
    for q, pose in zip(job["check_q"], poses):
        gap = float(np.abs(np.reshape(pose, (4, 4)) - robot.fk(q, TIP_FRAME[name])).max())
        if not gap < 1e-9:
            raise AssertionError(
                f"PlaCo's {name} is not redres' {name}: tip poses differ "
                f"by {gap:.3g}; fix benchmarks/peers.py before comparing"
            )


class PlacoSteps:
    """PlaCo's steps of a ``"step"`` job in its own process, timed there one block at a time
    on request (``placo_peer.py --serve``): a benchmark interleaves :meth:`block` with its
    own contenders, so that the machine's load hits PlaCo as it hits them. ``q_after``:
    each setup's ``q`` after one step. Use :func:`placo_steps` (None without PlaCo)."""

    def __init__(self, name: str, job: dict[str, Any], python: str) -> None:
        """The arguments are described in ``help(PlacoSteps)``."""
        import json
        import subprocess

        self._json = json
        self._process = subprocess.Popen(
            [python, str(PLACO_WORKER), "--serve"], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        first = self._ask(json.dumps(job))
        _check_placo_poses(name, job, first["fk"])
        self.q_after: dict[str, list[float]] = first["q_after"]

    def _ask(self, line: str) -> Any:
        stdin, stdout = self._process.stdin, self._process.stdout
        if stdin is None or stdout is None:  # pragma: no cover - Popen was given pipes
            raise RuntimeError("PlaCo's process has no pipes")
        stdin.write(line + "\n")
        stdin.flush()
        answer = stdout.readline()
        if not answer:
            raise RuntimeError("PlaCo's process ended; its error is above")
        return self._json.loads(answer)

    def block(self, key: str, calls: int, per_call: bool) -> list[float]:
        """One block of ``calls`` calls of setup ``key``: each call's time, or the block's
        mean per call (µs)."""
        return list(self._ask(f"{key} {calls} {int(per_call)}"))

    def close(self) -> None:
        """End PlaCo's process."""
        if self._process.poll() is None:
            self._ask_quit()

    def _ask_quit(self) -> None:
        stdin = self._process.stdin
        if stdin is not None:
            stdin.write("quit\n")
            stdin.flush()
        self._process.wait(timeout=60)


def placo_steps(name: str, job: dict[str, Any]) -> PlacoSteps | None:
    """:class:`PlacoSteps` of ``job`` on arm ``name``, or None (with a note) without PlaCo."""
    python = placo_python()
    return None if python is None else PlacoSteps(name, job, python)


def placo_run(name: str, job: dict[str, Any], timeout: float = 900.0) -> dict[str, Any] | None:
    """Run one job in PlaCo's interpreter; None (with a note) when PlaCo is absent or
    fails. Aborts loudly when PlaCo's tip poses differ from redres' on arm ``name``."""
    import json
    import subprocess

    python = placo_python()
    if python is None:
        return None
    done = subprocess.run([python, str(PLACO_WORKER)], input=json.dumps(job),
                          capture_output=True, text=True, timeout=timeout, check=False)  # fmt: skip
    if done.returncode != 0:
        note(f"PlaCo failed: {done.stderr.strip().splitlines()[-1:]}; skipped")
        return None
    result: dict[str, Any] = json.loads(done.stdout)
    _check_placo_poses(name, job, result["fk"])
    return result
