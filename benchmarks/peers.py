"""The same Panda for every peer library, built from the same published parameters.

Each ``make_*`` returns ``None`` with a note when the peer is not installed, so a missing
peer is skipped, never a failure. KDL comes from Debian's ``python3-pykdl`` and is reached
through the system site-packages.
"""

from __future__ import annotations

import re
import sys
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
