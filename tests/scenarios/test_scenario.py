"""Scenario files: the built-in ones load; every kind of mistake gives one clear message
with the key path and the fix, exit code 2, and no report folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import tomllib

import redres as rr
from redres.cli import main
from redres.control import Circle, FigureEight
from redres.errors import install_hint
from redres.resolution import Scheme
from redres.scenarios.registry import scheme_types
from redres.scenarios.spec import (
    ScenarioError,
    builtin,
    builtin_scenarios,
    load_scenario,
    parse_scenario,
)

GOOD = """
name = "tiny"
description = "a short hold"

[robot]
model = "panda"

[trajectory]
type = "circle"
radius = 0.05
period = 1.0

[run]
dt = 0.002
duration = 0.02

[[schemes]]
type = "pinv"
"""


GRADIENT = 'type = "gradient_projection"\nobjectives = [{ type = "joint_limits" }]'


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    return path


def test_builtin_scenarios_load() -> None:
    found = builtin_scenarios()
    assert {"panda_joint_limit_circle", "iiwa_arm_angle_eight"} <= set(found)
    for path in found.values():
        spec = load_scenario(path)
        assert spec.schemes and spec.duration > 0


def test_a_good_scenario_runs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(write(tmp_path, GOOD)), "--quiet", "--out", str(tmp_path / "o")]) == 0
    assert "pinv" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            ("[run]\n", "[run]\nspeed = 3\n"),
            r"\[run\]\.speed: unknown key; valid keys here: dt, duration, gain",
        ),
        (
            ("dt = 0.002", 'dt = "fast"'),
            r"\[run\]\.dt: expected a number, got 'fast' \(write dt = 1.0\)",
        ),
        (("dt = 0.002", "dt = 0.0"), r"\[run\]\.dt: must be > 0; got 0.0"),
        (
            ('model = "panda"', 'model = "ur5"'),
            r"\[robot\]\.model: unknown robot 'ur5'; built-in robots: iiwa14",
        ),
        (
            ('model = "panda"', 'model = "panda"\ntip = "gripper"'),
            r"\[robot\]\.tip: unknown frame 'gripper'; frames: .*tcp",
        ),
        (
            ('type = "pinv"', 'type = "magic"'),
            r"\[schemes\]\[0\]\.type: unknown scheme 'magic'; use pinv, dls, gradient_projection, "
            r"wln, augmented, priority, qp, sns, osc$",
        ),
        (
            (
                'type = "pinv"',
                f"{GRADIENT}\ngain = 5.0",
            ),
            r"\[schemes\]\[0\]\.gain: unknown key; valid keys here: .*k_null",
        ),
        (
            ('type = "pinv"', 'type = "wln"\nk_nul = 5.0'),
            r"\[schemes\]\[0\]\.k_nul: unknown key; valid keys here: c, damping, k_null",
        ),
        (
            ('type = "pinv"', 'type = "pinv"\ninverse = "damped"'),
            r"\[schemes\]\[0\]\.inverse: unknown key; valid keys here: damping, label",
        ),
        (
            ('type = "pinv"', 'type = "pinv"\ndamping = 0.1\nrcond = 0.001'),
            r"\[schemes\]\[0\]\.rcond: rcond = 0.001 is used only by the exact inverse",
        ),
        (
            (
                'type = "pinv"',
                GRADIENT.replace('"joint_limits"', '"joint_limits", wieght = 2'),
            ),
            r"\.objectives\[0\]\.wieght: unknown key; valid keys here: type, weight",
        ),
        (("radius = 0.05", "radius = [0.05]"), r"\[trajectory\]\.radius: expected a number"),
        (
            ('type = "circle"', 'type = "spiral"'),
            r"\[trajectory\]\.type: unknown trajectory 'spiral'",
        ),
        (
            ('[[schemes]]\ntype = "pinv"', '[[schemes]]\ntype = "pinv"\ndamping = -1.0'),
            r"\[schemes\]\[0\]\.damping: must be > 0",
        ),
        (
            ('[robot]\nmodel = "panda"', '[robot]\nmodel = "panda"\nq0 = [0, 0, 0, 0, 0, 0, 0]'),
            r"\[robot\]\.q0: is outside the joint limits",
        ),
        (
            (
                '[[schemes]]\ntype = "pinv"',
                '[[schemes]]\ntype = "gradient_projection"\nobjectives = [{ type = "obstacles" }]',
            ),
            r"needs \[\[obstacles\]\]",
        ),
        (("period = 1.0", "period = 1.0\n\n[oops"), r"not valid TOML"),
        (("duration = 0.02", "duration = 0.02\nshaping = 1"), r"\[run\]\.shaping: expected"),
        (("duration = 0.02", 'duration = 0.02\nplant = "gazebo"'), r"use 'redres' or 'mujoco'"),
        (
            ("duration = 0.02", 'duration = 0.02\nplant = "mujoco"'),
            r"\[run\]\.plant: MuJoCo simulates an MJCF robot",
        ),
        (('model = "panda"', 'menagerie = "ur5e"'), r"\[robot\]\.menagerie: unknown Menagerie"),
        (("radius = 0.05", "radius = 1e300"), r"\[trajectory\]\.radius: must lie within ±1e\+09"),
        (("dt = 0.002", "dt = 0.002\ngain = 1e300"), r"\[run\]\.gain: must lie within ±1e\+09"),
        (
            ('type = "pinv"', 'type = "dls"\ndamping = -1e300'),
            r"\[schemes\]\[0\]\.damping: must lie within",
        ),
    ],
)
def test_bad_scenarios_name_the_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], edit: tuple[str, str], message: str
) -> None:
    old, new = edit
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new, 1))
    with pytest.raises(ScenarioError, match=message):
        load_scenario(path)
    out_dir = tmp_path / "report"
    assert main(["run", str(path), "--out", str(out_dir)]) == 2
    err = capsys.readouterr().err
    assert "scenario.toml" in err and err.count("\n") == 1  # one message, one line
    assert not out_dir.exists()  # no partial report


def test_a_scenario_asks_for_command_shaping(tmp_path: Path) -> None:
    """``shaping = true`` in ``[run]``: the rate-control runs end in command shaping (their
    logs keep the controller's own command beside the shaped one); a robot without
    acceleration or jerk limits is refused by name."""
    from redres.scenarios.runner import run_scenario

    spec = load_scenario(write(tmp_path, GOOD.replace("duration = 0.02", "shaping = true")))
    assert spec.shaping
    (log,) = run_scenario(spec, progress=False)
    assert "qd_wanted" in log.extra and log.qd.shape == log.extra["qd_wanted"].shape
    assert not load_scenario(write(tmp_path, GOOD)).shaping
    planar = GOOD.replace('model = "panda"', 'model = "planar3"').replace(
        "duration = 0.02", "shaping = true"
    )
    with pytest.raises(ScenarioError, match=r"\[run\]\.shaping: the robot 'planar3' has no"):
        load_scenario(write(tmp_path, planar))


def test_a_scenario_runs_on_mujoco() -> None:
    """``plant = "mujoco"`` with a Menagerie robot: each scheme runs on MuJoCo's
    simulation, the torque law through joint torques, the others through the position
    servos; the logs say so."""
    pytest.importorskip("mujoco", reason="the mujoco extra is not installed")
    from redres.scenarios.runner import run_scenario

    spec = builtin("panda_mujoco_circle")
    assert spec.plant == "mujoco" and spec.mjcf is not None and spec.mjcf.is_file()
    spec.duration = 0.05
    logs = run_scenario(spec, progress=False)
    assert [log.extra["plant"] for log in logs] == ["mujoco:panda_nohand"] * 3
    assert "q_command" in logs[0].extra and "tau" in logs[2].extra
    assert all(log.position_error.max() < 1e-3 for log in logs)


def test_missing_file_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(tmp_path / "none.toml")]) == 2
    assert "no such scenario file" in capsys.readouterr().err


def test_scenario_files_are_not_executed(tmp_path: Path) -> None:
    """A string that looks like code stays a string (tomllib only)."""
    text = GOOD.replace('description = "a short hold"', "description = \"__import__('os')\"")
    assert load_scenario(write(tmp_path, text)).description == "__import__('os')"


def scheme_table(kind: str) -> str:
    extra = {
        "gradient_projection": 'objectives = [{ type = "joint_limits" }]',
        "priority": 'levels = [{ type = "posture" }]',
    }.get(kind, "")
    return GOOD.replace('type = "pinv"', f'type = "{kind}"\n{extra}')


def _concrete_schemes(cls: type = Scheme) -> set[type]:
    found = set()
    for sub in cls.__subclasses__():
        if sub.__module__.startswith("redres.") and not getattr(sub, "__abstractmethods__", None):
            found.add(sub)
        found |= _concrete_schemes(sub)
    return found


def test_the_registry_lists_every_scheme_type() -> None:
    """Every scheme of redres.resolution and the operational-space law are registered, and
    each registered type builds from a table with its required keys only."""
    registered = scheme_types()
    assert list(registered) == [
        "pinv", "dls", "gradient_projection", "wln", "augmented", "priority", "qp", "sns", "osc"
    ]  # fmt: skip
    schemes = _concrete_schemes()
    declared = {t for cls in schemes for t in (cls.scenario_types or (cls.name,))}
    assert declared | {"osc"} == set(registered)
    missing = {cls.__name__ for cls in schemes if "from_scenario" not in dir(cls)}
    assert missing == set()  # every scheme builds itself from a scenario table
    for kind in registered:
        try:
            spec = parse_scenario(tomllib.loads(scheme_table(kind)))
            built = spec.schemes[0].build()
        except rr.errors.MissingDependencyError:
            continue
        assert spec.schemes[0].kind == kind
        assert built.name == ("osc" if kind == "osc" else kind), kind


def test_scheme_keys_reach_the_constructors() -> None:
    text = GOOD.replace(
        'type = "pinv"',
        'type = "gradient_projection"\nk_null = 2.5\nmax_damping = 0.2\nthreshold = 0.1\n'
        'objectives = [{ type = "joint_limits" }]',
    )
    scheme = parse_scenario(tomllib.loads(text)).schemes[0].build()
    assert scheme.k_null == 2.5
    assert scheme.inverse == rr.resolution.Inverse(rr.linalg.AdaptiveDamping(0.2, 0.1))
    dls = parse_scenario(tomllib.loads(scheme_table("dls"))).schemes[0].build()
    assert dls.name == "dls" and dls.inverse == rr.resolution.Inverse(0.05)
    aug = parse_scenario(tomllib.loads(scheme_table("augmented"))).schemes[0].build()
    assert aug.inverse == rr.resolution.AugmentedJacobianScheme().inverse
    objectives = 'objectives = [{ type = "joint_limits" }]'
    text = GOOD.replace('type = "pinv"', f'type = "sns"\nk_null = 2.0\n{objectives}')
    sns_spec = parse_scenario(tomllib.loads(text))
    sns = sns_spec.schemes[0].build()
    assert sns.k_null == 2.0 and sns.dt == sns_spec.dt == 0.002 and len(sns.objectives) == 1


def test_builtin_scenarios_are_the_shipped_files() -> None:
    """The one definition of the built-in scenarios, with the numbers they always had."""
    panda = builtin("panda_joint_limit_circle")
    q0 = np.array([-0.811, -1.061, 0.515, -2.269, -0.299, 1.036, 0.521])
    assert np.array_equal(panda.q0, q0) and panda.robot.name == rr.models.panda().name
    circle = Circle(panda.robot.fk(q0), 0.10, 2.5, normal=(-0.404, -0.565, -1.433),
                    phase=1.851, turns=4.0)  # fmt: skip
    iiwa = builtin("iiwa_arm_angle_eight")
    eight = FigureEight(iiwa.robot.fk(iiwa.q0), 0.15, 0.10, 5.0, normal=(1.0, 0.0, 0.0), turns=2.0)
    ring = builtin("iiwa_joint_limit_circle")  # the circle of tests/plan/test_iiwa_circle.py
    bent = np.array([0.3, 0.8, 0.2, -1.2, 0.3, 0.9, 0.1])
    assert np.array_equal(ring.q0, bent)
    round_path = Circle(ring.robot.fk(bent), 0.15, 2.5, normal=(1.0, 0.0, 0.0), turns=4.0)
    for spec, reference in ((panda, circle), (iiwa, eight), (ring, round_path)):
        assert spec.dt == 1e-3 and spec.gain == 50.0
        assert spec.duration == reference.duration
        for t in np.linspace(0.0, reference.duration, 7):
            assert np.array_equal(spec.trajectory.sample(t).pose, reference.sample(t).pose)
    listed = "built-in scenarios: iiwa_arm_angle_eight, iiwa_joint_limit_circle, panda"
    with pytest.raises(ScenarioError, match=listed):
        builtin("panda_circle")


@pytest.mark.parametrize(
    ("objective", "message"),
    [
        (
            '{ type = "posture", weights = [-1, 1, 1, 1, 1, 1, 1] }',
            r"\[schemes\]\[0\]\.objectives\[0\]: weights must be >= 0",
        ),
        ('{ type = "posture", weight = -1 }', r"objectives\[0\]\.weight: must be >= 0"),
    ],
)
def test_negative_objective_weights_name_the_objective(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], objective: str, message: str
) -> None:
    """Was a raw ValueError traceback from PostureObjective (issue 18, item 11)."""
    scheme = 'type = "gradient_projection"'
    text = GOOD.replace('type = "pinv"', f"{scheme}\nobjectives = [{objective}]")
    path = write(tmp_path, text)
    with pytest.raises(ScenarioError, match=message):
        load_scenario(path)
    assert main(["run", str(path), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_without_mujoco_the_mujoco_scenario_says_what_to_install(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a machine without the mujoco extra the list still lists every built-in scenario,
    the MuJoCo one with what it needs, and running it exits 2 naming the install."""
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "mujoco" else real(name, *a)
    )
    assert main(["run", "--list"]) == 0
    listed = capsys.readouterr().out
    hint = install_hint("mujoco")
    assert "panda_mujoco_circle" in listed and hint in listed
    assert main(["run", "panda_mujoco_circle", "--out", str(tmp_path / "r")]) == 2
    assert f"MuJoCo is not installed: {hint}" in capsys.readouterr().err


def test_without_the_qp_extra_the_other_schemes_run_and_the_qp_row_says_why(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import json
    import sys

    monkeypatch.setitem(sys.modules, "qpsolvers", None)  # a plain install: the import fails
    path = write(tmp_path, GOOD + '\n[[schemes]]\ntype = "qp"\n')
    assert main(["run", str(path), "--json", "--out", str(tmp_path / "r")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["scheme"] for r in out["runs"]] == ["pinv"]
    (miss,) = out["skipped"]
    assert miss["scenario"] == "tiny" and "qp" in miss["scheme"]
    assert miss["reason"].endswith(install_hint("qp"))
    assert main(["run", str(path), "--out", str(tmp_path / "t")]) == 0
    table = capsys.readouterr().out
    assert "not run: tiny" in table and install_hint("qp") in table
