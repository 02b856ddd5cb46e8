"""Sweep specs: one-line errors naming the file and the key; nothing in a spec executed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from redres import sweeps
from redres.sweeps import SweepSpecError

from .helpers import SMALL_MAP, write_spec

BAD = {
    "resolution": ({"resolution": "-0.1"}, "spec.toml: [capability].resolution: must be > 0"),
    "directions": ({"directions": "2.5"}, "[capability].directions: expected an integer"),
    "kind": ({"kind": '"maps"'}, "spec.toml: kind: unknown sweep kind 'maps'; kinds: capability"),
    "model": ({"model": '"robby"'}, "spec.toml: [robot].model: unknown robot 'robby'"),
    "shard": ({"small_shards": "false"}, "spec.toml: shard_size: must be >= 10000; got 60"),
    "solver": ({"max_restarts": "-1"}, "spec.toml: [solver].max_restarts: must be >= 0"),
    "bounds": ({"bounds": "[[1, 0], [0, 1], [0, 1]]"}, "[capability].bounds: each range must"),
    "seed": ({"seed": '"abc"'}, 'spec.toml: seed: expected a number, got \'abc\''),
    "directions large": ({"directions": "100000000"}, "[capability].directions: must be <= 10,000"),
    "fk samples large": ({"fk_samples": "1000000000"}, "fk_samples: must be <= 20,000,000"),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BAD))
def test_malformed_specs_give_one_line(case: str, tmp_path: Path) -> None:
    changes, message = BAD[case]
    path = write_spec(tmp_path, **changes)
    with pytest.raises(SweepSpecError) as error:
        sweeps.load_spec(path)
    text = str(error.value)
    assert message in text and "\n" not in text, text


def test_unknown_keys_and_files(tmp_path: Path) -> None:
    path = tmp_path / "typo.toml"
    path.write_text(SMALL_MAP.replace("fk_samples", "fk_sample"))
    with pytest.raises(SweepSpecError, match=r"typo.toml: \[capability\].fk_sample: unknown key"):
        sweeps.load_spec(path)
    path.write_text("kind = [")
    with pytest.raises(SweepSpecError, match="typo.toml': not valid TOML"):
        sweeps.load_spec(path)
    with pytest.raises(SweepSpecError, match="no such sweep spec file"):
        sweeps.load_spec(tmp_path / "absent.toml")
    path.write_text(SMALL_MAP.replace('model = "panda"', 'urdf = "missing.urdf"'))
    with pytest.raises(SweepSpecError, match=r"\[robot\].urdf: cannot read"):
        sweeps.load_spec(path)


def test_nothing_in_a_spec_is_executed(tmp_path: Path) -> None:
    """Strings that would run code if evaluated stay strings, and are refused as names."""
    marker = tmp_path / "ran"
    payload = f"__import__('pathlib').Path({str(marker)!r}).touch()"
    for key in ("model", "kind"):
        path = write_spec(tmp_path, **{key: repr(payload).replace("'", '"')})
        with pytest.raises(SweepSpecError):
            sweeps.load_spec(path)
    assert not marker.exists()


def test_builtin_specs_load() -> None:
    specs = sweeps.builtin_specs()
    assert {"panda_capability", "panda_ik_dataset", "iiwa14_capability"} <= set(specs)
    for path in specs.values():
        spec = sweeps.load_spec(path)
        assert spec.shard_size >= 10_000 and spec.description
    panda = sweeps.load_spec(specs["panda_capability"])
    assert panda.params.resolution == 0.05 and panda.params.directions == 50


def test_urdf_robot(tmp_path: Path, fixtures_dir: Path) -> None:
    urdf = (fixtures_dir / "panda_description.urdf").read_text()
    (tmp_path / "arm.urdf").write_text(urdf)
    text = SMALL_MAP.replace('model = "panda"', 'urdf = "arm.urdf"\ntip = "panda_hand"')
    path = tmp_path / "urdf.toml"
    path.write_text(text)
    spec = sweeps.load_spec(path)
    identity = spec.settings()["robot"]
    assert spec.robot.urdf == urdf and identity["label"] == "arm.urdf"
    assert len(identity["urdf_sha256"]) == 64 and identity["tip"] == "panda_hand"
    (tmp_path / "arm.urdf").write_text(urdf + "<!-- edited -->\n")
    assert sweeps.load_spec(path).settings()["robot"]["urdf_sha256"] != identity["urdf_sha256"]


def test_mjcf_and_menagerie_robots_with_limits(tmp_path: Path) -> None:
    """An MJCF file travels as its text, a Menagerie arm as its name; both with the limits
    the spec sets, recorded in the manifest's robot identity."""
    from redres.models import menagerie_path

    text = menagerie_path("fr3").read_text()
    (tmp_path / "fr3.xml").write_text(text)
    limits = "qd_max = [2.0, 2.0, 2.0, 2.0, 2.5, 2.5, 2.5]\nqdd_max = 10.0"
    path = tmp_path / "mjcf.toml"
    path.write_text(SMALL_MAP.replace('model = "panda"', f'mjcf = "fr3.xml"\n{limits}'))
    spec = sweeps.load_spec(path)
    identity = spec.settings()["robot"]
    assert spec.robot.mjcf == text and identity["label"] == "fr3.xml"
    assert identity["limits"] == {"qd_max": [2.0] * 4 + [2.5] * 3, "qdd_max": [10.0] * 7}
    robot = spec.robot.build()
    np.testing.assert_array_equal(robot.qd_max, [2.0] * 4 + [2.5] * 3)
    np.testing.assert_array_equal(robot.tau_max, [87.0] * 4 + [12.0] * 3)  # the file's
    path.write_text(SMALL_MAP.replace('model = "panda"', f'menagerie = "fr3"\n{limits}'))
    named = sweeps.load_spec(path).settings()["robot"]
    assert named["menagerie"] == "fr3" and named["model_sha256"] == identity["model_sha256"]
    path.write_text(SMALL_MAP.replace('model = "panda"', 'mjcf = "fr3.xml"\nmodel = "panda"'))
    with pytest.raises(SweepSpecError, match=r"\[robot\]\.mjcf: give exactly one of .* and mjcf"):
        sweeps.load_spec(path)
    path.write_text(SMALL_MAP.replace('model = "panda"', 'mjcf = "fr3.xml"\nqd_max = [1.0]'))
    with pytest.raises(SweepSpecError, match=r"\[robot\]\.qd_max: expected 7 numbers"):
        sweeps.load_spec(path)


def test_a_robot_file_is_named_as_the_user_wrote_it_and_must_be_regular(
    tmp_path: Path, fixtures_dir: Path
) -> None:
    """A model error names the spec's file, not the temporary copy the loader reads; a
    device such as /dev/zero is refused instead of read until memory runs out."""
    bad = (fixtures_dir / "arm3.urdf").read_text().replace('xyz="0 1 0"', 'xyz="0 0 0"', 1)
    assert 'xyz="0 0 0"' in bad
    (tmp_path / "bad.urdf").write_text(bad)
    path = tmp_path / "spec.toml"
    path.write_text(SMALL_MAP.replace('model = "panda"', 'urdf = "bad.urdf"\ntip = "tool"'))
    with pytest.raises(SweepSpecError, match=r"\[robot\]\.urdf: bad\.urdf: joint .* no dir") as e:
        sweeps.load_spec(path)
    assert "redres-sweep-" not in str(e.value)
    for device, why in (("/dev/zero", "not a regular file"), ("missing.urdf", "not found")):
        path.write_text(SMALL_MAP.replace('model = "panda"', f'urdf = "{device}"'))
        with pytest.raises(SweepSpecError, match=rf"\[robot\]\.urdf: .*{why}"):
            sweeps.load_spec(path)
