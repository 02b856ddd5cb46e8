"""Capability maps against forward kinematics, Pinocchio and the geometry of the lattice.

Oracles: forward kinematics of random configurations through Pinocchio (every such pose
is reachable, so the map must say so at its voxel and orientation bin, and the reach
bound must hold for it); Pinocchio's Jacobian for the stored manipulability; the
spherical-cap areas of a uniform distribution for the direction lattice.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres import batch, sweeps
from redres.sweeps.kinds.grid import reach_bound
from redres.sweeps.kinds.orientations import directions, frames, nearest

from ..helpers import write_spec

#: A finer map of a 20 cm cube in front of the Panda: 5 cm voxels, 50 directions x 4
#: rolls (the roll of a pose binned to within 45°).
FINE = {"resolution": "0.05", "bounds": "[[0.3, 0.5], [-0.1, 0.1], [0.3, 0.5]]",
        "directions": "50", "shard_size": "4000", "fk_samples": "20000",
        "max_restarts": "2"}  # fmt: skip


@pytest.fixture(scope="module")
def fine_map(tmp_path_factory: pytest.TempPathFactory) -> sweeps.CapabilityMap:
    folder = tmp_path_factory.mktemp("fine")
    spec = write_spec(folder, **FINE)
    spec.write_text(spec.read_text() + "rolls = 4\n")
    sweeps.run(spec, folder / "out", workers=1, progress=False)
    return sweeps.load_map(folder / "out")


def test_fk_poses_are_reachable_in_the_map(fine_map: sweeps.CapabilityMap) -> None:
    """Every pose of a random configuration (inside the limits by 0.3 rad, away from
    singularities) whose position falls in the mapped cube is reachable in the map at
    its voxel and nearest tested orientation."""
    robot = rr.models.panda()
    rng = np.random.default_rng(11)
    q = np.array([robot.random_configuration(rng, margin=0.3) for _ in range(60_000)])
    T = batch.fk(robot, q)
    low, high = np.array([0.3, -0.1, 0.3]), np.array([0.5, 0.1, 0.5])  # the voxels' faces
    inside = np.all((T[:, :3, 3] >= low) & (T[:, :3, 3] < high), axis=1)
    sigma = np.array([np.linalg.svd(robot.jacobian(x), compute_uv=False)[-1] for x in q[inside]])
    keep = np.flatnonzero(inside)[sigma > 0.05]
    assert len(keep) >= 100, len(keep)
    for i in keep[:5]:  # Pinocchio agrees with the batch FK used to place them
        np.testing.assert_allclose(robot.fk(q[i]), T[i], atol=1e-12)
    rows, _ = fine_map.lookup(T[keep])
    assert (rows >= 0).all()  # every voxel holding such a pose was tested
    reached = fine_map.reachable_at(T[keep])
    assert reached.all(), f"{(~reached).sum()} of {len(keep)} FK poses unreachable in the map"


def test_unreachable_queries_have_no_measures(fine_map: sweeps.CapabilityMap) -> None:
    reachable = fine_map.reachable
    assert 0.2 < reachable.mean() < 1.0  # the cube holds reachable and unreachable poses
    assert (fine_map.manipulability[reachable] > 0).all() and (
        fine_map.margin[reachable] >= 0
    ).all()
    assert np.isnan(fine_map.manipulability[~reachable]).all()
    assert np.isnan(fine_map.margin[~reachable]).all()


def test_measures_against_pinocchio(tmp_path: Path) -> None:
    spec = write_spec(tmp_path)
    spec.write_text(spec.read_text() + "keep_configurations = true\n")
    sweeps.run(spec, tmp_path / "out", workers=1, progress=False)
    data = sweeps.load(tmp_path / "out")
    m = sweeps.load_map(tmp_path / "out")
    robot = rr.models.panda()
    v, o = np.nonzero(m.reachable)
    assert len(v) > 50
    for i in range(0, len(v), max(1, len(v) // 40)):
        q = data["q"][v[i], o[i]]
        T = robot.fk(q)  # Pinocchio
        assert np.linalg.norm(T[:3, 3] - m.centres[v[i]]) <= 1e-4
        angle = np.linalg.norm(pin.log3(m.rotations[o[i]].T @ T[:3, :3]))
        assert angle <= 1e-3 + 1e-9
        J = robot.jacobian(q)
        assert math.isclose(m.manipulability[v[i], o[i]], math.sqrt(np.linalg.det(J @ J.T)),
                            rel_tol=1e-9)  # fmt: skip
        margin = np.minimum(q - robot.q_min, robot.q_max - q).min()
        assert m.margin[v[i], o[i]] == pytest.approx(margin, abs=1e-12) and margin >= 0
    index = m.reachability_index
    assert np.allclose(index, 100.0 * m.reachable.sum(axis=1) / m.reachable.shape[1])


def test_reach_bound_holds_for_fk_samples() -> None:
    for name in ("panda", "iiwa14"):
        robot = rr.models.load(name)
        origin, rho = reach_bound(robot)
        rng = np.random.default_rng(5)
        q = np.array([robot.random_configuration(rng) for _ in range(20_000)])
        distance = np.linalg.norm(batch.fk(robot, q)[:, :3, 3] - origin, axis=1)
        assert distance.max() <= rho and distance.max() >= 0.8 * rho, (name, distance.max(), rho)
        i = int(np.argmax(distance))
        assert np.linalg.norm(robot.fk(q[i])[:3, 3] - origin) <= rho  # Pinocchio too


def test_direction_lattice_is_uniform_and_frames_are_rotations() -> None:
    count = 400
    d = directions(count)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    rng = np.random.default_rng(3)
    for axis in rng.normal(size=(30, 3)):
        axis /= np.linalg.norm(axis)
        for half in (0.5, 1.0, 2.0):  # cap of half-angle `half`: area 2π(1 − cos)
            share = np.mean(d @ axis >= math.cos(half))
            assert abs(share - (1 - math.cos(half)) / 2) < 0.02, (half, share)
    R = frames(d[:20], 3)
    assert R.shape == (60, 3, 3)
    assert np.allclose(R @ np.swapaxes(R, 1, 2), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(R), 1.0)
    assert np.allclose(R[::3, :, 2], d[:20]) and np.allclose(R[1::3, :, 2], d[:20])
    roll = np.einsum("nba,nbc->nac", R[::3], R[1::3])  # R_0ᵀ R_1: 120° about z
    assert np.allclose(roll[:, 2, 2], 1.0) and np.allclose(roll[:, 0, 0], math.cos(2 * math.pi / 3))


def test_nearest_bins_small_rotations_home() -> None:
    R = frames(directions(50), 2)
    rng = np.random.default_rng(8)
    turned = np.array([r @ pin.exp3(rng.normal(size=3) * 0.02) for r in R])
    assert np.array_equal(nearest(R, turned), np.arange(len(R)))


def test_a_grid_too_fine_to_hold_is_refused_before_it_is_allocated(tmp_path: Path) -> None:
    """resolution = 0.0001 m over the Panda's reach is 10**13 voxels: a raw MemoryError
    (226 TiB) before; now one line naming the count and the limit."""
    from redres.errors import InvalidParameterError

    from ..helpers import write_spec

    spec = write_spec(tmp_path, resolution="0.0001", bounds="[[-1, 1], [-1, 1], [-0.5, 1.3]]")
    with pytest.raises(InvalidParameterError, match=r"voxels; a map has at most 50,000,000"):
        sweeps.run(spec, tmp_path / "out", workers=1, progress=False)
    assert not (tmp_path / "out" / "manifest").exists() or not any(
        (tmp_path / "out" / "manifest").iterdir()
    )
