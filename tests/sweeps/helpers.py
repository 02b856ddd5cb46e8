"""Small sweep specs for the tests (a few hundred queries each, shards of tens)."""

from __future__ import annotations

import hashlib
from pathlib import Path

#: A capability map of 27 voxels in front of the Panda, 12 orientations: 324 queries in
#: shards of 5 voxels (7 shards, the last smaller).
SMALL_MAP = """
kind = "capability"
name = "small"
seed = 7
shard_size = 60
small_shards = true

[robot]
model = "panda"

[solver]
max_restarts = 1

[capability]
resolution = 0.1
bounds = [[0.2, 0.5], [-0.1, 0.2], [0.2, 0.5]]
directions = 12
fk_samples = 5000
"""


def write_spec(
    folder: Path, text: str = SMALL_MAP, name: str = "spec.toml", **changes: str
) -> Path:
    """``text`` with ``key = value`` lines replaced (``changes``), written to ``folder``."""
    lines = []
    for line in text.splitlines():
        key = line.split("=")[0].strip()
        lines.append(f"{key} = {changes.pop(key)}" if key in changes else line)
    assert not changes, changes
    path = folder / name
    path.write_text("\n".join(lines) + "\n")
    return path


def tree_digest(folder: Path) -> dict[str, str]:
    """Relative path -> SHA-256 of every file under ``folder``."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*")) if p.is_file()
    }  # fmt: skip
