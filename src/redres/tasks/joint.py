"""Joint-space task: hold joints at a reference (the usual lowest priority level)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_vector
from ..errors import InvalidParameterError, ShapeError
from .base import Task, TaskState

if TYPE_CHECKING:
    from ..robot import Robot


class PostureTask(Task):
    """Joint positions toward a reference: ``e = q_ref − q`` on some joints, ``J`` = rows of ``I``.

    The usual lowest level ("posture third"). Args:
        q_ref: reference configuration, shape ``(n,)``, rad (``None``: ``robot.neutral()``).
        joints: indices of the joints to hold (default: all).
        name: name for logs.
    """

    def __init__(
        self, q_ref: Any = None, joints: Sequence[int] | None = None, *, name: str = "posture"
    ) -> None:
        """The arguments are described in ``help(PostureTask)``."""
        self.q_ref = None if q_ref is None else as_vector(q_ref, "q_ref").copy()
        self.joints = None if joints is None else [int(j) for j in joints]
        if self.joints is not None and (
            not self.joints or len(set(self.joints)) != len(self.joints)
        ):
            raise InvalidParameterError(f"joints must be distinct indices; got {joints}")
        n_ref = 0 if self.q_ref is None else self.q_ref.size
        self.dim = n_ref if self.joints is None else len(self.joints)
        self.name = name
        self._rows: FloatArray | None = None  # the rows of I, built for the robot's n
        self._idx: list[int] = []

    def compute(self, robot: Robot, q: FloatArray) -> TaskState:
        n = robot.n
        q_ref = robot.neutral() if self.q_ref is None else self.q_ref
        if q_ref.shape != (n,):
            raise ShapeError(
                f"q_ref must have shape ({n},) for robot {robot.name!r}; got {q_ref.shape}"
            )
        if self._rows is None or self._rows.shape[1] != n:
            idx = list(range(n)) if self.joints is None else self.joints
            if not 0 <= min(idx) <= max(idx) < n:
                raise InvalidParameterError(f"joints must be indices in 0..{n - 1}; got {idx}")
            self._rows, self._idx, self.dim = np.eye(n)[idx], idx, len(idx)
        return TaskState((q_ref - q)[self._idx], self._rows, np.zeros(self.dim))
