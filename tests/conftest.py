"""Shared fixtures: seeded generators and the built-in robots (built once per session)."""

from __future__ import annotations

import os
from pathlib import Path

# Compile on first use in the tests' own process (a cold cache must not route them to the
# reference paths while a background process compiles); tests/test_first_use.py covers
# compiling behind in processes of its own.
os.environ.setdefault("REDRES_COMPILE", "foreground")

import numpy as np
import pytest

import redres as rr

FIXTURES = Path(__file__).parent / "fixtures"


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


@pytest.fixture(scope="session")
def builtin_robots() -> dict[str, rr.Robot]:
    return {name: rr.models.load(name) for name in rr.models.names()}


@pytest.fixture(scope="session")
def fixtures_dir() -> Path:
    return FIXTURES
