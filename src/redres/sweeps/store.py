"""Where a sweep's arrays live: Zarr (one chunk per shard), or NPZ files without Zarr.

Both stores hold the same arrays: every output field of the plan, shape
``(units, *field shape)``, and the plan's tables (written once, at the start).

* **Zarr** (``redres[zarr]``): ``data.zarr/``, a Zarr group with one array per field,
  chunked along the unit axis exactly by shard (``chunks = (shard_units, *shape)``), so
  no two shards ever write the same chunk file, and each chunk file is written
  atomically by Zarr's local store (temporary file, rename); the tables are arrays of the
  group too (``data.zarr/tables/<name>``).
* **NPZ** (no Zarr installed, or ``storage = "npz"``): ``shards/<k>.npz`` per shard and
  ``tables.npz``, each written to a temporary file and renamed into place. The archives
  carry a fixed timestamp, so the same arrays give the same bytes.

A shard's checksum (:func:`checksum`) is the SHA-256 of its arrays' names, dtypes,
shapes and bytes, the same in either store; the manifest keeps it, and a shard whose
stored arrays do not give it back (a truncated or altered file) is computed again. The
tables' checksum is in the folder's header: tables that do not give it back are written
again on resume, and reading refuses them (Zarr reads a lost chunk file as zeros).
"""

from __future__ import annotations

import hashlib
import io
import os
import tempfile
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .kind import Field

__all__ = ["NpzStore", "Store", "ZarrStore", "checksum", "open_store", "write_atomic"]

Storage = Literal["zarr", "npz"]
ZARR_DIR, NPZ_DIR, NPZ_TABLES = "data.zarr", "shards", "tables.npz"


def checksum(arrays: Mapping[str, np.ndarray]) -> str:
    """SHA-256 of the arrays in name order: each name, dtype, shape and C-order bytes."""
    digest = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        digest.update(a.tobytes())
    return digest.hexdigest()


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a
    rename, so that ``path`` is either its old content or all of ``data``."""
    handle, temp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".partial")
    try:
        with os.fdopen(handle, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(temp, path)
    except OSError as exc:  # a write to a full disk names no file: name the one meant
        Path(temp).unlink(missing_ok=True)
        if exc.filename is None:
            raise OSError(exc.errno, exc.strerror, str(path)) from exc
        raise
    except BaseException:
        Path(temp).unlink(missing_ok=True)
        raise


def zarr_available() -> bool:
    """Whether Zarr (version 3) can be imported."""
    try:
        import zarr
    except ImportError:
        return False
    return int(zarr.__version__.split(".")[0]) >= 3


class Store:
    """The arrays of one sweep folder (a base for :class:`ZarrStore`, :class:`NpzStore`)."""

    name: Storage

    def __init__(self, folder: Path, fields: Mapping[str, Field], units: int, shard_units: int):
        self.folder, self.fields = folder, dict(fields)
        self.units, self.shard_units = units, shard_units

    def rows(self, shard: int) -> tuple[int, int]:
        """The units ``(start, stop)`` of ``shard``."""
        start = shard * self.shard_units
        return start, min(self.units, start + self.shard_units)

    def create(self, tables: Mapping[str, np.ndarray]) -> None:
        """Create the (empty) arrays and store the plan's tables."""
        raise NotImplementedError

    def valid(self) -> bool:
        """Whether the store exists whole (its creation was not cut short)."""
        raise NotImplementedError

    def write(self, shard: int, arrays: Mapping[str, np.ndarray]) -> None:
        raise NotImplementedError

    def read(self, shard: int) -> dict[str, np.ndarray] | None:
        """The stored arrays of ``shard``, or None when they cannot be read whole."""
        raise NotImplementedError

    def tables(self) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def write_tables(self, tables: Mapping[str, np.ndarray]) -> None:
        """Store the plan's tables again (one was lost or altered)."""
        raise NotImplementedError

    def tables_sha256(self) -> str | None:
        """:func:`checksum` of the stored tables, or None when they cannot be read whole."""
        try:
            return checksum(self.tables())
        except Exception:  # a cut or altered file: codec, format or I/O errors
            return None

    def load(self, name: str) -> np.ndarray:
        """Field ``name`` over every unit (unfinished shards read as zeros)."""
        raise NotImplementedError


