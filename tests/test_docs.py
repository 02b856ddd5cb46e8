"""Every Python block of the README and docs/ runs as written.

The blocks of one page run in order in one fresh interpreter (a page's later blocks may use
names an earlier one defined), in a temporary folder, with matplotlib's file backend.
Signatures and other text that is not meant to run are fenced as ``text``.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted([*(ROOT / "docs").glob("*.md"), ROOT / "README.md"])
_BLOCK = re.compile(r"```python\n(.*?)```", re.S)


def _blocks(page: Path) -> list[str]:
    return _BLOCK.findall(page.read_text(encoding="utf-8"))


@pytest.mark.parametrize(
    "page", [p for p in PAGES if _blocks(p)], ids=lambda p: str(p.relative_to(ROOT))
)
def test_the_python_blocks_of_a_page_run(page: Path, tmp_path: Path) -> None:
    code = "\n".join(_blocks(page))
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
        timeout=600, env={**os.environ, "MPLBACKEND": "Agg"},
    )  # fmt: skip
    assert done.returncode == 0, f"{page.name}: {done.stderr.strip().splitlines()[-1:]}"


def test_the_pages_hold_python_blocks() -> None:
    """The walk finds the blocks it should test (a changed fence would skip them all)."""
    assert sum(len(_blocks(p)) for p in PAGES) >= 10
