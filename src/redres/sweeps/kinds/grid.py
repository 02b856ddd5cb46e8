"""The voxel grid of a capability map, and which voxels are worth testing.

Grid: cubes of edge ``resolution`` aligned on the world origin: voxel ``(i, j, k)`` is
``[i, i + 1) × [j, j + 1) × [k, k + 1)`` times the resolution, its centre at
``(i + ½, j + ½, k + ½)·resolution``. The map covers the voxels whose centres lie in the
bounds; by default a cube around the first joint of half-width the reach bound.

Which voxels are tested (every other voxel is recorded as not reachable, untested):

1. **Reach bound (a proof).** For revolute joints the joint origin lies on its axis, so
   the frame's distance from the first joint's origin is at most the sum ``ρ`` of the
   lengths of the joint-to-joint translations after it and of the frame's offset (plus
   the largest travel of each prismatic joint): the triangle inequality along the chain.
   A voxel whose nearest point is farther than ``ρ`` from that origin is empty.
2. **Forward-kinematics sampling (evidence).** ``fk_samples`` configurations drawn
   uniformly within the joint limits are mapped through :func:`redres.batch.fk`; a
   voxel that a sample reached is reachable by position, and is kept with every voxel
   within ``dilation`` voxels of it (Chebyshev distance). A voxel that no sample came
   within ``dilation`` of is skipped: sampling cannot prove a voxel empty, so this is a
   bet that a voxel reachable by position is rarely farther than ``dilation`` voxels
   from every one of the samples' voxels. ``docs/sweeps.md`` gives the miss rate
   measured against fresh samples; ``dilation = -1`` keeps every voxel within the reach
   bound.

The samples found in each voxel also seed its IK queries (:mod:`redres.sweeps.kinds.capability`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import batch
from ...errors import InvalidParameterError
from ...robot import Robot

if TYPE_CHECKING:
    from ..._toml import Reader

__all__ = [
    "GridSource",
    "Occupancy",
    "grid_bounds",
    "occupancy",
    "reach_bound",
    "read_grid_source",
    "voxel_poses",
]

_CHUNK = 100_000  # configurations per batch.fk call (bounded memory)
#: The most voxels a map's grid may have (a 5 mm grid over a 1.5 m cube is 27 million).
MAX_VOXELS = 50_000_000
#: The most configurations sampled for occupancy (about 20 s of forward kinematics).
MAX_FK_SAMPLES = 20_000_000


def reach_bound(robot: Robot, frame: str | None = None) -> tuple[np.ndarray, float]:
    """``(origin, ρ)``: the first joint's origin (world, m) and the bound ``ρ`` (m) on the
    frame's distance from it over all configurations (module docstring)."""
    chain = robot.chain(frame)
    links = chain.arrays[0]
    origin = links[0][:, 3].copy()
    rho = float(sum(np.linalg.norm(links[j][:, 3]) for j in range(1, len(links))))
    for j in np.flatnonzero(chain.prismatic):
        rho += float(max(abs(robot.q_min[j]), abs(robot.q_max[j])))
    return origin, rho


@dataclass(frozen=True)
class Occupancy:
    """The voxels to test and the samples that reached them.

    Attributes:
        index: grid indices of the tested voxels, ``(V, 3)`` int64, in lexicographic
            order.
        hits: samples that reached each voxel, ``(V,)`` (0 for voxels kept by dilation).
        seeds: up to ``K`` of those samples' configurations per voxel, ``(V, K, n)``,
            NaN where fewer reached it, in the order drawn.
        shape: voxels of the grid per axis; ``low``: grid index of its first voxel.
        in_reach: voxels of the grid within the reach bound.
    """

    index: np.ndarray
    hits: np.ndarray
    seeds: np.ndarray
    shape: tuple[int, int, int]
    low: np.ndarray
    in_reach: int


