"""Guarded imports of the ``report`` extra (matplotlib, plotly)."""

from __future__ import annotations

import importlib
from types import ModuleType

from ..errors import MissingDependencyError, install_hint


def require(module: str) -> ModuleType:
    """Import ``module`` or raise :class:`MissingDependencyError` naming the extra.

    Args:
        module: dotted module name, e.g. ``"matplotlib.figure"``.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        package = module.split(".", 1)[0]
        raise MissingDependencyError(
            f"redres reports need {package}, which is not installed; install the report "
            f"extra: {install_hint('report')}"
        ) from exc


def check_report_dependencies() -> None:
    """Fail early, before anything is written, when the report extra is missing."""
    require("matplotlib.figure")
    require("plotly.offline")
