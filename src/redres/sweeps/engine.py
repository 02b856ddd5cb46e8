"""Running a sweep: plan, resume, fan the shards out, store each one as it finishes.

:func:`run` plans the sweep in the calling process, checks the output folder
(:mod:`redres.sweeps.folder`: resume only the same sweep, never write into a folder of
other files), skips the finished shards and redoes those whose stored arrays do not give
back their manifest checksum, compiles the kernels the kind uses (so that workers load
them from the disk cache instead of compiling them each), then hands the other shards
to an engine and stores each result the moment it comes back: arrays first, manifest
entry second, both atomically.

Engines:

* in-process (``workers=1``, or a single shard to do): the shards in order, the compiled
  kernels on all threads;
* a local process pool (the default: ``workers=None`` takes every core): spawned worker
  processes, one thread of compiled code each;
* any :class:`concurrent.futures.Executor` (``executor=``), one thread each;
* Dask (``scheduler="tcp://host:8786"``, ``redres[dask]``): a
  :class:`distributed.Client` on that scheduler and its ``get_executor()``; the
  scheduler retries the shard of a worker lost midway (its ``allowed-failures``).

A job carries the robot as its URDF text or built-in name (:class:`RobotSource`), the
kind's parameters, its slice of the plan and its seed ``[seed, k]``; workers rebuild the
robot once per process. Every shard is a function of its job only, so the stored bytes
do not depend on the engine, the number of workers or the order in which shards finish.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import _compile
from ..errors import InvalidParameterError, MissingDependencyError, RedresError, install_hint
from .folder import (
    FORMAT,
    FORMAT_VERSION,
    HEADER,
    MANIFEST,
    check_folder,
    read_json,
    versions,
    write_json,
)
from .kind import Plan, ShardJob, SweepSpec
from .spec import load_spec
from .store import Storage, Store, checksum, open_store, zarr_available

__all__ = ["SweepReport", "execute", "run"]


@dataclass
class SweepReport:
    """What :func:`run` did.

    Attributes:
        folder: the output folder.
        kind: the sweep kind.
        shards: shards of the sweep.
        skipped: shards found finished (resumed past).
        redone: shards whose stored arrays did not match their checksum, computed again.
        tables_rewritten: the plan's stored tables did not match their checksum (a file
            lost or altered) and were written again.
        computed: shards computed by this call.
        queries: queries of the computed shards.
        seconds: wall-clock time of this call, s.
        engine: ``"in-process"``, ``"process pool"``, the executor's class, or ``"dask"``.
        workers: workers used.
    """

    folder: Path
    kind: str
    shards: int
    skipped: int = 0
    redone: list[int] = field(default_factory=list)
    tables_rewritten: bool = False
    computed: int = 0
    queries: int = 0
    seconds: float = 0.0
    engine: str = "in-process"
    workers: int = 1

    @property
    def queries_per_second(self) -> float:
        return self.queries / self.seconds if self.seconds > 0 else 0.0

    def as_dict(self) -> dict[str, Any]:
        return {
            "folder": str(self.folder), "kind": self.kind, "shards": self.shards,
            "skipped": self.skipped, "redone": self.redone,
            "tables_rewritten": self.tables_rewritten, "computed": self.computed,
            "queries": self.queries, "seconds": round(self.seconds, 3),
            "queries_per_second": round(self.queries_per_second, 1), "engine": self.engine,
            "workers": self.workers,
        }  # fmt: skip


def run(
    spec: SweepSpec | str | Path,
    out: str | Path,
    *,
    workers: int | None = None,
    executor: cf.Executor | None = None,
    scheduler: str | None = None,
    storage: Storage | None = None,
    progress: bool = True,
) -> SweepReport:
    """Run (or resume) the sweep of ``spec`` into the folder ``out``.

    Args:
        spec: a :class:`SweepSpec` or the path of its TOML file.
        out: the output folder: absent, empty, or this sweep (resumed).
        workers: local worker processes (``None``: every core; ``1``: in-process).
        executor: run the shards on this executor instead (``workers`` is ignored).
        scheduler: the address of a running Dask scheduler (``redres[dask]``).
        storage: ``"zarr"`` (default when Zarr is installed) or ``"npz"``; when
            resuming, the folder's.
        progress: show a progress bar on standard error (shards, queries/s, time left).

    Raises:
        SweepSpecError: the spec is invalid.
        SweepFolderError: ``out`` holds other files, or a sweep that differs.
        MissingDependencyError: ``scheduler`` without Dask, or ``storage="zarr"``
            without Zarr.
        InvalidParameterError: ``workers < 1``, or both ``executor`` and ``scheduler``.
    """
    from .kinds import KINDS

    if executor is not None and scheduler is not None:
        raise InvalidParameterError("give executor= or scheduler=, not both")
    if workers is not None and (isinstance(workers, bool) or int(workers) < 1):
        raise InvalidParameterError(f"workers must be >= 1 (or None: every core); got {workers}")
    start = time.perf_counter()
    if not isinstance(spec, SweepSpec):
        spec = load_spec(spec)
    folder = Path(out)
    kind = KINDS[spec.kind]
    robot = spec.robot.build()
    if kind.warmup:  # before the plan, which may use batch kernels itself (FK sampling)
        _compile.warm(kind.warmup)
    plan = kind.plan(spec, robot)
    shard_units = plan.shard_units(spec.shard_size)
    count = -(-plan.units // shard_units)
    old = read_json(folder / HEADER) if folder.is_dir() else None
    storage = storage or (old or {}).get("storage") or ("zarr" if zarr_available() else "npz")
    if storage == "zarr" and not zarr_available():
        raise MissingDependencyError(f"storage 'zarr' needs Zarr 3: {install_hint('zarr')}")
    header = _header(spec, plan, storage, shard_units, count)
    store = open_store(storage, folder, plan.fields, plan.units, shard_units)
    report = SweepReport(folder, spec.kind, count)
    resume = check_folder(folder, header)
    if not resume:  # the header first: from then on the folder is recognisably a sweep's
        folder.mkdir(parents=True, exist_ok=True)
        write_json(folder / HEADER, header)
    (folder / MANIFEST).mkdir(exist_ok=True)
    if not (resume and store.valid()):  # new, or killed while it was being created
        store.create(plan.tables)
    elif store.tables_sha256() != header["tables_sha256"]:  # a table file lost or altered
        store.write_tables(plan.tables)
        report.tables_rewritten = True
    todo = _unfinished(folder, store, count, header, report) if resume else list(range(count))
    report.skipped = count - len(todo)
    if todo:
        jobs = [_job(spec, plan, store, k) for k in todo]
        finish = _finisher(folder, store, header, plan, report)
        with _progress(spec.name, count, report.skipped, plan, progress) as tick:
            _dispatch(jobs, finish, tick, report, workers, executor, scheduler)
    report.seconds = time.perf_counter() - start
    return report


def execute(job: ShardJob) -> dict[str, np.ndarray]:
    """One shard's arrays (what a worker runs): the robot rebuilt once per process, the
    kernels compiled or loaded on this process's path, then the kind's ``run``."""
    from .kinds import KINDS

    kind = KINDS[job.kind]
    _compile.warm(kind.warmup, quiet=True)
    return kind.run(job, job.robot.build())


# ---------------------------------------------------------------------- the folder


def _header(
    spec: SweepSpec, plan: Plan, storage: str, shard_units: int, count: int
) -> dict[str, Any]:
    arrays = {f"inputs/{k}": v for k, v in plan.inputs.items()}
    arrays.update({f"constants/{k}": v for k, v in plan.constants.items()})
    arrays.update({f"tables/{k}": v for k, v in plan.tables.items()})
    return {
        "format": FORMAT, "format_version": FORMAT_VERSION, "kind": spec.kind,
        "name": spec.name, "description": spec.description, "settings": spec.settings(),
        "settings_sha256": spec.digest(), "versions": versions(), "storage": storage,
        "units": plan.units, "queries_per_unit": plan.queries_per_unit,
        "shard_units": shard_units, "shards": count, "plan_sha256": checksum(arrays),
        "tables_sha256": checksum(plan.tables),
        "fields": {k: {"dtype": f.dtype, "shape": list(f.shape), "doc": f.doc}
                   for k, f in plan.fields.items()},
        "tables": sorted(plan.tables), "meta": plan.meta,
    }  # fmt: skip


def _entry_path(folder: Path, shard: int) -> Path:
    return folder / MANIFEST / f"{shard:06d}.json"


def _unfinished(
    folder: Path, store: Store, count: int, header: dict[str, Any], report: SweepReport
) -> list[int]:
    """Shards to compute: no manifest entry, or stored arrays that do not give back the
    entry's checksum (recorded in ``report.redone``)."""
    todo = []
    for k in range(count):
        entry = read_json(_entry_path(folder, k))
        if not isinstance(entry, dict) or entry.get("settings_sha256") != header["settings_sha256"]:
            todo.append(k)
            continue
        arrays = store.read(k)
        if arrays is None or checksum(arrays) != entry.get("sha256"):
            todo.append(k)
            report.redone.append(k)
    return todo


