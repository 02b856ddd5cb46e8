"""Planar serial arms with revolute joints about the world z axis (the textbook RR, RRR)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InvalidParameterError
from ..robot import DHLink, Robot


def planar(lengths: Sequence[float] = (1.0, 1.0, 1.0), *, link_mass: float = 1.0) -> Robot:
    """A planar arm in the world x-y plane, standard DH with ``a_i = lengths[i]``.

    The Jacobian rows ``[0, 1, 5]`` are the textbook ``(ẋ, ẏ, ω_z)``. Each link is a thin
    uniform rod of mass ``link_mass`` (kg) so that the dynamics are defined; joint
    limits are ±π. Frames: ``base``, ``link1`` … ``link<n>`` and ``tool`` (the tip).
    """
    ls = np.asarray(lengths, dtype=float)
    if ls.ndim != 1 or ls.size == 0 or not np.all(np.isfinite(ls)) or np.any(ls <= 0):
        raise InvalidParameterError(f"lengths must be positive link lengths (m); got {lengths}")
    if not np.isfinite(link_mass) or link_mass < 0:
        raise InvalidParameterError(f"link_mass must be >= 0 kg; got {link_mass}")
    links = [
        DHLink(
            a=float(length),
            alpha=0.0,
            d=0.0,
            mass=link_mass,
            com=(-length / 2, 0.0, 0.0),
            inertia=np.diag([0.0, 1.0, 1.0]) * link_mass * length**2 / 12.0,
        )
        for length in ls
    ]
    return Robot.from_dh(links, "standard", name=f"planar{ls.size}", tip="tool")
