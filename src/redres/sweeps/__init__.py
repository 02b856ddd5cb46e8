"""Sweeps: the same solver run millions of times, sharded, resumable, on a cluster.

A sweep is a TOML spec (:mod:`redres.sweeps.spec`) of one kind
(:data:`~redres.sweeps.kinds.KINDS`): capability maps, redundancy maps, IK datasets, base
placement from a map. :func:`run` cuts it into shards of at least 10⁴ queries, runs them
in-process, on a local process pool (default), any :class:`concurrent.futures.Executor`
or a Dask cluster, and stores each one atomically with its manifest entry, so that a
sweep killed at any moment resumes where it stopped and gives the same bytes whatever
the engine.
:func:`load` reads a sweep folder back as named arrays. See docs/sweeps.md.

>>> import redres.sweeps as sw                                  # doctest: +SKIP
>>> report = sw.run("panda-capability.toml", "maps/panda")      # doctest: +SKIP
>>> sw.load_map("maps/panda").reachability_index                # doctest: +SKIP
"""

from __future__ import annotations

from .engine import SweepReport, run
from .folder import SweepFolderError
from .kind import SweepSpec, SweepSpecError
from .kinds import KINDS  # noqa: F401 - importable, documented in redres.sweeps.kinds
from .kinds.capability import CapabilityMap, load_map
from .kinds.redundancy import RedundancyMap, load_redundancy_map
from .results import SweepData, load
from .spec import builtin_specs, load_spec, parse_spec

__all__ = [
    "CapabilityMap",
    "RedundancyMap",
    "SweepData",
    "SweepFolderError",
    "SweepReport",
    "SweepSpec",
    "SweepSpecError",
    "builtin_specs",
    "load",
    "load_map",
    "load_redundancy_map",
    "load_spec",
    "parse_spec",
    "run",
]
