"""Shared fixtures: seeded generators and the built-in robots (built once per session)."""

from __future__ import annotations

from pathlib import Path

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
