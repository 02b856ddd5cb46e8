"""A generic 7-DOF S-R-S anthropomorphic arm (Kreutz-Delgado, Long & Seraji 1992).

Three intersecting shoulder axes, a pitch elbow, three intersecting wrist axes, in
standard DH with ``a = 0``: base-to-shoulder 0.34 m, upper arm 0.40 m, forearm 0.40 m,
wrist-to-flange 0.126 m (the proportions of a KUKA LBR iiwa 7). The inertial parameters
are synthetic (uniform cylinders of radius 0.05 m), for dynamics examples only.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..robot import Capsule, DHLink, Robot, capsule_chain

D_BS, D_SE, D_EW, D_WF = 0.34, 0.40, 0.40, 0.126
HOME = (0.0, np.pi / 6, 0.0, -np.pi / 2, 0.0, np.pi / 3, 0.0)

_DEG = np.pi / 180.0
_LIMITS = (170, 120, 170, 120, 170, 120, 175)
_QD_MAX = (1.5, 1.5, 1.75, 1.75, 2.5, 2.5, 2.5)
_TAU_MAX = (200.0, 200.0, 100.0, 100.0, 50.0, 30.0, 30.0)
_RADIUS = 0.05


def _cylinder(mass: float, length: float, axis: int) -> np.ndarray:
    """Inertia about the centre of a uniform solid cylinder along ``axis`` (0, 1, 2)."""
    perp = mass * (3 * _RADIUS**2 + length**2) / 12.0
    inertia = np.full(3, perp)
    inertia[axis] = mass * _RADIUS**2 / 2.0
    return np.diag(inertia)


def srs7() -> Robot:
    """The generic S-R-S arm. Frames: ``link1`` … ``link7``, ``tool`` (default tip,
    at the flange), ``shoulder``, ``elbow``, ``wrist`` (centres of the three groups)."""
    # (d, alpha, mass, com in the DH frame, inertia) per joint; frames 1, 3, 5 sit at the
    # shoulder, elbow and wrist centres.
    geometry = (
        (D_BS, -np.pi / 2, 3.0, (0.0, 0.0, 0.0), _cylinder(3.0, 0.12, 2)),
        (0.0, np.pi / 2, 2.0, (0.0, 0.0, 0.0), _cylinder(2.0, 0.12, 2)),
        (D_SE, np.pi / 2, 3.0, (0.0, -D_SE / 2, 0.0), _cylinder(3.0, D_SE, 1)),
        (0.0, -np.pi / 2, 1.5, (0.0, 0.0, 0.0), _cylinder(1.5, 0.10, 2)),
        (D_EW, -np.pi / 2, 2.0, (0.0, D_EW / 2, 0.0), _cylinder(2.0, D_EW, 1)),
        (0.0, np.pi / 2, 1.0, (0.0, 0.0, 0.0), _cylinder(1.0, 0.08, 2)),
        (D_WF, 0.0, 0.5, (0.0, 0.0, -0.03), _cylinder(0.5, 0.06, 2)),
    )
    links = [
        DHLink(
            a=0.0,
            alpha=alpha,
            d=d,
            q_min=-_LIMITS[i] * _DEG,
            q_max=_LIMITS[i] * _DEG,
            qd_max=_QD_MAX[i],
            tau_max=_TAU_MAX[i],
            mass=m,
            com=com,
            inertia=inertia,
        )
        for i, (d, alpha, m, com, inertia) in enumerate(geometry)
    ]
    eye = np.eye(4)
    robot = Robot.from_dh(
        links,
        "standard",
        name="srs7",
        tip="tool",
        frames={"shoulder": ("link1", eye), "elbow": ("link3", eye), "wrist": ("link5", eye)},
        home=HOME,
    )
    robot.capsules = sew_capsules(robot, "base", "tool", (0.08, 0.07, 0.06, 0.05))
    return robot


def sew_capsules(robot: Robot, base: str, tip: str, radii: Sequence[float]) -> list[Capsule]:
    """The four capsules of a spherical–revolute–spherical arm whose frames ``shoulder``,
    ``elbow`` and ``wrist`` sit at the joint centres: base → shoulder on ``link1``, the
    upper arm on ``link3``, the forearm on ``link5``, wrist → ``tip`` on ``link7``."""
    return capsule_chain(
        robot, (base, "shoulder", "elbow", "wrist", tip),
        links=("link1", "link3", "link5", "link7"), radii=radii,
        names=("base", "upper_arm", "forearm", "hand"),
    )  # fmt: skip