def grid_range(bounds: np.ndarray, resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """First and last grid index (inclusive) per axis of the voxels centred in ``bounds``
    ``(3, 2)``."""
    low = np.ceil(bounds[:, 0] / resolution - 0.5).astype(np.int64)
    high = np.floor(bounds[:, 1] / resolution - 0.5).astype(np.int64)
    return low, np.maximum(high, low - 1)


def occupancy(
    robot: Robot,
    frame: str | None,
    resolution: float,
    bounds: np.ndarray,
    samples: int,
    dilation: int,
    seeds_per_voxel: int,
    rng: np.random.Generator,
) -> Occupancy:
    """The voxels of ``bounds`` (3, 2) to test (module docstring)."""
    origin, rho = reach_bound(robot, frame)
    low, high = grid_range(bounds, resolution)
    shape = tuple(int(s) for s in high - low + 1)
    voxels = shape[0] * shape[1] * shape[2]
    if voxels > MAX_VOXELS:  # before anything of that size is allocated
        raise InvalidParameterError(
            f"resolution = {resolution:g} m over the bounds gives {voxels:,} voxels; a map has at "
            f"most {MAX_VOXELS:,}: choose a coarser resolution or narrower bounds"
        )
    grid = np.indices(shape).reshape(3, -1).T + low  # every voxel, lexicographic
    lo_corner, hi_corner = grid * resolution, (grid + 1) * resolution
    nearest = np.clip(origin, lo_corner, hi_corner)
    reach = np.linalg.norm(nearest - origin, axis=1) <= rho
    counts = np.zeros(len(grid), dtype=np.int64)
    first: list[np.ndarray] = []
    configs: list[np.ndarray] = []
    for begin in range(0, samples, _CHUNK):
        q = robot.q_min + (robot.q_max - robot.q_min) * rng.random((min(_CHUNK, samples - begin),
                                                                    robot.n))  # fmt: skip
        ijk = np.floor(batch.fk(robot, q, frame)[:, :3, 3] / resolution).astype(np.int64)
        inside = np.all((ijk >= low) & (ijk <= high), axis=1)
        cells = np.ravel_multi_index(tuple((ijk[inside] - low).T), shape)
        counts += np.bincount(cells, minlength=len(grid))
        first.append(cells)
        configs.append(q[inside])
    cells, q_all = np.concatenate(first), np.concatenate(configs)
    keep = counts > 0
    if dilation < 0:
        keep = reach.copy()
    elif dilation > 0:
        keep = _dilate(keep.reshape(shape), dilation).ravel()
    keep &= reach
    rows = np.flatnonzero(keep)
    seeds = np.full((len(rows), seeds_per_voxel, robot.n), np.nan)
    slot = np.full(len(grid), -1, dtype=np.int64)
    slot[rows] = np.arange(len(rows))
    order = np.argsort(cells, kind="stable")  # by voxel, then in the order drawn
    sorted_cells = cells[order]
    starts = np.searchsorted(sorted_cells, rows)
    for k in range(seeds_per_voxel):
        at = starts + k
        valid = at < len(sorted_cells)
        valid[valid] &= sorted_cells[at[valid]] == rows[valid]
        seeds[valid, k] = q_all[order[at[valid]]]
    return Occupancy(grid[rows], counts[rows], seeds, shape, low, int(reach.sum()))  # type: ignore[arg-type]


def _dilate(mask: np.ndarray, radius: int) -> np.ndarray:
    """``mask`` grown by ``radius`` voxels in the Chebyshev metric (a cube)."""
    from scipy.ndimage import maximum_filter

    return np.asarray(maximum_filter(mask, size=2 * radius + 1, mode="constant", cval=0))


@dataclass(frozen=True)
class GridSource:
    """The keys of a sweep spec that choose the voxels and orientations of a map (module
    docstring): the parameters of a capability map and of a redundancy map's grid source
    share them as a base class, each with its own defaults (:func:`read_grid_source`).

    Attributes:
        resolution: voxel edge, m.
        bounds: ``((x_min, x_max), (y_min, y_max), (z_min, z_max))`` of the voxel centres,
            m; None: a cube of half-width the reach bound around the first joint.
        directions: approach directions per voxel (Fibonacci lattice).
        rolls: roll angles about each direction.
        fk_samples: forward-kinematics samples that find the occupied voxels.
        dilation: voxels kept around each sampled one (-1: every voxel within reach).
    """

    resolution: float = 0.05
    bounds: tuple[tuple[float, float], ...] | None = None
    directions: int = 50
    rolls: int = 1
    fk_samples: int = 200_000
    dilation: int = 1


def grid_bounds(bounds: Any, robot: Robot, frame: str | None) -> np.ndarray:
    """The voxel centres' bounds ``(3, 2)``, m: ``bounds`` as given, else (None) a cube of
    half-width the reach bound around the first joint (module docstring)."""
    if bounds is not None:
        return np.array(bounds, dtype=np.float64)
    origin, rho = reach_bound(robot, frame)
    return np.column_stack((origin - rho, origin + rho))


def voxel_poses(centres: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """Every orientation of ``rotations`` (O, 3, 3) at every centre (V, 3), ``(V, O, 4, 4)``."""
    T = np.zeros((len(centres), len(rotations), 4, 4))
    T[:, :, :3, :3] = rotations
    T[:, :, :3, 3] = centres[:, None, :]
    T[:, :, 3, 3] = 1.0
    return T


def read_grid_source(r: Reader, params: type[GridSource]) -> dict[str, Any]:
    """The keys of :class:`GridSource` in a sweep spec, checked, with the defaults of the
    sweep kind's parameter class ``params`` (a subclass of :class:`GridSource`)."""
    bounds = r.bounds("bounds")
    return {
        "resolution": r.positive("resolution", params.resolution),
        "bounds": None if bounds is None else tuple((lo, hi) for lo, hi in bounds),
        "directions": r.integer("directions", params.directions, minimum=1, maximum=10_000),
        "rolls": r.integer("rolls", params.rolls, minimum=1, maximum=360),
        "fk_samples": r.integer("fk_samples", params.fk_samples, minimum=0, maximum=MAX_FK_SAMPLES),
        "dilation": r.integer("dilation", params.dilation, minimum=-1, maximum=100),
    }
