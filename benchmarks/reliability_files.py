"""The file surfaces of the reliability campaign (:mod:`reliability_surfaces`): URDF
strings, MJCF files (the fixture and Menagerie's arms), sweep specs, and the plans of
sweep specs with large sizes (in child processes)."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from reliability_inputs import FIXTURES, ROOT, Case, attribute_mutations

import redres as rr


def urdf_cases() -> Iterator[Case]:
    good = (FIXTURES / "arm3.urdf").read_text()
    reference = rr.Robot.from_urdf(FIXTURES / "arm3.urdf")
    q = reference.neutral() + 0.1

    def same(out: Any) -> bool:
        return bool(np.allclose(out.fk(q), reference.fk(q), atol=1e-12))

    yield (
        "URDF string",
        "valid",
        lambda: rr.Robot.from_urdf_string(good, mesh_dir=FIXTURES),
        True,
        same,
    )
    names = ("xyz", "rpy", "value", "ixx", "iyy", "izz", "lower", "upper", "velocity", "effort")
    for label, text in attribute_mutations(good, names):
        if label.startswith(("rpy", "xyz")) and "= comma" in label:
            pass
        yield (
            "URDF string",
            label,
            lambda t=text: rr.Robot.from_urdf_string(t, mesh_dir=FIXTURES),
            False,
            None,
        )
    panda_text = (FIXTURES / "panda_description.urdf").read_text()
    tip = "panda_hand_tcp"
    for label, text in attribute_mutations(panda_text, ("xyz", "rpy", "value", "lower", "upper")):
        yield (
            "URDF string",
            f"panda {label}",
            lambda t=text: rr.Robot.from_urdf_string(t, tip=tip, capsules=False),
            False,
            None,
        )
    for i, match in enumerate(re.finditer(r'\borigin xyz="([^"]*)"', panda_text)):
        scaled = " ".join(f"{1.01 * float(v):.6g}" for v in match.group(1).split())
        text = panda_text[: match.start(1)] + scaled + panda_text[match.end(1) :]

        def loads(out: Any) -> bool:  # a valid file: a robot whose FK is a rigid motion
            T = out.fk(out.neutral())
            return bool(np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12))

        yield (
            "URDF string",
            f"panda origin {i} scaled by 1.01 (valid)",
            lambda t=text: rr.Robot.from_urdf_string(t, tip=tip, capsules=False),
            True,
            loads,
        )
    structural = {
        "no robot element": "<urdf/>",
        "not XML": "<robot",
        "empty": "",
        "mass -1": good.replace('<mass value="', '<mass value="-', 1),
        "axis without xyz": re.sub(r'<axis xyz="[^"]*"/>', "<axis/>", good, count=1),
        "zero axis": re.sub(r'<axis xyz="[^"]*"/>', '<axis xyz="0 0 0"/>', good, count=1),
        "lower above upper": re.sub(
            r'lower="([^"]*)" upper="([^"]*)"', r'lower="\2" upper="\1"', good, count=1
        ),
        "child link missing": re.sub(
            r'<child link="[^"]*"/>', '<child link="ghost"/>', good, count=1
        ),
        "no links": re.sub(r"<link[\s\S]*?</link>|<link[^>]*/>", "", good),
        "billion laughs": '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaaaaaaaa">'
        '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]><robot name="&b;"/>',
    }
    for label, text in structural.items():
        yield (
            "URDF string",
            label,
            lambda t=text: rr.Robot.from_urdf_string(t, mesh_dir=FIXTURES),
            False,
            None,
        )


def mjcf_cases(tmp: Path) -> Iterator[Case]:
    good = (FIXTURES / "arm3.xml").read_text()
    reference = rr.Robot.from_mjcf(FIXTURES / "arm3.xml")
    q = reference.neutral() + 0.1
    (tmp / "meshes").mkdir(exist_ok=True)
    for mesh in (FIXTURES / "meshes").iterdir():
        (tmp / "meshes" / mesh.name).write_bytes(mesh.read_bytes())

    def load(text: str) -> Any:
        path = tmp / "arm.xml"
        path.write_text(text)
        return rr.Robot.from_mjcf(path)

    def same(out: Any) -> bool:
        return bool(np.allclose(out.fk(q), reference.fk(q), atol=1e-12))

    yield "MJCF file", "valid", lambda: load(good), True, same
    names = ("pos", "axis", "range", "size", "mass", "diaginertia", "euler")
    for label, text in attribute_mutations(good, names):
        yield "MJCF file", label, lambda t=text: load(t), False, None
    menagerie = ROOT / "src" / "redres" / "models" / "data" / "menagerie"
    for folder in sorted(p for p in menagerie.iterdir() if p.is_dir()):
        copy = tmp / folder.name
        shutil.copytree(folder, copy, dirs_exist_ok=True)
        for xml in sorted(folder.glob("*.xml")):
            text = xml.read_text()

            def load_arm(t: str, xml: Path = xml, copy: Path = copy) -> Any:
                path = copy / f"mutated-{xml.name}"
                path.write_text(t)
                return rr.Robot.from_mjcf(path, capsules=False)

            for label, mutated in attribute_mutations(text, names + ("quat", "fullinertia")):
                yield (
                    "MJCF file",
                    f"{folder.name}/{xml.name} {label}",
                    lambda t=mutated, f=load_arm: f(t),
                    False,
                    None,
                )
    signs = {
        "negative mass": ('mass="2.0"', 'mass="-2.0"'),
        "negative size": ('size="0.04 0.15"', 'size="-0.04 0.15"'),
        "zero axis": ('axis="0 0 1"', 'axis="0 0 0"'),
        "zero quat": ('euler="0 0.3 0"', 'quat="0 0 0 0"'),
        "reversed range": ('range="-2.5 2.5"', 'range="2.5 -2.5"'),
        "negative inertia": ('diaginertia="0.016', 'diaginertia="-0.016'),
    }
    for label, (old, new) in signs.items():
        yield "MJCF file", label, lambda o=old, n=new: load(good.replace(o, n, 1)), False, None


def sweep_spec_cases(tmp: Path) -> Iterator[Case]:
    from redres import sweeps

    specs = ROOT / "src" / "redres" / "sweeps" / "specs"

    def load(text: str) -> Any:
        path = tmp / "spec.toml"
        path.write_text(text)
        spec = sweeps.load_spec(path)
        return spec

    for spec_file in sorted(specs.glob("*.toml")):
        good = spec_file.read_text()
        yield "sweep spec", f"{spec_file.stem} valid", lambda t=good: load(t), True, None
        for match in re.finditer(r"^(\w+) = (.+)$", good, flags=re.M):
            key, value = match.group(1), match.group(2)
            if key in ("name", "description", "kind"):
                continue
            numeric = re.fullmatch(r"-?[\d.e_+-]+", value) is not None
            bad = {"string": '"abc"', "table": "{ a = 1 }", "bool": "true"}
            if not value.startswith("["):
                bad["array"] = "[1, 2]"
            if numeric:
                bad |= {
                    "1e300": "1e300",
                    "-1": "-1",
                    "10**30 integer": "1" + "0" * 30,
                    "nan": "nan",
                    "inf": "inf",
                }
                if key == "dilation":
                    bad.pop("-1")  # -1 means every voxel within reach
                    bad["-2"] = "-2"
            for label, token in bad.items():
                text = good[: match.start(2)] + token + good[match.end(2) :]
                yield (
                    "sweep spec",
                    f"{spec_file.stem}: {key} = {label}",
                    lambda t=text: load(t),
                    False,
                    None,
                )


_PLAN_CHILD = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (8 * 2**30, 8 * 2**30))  # a blow-up: MemoryError
from redres import sweeps
from redres.errors import RedresError
from redres.sweeps.kinds import KINDS
try:
    spec = sweeps.load_spec(sys.argv[1])
    KINDS[spec.kind].plan(spec, spec.robot.build())
except RedresError:
    print("clear error")
except BaseException as exc:
    print("raw", type(exc).__name__)
else:
    print("valid")
"""
PLAN_TIMEOUT = 120  # s: a plan takes seconds; beyond this it shows no progress


