"""Sweep specs: the TOML file that says what a sweep computes (docs/sweeps.md).

A spec is read with :mod:`tomllib` only; nothing in it is executed (no code, no pickle,
no paths run). Every problem is one :class:`SweepSpecError` line naming the file and the
key (``panda.toml: [capability].resolution: must be > 0; got -0.05``), through the same
typed reader as scenario files (:mod:`redres.scenarios.spec`).

Layout::

    kind = "capability"          # a kind of redres.sweeps.kinds: capability, ik_dataset, ...
    name = "panda-capability"    # optional (default: the file name)
    description = "..."          # optional
    seed = 0                     # shard k draws from numpy.random.default_rng([seed, k])
    shard_size = 10000           # queries per shard, >= 10000 unless small_shards = true

    [robot]                      # model, menagerie, urdf or mjcf (+ tip, frame, qd_max, ...)
    model = "panda"

    [solver]                     # the IK settings of redres.batch.ik (kinds that solve IK)
    max_restarts = 2

    [capability]                 # the kind's own table, named as the kind
    resolution = 0.05
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .._toml import Reader, load
from ..scenarios.spec import ScenarioError
from .kind import SweepSpec, SweepSpecError
from .source import RobotSource

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


def load_spec(path: str | Path) -> SweepSpec:
    """Read and validate a sweep spec file; raises :class:`SweepSpecError`."""
    file = Path(path)
    return parse_spec(load(file, "sweep spec", SweepSpecError), file.name, file.parent)


def parse_spec(data: dict[str, Any], file: str = "<spec>", base: Path = Path()) -> SweepSpec:
    """Validate a parsed spec (a dict as :mod:`tomllib` returns); ``base`` is the folder
    relative paths in it are taken from."""
    try:
        return _parse(data, file, base)
    except ScenarioError as exc:
        raise SweepSpecError(str(exc)) from None


def _parse(data: dict[str, Any], file: str, base: Path) -> SweepSpec:
    from .kinds import KINDS

    top = Reader(data, "", file, SweepSpecError)
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
