"""Export a capability map to the HDF5 layout of ROS Reuleaux, to open it in RViz.

Reuleaux (ros-industrial, ``map_creator``; A. Makhal and A. K. Goins, "Reuleaux: robot
base placement by reachability analysis", IEEE IRC 2018) stores a reachability map in
one HDF5 file with two groups:

* ``/Spheres/sphere_dataset``: float64, one row per voxel with a reachable pose:
  ``[x, y, z, D]``, the voxel centre (m) and its reachability index ``D = 100 R/N``
  (percent); the dataset has the attribute ``Resolution`` (float32, one value: the voxel
  edge, m).
* ``/Poses/poses_dataset``: float32, one row per reachable pose:
  ``[x, y, z, px, py, pz, qx, qy, qz, qw]``, the voxel centre, then the pose's position
  and its orientation as a unit quaternion, scalar last (``geometry_msgs/Pose``).

redres tests its poses at the voxel centre, so ``p`` equals the centre here (Reuleaux
places its poses on a small sphere around it). Reuleaux's loaders join the two datasets by
exact equality of the centres (the float32 one cast to double): the centres in both are
rounded to float32 (within 4e-9 m of the map's at a few metres). The file is written to a
temporary name and renamed into place.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...errors import MissingDependencyError, install_hint
from .capability import CapabilityMap, load_map

__all__ = ["export_reuleaux", "quaternions"]


def quaternions(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``[qx, qy, qz, qw]`` (``qw >= 0``) of rotations ``R`` (N, 3, 3)."""
    import pinocchio as pin

    out = np.empty((len(R), 4))
    for i, rotation in enumerate(np.asarray(R, dtype=np.float64)):
        q = pin.Quaternion(rotation).coeffs()  # (x, y, z, w)
        out[i] = q if q[3] >= 0 else -q
    return out


def export_reuleaux(source: CapabilityMap | str | Path, path: str | Path) -> Path:
    """Write the capability map ``source`` (or the map in that sweep folder) to ``path``
    in Reuleaux's layout (module docstring); returns the path.

    Raises:
        MissingDependencyError: h5py is not installed (``pip install -e '.[h5py]'``).
    """
    try:
        import h5py
    except ImportError:
        raise MissingDependencyError(
            f"the Reuleaux export writes HDF5 with h5py: {install_hint('h5py')}"
        ) from None
    m = source if isinstance(source, CapabilityMap) else load_map(source)
    index = m.reachability_index
    voxels = np.flatnonzero(index > 0)
    # Reuleaux's loaders join a pose to its sphere by exact equality of the float32 centre
    # (cast to double) with the float64 one: the centres are written float32-exact
    # (0.05 is not), or no sphere survives loading.
    centres = m.centres[voxels].astype(np.float32).astype(np.float64)
    spheres = np.column_stack((centres, index[voxels]))
    v, o = np.nonzero(m.reachable[voxels])
    q = quaternions(m.rotations)
    centre = centres[v]
    poses = np.column_stack((centre, centre, q[o])).astype(np.float32)
    target = Path(path)
    temp = target.with_name(f".{target.name}.partial")
    try:
        with h5py.File(temp, "w") as f:
            sphere_set = f.create_group("Spheres").create_dataset("sphere_dataset", data=spheres)
            sphere_set.attrs.create("Resolution", np.array([m.resolution], dtype=np.float32))
            f.create_group("Poses").create_dataset("poses_dataset", data=poses)
        os.replace(temp, target)
    finally:
        temp.unlink(missing_ok=True)
    return target