def _job(spec: SweepSpec, plan: Plan, store: Store, shard: int) -> ShardJob:
    start, stop = store.rows(shard)
    inputs = {k: np.ascontiguousarray(v[start:stop]) for k, v in plan.inputs.items()}
    return ShardJob(spec.kind, spec.robot, spec.params, dict(spec.solver), spec.seed, shard,
                    start, stop, inputs, plan.constants)  # fmt: skip


def _finisher(
    folder: Path, store: Store, header: dict[str, Any], plan: Plan, report: SweepReport
) -> Any:
    """The function storing one finished shard: checks, arrays, then manifest entry."""
    robot = header["settings"]["robot"]

    def finish(job: ShardJob, arrays: dict[str, np.ndarray]) -> None:
        rows = job.stop - job.start
        for name, f in plan.fields.items():
            got = arrays.get(name)
            if got is None or got.shape != (rows, *f.shape) or got.dtype != np.dtype(f.dtype):
                shape = None if got is None else (got.shape, str(got.dtype))
                raise RedresError(f"shard {job.shard}: field {name!r} came back as {shape}, "
                                  f"expected {((rows, *f.shape), f.dtype)}")  # fmt: skip
        arrays = {name: arrays[name] for name in plan.fields}
        store.write(job.shard, arrays)
        entry = {
            "shard": job.shard, "units": [job.start, job.stop],
            "rows": rows * plan.queries_per_unit, "sha256": checksum(arrays),
            "versions": header["versions"], "settings_sha256": header["settings_sha256"],
            "robot": {k: v for k, v in robot.items() if k.endswith("sha256") or k == "model"},
            "solver": header["settings"]["solver"],
        }  # fmt: skip
        write_json(_entry_path(folder, job.shard), entry)
        report.computed += 1
        report.queries += rows * plan.queries_per_unit

    return finish


