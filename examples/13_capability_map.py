"""
A capability map of the Panda
=============================

Where can the hand reach, and in how many orientations? A capability map (Zacharias,
Borst & Hirzinger, IROS 2007) answers it voxel by voxel: at each voxel centre, a set of
approach directions (uniform on the sphere) times roll angles is tried by position IK
within the joint limits, and the *reachability index* of the voxel is the percentage of
them that are reached. ``redres.sweeps`` cuts the work into shards that can run on all
cores or a Dask cluster and resume after a crash; this page computes a coarse slice of
the map in one process. ``redres sweep panda_capability --out maps/panda`` computes the
full map (5 cm voxels, 50 orientations each; docs/sweeps.md).

Run: python examples/13_capability_map.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

# %%
# The sweep
# ---------
# A vertical slice beside the base (one row of voxels, centres at y = 5 cm), 10 cm
# voxels, 20 approach directions with one roll each. Voxels that forward-kinematics
# sampling of random configurations never visits are proved empty and skipped
# (docs/sweeps.md says how).
import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from redres import sweeps

short = int(os.environ.get("REDRES_EXAMPLE_STEPS", "3000")) < 1000  # the test run
res = 0.2 if short else 0.1
spec = f"""
kind = "capability"
shard_size = 200
small_shards = true
[robot]
model = "panda"
[capability]
resolution = {res}
bounds = [[-0.9, 0.9], [0.0, {res}], [-0.4, 1.3]]
directions = {8 if short else 20}
fk_samples = 20000
"""
folder = Path(tempfile.mkdtemp(prefix="redres-map-"))
(folder / "slice.toml").write_text(spec)
report = sweeps.run(folder / "slice.toml", folder / "map", workers=1, progress=False)
print(f"{report.queries} IK queries in {report.shards} shards, "
      f"{report.queries_per_second:.0f} queries/s on one core")  # fmt: skip

# %%
# The reachability index
# ----------------------
# Each tested voxel of the slice, coloured by the share of orientations reached. The
# index is highest at mid reach around the shoulder (0.33 m above the base) and falls to
# a few orientations at the edge of the reach. The map knows only the joint limits: the
# voxels below the base's floor are reachable for it (no collision model).
m = sweeps.load_map(folder / "map")
index = m.reachability_index
assert m.done and index.shape == (len(m.centres),)
assert 0.0 <= index.min() and index.max() <= 100.0 and index.max() > 50.0
fig, ax = plt.subplots(figsize=(6, 5.5))
points = ax.scatter(m.centres[:, 0], m.centres[:, 2], c=index, s=160 if short else 90,
                    marker="s", cmap="viridis", vmin=0, vmax=100)  # fmt: skip
ax.plot([0.0], [0.0], "k^", markersize=10, label="base")
ax.set(xlabel="x (m)", ylabel="z (m)", aspect="equal",
       title=f"Panda, slice y = {res / 2:.2f} m: reachability index (%)")  # fmt: skip
ax.legend(loc="lower right")
fig.colorbar(points, ax=ax, shrink=0.8)
fig.tight_layout()
print(f"{len(index)} voxels tested, {np.count_nonzero(index > 0)} reachable in some "
      f"orientation, best {index.max():.0f} %")  # fmt: skip
plt.show()
