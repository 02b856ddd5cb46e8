"""Sweeps at scale: queries per second per core of each kind, engines, the full Panda map.

    .venv/bin/python benchmarks/sweeps.py                # the small measurements (~2 min)
    .venv/bin/python benchmarks/sweeps.py --full         # also the full Panda map (minutes)
    .venv/bin/python benchmarks/sweeps.py --full --no-small   # the full map alone
    .venv/bin/python benchmarks/sweeps.py --json PATH
    .venv/bin/python benchmarks/sweeps.py --redundancy --no-small   # Panda: trace vs closed form

Measures, each in a fresh temporary folder, after a warm-up (compiled kernels cached):

* **per kind**: a capability map of an 80 cm cube of the Panda's workspace (5 cm
  voxels, 50 directions), an IK dataset of Panda poses (8 solutions from 32 attempts
  each), a base placement from that map, scheme statistics of the demo scenario's
  schemes on 6 random paths of 1 s, and redundancy maps (arm-angle intervals at random
  poses; a query is one pose): 20,000 iiwa14 poses by the closed form (Shimizu et al.
  2008; shards of 10,000) and 200 Panda poses by self-motion tracing (2 manifolds
  each, one shard): in-process (all threads) and, for the capability map, on one
  thread; queries per second per core is the one-thread rate (or the all-core rate over
  the cores);
* **engines**: the same small map on the local process pool with 1 and 2 workers, and
  through a Dask ``LocalCluster`` of 2 single-threaded worker processes (its overhead
  against the pool: cluster start-up, then the run itself);
* **the goal** (``--full``): the built-in ``panda_capability`` spec, 5 cm voxels over the
  full reach, 50 orientations per voxel, end to end (plan, FK sampling, every shard,
  storage) on all cores; how many of its unreachable queries a solve with 50 restarts
  finds after all (the cost of the bounded budget); and how many of 200,000 fresh
  forward-kinematics samples land in a voxel the sampling skipped (the cost of the bet).

* **the Panda's redundancy map, traced and by the closed form at q7** (``--redundancy``):
  the same 200 random poses (seed 1, one shard, in-process) by ``method = "trace"`` (2
  manifolds, as above) and by ``method = "closed_form"`` (:mod:`redres.sweeps.kinds.q7arcs`),
  timed in the same run after an untimed sweep of 120 poses by each (a process's first
  sweep loads the kernels' overloads from the cache, and the first parallel launch
  starts the threads: about 1 s, more than the closed form's 200 poses), then the
  closed form alone on 2,000 poses (one shard); and the agreement: each traced arc
  against the connected piece of the closed form's self-motion with the same number of
  pieces and the nearest ends (within 1e-3 rad counts as agreeing); each disagreeing arc
  of ``q_true`` (slot 0) is traced again with steps of 0.001 rad (the independent check:
  the trace's arm-angle extremes are its samples').

Every figure is one run (the sweeps take seconds to minutes; repeat to see the spread);
the load average before and after is printed with them.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pinocchio as pin

import redres as rr
from redres import sweeps

SMALL = """
kind = "capability"
name = "bench-small"
seed = 1
shard_size = 10000
[robot]
model = "panda"
[capability]
resolution = 0.05
bounds = [[-0.2, 0.6], [-0.4, 0.4], [0.0, 0.8]]
directions = 50
fk_samples = 100000
"""

STATS = """
kind = "scheme_statistics"
seed = 1
[robot]
model = "panda"
[scheme_statistics]
scenario = "panda_joint_limit_circle"
paths = 6
duration = 1.0
"""

REDUNDANCY = """
kind = "redundancy_map"
seed = 1
shard_size = {shard}
small_shards = true
[robot]
model = "{model}"
[redundancy_map]
poses = {poses}
method = "{method}"
manifolds = 2
"""

DATASET = """
kind = "ik_dataset"
seed = 1
shard_size = 2000
small_shards = true
[robot]
model = "panda"
[solver]
tol_position = 1e-6
tol_orientation = 1e-5
max_iterations = 100
patience = 10
[ik_dataset]
poses = 4000
solutions = 8
attempts = 32
"""


def load() -> str:
    return "/".join(f"{x:.2f}" for x in os.getloadavg())


def timed_run(spec: Path, out: Path, **kw: object) -> sweeps.SweepReport:
    start = time.perf_counter()
    report = sweeps.run(spec, out, progress=False, **kw)  # type: ignore[arg-type]
    report.seconds = time.perf_counter() - start
    return report


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text)
    return path


def small_measurements(folder: Path) -> dict[str, object]:
    cores = os.cpu_count() or 1
    out: dict[str, object] = {"cores": cores}
    spec = write(folder, "small.toml", SMALL)
    runs: dict[str, sweeps.SweepReport] = {}
    runs["in-process"] = timed_run(spec, folder / "inproc", workers=1)
    with ThreadPoolExecutor(1) as one:  # one job at a time, one thread of compiled code
        runs["one thread"] = timed_run(spec, folder / "thread", executor=one)
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        runs["pool 1"] = timed_run(spec, folder / "pool1", executor=pool)
    runs["pool 2"] = timed_run(spec, folder / "pool2", workers=2)
    try:
        import distributed

        start = time.perf_counter()
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                      dashboard_address=None) as cluster:  # fmt: skip
            started = time.perf_counter() - start
            runs["dask 2"] = timed_run(spec, folder / "dask", scheduler=cluster.scheduler_address)
        out["dask_startup_s"] = round(started, 2)
    except ImportError:
        out["dask"] = "distributed not installed"
    queries = runs["in-process"].queries
    out["small_map_queries"] = queries
    out["engines"] = {
        k: {"seconds": round(r.seconds, 2), "queries_per_s": round(queries / r.seconds)}
        for k, r in runs.items()
    }
    per_core = {"capability": queries / runs["one thread"].seconds}
    spec = write(folder, "dataset.toml", DATASET)
    report = timed_run(spec, folder / "dataset", workers=1)
    per_core["ik_dataset (poses)"] = report.queries / report.seconds / cores
    per_core["ik_dataset (attempts)"] = (
        float(sweeps.load(folder / "dataset")["attempts"].sum()) / report.seconds / cores
    )
    m = sweeps.load_map(folder / "inproc")
    reachable = np.argwhere(m.reachable)[:: max(1, int(m.reachable.sum()) // 40)]
    poses = []
    for v, o in reachable:
        q = pin.Quaternion(m.rotations[o]).coeffs()
        poses.append([*m.centres[v], *q])
    text = f"""
