"""``redres sweep``: the built-in list, a run with --json, one-line errors, exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from redres.cli import main

from .helpers import SMALL_MAP, write_spec


def test_list(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sweep", "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(line.startswith("panda_capability") and "capability" in line for line in lines)
    assert main(["sweep", "--list", "--json"]) == 0
    names = {row["name"] for row in json.loads(capsys.readouterr().out)}
    assert {"panda_capability", "panda_ik_dataset", "iiwa14_capability"} <= names


def test_run_resume_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = write_spec(tmp_path)
    out = tmp_path / "out"
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--json"]) == 0
    first = json.loads(capsys.readouterr().out)
    assert first["computed"] == first["shards"] == 6 and first["queries"] > 0
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "1"]) == 0
    assert "0 shards computed, 6 already done" in capsys.readouterr().out
    bad = write_spec(tmp_path, name="bad.toml", resolution="0")
    assert main(["sweep", str(bad), "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("redres: error: bad.toml: [capability].resolution: must be > 0")
    assert err.count("\n") == 1
    other = write_spec(tmp_path, name="other.toml", seed="8")
    assert main(["sweep", str(other), "--out", str(out), "--workers", "1"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(errors) == 1 and "seed was 7, the spec gives 8" in errors[0]
    assert main(["sweep", str(spec)]) == 2
    assert "give a spec and --out" in capsys.readouterr().err


def test_a_sweep_of_an_mjcf_arm_equals_the_same_arm_by_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`redres sweep` maps a Menagerie MJCF file (with limits set in the spec) and finds
    what it finds for the same file loaded by name: the file's text reaches the workers
    whole."""
    from redres import sweeps
    from redres.models import menagerie_path

    (tmp_path / "fr3.xml").write_text(menagerie_path("fr3").read_text())
    maps = {}
    for name, robot in (("file", 'mjcf = "fr3.xml"'), ("named", 'menagerie = "fr3"')):
        spec = tmp_path / f"{name}.toml"
        spec.write_text(SMALL_MAP.replace('model = "panda"', f"{robot}\nqd_max = 2.0"))
        out = tmp_path / name
        assert main(["sweep", str(spec), "--out", str(out), "--workers", "1", "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["queries"] > 0
        maps[name] = sweeps.load(out)
    reachable = maps["file"]["reachable"]
    assert reachable.any()
    for field in ("reachable", "manipulability", "margin"):
        np.testing.assert_array_equal(maps["file"][field], maps["named"][field])
