"""A sweep folder damaged on disk is never read as data: every kind of file the store
writes (a field's chunk or shard archive, a plan table, the store's metadata, a manifest
entry), deleted, truncated or with one byte flipped. Reading names the damaged shard or
table, or gives exactly the undamaged arrays; resuming redoes what was damaged and ends
with arrays equal to an undamaged run's.

Oracle: the undamaged run of the same spec, array by array."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from redres import sweeps
from redres.sweeps import SweepFolderError
from redres.sweeps.store import zarr_available

from .helpers import write_spec

DAMAGES = ("delete", "truncate", "flip")


def _damage(path: Path, how: str, rng: np.random.Generator) -> None:
    data = path.read_bytes()
    if how == "delete":
        path.unlink()
    elif how == "truncate":
        path.write_bytes(data[: int(rng.integers(0, len(data)))])
    else:
        i = int(rng.integers(0, len(data)))
        path.write_bytes(data[:i] + bytes([data[i] ^ 0xFF]) + data[i + 1 :])


def _files(out: Path, storage: str) -> dict[str, list[Path]]:
    """The folder's files by kind."""
    every = [p for p in sorted(out.rglob("*")) if p.is_file()]
    if storage == "zarr":
        chunks = [p for p in every if "/c/" in str(p.relative_to(out))]
        return {
            "field chunk": [p for p in chunks if "tables" not in p.parts],
            "table chunk": [p for p in chunks if "tables" in p.parts],
            "store metadata": [p for p in every if p.name == "zarr.json"],
            "manifest entry": sorted((out / "manifest").glob("*.json")),
        }
    return {
        "shard archive": sorted((out / "shards").glob("*.npz")),
        "table archive": [out / "tables.npz"],
        "manifest entry": sorted((out / "manifest").glob("*.json")),
    }


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Byte-identical (NaN where the map has no answer compares equal to itself)."""
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _arrays(out: Path) -> dict[str, np.ndarray]:
    data = sweeps.load(out)
    arrays = {name: data[name] for name in data}
    arrays.update({f"tables/{k}": v for k, v in data.tables.items()})
    return arrays


@pytest.fixture(scope="module")
def undamaged(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, dict]]:
    out = {}
    for storage in ("npz", "zarr"):
        if storage == "zarr" and not zarr_available():
            continue
        folder = tmp_path_factory.mktemp(storage)
        spec = write_spec(folder)
        sweeps.run(spec, folder / "out", workers=1, progress=False, storage=storage)
        out[storage] = (folder, _arrays(folder / "out"))
    return out


@pytest.mark.parametrize("storage", ["npz", "zarr"])
@pytest.mark.parametrize("how", DAMAGES)
def test_damage_is_named_on_reading_and_redone_on_resume(
    undamaged: dict[str, tuple[Path, dict]], tmp_path: Path, storage: str, how: str
) -> None:
    if storage not in undamaged:
        pytest.skip("zarr is not installed")
    source, expected = undamaged[storage]
    rng = np.random.default_rng(["npz", "zarr"].index(storage) * 10 + DAMAGES.index(how))
    kinds = _files(source / "out", storage)
    assert all(kinds.values()), {k: len(v) for k, v in kinds.items()}
    for kind, files in kinds.items():
        copy = tmp_path / kind.replace(" ", "_")
        shutil.copytree(source, copy)
        victim = copy / "out" / files[int(rng.integers(0, len(files)))].relative_to(source / "out")
        _damage(victim, how, rng)
        try:
            read = _arrays(copy / "out")
        except SweepFolderError as exc:  # named: a shard, the tables, or the folder
            assert "shard" in str(exc) or "tables" in str(exc) or "sweep" in str(exc), exc
        else:  # nothing the arrays hold was changed (a manifest's or archive's padding)
            assert read.keys() == expected.keys()
            for name, array in expected.items():
                assert _same(read[name], array), (kind, how, victim, name)
        report = sweeps.run(copy / "spec.toml", copy / "out", workers=1, progress=False)
        again = _arrays(copy / "out")
        for name, array in expected.items():
            assert _same(again[name], array), (kind, how, victim, name)
        if kind.startswith(("field", "shard")):  # a damaged shard file is found and redone
            assert report.redone or report.computed, (kind, how, victim)


def test_a_full_disk_names_the_file_being_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A write to a full disk raises an OSError without a file name; the message said
    "a file". It now names the file the sweep was writing."""
    import errno
    import os

    from redres.errors import describe_os_error
    from redres.sweeps.store import write_atomic

    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    target = tmp_path / "manifest.json"
    with pytest.raises(OSError) as caught:
        write_atomic(target, b"{}")
    text = describe_os_error(caught.value)
    assert str(target) in text and "the disk is full" in text, text
    assert list(tmp_path.iterdir()) == []  # nothing half-written left behind