kind = "base_placement"
shard_size = 10000
[robot]
model = "panda"
[base_placement]
map = "inproc"
x = [-0.5, 0.5, 0.05]
y = [-0.5, 0.5, 0.05]
yaws = 16
poses = {json.dumps([[float(x) for x in p] for p in poses])}
"""
    spec = write(folder, "place.toml", text)
    report = timed_run(spec, folder / "place", workers=1)
    per_core["base_placement"] = report.queries / report.seconds / cores
    spec = write(folder, "stats.toml", STATS)
    report = timed_run(spec, folder / "stats", workers=1)
    per_core["scheme_statistics (control steps)"] = report.queries / report.seconds / cores
    for model, poses, method in (("iiwa14", 20000, "closed_form"), ("panda", 200, "trace")):
        shard = min(poses, 10000)
        text = REDUNDANCY.format(model=model, poses=poses, method=method, shard=shard)
        spec = write(folder, f"redundancy-{model}.toml", text)
        report = timed_run(spec, folder / f"redundancy-{model}", workers=1)
        per_core[f"redundancy_map {model} {method} (poses)"] = (
            report.queries / report.seconds / cores
        )
    out["queries_per_s_per_core"] = {k: round(v, 1) for k, v in per_core.items()}
    return out


PANDA_MAP = """
kind = "redundancy_map"
seed = 1
shard_size = {poses}
small_shards = true
[robot]
model = "panda"
[redundancy_map]
poses = {poses}
method = "{method}"
manifolds = 2
"""


def redundancy_comparison(folder: Path) -> dict[str, object]:
    """The Panda's redundancy map traced and by the closed form at q7 (module docstring)."""
    from redres.sweeps.kinds.q7arcs import q7_arcs

    cores = os.cpu_count() or 1
    out: dict[str, object] = {"load_before": load()}
    rates = {}
    for method in ("trace", "closed_form"):  # first use (kernels' overloads loaded): untimed
        # 120 poses: 4,920 evaluations at once on the grid, past one thread's 4,096
        spec = write(folder, f"warm-{method}.toml", PANDA_MAP.format(poses=120, method=method))
        sweeps.run(spec, folder / f"warm-{method}", workers=1, progress=False)
    for method, poses in (("trace", 200), ("closed_form", 200), ("closed_form", 2000)):
        spec = write(folder, f"panda-{method}-{poses}.toml",
                     PANDA_MAP.format(poses=poses, method=method))  # fmt: skip
        report = timed_run(spec, folder / f"panda-{method}-{poses}", workers=1)
        rates[f"{method} {poses}"] = report.queries / report.seconds
    out["poses_per_s_in_process"] = {k: round(v, 1) for k, v in rates.items()}
    out["poses_per_s_per_core"] = {k: round(v / cores, 1) for k, v in rates.items()}
    out["ratio_200"] = round(rates["closed_form 200"] / rates["trace 200"], 1)
    out["ratio_2000"] = round(rates["closed_form 2000"] / rates["trace 200"], 1)
    traced = sweeps.load_redundancy_map(folder / "panda-trace-200")
    closed = sweeps.load_redundancy_map(folder / "panda-closed_form-200")
    assert closed.method == "closed_form_q7" and np.array_equal(traced.pose, closed.pose)
    panda = rr.models.panda()
    components = q7_arcs(panda, traced.pose).components()

    def gap(i: int, arc: list[tuple[float, float]]) -> float:
        best = np.inf
        for comp in components[i]:
            if len(comp) == len(arc):
                g = max(abs(a - b) for pa, pb in zip(arc, comp) for a, b in zip(pa, pb))
                best = min(best, g)
        return best

    gaps, where = [], []
    for i in range(len(traced.pose)):
        for slot in range(traced.count.shape[1]):
            if traced.count[i, slot] == 0:
                continue
            arc = [tuple(p) for p in traced.intervals[i, slot, : traced.count[i, slot]]]
            gaps.append(gap(i, arc))
            where.append((i, slot))
    g = np.array(gaps)
    ok = g < 1e-3
    out["traced_arcs"] = len(g)
    out["agreeing_within_1e-3"] = int(ok.sum())
    out["largest_difference_agreeing"] = float(g[ok].max()) if ok.any() else None
    # the independent check of a disagreement: the arc of q_true (slot 0) traced again
    # with steps of 0.001 rad (the trace misses an arm angle that turns back in a step)
    again = [k for k in np.flatnonzero(~ok) if where[k][1] == 0]
    poses = np.array([where[k][0] for k in again], dtype=np.int64)
    if len(poses):
        from redres.ik.arcs import pieces
        from redres.sweeps.kinds.selfmotion import trace

        fine = trace(panda, traced.pose[poses], traced.extra["q_true"][poses], step=0.001,
                     max_steps=80_000)  # fmt: skip
        for k, (item, i) in enumerate(zip(again, poses)):
            g[item] = min(g[item], gap(int(i), pieces([fine.arc(k)])))
    out["disagreeing_slot0_retraced_0.001"] = len(again)
    out["agreeing_after_retrace"] = int((g < 1e-3).sum())
    out["disagreeing_after_retrace"] = [where[k] for k in np.flatnonzero(g >= 1e-3)]
    # the trace's lower bound: the arm angles it finds, over the closed form's
    out["union_widths_traced_over_closed"] = round(
        float(traced.total_width.sum() / closed.total_width.sum()), 3
    )
    out["load_after"] = load()
    return out


