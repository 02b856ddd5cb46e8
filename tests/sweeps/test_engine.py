"""The sweep engine: resume, faults, engines, and folders it must refuse.

Oracle throughout: an uninterrupted in-process run of the same spec, compared file by
file (SHA-256 of every byte under the output folder).
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from redres import sweeps
from redres.errors import install_hint
from redres.sweeps import SweepFolderError
from redres.sweeps.folder import read_json
from redres.sweeps.store import checksum

from .helpers import tree_digest, write_spec

#: Larger shards (about 1,000 queries, a fraction of a second each) for the kill test.
KILL_MAP = {"resolution": "0.05", "bounds": "[[0.2, 0.6], [-0.2, 0.2], [0.2, 0.6]]",
            "shard_size": "1000"}  # fmt: skip


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    """The small map, run in-process once: (folder, digest of its files)."""
    folder = tmp_path_factory.mktemp("reference")
    spec = write_spec(folder)
    report = sweeps.run(spec, folder / "out", workers=1, progress=False)
    assert report.computed == report.shards == 6 and report.engine == "in-process"
    return folder / "out", tree_digest(folder / "out")


def test_layout_and_load(reference: tuple[Path, dict[str, str]]) -> None:
    out, digest = reference
    assert {"sweep.json", "data.zarr/zarr.json"} <= set(digest)
    assert sum(k.startswith("manifest/") for k in digest) == 6
    header = json.loads((out / "sweep.json").read_text())
    entry = json.loads((out / "manifest" / "000002.json").read_text())
    assert entry["shard"] == 2 and entry["units"] == [10, 15] and entry["rows"] == 60
    assert set(entry["versions"]) >= {"redres", "pin", "numba"}
    assert entry["settings_sha256"] == header["settings_sha256"]
    assert entry["robot"]["model"] == "panda" and len(entry["robot"]["model_sha256"]) == 64
    assert entry["solver"]["max_restarts"] == 1
    data = sweeps.load(out)
    assert data.done and data.kind == "capability" and set(data) == {
        "reachable", "manipulability", "margin"}  # fmt: skip
    store = data.store
    assert checksum(store.read(2)) == entry["sha256"]  # the entry checks the stored arrays
    units = header["units"]
    assert data["reachable"].shape == (units, 12) and data.tables["centres"].shape == (units, 3)


def test_resume_skips_finished_shards(reference: tuple[Path, dict[str, str]]) -> None:
    out, digest = reference
    spec = out.parent / "spec.toml"
    again = sweeps.run(spec, out, workers=1, progress=False)
    assert again.skipped == 6 and again.computed == 0 and not again.redone
    assert tree_digest(out) == digest


@pytest.mark.parametrize("storage", ["npz", "zarr"])
def test_bad_shards_are_redone(tmp_path: Path, storage: str) -> None:
    spec = write_spec(tmp_path)
    out = tmp_path / "out"
    sweeps.run(spec, out, workers=1, progress=False, storage=storage)
    digest = tree_digest(out)
    if storage == "zarr":
        chunk = out / "data.zarr" / "reachable" / "c" / "1" / "0"
        chunk.write_bytes(chunk.read_bytes()[:-7])  # truncated
        other = out / "data.zarr" / "margin" / "c" / "4" / "0"
    else:
        chunk = out / "shards" / "000001.npz"
        chunk.write_bytes(chunk.read_bytes()[:100])
        other = out / "shards" / "000004.npz"
    manifest = out / "manifest" / "000003.json"
    entry = json.loads(manifest.read_text())
    entry["sha256"] = "0" * 64  # a checksum that does not match
    manifest.write_text(json.dumps(entry))
    other.unlink()  # a lost file
    report = sweeps.run(spec, out, workers=1, progress=False)
    assert sorted(report.redone) == [1, 3, 4] and report.computed == 3
    assert tree_digest(out) == digest


def test_engines_give_identical_bytes(
    tmp_path: Path, reference: tuple[Path, dict[str, str]]
) -> None:
    _, digest = reference
    for workers in (2, 4):
        (tmp_path / f"w{workers}").mkdir()
        spec = write_spec(tmp_path / f"w{workers}")
        report = sweeps.run(spec, spec.parent / "out", workers=workers, progress=False)
        assert report.engine == "process pool" and report.workers == workers
        assert tree_digest(spec.parent / "out") == digest, workers
    (tmp_path / "threads").mkdir()
    spec = write_spec(tmp_path / "threads")
    with ThreadPoolExecutor(3) as pool:
        report = sweeps.run(spec, spec.parent / "out", executor=pool, progress=False)
    assert report.engine == "ThreadPoolExecutor"
    assert tree_digest(spec.parent / "out") == digest


def test_sigkill_midway_then_resume(tmp_path: Path) -> None:
    """Kill -9 the `redres sweep` process once some shards are stored; resuming gives
    the bytes of an uninterrupted run."""
    (tmp_path / "whole").mkdir()
    spec = write_spec(tmp_path / "whole", **KILL_MAP)
    sweeps.run(spec, tmp_path / "whole" / "out", workers=1, progress=False)
    digest = tree_digest(tmp_path / "whole" / "out")
    spec = write_spec(tmp_path, **KILL_MAP)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "redres", "sweep", str(spec), "--out", str(out),
               "--workers", "1", "--quiet"]  # fmt: skip
    process = subprocess.Popen(command, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while len(list(out.glob("manifest/*.json"))) < 2 and time.monotonic() < deadline:
        assert process.poll() is None, process.stderr.read() if process.stderr else ""
        time.sleep(0.005)
    process.send_signal(signal.SIGKILL)
    process.wait()
    done = len(list((out / "manifest").glob("*.json")))
    shards = json.loads((out / "sweep.json").read_text())["shards"]
    assert 2 <= done < shards, (done, shards)  # killed midway
    report = sweeps.run(spec, out, workers=1, progress=False)
    assert report.skipped == done and report.computed == shards - done
    assert tree_digest(out) == digest


def test_mismatched_spec_is_refused(reference: tuple[Path, dict[str, str]], tmp_path: Path) -> None:
    out, digest = reference
    cases = {
        "resolution": ("its settings differ (capability.resolution was 0.1, the spec gives 0.12)",
                       {"resolution": "0.12"}),
        "robot": ("its robot differs (robot.label was 'panda', the spec gives 'iiwa14')",
                  {"model": '"iiwa14"'}),
        "solver": ("solver.max_restarts was 1, the spec gives 3", {"max_restarts": "3"}),
    }  # fmt: skip
    for name, (message, changes) in cases.items():
        spec = write_spec(tmp_path, name=f"{name}.toml", **changes)
        with pytest.raises(SweepFolderError) as error:
            sweeps.run(spec, out, workers=1, progress=False)
        text = str(error.value)
        assert message in text and "\n" not in text, text
    original = (out / "sweep.json").read_bytes()
    header = json.loads(original)
    header["versions"]["redres"] = "0.0.1"
    (out / "sweep.json").write_text(json.dumps(header))
    try:
        with pytest.raises(SweepFolderError, match=r"written by redres 0\.0\.1, this is redres"):
            sweeps.run(out.parent / "spec.toml", out, workers=1, progress=False)
    finally:
        (out / "sweep.json").write_bytes(original)
    assert tree_digest(out) == digest


def test_foreign_folders_are_refused(small_spec: Path, tmp_path: Path) -> None:
    mine = tmp_path / "photos"
    mine.mkdir()
    (mine / "holiday.jpg").write_bytes(b"\xff\xd8")
    with pytest.raises(SweepFolderError, match="holds files that are not a sweep"):
        sweeps.run(small_spec, mine, workers=1, progress=False)
    assert [p.name for p in mine.iterdir()] == ["holiday.jpg"]
    out = tmp_path / "out"
    sweeps.run(small_spec, out, workers=1, progress=False)
    (out / "notes.txt").write_text("mine")
    with pytest.raises(SweepFolderError, match="also holds notes.txt"):
        sweeps.run(small_spec, out, workers=1, progress=False)
    with pytest.raises(SweepFolderError, match="is a file"):
        sweeps.run(small_spec, small_spec, workers=1, progress=False)


def test_shards_draw_from_their_own_generator(reference: tuple[Path, dict[str, str]]) -> None:
    """Shard k's restart keys are default_rng([seed, k]): recomputing one shard alone
    from its job gives its stored arrays."""
    from redres.sweeps import engine
    from redres.sweeps.kinds import KINDS

    out, _ = reference
    spec = sweeps.load_spec(out.parent / "spec.toml")
    plan = KINDS["capability"].plan(spec, spec.robot.build())
    data = sweeps.load(out)
    job = engine._job(spec, plan, data.store, 3)
    assert job.rng().integers(0, 2**62) == np.random.default_rng([7, 3]).integers(0, 2**62)
    assert checksum(engine.execute(job)) == checksum(data.store.read(3))


def test_npz_when_zarr_is_absent(
    small_spec: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    reference: tuple[Path, dict[str, str]],
) -> None:  # fmt: skip
    from redres.errors import MissingDependencyError
    from redres.sweeps import engine

    monkeypatch.setattr(engine, "zarr_available", lambda: False)
    with pytest.raises(MissingDependencyError, match=re.escape(install_hint("zarr"))):
        sweeps.run(small_spec, tmp_path / "z", workers=1, progress=False, storage="zarr")
    report = sweeps.run(small_spec, tmp_path / "out", workers=1, progress=False)
    assert json.loads((tmp_path / "out" / "sweep.json").read_text())["storage"] == "npz"
    assert (tmp_path / "out" / "shards").is_dir() and not (tmp_path / "out" / "data.zarr").exists()
    npz, zarr_data = sweeps.load(tmp_path / "out"), sweeps.load(reference[0])
    assert report.computed == report.shards and set(npz) == set(zarr_data)
    for name in npz:  # the same arrays in either store
        assert np.array_equal(npz[name], zarr_data[name], equal_nan=True)


def test_bad_engine_arguments(small_spec: Path, tmp_path: Path) -> None:
    from redres.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="workers must be >= 1"):
        sweeps.run(small_spec, tmp_path / "a", workers=0, progress=False)
    with ThreadPoolExecutor(1) as pool, pytest.raises(InvalidParameterError, match="not both"):
        sweeps.run(small_spec, tmp_path / "b", executor=pool, scheduler="tcp://x:1")
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()  # nothing written


def _children(pid: int) -> set[int]:
    """The processes whose parent is ``pid`` (from /proc)."""
    found = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.add(int(stat.parent.name))
    return found


def _alive(pid: int) -> bool:
    """Whether ``pid`` exists and is not a zombie (a reaped or zombie process is gone)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux's /proc")
