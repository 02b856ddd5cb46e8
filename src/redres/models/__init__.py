"""Built-in robot models from published parameters (sources cited in each module).

>>> import redres as rr
>>> rr.models.names()
['iiwa14', 'panda', 'planar2', 'planar3', 'srs7']
>>> rr.models.load("panda").n
7
"""

from __future__ import annotations

import difflib
from collections.abc import Callable

from ..errors import RobotNotFoundError
from ..robot import Robot
from .example_robots import example_robot, example_robot_names
from .iiwa import iiwa14
from .mujoco_menagerie import menagerie, menagerie_path
from .panda import panda
from .planar import planar
from .srs import srs7

_BUILTIN: dict[str, Callable[[], Robot]] = {
    "iiwa14": iiwa14,
    "panda": panda,
    "planar2": lambda: planar([1.0, 1.0]),
    "planar3": lambda: planar([1.0, 1.0, 1.0]),
    "srs7": srs7,
}


def names() -> list[str]:
    """Names of the built-in robots, for :func:`load`."""
    return sorted(_BUILTIN)


def load(name: str) -> Robot:
    """A fresh instance of the built-in robot ``name`` (see :func:`names`)."""
    try:
        factory = _BUILTIN[name]
    except (KeyError, TypeError):
        close = difflib.get_close_matches(str(name), names(), n=2, cutoff=0.5)
        hint = f"did you mean {' or '.join(map(repr, close))}? " if close else ""
        raise RobotNotFoundError(
            f"unknown robot {name!r}; {hint}built-in robots: {', '.join(names())}"
        ) from None
    return factory()


__all__ = [
    "example_robot",
    "example_robot_names",
    "iiwa14",
    "load",
    "menagerie",
    "menagerie_path",
    "names",
    "panda",
    "planar",
    "srs7",
]
