"""Franka Emika Panda (FER): 7-DOF arm, modified DH, with its hand.

Sources:
    Kinematics, limits: Franka Robotics, "Robot and interface specifications — Panda"
        (modified DH table: a, d, α per joint; flange at d = 0.107 m along z7; the hand is
        turned −π/4 about the flange z; the TCP is 0.1034 m along the hand z), and
        "Limits for Panda" (position, velocity, acceleration and torque limits).
    Link inertias: C. Gaz, M. Cognetti, A. Oliva, P. Robuffo Giordano, A. De Luca,
        "Dynamic Identification of the Franka Emika Panda Robot With Retrieval of Feasible
        Parameters Using Penalty-Based Optimization", IEEE RA-L 4(4):4147–4154, 2019,
        in the same modified-DH link frames (the link-1 centre-of-mass height is the value
        adopted by Franka's robot description; it lies on joint 1's axis and does not
        enter the dynamics).
    Hand: mass 0.73 kg, centre of mass and inertia from Franka's robot description.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..robot import DHLink, Robot, capsule_chain
from .franka import PANDA

#: Joint limits (Franka "Limits for Panda", :data:`redres.models.franka.PANDA`).
Q_MIN, Q_MAX, QD_MAX, QDD_MAX, QDDD_MAX, TAU_MAX = PANDA[:6]

#: Modified DH (a_{i-1} m, d_i m, α_{i-1} rad) per joint.
DH = (
    (0.0, 0.333, 0.0),
    (0.0, 0.0, -np.pi / 2),
    (0.0, 0.316, np.pi / 2),
    (0.0825, 0.0, np.pi / 2),
    (-0.0825, 0.384, -np.pi / 2),
    (0.0, 0.0, np.pi / 2),
    (0.088, 0.0, np.pi / 2),
)
FLANGE_D = 0.107
TCP_D = 0.1034

#: Gaz et al. 2019: (mass kg, com m, [ixx, ixy, ixz, iyy, iyz, izz] kg·m² about the com).
INERTIALS = (
    (
        4.970684,
        (3.875e-3, 2.081e-3, -4.762e-2),
        (7.0337e-1, -1.39e-4, 6.772e-3, 7.0661e-1, 1.9169e-2, 9.117e-3),
    ),
    (
        0.646926,
        (-3.141e-3, -2.872e-2, 3.495e-3),
        (7.962e-3, -3.925e-3, 1.0254e-2, 2.811e-2, 7.04e-4, 2.5995e-2),
    ),
    (
        3.228604,
        (2.7518e-2, 3.9252e-2, -6.6502e-2),
        (3.7242e-2, -4.761e-3, -1.1396e-2, 3.6155e-2, -1.2805e-2, 1.083e-2),
    ),
    (
        3.587895,
        (-5.317e-2, 1.04419e-1, 2.7454e-2),
        (2.5853e-2, 7.796e-3, -1.332e-3, 1.9552e-2, 8.641e-3, 2.8323e-2),
    ),
    (
        1.225946,
        (-1.1953e-2, 4.1065e-2, -3.8437e-2),
        (3.5549e-2, -2.117e-3, -4.037e-3, 2.9474e-2, 2.29e-4, 8.627e-3),
    ),
    (
        1.666555,
        (6.0149e-2, -1.4117e-2, -1.0517e-2),
        (1.964e-3, 1.09e-4, -1.158e-3, 4.354e-3, 3.41e-4, 5.433e-3),
    ),
    (
        0.735522,
        (1.0517e-2, -4.252e-3, 6.1597e-2),
        (1.2516e-2, -4.28e-4, -1.196e-3, 1.0027e-2, -7.41e-4, 4.815e-3),
    ),
)
HAND_MASS = 0.73
HAND_COM = (-0.01, 0.0, 0.03)  # in the hand frame
HAND_INERTIA = (0.001, 0.0, 0.0, 0.0025, 0.0, 0.0017)

#: The "ready" pose of Franka's examples.
HOME = (0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, np.pi / 4)


def inertia_matrix(
    ixx: float, ixy: float, ixz: float, iyy: float, iyz: float, izz: float
) -> np.ndarray:
    """Symmetric 3x3 inertia matrix from its six URDF-style entries."""
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


def _rot_z(angle: float) -> np.ndarray:
    return pin.SE3(pin.utils.rotate("z", angle), np.zeros(3)).homogeneous


def _trans_z(d: float) -> np.ndarray:
    return pin.SE3(np.eye(3), np.array([0.0, 0.0, d])).homogeneous


def panda_links(*, hand: bool = True) -> list[DHLink]:
    """The Panda's seven modified-DH records with limits and inertias."""
    links = []
    for i, ((a, d, alpha), (mass, com, inertia)) in enumerate(zip(DH, INERTIALS)):
        m, c, I = mass, np.array(com), inertia_matrix(*inertia)
        if hand and i == 6:
            body = _merge_hand(m, c, I)
            m, c, I = body.mass, body.lever, body.inertia
        links.append(
            DHLink(
                a=a,
                alpha=alpha,
                d=d,
                q_min=Q_MIN[i],
                q_max=Q_MAX[i],
                qd_max=QD_MAX[i],
                qdd_max=QDD_MAX[i],
                qddd_max=QDDD_MAX[i],
                tau_max=TAU_MAX[i],
                mass=m,
                com=tuple(c),
                inertia=I,
                name=f"panda_joint{i + 1}",
            )
        )
    return links


def _merge_hand(m7: float, c7: np.ndarray, I7: np.ndarray) -> pin.Inertia:
    """Link 7 and the rigidly attached hand as one body, in the link-7 frame (Pinocchio's
    sum of inertias: combined centre of mass, parallel-axis theorem)."""
    hand = pin.Inertia(HAND_MASS, np.array(HAND_COM), inertia_matrix(*HAND_INERTIA))
    T_7_hand = pin.SE3(_trans_z(FLANGE_D) @ _rot_z(-np.pi / 4))
    return pin.Inertia(m7, c7, I7) + T_7_hand.act(hand)


def panda(*, hand: bool = True) -> Robot:
    """The Franka Emika Panda.

    Args:
        hand: include the Franka Hand's mass in link 7 (the frames ``hand`` and ``tcp``
            exist either way).

    Frames: ``base``, ``link1`` … ``link7`` (modified DH), ``flange``, ``hand``, ``tcp``
    (default tip), and ``shoulder``, ``elbow``, ``wrist`` (the origins of DH frames 2, 4
    and 6: the shoulder point where axes 1–3 meet, the elbow joint, the point where
    axes 5 and 6 meet). ``neutral()`` is Franka's ready pose.
    """
    robot = Robot.from_dh(
        panda_links(hand=hand),
        "modified",
        tool=_trans_z(FLANGE_D),
        name="panda",
        tip="tcp",
        tool_name="flange",
        frames={
            "hand": ("flange", _rot_z(-np.pi / 4)),
            "tcp": ("hand", _trans_z(TCP_D)),
            "shoulder": ("link2", np.eye(4)),
            "elbow": ("link4", np.eye(4)),
            "wrist": ("link6", np.eye(4)),
        },
        home=HOME,
    )
    robot.capsules = capsule_chain(
        robot, ("base", "shoulder", "elbow", "wrist", "link7", "tcp"),
        links=("link1", "link3", "link4", "link6", "link7"), radii=(0.09, 0.08, 0.07, 0.06, 0.05),
        names=("base", "upper_arm", "forearm", "wrist", "hand"),
    )  # fmt: skip
    return robot