@pytest.mark.parametrize("moment", [0.0, 0.3, 0.6, 1.0])
def test_sigkill_of_a_pool_sweep_leaves_no_process(tmp_path: Path, moment: float) -> None:
    """`kill -9` of `redres sweep --workers 2` at a moment of its work (the fraction of its
    shards stored): its pool processes end with it (they were left running for good)."""
    spec = write_spec(tmp_path, **KILL_MAP)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "redres", "sweep", str(spec), "--out", str(out),
               "--workers", "2", "--quiet"]  # fmt: skip
    process = subprocess.Popen(command, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 300
    workers: set[int] = set()
    while time.monotonic() < deadline and process.poll() is None:
        workers |= _children(process.pid)
        header = read_json(out / "sweep.json")
        stored = len(list(out.glob("manifest/*.json")))
        if len(workers) >= 2 and header and stored >= moment * (header["shards"] - 1):
            break
        time.sleep(0.01)
    assert process.poll() is None, "the sweep ended before it could be killed"
    assert len(workers) >= 2, workers  # the pool (and multiprocessing's tracker) are up
    process.send_signal(signal.SIGKILL)
    process.wait()
    deadline = time.monotonic() + 60  # they end within a second; generous on a loaded machine
    while any(map(_alive, workers)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in workers if _alive(pid)], "pool processes outlived the sweep"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux's /proc")
def test_ctrl_c_of_a_pool_sweep_says_how_to_resume_in_one_line(tmp_path: Path) -> None:
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) printed a
    35-line traceback from the sweep and each worker; now one line, exit code 130, and
    the stored shards resume."""
    spec = write_spec(tmp_path, **KILL_MAP)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "redres", "sweep", str(spec), "--out", str(out),
               "--workers", "2", "--quiet"]  # fmt: skip
    process = subprocess.Popen(command, stderr=subprocess.PIPE, start_new_session=True)
    deadline = time.monotonic() + 300
    while not list(out.glob("manifest/*.json")) and time.monotonic() < deadline:
        assert process.poll() is None, process.stderr.read() if process.stderr else ""
        time.sleep(0.01)
    workers = _children(process.pid)
    os.killpg(process.pid, signal.SIGINT)
    _, err = process.communicate(timeout=600)
    text = err.decode()
    assert process.returncode == 130, text
    assert "Traceback" not in text and text.strip().count("\n") == 0, text
    assert "interrupted" in text and "run the same command again to resume" in text
    deadline = time.monotonic() + 60
    while any(map(_alive, workers)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in workers if _alive(pid)]
    report = sweeps.run(spec, out, workers=1, progress=False)
    assert report.skipped >= 1 and report.skipped + report.computed == report.shards
