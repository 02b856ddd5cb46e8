"""Shared fixtures: seeded generators and the built-in robots (built once per session);
under pytest-xdist (``make test`` runs the suite on every core), the tests that start fresh
processes first. The workers share the compiled-code cache: one compilation of each kernel
at a time across them is redres' own (:mod:`redres._compile._lock`)."""

from __future__ import annotations

import os
from pathlib import Path

# Compile on first use in the tests' own process (a cold cache must not route them to the
# reference paths while a background process compiles); tests/compile/test_first_use.py covers
# compiling behind in processes of its own.
os.environ.setdefault("REDRES_COMPILE", "foreground")

import numpy as np
import pytest

import redres as rr

FIXTURES = Path(__file__).parent / "fixtures"

#: Files of the tests that each start fresh processes on empty compiled-code caches (minutes
#: of compiling each): run first under xdist, so that the other worker takes the rest of
#: the suite meanwhile instead of one of them coming last, alone on the machine.
FRESH_PROCESS_FILES = (
    "test_first_use.py",
    "test_readonly_install.py",
    "test_jit.py",
    "test_warmup_helper.py",
)


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "robot_loop: a 1 kHz loop against a robot simulator; run alone on the "
        "machine (make test runs these after the parallel suite)",
    )  # fmt: skip


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        return  # one process: the files' own order
    first = [i for i in items if i.path.name in FRESH_PROCESS_FILES]
    items[:] = first + [i for i in items if i.path.name not in FRESH_PROCESS_FILES]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


@pytest.fixture(scope="session")
def builtin_robots() -> dict[str, rr.Robot]:
    return {name: rr.models.load(name) for name in rr.models.names()}


@pytest.fixture(scope="session")
def fixtures_dir() -> Path:
    return FIXTURES
