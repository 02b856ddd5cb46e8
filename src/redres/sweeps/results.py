"""Reading a sweep folder back: :func:`load` gives its arrays by name.

Works on a finished sweep and on one still running or interrupted (``done`` says which;
the units of unfinished shards read as zeros), in either store. A finished shard whose
stored arrays do not give back its manifest checksum, or tables that do not give back the
header's, are refused by name (:class:`~redres.sweeps.SweepFolderError`), never read as
zeros. The kinds add typed
views on top (:func:`redres.sweeps.kinds.capability.load_map`, ...).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import install_hint, shown_path
from .folder import FORMAT, HEADER, MANIFEST, SweepFolderError, read_json
from .kind import Field
from .store import Store, checksum, open_store

__all__ = ["SweepData", "load"]


@dataclass
class SweepData(Mapping[str, np.ndarray]):
    """The arrays of a sweep folder: ``data["reachable"]`` etc. (every output field,
    ``(units, *shape)``), read on first access.

    Attributes:
        folder: the sweep folder.
        kind: the sweep kind; ``name`` its spec's name.
        header: the folder's ``sweep.json``.
        tables: the plan's tables (voxel centres, orientations, ...).
        finished: the shards finished (with a manifest entry).
        done: whether every shard is finished.
    """

    folder: Path
    kind: str
    name: str
    header: dict[str, Any]
    tables: dict[str, np.ndarray]
    finished: list[int]
    store: Store = field(repr=False)
    _cache: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    _verified: bool = field(default=False, repr=False)

    @property
    def meta(self) -> dict[str, Any]:
        """The plan's plain values (scheme labels, ...)."""
        return dict(self.header.get("meta", {}))

    @property
    def done(self) -> bool:
        return len(self.finished) == int(self.header["shards"])

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self.store.fields:
            raise KeyError(f"no field {name!r} in this {self.kind} sweep; fields: "
                           f"{', '.join(self.store.fields)}")  # fmt: skip
        if name not in self._cache:
            if not self._verified:
                self._verify()
            self._cache[name] = self.store.load(name)
        return self._cache[name]

    def _verify(self) -> None:
        """Check every finished shard's stored arrays against its manifest checksum (once,
        shard by shard), so that a lost or altered file is named, never read as zeros."""
        for k in self.finished:
            entry = read_json(self.folder / MANIFEST / f"{k:06d}.json")
            arrays = self.store.read(k)
            sha = entry.get("sha256") if isinstance(entry, dict) else None
            if arrays is None or checksum(arrays) != sha:
                why = "cannot be read" if arrays is None else "do not give back its checksum"
                raise SweepFolderError(
                    f"{shown_path(self.folder)}: shard {k} is damaged (its stored arrays {why}); "
                    f"run the sweep again with --out {shown_path(self.folder)} to redo it"
                )
        self._verified = True

    def __iter__(self) -> Iterator[str]:
        return iter(self.store.fields)

    def __len__(self) -> int:
        return len(self.store.fields)


def load(out: str | Path) -> SweepData:
    """The sweep in folder ``out`` (:class:`SweepData`).

    Raises:
        SweepFolderError: ``out`` is not a sweep folder (or its store needs Zarr, absent).
    """
    folder = Path(out)
    header = read_json(folder / HEADER)
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise SweepFolderError(f"{shown_path(folder)} is not a sweep folder (no {HEADER})")
    fields = {k: Field(v["dtype"], tuple(v["shape"]), v.get("doc", ""))
              for k, v in header["fields"].items()}  # fmt: skip
    if header["storage"] == "zarr":
        from .store import zarr_available

        if not zarr_available():
            raise SweepFolderError(
                f"{shown_path(folder)} is stored in Zarr; install it: {install_hint('zarr')}"
            )
    store = open_store(header["storage"], folder, fields, header["units"], header["shard_units"])
    finished = sorted(int(p.stem) for p in (folder / MANIFEST).glob("*.json") if p.stem.isdigit())
    try:
        tables = store.tables()
    except Exception:  # a cut or altered file: codec, format or I/O errors
        tables = None
    expected = header.get("tables_sha256")  # absent in folders of older versions
    if tables is None or (expected is not None and checksum(tables) != expected):
        raise SweepFolderError(
            f"{shown_path(folder)}: the plan's tables are damaged (a file lost or altered); run "
            f"the sweep again with --out {shown_path(folder)} to write them again"
        )
    return SweepData(folder, header["kind"], header.get("name", ""), header, tables, finished,
                     store)  # fmt: skip
