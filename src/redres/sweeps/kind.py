"""What a sweep kind is: its parameters, its plan, and the work of one shard; and the
validated spec a kind plans from (:class:`SweepSpec`, read by :mod:`redres.sweeps.spec`).

A kind (:data:`redres.sweeps.kinds.KINDS`) turns a spec into a :class:`Plan` in the
process that runs the sweep (deterministic: the same spec gives the same plan), and
computes one shard at a time in a worker (:attr:`Kind.run`), from a :class:`ShardJob`
that carries everything the shard needs: the robot as text, the parameters, its slice
of the plan's inputs and its generator's seed ``[seed, k]``.

The plan's leading axis counts *units* (a voxel of a capability map, a pose of an IK
dataset, a candidate base), each of ``queries_per_unit`` queries; a shard is
``shard_units`` consecutive units, at least the spec's ``shard_size`` queries.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import RedresError

if TYPE_CHECKING:
    from .._toml import Reader
    from ..robot import Robot
    from .source import RobotSource

__all__ = ["Field", "Kind", "Plan", "ShardJob", "SweepSpec", "SweepSpecError"]


class SweepSpecError(RedresError, ValueError):
    """A sweep spec is unreadable or invalid (one line: the file, the key, the fix)."""


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep spec.

    Attributes:
        kind: the sweep kind (:data:`redres.sweeps.kinds.KINDS`).
        name, description: for people.
        seed: the seed of every shard's generator, ``default_rng([seed, k])``.
        shard_size: queries per shard (a kind rounds it to whole units, e.g. voxels).
        robot: the robot, as built-in name or URDF text.
        solver: the IK settings (:data:`redres.sweeps.spec.SOLVER_KEYS`), passed to
            :func:`redres.batch.ik`.
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


@dataclass(frozen=True)
class Field:
    """An output array of a sweep: ``(units, *shape)`` of ``dtype`` (a NumPy name)."""

    dtype: str
    shape: tuple[int, ...] = ()
    doc: str = ""


@dataclass
class Plan:
    """What a sweep computes, fixed before any shard runs.

    Attributes:
        units: units of the sweep (rows of every output field).
        queries_per_unit: queries (solves) per unit.
        fields: the output arrays by name.
        inputs: arrays with one row per unit, sliced into each shard's job.
        constants: arrays every shard receives whole (orientations, a map's tables).
        tables: arrays stored once with the results (voxel centres, directions), for
            :func:`redres.sweeps.load`.
        meta: plain JSON values kept in the header (scheme labels), for people and
            :func:`redres.sweeps.load`.
    """

    units: int
    queries_per_unit: int
    fields: dict[str, Field]
    inputs: dict[str, np.ndarray] = field(default_factory=dict)
    constants: dict[str, np.ndarray] = field(default_factory=dict)
    tables: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)

    def shard_units(self, shard_size: int) -> int:
        """Units per shard: whole units of at least ``shard_size`` queries."""
        return max(1, -(-shard_size // max(1, self.queries_per_unit)))


@dataclass(frozen=True)
class ShardJob:
    """One shard's work, as sent to a worker (small and picklable).

    Attributes:
        kind: the kind's name.
        robot: the robot to rebuild.
        params: the kind's parameters.
        solver: IK settings (:func:`redres.batch.ik` keywords).
        seed: the sweep's seed; the shard draws from ``default_rng([seed, shard])``.
        shard: the shard's index.
        start, stop: its units.
        inputs: the plan's inputs, rows ``start:stop``.
        constants: the plan's constants.
        threads: threads of the compiled kernels (None: all).
    """

    kind: str
    robot: RobotSource
    params: Any
    solver: dict[str, Any]
    seed: int
    shard: int
    start: int
    stop: int
    inputs: dict[str, np.ndarray]
    constants: dict[str, np.ndarray]
    threads: int | None = None

    def rng(self) -> np.random.Generator:
        """The shard's generator, ``default_rng([seed, shard])``."""
        return np.random.default_rng([self.seed, self.shard])


@dataclass(frozen=True)
class Kind:
    """A sweep kind.

    Attributes:
        name: its spec name (``kind = "capability"``).
        summary: one line for ``redres sweep --list`` and the docs.
        parse: reads the kind's table of a spec into its frozen parameters
            (``parse(reader, spec folder)``).
        plan: ``plan(spec, robot) -> Plan`` in the process running the sweep.
        run: ``run(job, robot) -> {field: array (stop - start, *shape)}`` in a worker.
        warmup: the warm-up groups of :mod:`redres._warmup` its shards use (compiled
            before the fan-out, so that workers load them from the disk cache).
    """

    name: str
    summary: str
    parse: Callable[[Reader, Path], Any]
    plan: Callable[[SweepSpec, Robot], Plan]
    run: Callable[[ShardJob, Robot], dict[str, np.ndarray]]
    warmup: tuple[str, ...] = ("linalg", "batch")
