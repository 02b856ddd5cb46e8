"""The Reuleaux HDF5 export, read back with h5py: Reuleaux's groups, datasets, columns,
dtypes and attribute, and the map's numbers in them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from redres import sweeps
from redres.sweeps.kinds.reuleaux import export_reuleaux

from ..helpers import write_spec

h5py = pytest.importorskip("h5py")


def test_round_trip(tmp_path: Path) -> None:
    spec = write_spec(tmp_path)
    sweeps.run(spec, tmp_path / "out", workers=1, progress=False)
    m = sweeps.load_map(tmp_path / "out")
    path = export_reuleaux(tmp_path / "out", tmp_path / "panda_r0.1_reachability.h5")
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "out",
        "panda_r0.1_reachability.h5",
        "spec.toml",
    ]  # no temporary file left
    with h5py.File(path, "r") as f:
        assert set(f) == {"Spheres", "Poses"}
        spheres, poses = f["/Spheres/sphere_dataset"], f["/Poses/poses_dataset"]
        assert spheres.dtype == np.float64 and spheres.shape[1] == 4
        assert poses.dtype == np.float32 and poses.shape[1] == 10
        resolution = spheres.attrs["Resolution"]
        assert resolution.dtype == np.float32 and resolution.shape == (1,)
        assert resolution[0] == np.float32(m.resolution)
        spheres, poses = spheres[...], poses[...]
    index = m.reachability_index
    reachable_voxels = np.flatnonzero(index > 0)
    assert len(spheres) == len(reachable_voxels) and len(poses) == int(m.reachable.sum())
    np.testing.assert_allclose(spheres[:, :3], m.centres[reachable_voxels], rtol=0, atol=1e-7)
    np.testing.assert_array_equal(spheres[:, 3], index[reachable_voxels])
    rows, _ = m.lookup(np.tile(np.eye(4), (len(poses), 1, 1)) + _at(poses[:, :3]))
    for row, pose in zip(rows[::7], poses[::7]):
        np.testing.assert_allclose(pose[:3], m.centres[row], atol=1e-6)
        np.testing.assert_allclose(pose[3:6], pose[:3])
        x, y, z, w = (float(v) for v in pose[6:])
        R = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
        angles = [np.linalg.norm(pin.log3(Ro.T @ R)) for Ro in m.rotations]
        o = int(np.argmin(angles))
        assert angles[o] < 1e-5 and m.reachable[row, o]


def test_reuleaux_loaders_join_every_pose_to_its_sphere(tmp_path: Path) -> None:
    """A re-implementation of the join of Reuleaux's loaders (map_creator's HDF5 reader):
    a pose belongs to the sphere whose double centre equals the pose's float32 centre
    cast to double, exactly. Centres such as 0.05 written as float64 matched no pose."""
    spec = write_spec(tmp_path)
    sweeps.run(spec, tmp_path / "out", workers=1, progress=False)
    path = export_reuleaux(tmp_path / "out", tmp_path / "map.h5")
    with h5py.File(path, "r") as f:
        spheres = f["/Spheres/sphere_dataset"][...]
        poses = f["/Poses/poses_dataset"][...]
    by_centre: dict[tuple[float, float, float], int] = {}
    for row in poses:
        key = tuple(float(np.float64(x)) for x in row[:3])
        by_centre[key] = by_centre.get(key, 0) + 1
    joined = [by_centre.get(tuple(float(x) for x in s[:3]), 0) for s in spheres]
    assert len(spheres) > 0 and min(joined) >= 1  # every sphere survives loading
    assert sum(joined) == len(poses)  # and every pose has its sphere
    exact = sweeps.load_map(tmp_path / "out").centres
    assert (exact.astype(np.float32).astype(np.float64) != exact).any()  # the case that failed


def _at(p: np.ndarray) -> np.ndarray:
    out = np.zeros((len(p), 4, 4))
    out[:, :3, 3] = p
    return out
