"""Sweep specs: the TOML file that says what a sweep computes (docs/sweeps.md).

A spec is read with :mod:`tomllib` only; nothing in it is executed (no code, no pickle,
no paths run). Every problem is one :class:`SweepSpecError` line naming the file and the
key (``panda.toml: [capability].resolution: must be > 0; got -0.05``), through the same
typed reader as scenario files (:mod:`redres.scenario`).

Layout::

    kind = "capability"          # a kind of redres.sweeps.kinds: capability, ik_dataset, ...
    name = "panda-capability"    # optional (default: the file name)
    description = "..."          # optional
    seed = 0                     # shard k draws from numpy.random.default_rng([seed, k])
    shard_size = 10000           # queries per shard, >= 10000 unless small_shards = true

    [robot]                      # model = "<built-in>" or urdf = "<path>" (+ tip)
    model = "panda"

    [solver]                     # the IK settings of redres.batch.ik (kinds that solve IK)
    max_restarts = 2

    [capability]                 # the kind's own table, named as the kind
    resolution = 0.05
"""

from __future__ import annotations

import hashlib
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import RedresError, describe_os_error, shown_path
from ..scenario import ScenarioError, _Reader
from .source import RobotSource

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = [
    "MIN_SHARD",
    "Reader",
    "SweepSpec",
    "SweepSpecError",
    "builtin_specs",
    "load_spec",
    "parse_spec",
]

#: Queries per shard at least (a shard must amortise its dispatch and its files).
MIN_SHARD = 10_000
#: The IK settings a ``[solver]`` table may hold (those of :func:`redres.batch.ik`), by
#: kind of value: > 0, >= 0, integers >= 1, integers >= 0; with their defaults.
SOLVER_KEYS: dict[str, tuple[str, float]] = {
    "tol_position": ("positive", 1e-4),
    "tol_orientation": ("positive", 1e-3),
    "max_step": ("positive", 0.5),
    "k_limits": ("nonnegative", 0.1),
    "max_iterations": ("count", 60),
    "patience": ("count", 8),
    "max_restarts": ("integer", 2),
}


class SweepSpecError(RedresError, ValueError):
    """A sweep spec is unreadable or invalid (one line: the file, the key, the fix)."""


