"""MathJax served from the built site itself, so formulas render without a network.

The files come from the ``sphinx-mathjax-offline`` distribution (a ``docs`` extra); its
own Sphinx hook cannot be imported (the package directory's name has dashes), so this
extension locates the files, points ``mathjax_path`` at the copy and copies the subset
that TeX input with CommonHTML output needs (about 2.5 MB) after a successful build.
Without that distribution Sphinx's default (a CDN) is left in place.
"""

from __future__ import annotations

import shutil
from importlib import metadata
from pathlib import Path
from typing import Any

_PARTS = ("tex-chtml.js", "output/chtml", "input/tex", "ui", "a11y", "adaptors")


def _source() -> Path | None:
    try:
        dist = metadata.distribution("sphinx-mathjax-offline")
    except metadata.PackageNotFoundError:
        return None
    path = Path(str(dist.locate_file("sphinx-mathjax-offline/static/mathjax")))
    return path if (path / "tex-chtml.js").is_file() else None


def _copy(app: Any, exc: Exception | None) -> None:
    source = _source()
    if exc is not None or source is None or app.builder.format != "html":
        return
    target = Path(app.outdir) / "_static" / "mathjax"
    for part in _PARTS:
        src = source / part
        if src.is_dir():
            shutil.copytree(src, target / part, dirs_exist_ok=True)
        elif src.is_file():
            target.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, target / part)


def setup(app: Any) -> dict[str, Any]:
    if _source() is not None:
        app.config.mathjax_path = "mathjax/tex-chtml.js"
        app.connect("build-finished", _copy)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
