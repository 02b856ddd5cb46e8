"""What a missing extra's message tells the user to run: a command that works, since redres
is not on a package index (``pip install 'redres[qp]'`` fails with "No matching
distribution")."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

import pytest
import tomllib

from redres import errors
from redres.errors import MissingDependencyError, install_hint

ROOT = Path(__file__).parents[1]


def test_from_a_checkout_the_hint_installs_the_extra_from_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(errors, "_checkout", lambda: ".")
    hint = install_hint("qp")
    assert hint.endswith("-m pip install -e '.[qp]'")
    assert "redres[" not in hint


def test_elsewhere_the_hint_names_the_extras_own_requirements(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(errors, "_checkout", lambda: None)
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    words = shlex.split(install_hint("qp"))
    assert words[1:4] == ["-m", "pip", "install"]
    assert words[4:] == declared["optional-dependencies"]["qp"]


def test_the_interpreter_is_this_environments(monkeypatch: pytest.MonkeyPatch) -> None:
    exe = Path(sys.executable)
    monkeypatch.chdir(exe.parents[2])  # the folder holding the environment (.venv/bin/python)
    assert install_hint("viewer").startswith(f"./{exe.relative_to(exe.parents[2])} -m pip ")


def test_a_missing_qp_extra_says_how_to_install_it(monkeypatch: pytest.MonkeyPatch) -> None:
    from redres.resolution.hard_limits import _solvers

    monkeypatch.setitem(sys.modules, "qpsolvers", None)  # the import fails
    with pytest.raises(MissingDependencyError) as caught:
        _solvers.backend("daqp")
    assert str(caught.value).endswith(install_hint("qp"))
    assert "redres[" not in str(caught.value)


def test_no_message_or_page_names_an_install_that_cannot_work() -> None:
    places = [*ROOT.joinpath("src").rglob("*.py"), *ROOT.joinpath("docs").glob("*.md"),
              ROOT / "README.md"]  # fmt: skip
    offenders = [str(p.relative_to(ROOT)) for p in places
                 if "install 'redres[" in p.read_text() and p.name != "errors.py"]  # fmt: skip
    assert offenders == []