class ZarrStore(Store):
    name: Storage = "zarr"

    def _group(self, mode: Literal["r", "r+", "w"] = "r+") -> Any:
        import zarr

        return zarr.open_group(self.folder / ZARR_DIR, mode=mode)

    def create(self, tables: Mapping[str, np.ndarray]) -> None:
        group = self._group("w")
        self._tables(group, tables)  # first: the fields' arrays exist only after them
        for name, f in self.fields.items():
            group.create_array(
                name, shape=(self.units, *f.shape), chunks=(self.shard_units, *f.shape),
                dtype=f.dtype, fill_value=np.zeros((), f.dtype).item(),
                attributes={"doc": f.doc},
            )  # fmt: skip

    def valid(self) -> bool:
        try:
            group = self._group("r")
            ok = all(group[n].shape == (self.units, *f.shape) for n, f in self.fields.items())
            return ok
        except Exception:  # absent or cut: no group, a missing array
            return False

    def write(self, shard: int, arrays: Mapping[str, np.ndarray]) -> None:
        start, stop = self.rows(shard)
        group = self._group()
        for name in self.fields:
            group[name][start:stop] = arrays[name]

    def read(self, shard: int) -> dict[str, np.ndarray] | None:
        start, stop = self.rows(shard)
        try:
            group = self._group("r")
            return {name: np.asarray(group[name][start:stop]) for name in self.fields}
        except Exception:  # a cut or altered chunk file: codec, shape or I/O errors
            return None

    @staticmethod
    def _tables(group: Any, tables: Mapping[str, np.ndarray]) -> None:
        sub = group.create_group("tables", overwrite=True)
        for name, table in tables.items():
            array = np.ascontiguousarray(table)
            chunks = tuple(max(1, size) for size in array.shape)
            sub.create_array(name, shape=array.shape, dtype=array.dtype, chunks=chunks)
            sub[name][...] = array

    def write_tables(self, tables: Mapping[str, np.ndarray]) -> None:
        self._tables(self._group(), tables)

    def tables(self) -> dict[str, np.ndarray]:
        sub = self._group("r")["tables"]
        return {name: np.asarray(array[...]) for name, array in sub.arrays()}

    def load(self, name: str) -> np.ndarray:
        return np.asarray(self._group("r")[name][...])


class NpzStore(Store):
    name: Storage = "npz"

    def _file(self, shard: int) -> Path:
        return self.folder / NPZ_DIR / f"{shard:06d}.npz"

    def create(self, tables: Mapping[str, np.ndarray]) -> None:
        self.write_tables(tables)
        (self.folder / NPZ_DIR).mkdir(exist_ok=True)

    def valid(self) -> bool:
        return (self.folder / NPZ_DIR).is_dir()

    def write_tables(self, tables: Mapping[str, np.ndarray]) -> None:
        write_atomic(self.folder / NPZ_TABLES, _npz_bytes(tables))

    def write(self, shard: int, arrays: Mapping[str, np.ndarray]) -> None:
        write_atomic(self._file(shard), _npz_bytes({k: arrays[k] for k in self.fields}))

    def read(self, shard: int) -> dict[str, np.ndarray] | None:
        try:
            with np.load(self._file(shard), allow_pickle=False) as data:
                return {name: data[name] for name in self.fields}
        except Exception:  # missing, cut or altered: zip, format or I/O errors
            return None

    def tables(self) -> dict[str, np.ndarray]:
        with np.load(self.folder / NPZ_TABLES, allow_pickle=False) as data:
            return {name: data[name] for name in data.files}

    def load(self, name: str) -> np.ndarray:
        f = self.fields[name]
        out = np.zeros((self.units, *f.shape), dtype=f.dtype)
        for shard in range(-(-self.units // self.shard_units)):
            arrays = self.read(shard)
            if arrays is not None:
                start, stop = self.rows(shard)
                out[start:stop] = arrays[name]
        return out


def _npz_bytes(arrays: Mapping[str, np.ndarray]) -> bytes:
    """An ``.npz`` archive (readable by :func:`numpy.load`) with a fixed timestamp."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name in sorted(arrays):
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with archive.open(info, "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.ascontiguousarray(arrays[name]),
                                          allow_pickle=False)  # fmt: skip
    return buffer.getvalue()


def open_store(
    storage: Storage, folder: Path, fields: Mapping[str, Field], units: int, shard_units: int
) -> Store:
    """The store of ``storage`` for ``folder``."""
    cls = ZarrStore if storage == "zarr" else NpzStore
    return cls(folder, fields, units, shard_units)
