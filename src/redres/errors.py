"""The redres error tree.

Every error raised on purpose by redres derives from :class:`RedresError` and also from
the builtin exception a Python user would expect (``ValueError``, ``KeyError``,
``FileNotFoundError``), so ``except ValueError`` keeps working in code that does not
know about redres.
"""

from __future__ import annotations

import errno
import os

__all__ = [
    "DHParameterError",
    "FrameNotFoundError",
    "InvalidParameterError",
    "JointLimitError",
    "MJCFError",
    "MissingDependencyError",
    "ModelFileError",
    "ModelFileNotFoundError",
    "NonFiniteError",
    "NotPositiveDefiniteError",
    "RedresError",
    "RobotNotFoundError",
    "RobotStoppedError",
    "ShapeError",
    "SimulationError",
    "URDFError",
    "UnknownParameterError",
    "describe_os_error",
    "install_hint",
    "shown_path",
]


class RedresError(Exception):
    """Root of every error raised on purpose by redres."""


class ShapeError(RedresError, ValueError):
    """An array argument has the wrong shape (message names the argument and both shapes)."""


class NonFiniteError(RedresError, ValueError):
    """An array argument contains NaN or infinity."""


class InvalidParameterError(RedresError, ValueError):
    """A scalar parameter is out of its domain (a negative damping, a non-positive dt, ...)."""


class UnknownParameterError(RedresError, TypeError):
    """A keyword argument is not one the callable takes (message lists the valid names and
    the nearest match)."""


class NotPositiveDefiniteError(RedresError, ValueError):
    """A matrix that must be symmetric positive definite (weights, mass matrix) is not."""


class JointLimitError(RedresError, ValueError):
    """Joint limits are inconsistent (``q_min > q_max``) or a configuration violates them."""


class DHParameterError(RedresError, ValueError):
    """A Denavit–Hartenberg record is malformed (message names the record and the key)."""


class ModelFileError(RedresError, ValueError):
    """A robot description (URDF or MJCF) cannot be turned into a robot model."""


class URDFError(ModelFileError):
    """A URDF file or string cannot be turned into a robot model."""


class MJCFError(ModelFileError):
    """An MJCF file (MuJoCo's format) cannot be turned into a robot model."""


class ModelFileNotFoundError(RedresError, FileNotFoundError):
    """A model file named by the user does not exist."""


class MissingDependencyError(RedresError, ImportError):
    """An optional dependency is needed; the message names the extra that installs it
    and the command that does (:func:`install_hint`)."""


def install_hint(extra: str) -> str:
    """The command that installs redres' optional ``extra`` into the running environment.

    redres is not on a package index, so ``pip install 'redres[extra]'`` cannot work.
    From a source checkout (an editable install) the command installs the extra from it;
    otherwise it names the extra's own requirements, which pip finds on PyPI. Both run
    this environment's pip (``python -m pip``, with the interpreter as the user would type
    it)."""
    import shlex
    from importlib import metadata  # here: every redres import reads this module

    python = _shown_executable()
    checkout = _checkout()
    if checkout is not None:
        return f"{python} -m pip install -e {shlex.quote(f'{checkout}[{extra}]')}"
    try:
        requirements = metadata.requires("redres") or []
    except metadata.PackageNotFoundError:  # pragma: no cover - run from a bare source tree
        requirements = []
    tag = f'extra == "{extra}"'
    wanted = [r.split(";")[0].strip() for r in requirements if tag in r]
    if not wanted:  # pragma: no cover - an extra pyproject.toml does not declare
        return f"{python} -m pip install -e {shlex.quote(f'.[{extra}]')} (from the redres source)"
    return f"{python} -m pip install {' '.join(map(shlex.quote, wanted))}"


def _checkout() -> str | None:
    """The source folder redres is installed from in editable mode (shown relative to the
    working directory where it is inside it), or None."""
    import json
    from importlib import metadata
    from pathlib import Path
    from urllib.parse import unquote, urlparse

    try:
        text = metadata.distribution("redres").read_text("direct_url.json")
    except metadata.PackageNotFoundError:  # pragma: no cover
        return None
    if not text:
        return None
    info = json.loads(text)
    if not info.get("dir_info", {}).get("editable"):
        return None
    folder = Path(unquote(urlparse(info.get("url", "")).path))
    try:
        relative = folder.relative_to(Path.cwd())
    except ValueError:
        return str(folder)
    return "." if str(relative) == "." else f"./{relative}"


def _shown_executable() -> str:
    """``sys.executable`` relative to the working directory where it is inside it (a
    project's ``.venv/bin/python``), else ``python`` when that is the same interpreter."""
    import sys
    from pathlib import Path

    exe = Path(sys.executable)
    try:
        return f"./{exe.relative_to(Path.cwd())}" if exe.is_absolute() else str(exe)
    except ValueError:
        return "python" if Path(sys.prefix) == Path(sys.base_prefix) else str(exe)


class SimulationError(RedresError, RuntimeError):
    """A control loop or simulation produced a non-finite value (message names the step)."""


class RobotStoppedError(RedresError, RuntimeError):
    """A real robot (or its protocol simulator) stopped the motion: the message names the
    robot's own reason (``communication_constraints_violation``, a limit, ...); ``log``
    holds the run up to that cycle (a :class:`~redres.control.RunLog`, or None)."""

    def __init__(self, message: str, log: object = None) -> None:
        super().__init__(message)
        self.log = log


class _KeyLookupError(RedresError, KeyError):
    # KeyError.__str__ quotes its argument; show a readable sentence instead.
    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class FrameNotFoundError(_KeyLookupError):
    """A frame name is unknown (message lists the valid frames)."""


class RobotNotFoundError(_KeyLookupError):
    """A built-in robot name is unknown (message lists the valid names)."""


_FIXES = {
    errno.ENOENT: "a folder on the way does not exist or cannot hold files; create it or "
    "choose another path",
    errno.ENOTDIR: "a part of the path is a file, not a folder; choose another path",
    errno.EISDIR: "a folder is in the way; rename or remove it, or choose another path",
    errno.EACCES: "you may not write there; choose a folder you can write to",
    errno.EPERM: "you may not write there; choose a folder you can write to",
    errno.EROFS: "the file system is read-only; choose a folder you can write to",
    errno.ENOSPC: "the disk is full; free some space or choose a folder on another disk",
    errno.EDQUOT: "your disk quota is used up; free some space or choose another disk",
    errno.ENAMETOOLONG: "the path or one of its names is too long; choose a shorter path",
    errno.EEXIST: "something of that name is in the way; rename or remove it",
}


def shown_path(path: str | os.PathLike[str], limit: int = 160) -> str:
    """``path`` quoted for a one-line message, its middle elided beyond ``limit`` characters."""
    text = str(path)
    if len(text) <= limit:
        return repr(text)
    return f"{text[: limit // 2]!r}...{text[-limit // 2 :]!r} ({len(text)} characters)"


def describe_os_error(exc: OSError) -> str:
    """One line for a file-system error: the path, what went wrong and the fix."""
    where = shown_path(exc.filename) if exc.filename is not None else "a file"
    reason = exc.strerror or type(exc).__name__
    fix = _FIXES.get(exc.errno or 0, "check the path and its permissions")
    return f"{where}: {reason}; {fix}"