# ---------------------------------------------------------------------- engines


def _dispatch(
    jobs: list[ShardJob],
    finish: Callable[[ShardJob, dict[str, np.ndarray]], None],
    tick: Callable[[int], None],
    report: SweepReport,
    workers: int | None,
    executor: cf.Executor | None,
    scheduler: str | None,
) -> None:
    if executor is None and scheduler is None:
        count = (os.cpu_count() or 1) if workers is None else int(workers)
        if count == 1 or len(jobs) == 1:
            report.engine, report.workers = "in-process", 1
            for job in jobs:
                finish(job, execute(job))
                tick(job.stop - job.start)
            return
        context = multiprocessing.get_context("spawn")  # numba's threads do not survive fork
        pool = cf.ProcessPoolExecutor(
            min(count, len(jobs)),
            mp_context=context,
            initializer=die_with_parent,
            initargs=(os.getpid(),),
        )
        report.engine, report.workers = "process pool", min(count, len(jobs))
        try:
            _gather(pool, jobs, finish, tick)
        except BaseException:  # Ctrl-C, a failed shard: no wait for the running shards
            pool.shutdown(wait=False, cancel_futures=True)
            raise
        pool.shutdown()
        return
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise MissingDependencyError(
                f"--scheduler needs Dask's distributed scheduler: {install_hint('dask')}"
            ) from None
        with Client(scheduler) as client:  # type: ignore[no-untyped-call]
            report.engine = "dask"
            report.workers = len(client.scheduler_info().get("workers", {})) or 1
            _gather(client.get_executor(), jobs, finish, tick)
            # workers that joined while the sweep ran count too (the count at the start
            # said "1" for a cluster whose second worker connected a moment later)
            report.workers = max(report.workers, len(client.scheduler_info().get("workers", {})))
        return
    assert executor is not None
    report.engine = type(executor).__name__
    report.workers = int(getattr(executor, "_max_workers", 0) or 1)
    _gather(executor, jobs, finish, tick)


def die_with_parent(parent: int) -> None:
    """A pool worker's initializer: end this process when ``parent`` (the sweep) is gone,
    even by ``kill -9`` (which runs no clean-up of its own): Linux's parent-death signal,
    and everywhere a thread that watches for the process to be re-parented. Ctrl-C is
    ignored here: the sweep stops the pool and says how to resume, once."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the watcher alone
        pass
    if os.getppid() != parent:  # gone before the signal was armed
        os._exit(1)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the sweep's to handle

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="redres-parent-watch", daemon=True).start()


def _gather(
    executor: cf.Executor,
    jobs: list[ShardJob],
    finish: Callable[[ShardJob, dict[str, np.ndarray]], None],
    tick: Callable[[int], None],
) -> None:
    """Submit every job (one compiled thread each) and store the results as they come."""
    pending = {executor.submit(execute, replace(job, threads=1)): job for job in jobs}
    try:
        for future in cf.as_completed(pending):
            job = pending[future]
            try:
                arrays = future.result()
            except BrokenProcessPool:
                raise RedresError(
                    f"a worker process died while computing shard {job.shard}; the finished "
                    "shards are stored: run the same sweep again to resume"
                ) from None
            finish(job, arrays)
            tick(job.stop - job.start)
    finally:
        for future in pending:
            future.cancel()


@contextmanager
def _progress(
    name: str, total: int, done: int, plan: Plan, enabled: bool
) -> Iterator[Callable[[int], None]]:
    """A tqdm bar of shards (with queries/s and the time left), or nothing."""
    if not enabled:
        yield lambda units: None
        return
    from tqdm import tqdm

    start, queries = time.perf_counter(), 0
    with tqdm(total=total, initial=done, unit="shard", desc=name, file=sys.stderr,
              dynamic_ncols=True, smoothing=0.1) as bar:  # fmt: skip

        def tick(units: int) -> None:
            nonlocal queries
            queries += units * plan.queries_per_unit
            rate = queries / max(time.perf_counter() - start, 1e-9)
            bar.set_postfix_str(f"{rate:,.0f} queries/s", refresh=False)
            bar.update(1)

        yield tick
