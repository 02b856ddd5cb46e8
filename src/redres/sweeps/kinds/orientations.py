"""The orientations a capability map tests at each voxel, and binning a pose into them.

Directions: ``N`` points spread uniformly on the unit sphere by the Fibonacci (golden
angle) lattice: point ``i`` at height ``z_i = 1 − (2i + 1)/N`` and azimuth ``i·π(3 − √5)``
(Á. González, "Measurement of areas on a sphere using Fibonacci and latitude–longitude
lattices", Math. Geosci. 42, 2010): every point stands for an equal area ``4π/N``, the
same lattice Reuleaux's map creator offers. A direction is the tool's z axis (the
approach axis) in the world; its frame completes it with an x axis from the world x axis
(the world y axis when the direction is within 25° of x) by Gram–Schmidt, and ``R`` roll
angles ``2πj/R`` turn that frame about its z axis.

Binning: a rotation belongs to the tested orientation nearest to it, the one with the
largest ``tr(R_oᵀ R)`` (the smallest rotation angle between them, since
``tr = 1 + 2 cos θ``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["directions", "frames", "nearest"]


def directions(count: int) -> np.ndarray:
    """``count`` unit vectors of the Fibonacci lattice, ``(count, 3)``."""
    i = np.arange(count, dtype=np.float64)
    z = 1.0 - (2.0 * i + 1.0) / count
    radius = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    azimuth = i * math.pi * (3.0 - math.sqrt(5.0))
    return np.column_stack((radius * np.cos(azimuth), radius * np.sin(azimuth), z))


def frames(axes: np.ndarray, rolls: int) -> np.ndarray:
    """Rotations with z axis ``axes[i]`` and roll ``2πj/rolls`` about it,
    ``(len(axes) · rolls, 3, 3)``, direction-major (index ``i · rolls + j``)."""
    d = np.asarray(axes, dtype=np.float64)
    reference = np.where(np.abs(d[:, :1]) > math.cos(math.radians(25.0)),
                         [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])  # fmt: skip
    x = reference - np.sum(reference * d, axis=1, keepdims=True) * d
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(d, x)
    base = np.stack((x, y, d), axis=2)  # columns x, y, z
    angles = 2.0 * math.pi * np.arange(rolls) / rolls
    c, s = np.cos(angles), np.sin(angles)
    roll = np.zeros((rolls, 3, 3))
    roll[:, 0, 0], roll[:, 0, 1], roll[:, 1, 0], roll[:, 1, 1] = c, -s, s, c
    roll[:, 2, 2] = 1.0
    return np.einsum("dab,rbc->drac", base, roll).reshape(-1, 3, 3)


def nearest(rotations: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Index of the orientation of ``rotations`` (O, 3, 3) nearest to each of ``R``
    (N, 3, 3): the largest ``tr(R_oᵀ R)``."""
    traces = np.einsum("oab,nab->no", rotations, np.asarray(R, dtype=np.float64))
    return np.argmax(traces, axis=1)
