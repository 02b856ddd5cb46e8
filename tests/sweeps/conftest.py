"""Fixtures of the sweep tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from .helpers import write_spec


@pytest.fixture
def small_spec(tmp_path: Path) -> Path:
    return write_spec(tmp_path)
