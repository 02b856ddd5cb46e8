"""Arms of a local MuJoCo Menagerie checkout (github.com/google-deepmind/mujoco_menagerie).

redres does not download models: point ``root`` (or the environment variable
``MUJOCO_MENAGERIE``) at a checkout, or at any folder laid out like one
(``<folder>/<file>.xml`` with its meshes). Without either, the four arms of ``ARMS``
but the Gen3 come from copies shipped with redres (``models/data/menagerie``: the
Menagerie's files with the meshes removed, their licenses and commits kept there).
``menagerie("fr3")`` is the Franka FR3 of ``franka_fr3/fr3.xml`` with Franka's published
joint limits (:mod:`.franka`: MJCF files carry no velocity, acceleration or jerk limits);
:func:`menagerie_path` gives the file for :class:`redres.sim.MujocoPlant`.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import ModelFileNotFoundError, RobotNotFoundError
from ..robot import Robot
from .franka import FR3, PANDA, JointLimits

#: The Menagerie's Panda, FR3, iiwa14 and xArm7 shipped with redres, meshes removed.
SHIPPED = Path(__file__).parent / "data" / "menagerie"

#: Short names of the Menagerie's arms: (folder, file without a hand, published limits).
ARMS: dict[str, tuple[str, str, JointLimits | None]] = {
    "panda": ("franka_emika_panda", "panda_nohand.xml", PANDA),
    "fr3": ("franka_fr3", "fr3.xml", FR3),
    "iiwa14": ("kuka_iiwa_14", "iiwa14.xml", None),
    "xarm7": ("ufactory_xarm7", "xarm7_nohand.xml", None),
    "gen3": ("kinova_gen3", "gen3.xml", None),
}


def menagerie_path(name: str, root: str | Path | None = None) -> Path:
    """The MJCF file of arm ``name`` (a key of ``ARMS``, or ``"<folder>/<file>.xml"``)
    in the checkout ``root`` (default: ``$MUJOCO_MENAGERIE``, else the copies shipped with
    redres, ``SHIPPED``).

    Raises:
        RobotNotFoundError: an unknown name.
        ModelFileNotFoundError: the file is not in the checkout (the message says how to
            get one).
    """
    where = root if root is not None else os.environ.get("MUJOCO_MENAGERIE", SHIPPED)
    if name in ARMS:
        folder, file, _ = ARMS[name]
        relative = Path(folder) / file
    elif name.endswith(".xml"):
        relative = Path(name)
    else:
        raise RobotNotFoundError(
            f"unknown Menagerie arm {name!r}; known: {', '.join(ARMS)}, or '<folder>/<file>.xml'"
        )
    path = Path(where) / relative
    if not path.is_file():
        hint = ""
        if where == SHIPPED:
            hint = (" (redres ships four arms without meshes; for the others pass root=... or "
                    "set MUJOCO_MENAGERIE to a clone of "
                    "https://github.com/google-deepmind/mujoco_menagerie)")  # fmt: skip
        raise ModelFileNotFoundError(f"{relative} is not in the Menagerie checkout {where}{hint}")
    return path


def menagerie(name: str, root: str | Path | None = None, *, tip: str | None = None) -> Robot:
    """The robot of arm ``name`` of a Menagerie checkout (:func:`menagerie_path`), with the
    vendor's published velocity, acceleration, jerk and torque limits where
    ``ARMS`` has them."""
    robot = Robot.from_mjcf(menagerie_path(name, root), tip=tip)
    limits = ARMS[name][2] if name in ARMS else None
    return robot if limits is None else robot.with_limits(**limits.rates())
