"""URDFs shipped by the ``example-robot-data`` package (the ``robots`` extra)."""

from __future__ import annotations

import difflib
from importlib import metadata
from pathlib import Path

from ..errors import MissingDependencyError, RobotNotFoundError, install_hint
from ..robot import Robot

_DIST = "example-robot-data"


def _robots_dir() -> Path:
    try:
        dist = metadata.distribution(_DIST)
    except metadata.PackageNotFoundError:
        raise MissingDependencyError(
            "example-robot-data is not installed; install the robots extra: "
            + install_hint("robots")
        ) from None
    root = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    if not root.is_dir():
        raise MissingDependencyError(f"example-robot-data has no robots folder at {root}")
    return root


def example_robot_names() -> list[str]:
    """Names (URDF file stems) of the URDFs that example-robot-data ships."""
    return sorted({p.stem for p in _robots_dir().rglob("*.urdf")})


def example_robot(name: str, tip: str | None = None, **kwargs: object) -> Robot:
    """Load the example-robot-data URDF called ``name`` (e.g. ``"panda"``, ``"ur5_robot"``).

    Args:
        name: URDF file stem; :func:`example_robot_names` lists them.
        tip: end of the chain to keep (required when the URDF branches, e.g. a gripper).
        **kwargs: passed to :meth:`Robot.from_urdf` (``locked``, ``continuous_limits``).
    """
    paths = sorted(_robots_dir().rglob(f"{name}.urdf"))
    if not paths:
        names = example_robot_names()
        close = difflib.get_close_matches(name, names, n=3, cutoff=0.5)
        close += [n for n in names if n.startswith(name) and n not in close][:3]
        hint = f"did you mean {' or '.join(map(repr, close[:3]))}? " if close else ""
        raise RobotNotFoundError(
            f"example-robot-data has no URDF named {name!r}; {hint}names: {', '.join(names)}"
        )
    return Robot.from_urdf(paths[0], tip=tip, name=name, **kwargs)  # type: ignore[arg-type]
