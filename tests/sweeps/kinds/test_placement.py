"""Base placement from a capability map recovers the base a synthetic task was made for.

The task: poses the map marks reachable (a voxel centre at a tested orientation, one
per tested voxel), moved into the world by a known base ``B*``; seen from ``B*`` every
one is reachable, from any other candidate of the grid some fall outside the map.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin

from redres import sweeps
from redres.sweeps.kinds.placement import ranking

from ..helpers import write_spec

BEST = (0.4, -0.3, 2 * math.pi * 3 / 8)  # x, y, yaw of B*


def test_recovers_the_known_base(tmp_path: Path) -> None:
    spec = write_spec(tmp_path)
    sweeps.run(spec, tmp_path / "map", workers=1, progress=False)
    m = sweeps.load_map(tmp_path / "map")
    x, y, yaw = BEST
    B = np.eye(4)
    B[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, yaw)
    B[:2, 3] = x, y
    lines = []
    for v in range(len(m.index)):
        reachable = np.flatnonzero(m.reachable[v])
        if not len(reachable):
            continue
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = m.rotations[reachable[0]], m.centres[v]
        W = B @ T
        q = pin.Quaternion(W[:3, :3]).coeffs()  # x, y, z, w
        lines.append("[" + ", ".join(repr(float(a)) for a in (*W[:3, 3], *q)) + "]")
    assert len(lines) >= 20
    text = f"""
kind = "base_placement"
shard_size = 1000
small_shards = true
[robot]
model = "panda"
[base_placement]
map = "map"
x = [0.2, 0.6, 0.1]
y = [-0.5, -0.1, 0.1]
yaws = 8
poses = [{", ".join(lines)}]
"""
    (tmp_path / "place.toml").write_text(text)
    report = sweeps.run(tmp_path / "place.toml", tmp_path / "place", workers=1, progress=False)
    assert report.shards > 1
    ranked = ranking(tmp_path / "place")
    assert len(ranked["bases"]) == 5 * 5 * 8
    np.testing.assert_allclose(ranked["bases"][0], BEST, atol=1e-9)
    assert ranked["count"][0] == len(lines) and ranked["count"][1] < len(lines)
    assert (np.diff(ranked["count"]) <= 0).all()


def test_candidate_positions_lie_on_the_grid_exactly() -> None:
    """A base at y = 0 is at 0 (``np.arange(-0.3, 0.3, 0.1)`` has 5.55e-17 there): the
    ranking prints positions a user can read."""
    from redres.sweeps.kinds.placement import PlacementParams, candidates

    p = PlacementParams(map="m", map_sha256="", poses=(), x=(-0.3, 0.3, 0.1), y=(-0.3, 0.3, 0.1))
    c = candidates(p)
    for column in (c[:, 0], c[:, 1]):
        values = np.unique(column)
        np.testing.assert_array_equal(values, np.round(np.linspace(-0.3, 0.3, 7), 12))
        assert 0.0 in values and not np.any((values != 0.0) & (np.abs(values) < 1e-9))
        assert not np.any(np.signbit(values[values == 0.0]))  # +0.0, not -0.0
