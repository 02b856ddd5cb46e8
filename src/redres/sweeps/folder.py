"""A sweep's output folder: its header, its manifest, and what may be resumed.

Layout (docs/sweeps.md)::

    OUT/sweep.json          the header: format, kind, settings and their SHA-256,
                            versions, robot, plan digest, fields, storage, shard layout
    OUT/manifest/<k>.json   one entry per finished shard: shard id, units, rows
                            (queries), checksum, versions, robot hashes, settings digest
    OUT/data.zarr/ or OUT/shards/ + OUT/tables.npz    the arrays (redres.sweeps.store)

Every file is written atomically (temporary file, rename), a shard's arrays before its
manifest entry, so a shard is finished exactly when its entry exists and its arrays give
back the entry's checksum; a kill at any moment leaves at worst a shard to redo. No
entry holds a time or a host name, so the same sweep gives the same bytes.

A folder is used only if it is empty, absent, or a sweep of the same settings, plan and
versions; anything else is refused with one line saying why (:class:`SweepFolderError`),
and nothing in it is touched.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..errors import RedresError, shown_path
from .store import NPZ_DIR, NPZ_TABLES, ZARR_DIR, write_atomic

__all__ = ["HEADER", "SweepFolderError", "check_folder", "differences", "versions"]

HEADER, MANIFEST = "sweep.json", "manifest"
FORMAT = "redres-sweep"
FORMAT_VERSION = 1
#: The names a sweep folder holds (and nothing else).
_OURS = {HEADER, MANIFEST, ZARR_DIR, NPZ_DIR, NPZ_TABLES}


class SweepFolderError(RedresError, ValueError):
    """An output folder cannot take this sweep (it holds other files, or a sweep of other
    settings, robot or versions); the message says which and what to do."""


def versions() -> dict[str, str]:
    """The versions that decide a sweep's numbers: redres, pin (Pinocchio), numba, and
    numpy (the generators' streams)."""
    from importlib.metadata import PackageNotFoundError, version

    from .._version import __version__

    out = {"redres": __version__}
    for name in ("pin", "numba", "numpy"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:  # pragma: no cover - numpy/numba are dependencies
            out[name] = "absent"
    return out


#: Versions whose change refuses a resume (numpy's generator streams are stable by policy).
_STRICT = ("redres", "pin", "numba")


def write_json(path: Path, value: Any) -> None:
    """``value`` as sorted, indented JSON, written atomically."""
    write_atomic(path, (json.dumps(value, indent=1, sort_keys=True) + "\n").encode())


def read_json(path: Path) -> Any:
    """The JSON of ``path``, or None when it is missing or not whole JSON."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def check_folder(folder: Path, header: Mapping[str, Any]) -> bool:
    """Whether ``folder`` holds this sweep already (True: resume), or may be created
    (False: empty or absent); refuses anything else with :class:`SweepFolderError`."""
    shown = shown_path(folder)
    if folder.exists() and not folder.is_dir():
        raise SweepFolderError(f"--out {shown} is a file; give a folder")
    entries = sorted(p.name for p in folder.iterdir()) if folder.exists() else []
    if not entries:
        return False
    if HEADER not in entries:
        listed = ", ".join(entries[:3]) + (", ..." if len(entries) > 3 else "")
        raise SweepFolderError(
            f"--out {shown} holds files that are not a sweep ({listed}); choose an empty or "
            "new folder (nothing was written)"
        )
    foreign = [e for e in entries if e not in _OURS and not e.startswith(f".{HEADER}.")]
    if foreign:
        raise SweepFolderError(
            f"--out {shown} is a sweep but also holds {', '.join(foreign[:3])}, which a sweep "
            "does not write; move them away or choose another folder"
        )
    old = read_json(folder / HEADER)
    if not isinstance(old, dict) or old.get("format") != FORMAT:
        raise SweepFolderError(f"--out {shown}: {HEADER} is not a redres sweep header")
    why = differences(old, header)
    if why:
        raise SweepFolderError(
            f"--out {shown} holds a sweep that cannot be resumed with this spec: {why}; use "
            "the same spec and versions, or a new --out folder"
        )
    return True


def differences(old: Mapping[str, Any], new: Mapping[str, Any]) -> str:
    """Why the sweep of header ``old`` cannot be resumed as ``new`` ("" if it can)."""
    if old.get("format_version") != new.get("format_version"):
        return f"it has format version {old.get('format_version')}, this is {FORMAT_VERSION}"
    for name in _STRICT:
        was, now = old.get("versions", {}).get(name), new["versions"][name]
        if was != now:
            return f"it was written by {name} {was}, this is {name} {now}"
    robot_old, robot_new = old["settings"].get("robot", {}), new["settings"]["robot"]
    if robot_old != robot_new:
        return f"its robot differs ({_first_difference(robot_old, robot_new, 'robot')})"
    if old["settings"] != new["settings"]:
        return f"its settings differ ({_first_difference(old['settings'], new['settings'])})"
    for key in ("plan_sha256", "storage", "fields", "units", "shard_units", "meta"):
        if old.get(key) != new.get(key):
            return f"its {key.replace('_', ' ')} differs ({old.get(key)} vs {new.get(key)})"
    return ""


def _first_difference(old: Any, new: Any, path: str = "") -> str:
    """The first key path where ``old`` and ``new`` differ, with both values."""
    if isinstance(old, dict) and isinstance(new, dict):
        for key in sorted(set(old) | set(new)):
            if old.get(key) != new.get(key):
                inner = f"{path}.{key}" if path else str(key)
                return _first_difference(old.get(key), new.get(key), inner)
    return f"{path} was {old!r}, the spec gives {new!r}"