def plan_cases(tmp: Path) -> Iterator[Case]:
    """Large values of every count and size of the built-in specs, planned in a child
    process (a compiled call cannot be interrupted) under an 8 GiB address-space limit:
    a clear error or a plan, never a hang or a raw MemoryError."""
    specs = ROOT / "src" / "redres" / "sweeps" / "specs"
    for spec_file in sorted(specs.glob("*.toml")):
        good = spec_file.read_text()
        for match in re.finditer(r"^(\w+) = (-?[\d.e_+]+)$", good, flags=re.M):
            key = match.group(1)
            if key == "seed":
                continue
            for label, token in {
                "10**7": "10000000",
                "10**9": "1000000000",
                "1e-6": "1e-6",
            }.items():
                text = good[: match.start(2)] + token + good[match.end(2) :]
                yield (
                    "sweep plan",
                    f"{spec_file.stem}: {key} = {label}",
                    lambda t=text, k=f"{spec_file.stem}-{key}-{label}": _plan_child(tmp, k, t),
                    None,
                    None,
                )


def _plan_child(tmp: Path, name: str, text: str) -> str:
    path = tmp / f"{name}.toml"
    path.write_text(text)
    try:
        out = subprocess.run(
            [sys.executable, "-c", _PLAN_CHILD, str(path)],
            capture_output=True, text=True, timeout=PLAN_TIMEOUT, check=False,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return "hang"
    lines = out.stdout.strip().splitlines()
    return lines[-1] if lines else f"raw (exit {out.returncode}: {out.stderr[-200:]})"
