"""The Dask engine on a real ``distributed.LocalCluster`` with two worker processes:
the same bytes as an in-process run, also when a worker is killed midway (the
scheduler runs its shard again on another worker)."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import pytest

from redres import sweeps

from .helpers import tree_digest, write_spec

distributed = pytest.importorskip("distributed")

#: Shards of about 1,000 queries, long enough to kill a worker while one runs.
SLOW = {"resolution": "0.05", "bounds": "[[0.2, 0.6], [-0.2, 0.2], [0.2, 0.6]]",
        "shard_size": "1000"}  # fmt: skip


def test_local_cluster_with_a_worker_killed(tmp_path: Path) -> None:
    (tmp_path / "local").mkdir()
    spec = write_spec(tmp_path / "local", **SLOW)
    sweeps.run(spec, tmp_path / "local" / "out", workers=1, progress=False)
    expected = tree_digest(tmp_path / "local" / "out")
    spec = write_spec(tmp_path, **SLOW)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:  # fmt: skip
        with distributed.Client(cluster) as client:
            pids = list(client.run(os.getpid).values())
        assert len(pids) == 2
        out = tmp_path / "out"
        killed: list[int] = []

        def kill_once_started() -> None:  # a worker dies while its shard runs
            deadline = time.monotonic() + 60
            while not list(out.glob("manifest/*.json")) and time.monotonic() < deadline:
                time.sleep(0.005)
            os.kill(pids[0], signal.SIGKILL)
            killed.append(pids[0])

        killer = threading.Thread(target=kill_once_started)
        killer.start()
        report = sweeps.run(spec, out, scheduler=cluster.scheduler_address, progress=False)
        killer.join()
    assert killed and report.engine == "dask" and report.computed == report.shards
    assert tree_digest(out) == expected