class Reader(_Reader):
    """Typed access to one table of a spec (the scenario reader, plus integers and
    booleans); its errors are :class:`~redres.scenario.ScenarioError`, turned into
    :class:`SweepSpecError` by :func:`parse_spec`."""

    def fail(self, key: str | None, message: str) -> ScenarioError:
        if self.path or key is None:
            return super().fail(key, message)
        return ScenarioError(f"{self.file}: {key}: {message}")  # a top-level key

    def integer(self, key: str, default: Any = ..., minimum: int | None = None) -> int:
        value = self.number(key, default)
        if not float(value).is_integer():
            raise self.fail(key, f"expected an integer, got {self.table[key]!r}")
        if minimum is not None and value < minimum:
            raise self.fail(key, f"must be >= {minimum}; got {int(value)}")
        return int(value)

    def boolean(self, key: str, default: bool) -> bool:
        self.used.add(key)
        value = self.table.get(key, default)
        if not isinstance(value, bool):
            raise self.fail(key, f"expected true or false, got {value!r}")
        return value

    def sub(self, key: str) -> Reader:
        """The reader of the sub-table ``[key]`` (empty when absent)."""
        self.used.add(key)
        return Reader(self.table.get(key, {}), f"[{key}]", self.file)

    def bounds(self, key: str) -> list[list[float]] | None:
        """``[[x_min, x_max], [y_min, y_max], [z_min, z_max]]`` (m), or None if absent."""
        self.used.add(key)
        value = self.table.get(key)
        if value is None:
            return None
        ok = isinstance(value, list) and len(value) == 3 and all(
            isinstance(v, list) and len(v) == 2
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
            for v in value
        )  # fmt: skip
        if not ok:
            raise self.fail(key, "expected [[x_min, x_max], [y_min, y_max], [z_min, z_max]] (m)")
        out = [[self._float(key, x) for x in v] for v in value]
        if any(lo >= hi for lo, hi in out):
            raise self.fail(key, "each range must have min < max")
        return out


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep spec.

    Attributes:
        kind: the sweep kind (:data:`redres.sweeps.kinds.KINDS`).
        name, description: for people.
        seed: the seed of every shard's generator, ``default_rng([seed, k])``.
        shard_size: queries per shard (a kind rounds it to whole units, e.g. voxels).
        robot: the robot, as built-in name or URDF text.
        solver: the IK settings (:data:`SOLVER_KEYS`), passed to :func:`redres.batch.ik`.
        params: the kind's parameters (a frozen dataclass of the kind).
        file: the spec's file name (for messages), ``base`` its folder.
    """

    kind: str
    name: str
    description: str
    seed: int
    shard_size: int
    robot: RobotSource
    solver: dict[str, float | int]
    params: Any
    file: str = "<spec>"
    base: Path = field(default=Path(), compare=False)

    def settings(self) -> dict[str, Any]:
        """Everything that decides the results, as plain JSON values (the manifest's
        ``settings``; a sweep resumes only under the same settings)."""
        from dataclasses import asdict

        params = self.params.settings() if hasattr(self.params, "settings") else asdict(self.params)
        settings = {
            "kind": self.kind, "seed": self.seed, "shard_size": self.shard_size,
            "robot": self.robot.identity(), "solver": dict(self.solver), self.kind: params,
        }  # fmt: skip
        return json.loads(json.dumps(settings))  # tuples as lists, as the header reads back

    def digest(self) -> str:
        """SHA-256 of :meth:`settings` (canonical JSON)."""
        text = json.dumps(self.settings(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


def load_spec(path: str | Path) -> SweepSpec:
    """Read and validate a sweep spec file; raises :class:`SweepSpecError`."""
    file = Path(path)
    try:
        data = tomllib.loads(file.read_text(encoding="utf-8-sig"))  # a leading BOM is fine
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError, RecursionError) as exc:
        raise SweepSpecError(_unreadable(file, exc)) from None
    return parse_spec(data, file.name, file.parent)


def _unreadable(file: Path, exc: Exception) -> str:
    """The one line saying why ``file`` could not be read as TOML."""
    shown = shown_path(file)
    if isinstance(exc, FileNotFoundError):
        return f"{shown}: no such sweep spec file"
    if isinstance(exc, OSError):
        return f"cannot read the sweep spec: {describe_os_error(exc)}"
    if isinstance(exc, UnicodeDecodeError):
        return f"{shown}: not UTF-8 text ({exc.reason}); save it as UTF-8"
    if isinstance(exc, RecursionError):
        return f"{shown}: tables are nested too deeply to read"
    return f"{shown}: not valid TOML ({exc})"


def parse_spec(data: dict[str, Any], file: str = "<spec>", base: Path = Path()) -> SweepSpec:
    """Validate a parsed spec (a dict as :mod:`tomllib` returns); ``base`` is the folder
    relative paths in it are taken from."""
    try:
        return _parse(data, file, base)
    except ScenarioError as exc:
        raise SweepSpecError(str(exc)) from None


def _parse(data: dict[str, Any], file: str, base: Path) -> SweepSpec:
    from .kinds import KINDS

    top = Reader(data, "", file)
    kind = top.string("kind")
    if kind not in KINDS:
        raise top.fail("kind", f"unknown sweep kind {kind!r}; kinds: {', '.join(KINDS)}")
    name = top.string("name", Path(file).stem)
    description = top.string("description", "")
    seed = top.integer("seed", 0, minimum=0)
    if seed >= 2**63:
        raise top.fail("seed", "must be below 2**63")
    small = top.boolean("small_shards", False)
    shard_size = top.integer("shard_size", MIN_SHARD, minimum=1 if small else MIN_SHARD)
    if "robot" not in data:
        raise SweepSpecError(f'{file}: missing [robot] table; add [robot] with model = "panda"')
    robot = RobotSource.from_table(top.sub("robot"), base)
    solver = _solver(top.sub("solver"))
    params = KINDS[kind].parse(top.sub(kind), base)
    top.done()
    return SweepSpec(kind, name, description, seed, shard_size, robot, solver, params, file, base)


def _solver(r: Reader) -> dict[str, float | int]:
    out: dict[str, float | int] = {}
    for key, (kind, default) in SOLVER_KEYS.items():
        if kind == "positive":
            out[key] = r.positive(key, default)
        elif kind == "nonnegative":
            out[key] = r.nonnegative(key, default)
        else:
            out[key] = r.integer(key, int(default), minimum=1 if kind == "count" else 0)
    r.done()
    return out


def builtin_specs() -> dict[str, Path]:
    """Name -> path of the sweep specs shipped with redres (``redres sweep --list``)."""
    from importlib import resources

    folder = resources.files("redres") / "sweeps" / "specs"
    return {Path(str(p)).stem: Path(str(p)) for p in folder.iterdir() if str(p).endswith(".toml")}