def full_map(folder: Path) -> dict[str, object]:
    spec = sweeps.builtin_specs()["panda_capability"]
    before = load()
    report = timed_run(spec, folder / "full")
    after = load()
    m = sweeps.load_map(folder / "full")
    data = sweeps.load(folder / "full")
    untested = int(data.tables["in_reach"][0]) - len(m.index)
    # The bounded budget's price: unreachable queries that 50 restarts solve after all.
    rng = np.random.default_rng(0)
    v, o = np.nonzero(~m.reachable)
    pick = rng.choice(len(v), min(2000, len(v)), replace=False)
    T = np.tile(np.eye(4), (len(pick), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = m.rotations[o[pick]], m.centres[v[pick]]
    robot = rr.models.panda()
    fresh = rr.batch.fk(
        robot, robot.q_min + (robot.q_max - robot.q_min) * rng.random((200_000, robot.n))
    )  # independent of the plan's samples
    rows, _ = m.lookup(fresh)
    retry = rr.batch.ik(robot, T, seed=1, max_restarts=50, tol_position=1e-4,
                        tol_orientation=1e-3, max_iterations=100, patience=10)  # fmt: skip
    return {
        "seconds": round(report.seconds, 1), "shards": report.shards, "queries": report.queries,
        "queries_per_s": round(report.queries / report.seconds), "voxels_tested": len(m.index),
        "voxels_in_reach_untested": untested,
        "reachable_share": round(float(m.reachable.mean()), 4),
        "found_by_50_restarts": round(float(retry.converged.mean()), 4),
        "fresh_fk_samples_in_untested_voxels": int((rows < 0).sum()),
        "load_before": before, "load_after": after,
    }  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="also the full Panda map")
    parser.add_argument("--no-small", action="store_true", help="skip the small measurements")
    parser.add_argument(
        "--redundancy",
        action="store_true",
        help="the Panda's redundancy map: trace against the closed form",
    )
    parser.add_argument("--json", help="write the figures to this file")
    args = parser.parse_args()
    rr.warmup(["linalg", "batch", "ik", "analytic ik"], quiet=True)
    result: dict[str, object] = {"load_before": load()}
    with tempfile.TemporaryDirectory() as tmp:
        if not args.no_small:
            result["small"] = small_measurements(Path(tmp))
        if args.redundancy:
            result["redundancy"] = redundancy_comparison(Path(tmp))
        if args.full:
            result["full"] = full_map(Path(tmp))
    result["load_after"] = load()
    text = json.dumps(result, indent=1)
    print(text)
    if args.json:
        Path(args.json).write_text(text + "\n")
    print(f"load average {result['load_before']} -> {result['load_after']}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
