"""What a sweep kind is: its parameters, its plan, and the work of one shard.

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

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..robot import Robot
    from .source import RobotSource
    from .spec import Reader, SweepSpec

__all__ = ["Field", "Kind", "Plan", "ShardJob"]


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
