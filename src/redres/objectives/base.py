"""Secondary objectives: costs D(q) to minimise, with analytic gradients.

The null-space term of a scheme is ``−k N ∇D`` (docs/conventions.md). A quantity to
maximise is wrapped as a cost.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from .._validate import FloatArray, as_vector

if TYPE_CHECKING:
    from ..robot import Robot


class Objective(ABC):
    """A scalar cost ``D(q)`` and its gradient ``∇D(q)`` (shape ``(n,)``)."""

    name: str = "objective"

    @abstractmethod
    def cost(self, robot: Robot, q: FloatArray) -> float:
        """``D(q)``."""

    @abstractmethod
    def gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        """``∂D/∂q``, shape ``(n,)``."""

    def _gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        """:meth:`gradient` of a ``q`` the caller has checked (a scheme's step checked it
        once for all its objectives); an objective whose check costs more than its
        formula computes it here without one."""
        return self.gradient(robot, q)

    def quadratic_form(self, robot: Robot) -> tuple[FloatArray, FloatArray] | None:
        """``(a, r)``, each shape ``(n,)``, when ``∇D(q) = a ∘ (q − r)`` for every ``q``.

        A diagonal quadratic cost has such a form; the controller's fused path
        (:class:`redres.control.Controller`) evaluates its gradient inside its kernel.
        ``None`` (the default) for any other cost.
        """
        return None

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"


def quadratic_coefficients(
    robot: Robot, objectives: Sequence[tuple[Objective, float]]
) -> tuple[FloatArray, FloatArray] | None:
    """``(a, r)`` with ``Σ wᵢ ∇Dᵢ(q) = a ∘ (q − r)`` for weighted diagonal quadratic costs
    ``∇Dᵢ = aᵢ ∘ (q − rᵢ)``: ``a = Σ wᵢ aᵢ``, ``r = Σ wᵢ aᵢ rᵢ / a`` (0 where ``a = 0``;
    one cost's ``rᵢ`` as it is). None if a cost has no quadratic form (or there are none).
    """
    if not objectives:
        return None
    forms = []
    for obj, weight in objectives:
        form = obj.quadratic_form(robot)
        if form is None:
            return None
        ai, ri = (as_vector(x, f"quadratic form of {obj.name}", robot.n) for x in form)
        forms.append((weight * ai, ri))
    if len(forms) == 1:
        return forms[0]
    a = np.sum([ai for ai, _ in forms], axis=0)
    ar = np.sum([ai * ri for ai, ri in forms], axis=0)
    r = np.divide(ar, a, out=np.zeros(robot.n), where=a != 0.0)
    return a, r
