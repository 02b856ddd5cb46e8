"""Which pairs are checked: link capsules against obstacles, and against each other.

Environment pairs are every (capsule, obstacle). Self pairs are every two capsules except

- capsules on the same or on adjacent links (their frames' parent joints at most one
  apart along the chain): they touch at the joint by construction;
- pairs whose shapes are within the safety distance at the robot's neutral pose (in
  contact there: the model puts them so, a constraint could only push them apart);
- pairs a user allows (``allowed``, by capsule or frame name), the idea of an SRDF's
  ``<disable_collisions link1=… link2=…/>``, which :func:`read_srdf` reads.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import InvalidParameterError

if TYPE_CHECKING:
    from ..robot import Capsule, Robot


@dataclass(frozen=True)
class Pair:
    """One checked pair.

    Attributes:
        first: the link capsule's name.
        second: the obstacle's name, or the other capsule's.
        self_pair: both shapes are link capsules (both move).
    """

    first: str
    second: str
    self_pair: bool

    @property
    def names(self) -> tuple[str, str]:
        """``(first, second)``."""
        return self.first, self.second


def read_srdf(source: str | Path) -> list[tuple[str, str]]:
    """The ``(link1, link2)`` of every ``<disable_collisions>`` of an SRDF (a path, or the
    XML text itself when it starts with ``<``). Parsed as data, nothing executed.

    Raises:
        InvalidParameterError: the file cannot be read or is not XML.
    """
    text = str(source)
    try:
        root = ET.fromstring(text) if text.lstrip().startswith("<") else ET.parse(text).getroot()
    except (OSError, ET.ParseError) as exc:
        raise InvalidParameterError(f"srdf {text[:80]!r} cannot be read as XML: {exc}") from exc
    found = []
    for element in root.iter("disable_collisions"):
        a, b = element.get("link1"), element.get("link2")
        if not a or not b:
            raise InvalidParameterError(
                "srdf: every <disable_collisions> needs link1= and link2= attributes; got "
                f"{element.attrib}"
            )
        found.append((a, b))
    return found


def allowed_set(
    allowed: Iterable[Sequence[str]], srdf: str | Path | None
) -> frozenset[frozenset[str]]:
    """The allowed pairs (each a set of two names), the user's and the SRDF's.

    Raises:
        InvalidParameterError: an entry is not two names.
    """
    pairs = [tuple(p) for p in allowed]
    for p in pairs:
        if len(p) != 2 or not all(isinstance(x, str) for x in p):
            raise InvalidParameterError(
                f"allowed must list pairs of two names (capsules, links or obstacles); got {p!r}"
            )
    if srdf is not None:
        pairs += read_srdf(srdf)
    return frozenset(frozenset(p) for p in pairs)


def _names(capsule: Capsule) -> tuple[str, str]:
    return capsule.name, capsule.frame


def is_allowed(
    allowed: frozenset[frozenset[str]], first: Sequence[str], second: Sequence[str]
) -> bool:
    """Whether any name of the first shape and any of the second form an allowed pair."""
    return any(frozenset((a, b)) in allowed for a in first for b in second)


def candidate_self_pairs(
    robot: Robot, capsules: Sequence[Capsule], allowed: frozenset[frozenset[str]]
) -> list[tuple[int, int]]:
    """Indices ``(i, j)``, ``i < j``, of capsule pairs on links more than one joint apart
    that are not allowed to touch (module docstring)."""
    joints = [robot.model.frames[robot.frame_id(c.frame)].parentJoint for c in capsules]
    out = []
    for i in range(len(capsules)):
        for j in range(i + 1, len(capsules)):
            if abs(joints[i] - joints[j]) <= 1:
                continue
            if is_allowed(allowed, _names(capsules[i]), _names(capsules[j])):
                continue
            out.append((i, j))
    return out
