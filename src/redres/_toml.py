"""Files a user hands us, read as TOML (scenarios and sweep specs): :func:`load` and one
typed table reader, :class:`Reader`; and what a scheme reads of its scenario table,
:class:`ScenarioParams` (the contract between the scenario files and the schemes, which
build themselves from it).

Read with :mod:`tomllib` only: nothing in a file is executed.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Protocol, TypeVar

import numpy as np

from ._validate import short_repr
from .errors import RedresError, describe_os_error, shown_path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["LIMIT_KEYS", "Reader", "ScenarioBuilder", "ScenarioParams", "load", "tomllib"]

_T = TypeVar("_T")

#: The limits a ``[robot]`` table of a scenario or sweep spec may set (:meth:`Reader.joint_limits`).
LIMIT_KEYS = ("qd_max", "qdd_max", "qddd_max", "tau_max")
#: The largest magnitude of a number in a scenario or sweep spec (gains, lengths, times,
#: limits); integers (seeds, counts) may reach :data:`MAX_INTEGER` (exact in a float).
MAX_NUMBER = 1e9
MAX_INTEGER = float(2**53)
#: The largest file a spec may name (a robot model, a scenario), bytes: Menagerie's
#: largest MJCF is about 60 kB, a URDF with inline meshes a few MB.
MAX_FILE_BYTES = 64 * 1024 * 1024
#: The keys that name a ``[robot]`` table's robot, one of them per table.
ROBOT_SOURCES = ("model", "urdf", "mjcf", "menagerie")


def load(path: str | Path, what: str, error: type[RedresError]) -> dict[str, Any]:
    """The TOML file ``path`` as a dict (a leading BOM is fine); a file that cannot be read
    or parsed raises ``error``, one line naming the file and the fix (``what`` names the
    kind of file: ``"scenario"``, ``"sweep spec"``)."""
    file = Path(path)
    shown = shown_path(file)
    try:
        return tomllib.loads(file.read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise error(f"{shown}: no such {what} file") from None
    except OSError as exc:
        raise error(f"cannot read the {what} file: {describe_os_error(exc)}") from None
    except UnicodeDecodeError as exc:
        raise error(f"{shown}: not UTF-8 text ({exc.reason}); save it as UTF-8") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{shown}: not valid TOML ({exc})") from None
    except RecursionError:
        raise error(
            f"{shown}: arrays or tables are nested too deeply to read; a {what} needs at "
            "most a few levels"
        ) from None


class Reader:
    """Typed access to one TOML table, remembering its path and the keys used: each read
    checks the value's type and range, and :meth:`done` reports a key nobody read, with
    the valid ones. Errors are ``error(message)``, the message naming the file and the
    key path (``file: [run].dt: must be > 0; got 0``)."""

    def __init__(
        self, table: Any, path: str, file: str, error: type[RedresError] = RedresError
    ) -> None:
        if not isinstance(table, dict):
            raise error(f"{file}: {path} must be a table; got {type(table).__name__}")
        self.table, self.path, self.file, self.error = table, path, file, error
        self.used: set[str] = set()

    def fail(self, key: str | None, message: str) -> RedresError:
        """The error at ``key`` of this table (``None``: the table itself)."""
        where = self.path if key is None else f"{self.path}.{key}" if self.path else key
        return self.error(f"{self.file}: {where}: {message}")

    @contextmanager
    def blame(self, key: str | None) -> Iterator[None]:
        """Report a :class:`RedresError` raised inside (a constructor's check) at ``key``."""
        try:
            yield
        except self.error:
            raise
        except RedresError as exc:
            raise self.fail(key, str(exc)) from None

    def get(self, key: str, kind: str, default: Any = ..., *, size: int | None = None) -> Any:
        """The value at ``key`` of ``kind`` (``number``, ``string``, ``vector`` of ``size``
        numbers, ``tables``); ``default`` when absent, else absent is an error."""
        self.used.add(key)
        if key not in self.table:
            if default is ...:
                raise self.fail(key, f"missing; add `{key} = <{kind}>`")
            return default
        value = self.table[key]
        if kind in ("number", "integer"):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise self.fail(key, f"expected a number, got {value!r} (write {key} = 1.0)")
            return self._float(key, value, MAX_NUMBER if kind == "number" else MAX_INTEGER)
        if kind == "string":
            if not isinstance(value, str):
                raise self.fail(key, f'expected a string, got {value!r} (write {key} = "...")')
            return value
        if kind == "vector":
            ok = isinstance(value, list) and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
            )
            if not ok or (size is not None and len(value) != size):
                want = f"{size} numbers" if size else "a list of numbers"
                raise self.fail(key, f"expected {want}, got {short_repr(value)}")
            return np.array([self._float(key, v) for v in value])
        if kind == "tables":
            if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
                raise self.fail(key, f"expected a list of tables, got {value!r}")
            return value
        raise AssertionError(kind)

    def _float(self, key: str, value: int | float, limit: float = MAX_NUMBER) -> float:
        """``value`` as a finite float within ``±limit`` (an integer of hundreds of digits
        is not one; 1e300 is no setting of a scenario or sweep, refused here by key rather
        than at run time)."""
        try:
            x = float(value)
        except OverflowError:
            raise self.fail(key, f"{short_repr(value)} is too large for a number") from None
        if not math.isfinite(x):
            raise self.fail(key, f"must be finite; got {value!r}")
        if abs(x) > limit:
            raise self.fail(key, f"must lie within ±{limit:g}; got {value!r}")
        return x

    def number(self, key: str, default: Any = ...) -> float:
        return float(self.get(key, "number", default))

    def positive(self, key: str, default: Any = ...) -> float:
        value = self.number(key, default)
        if value <= 0:
            raise self.fail(key, f"must be > 0; got {value}")
        return value

    def nonnegative(self, key: str, default: Any = ...) -> float:
        value = self.number(key, default)
        if value < 0:
            raise self.fail(key, f"must be >= 0; got {value}")
        return value

    def string(self, key: str, default: Any = ...) -> str:
        return str(self.get(key, "string", default))

    def at(self, key: str, index: int) -> str:
        """The path of table ``index`` of the list at ``key``."""
        return f"{self.path}.{key}[{index}]" if self.path else f"[{key}][{index}]"

    def read(self, table: Any, path: str, parse: Callable[[Reader], _T]) -> _T:
        """``parse`` the sub-table ``table`` at ``path``; its unknown keys are errors."""
        reader = Reader(table, path, self.file, self.error)
        value = parse(reader)
        reader.done()
        return value

    def each(self, key: str, parse: Callable[[Reader], _T], default: Any = ...) -> list[_T]:
        """``parse`` each table of the list at ``key`` (:meth:`read`)."""
        tables = self.get(key, "tables", default)
        return [self.read(table, self.at(key, i), parse) for i, table in enumerate(tables)]

    def done(self) -> None:
        unknown = sorted(set(self.table) - self.used)
        if unknown:
            raise self.fail(
                unknown[0], f"unknown key; valid keys here: {', '.join(sorted(self.used))}"
            )

    def integer(
        self, key: str, default: Any = ..., minimum: int | None = None, maximum: int | None = None
    ) -> int:
        value = float(self.get(key, "integer", default))
        if not float(value).is_integer():
            raise self.fail(key, f"expected an integer, got {self.table[key]!r}")
        if minimum is not None and value < minimum:
            raise self.fail(key, f"must be >= {minimum}; got {int(value)}")
        if maximum is not None and value > maximum:
            raise self.fail(key, f"must be <= {maximum:,}; got {int(value):,}")
        return int(value)

    def boolean(self, key: str, default: bool) -> bool:
        self.used.add(key)
        value = self.table.get(key, default)
        if not isinstance(value, bool):
            raise self.fail(key, f"expected true or false, got {value!r}")
        return value

    def joint_limits(self, n: int) -> dict[str, Any]:
        """The rate and torque limits a ``[robot]`` table may set (:data:`LIMIT_KEYS`), each
        a positive number for every joint or ``n`` of them (rad/s, rad/s², rad/s³, N·m),
        as keywords of :meth:`redres.Robot.with_limits`."""
        out = {}
        for key in LIMIT_KEYS:
            if key not in self.table:
                self.used.add(key)
                continue
            kind = "vector" if isinstance(self.table[key], list) else "number"
            value = np.broadcast_to(self.get(key, kind, size=n), (n,)).astype(float)
            if not (value > 0).all():
                raise self.fail(key, f"must be > 0 for every joint; got {short_repr(value)}")
            out[key] = value
        return out

    def robot_source(self) -> tuple[str, str]:
        """The one robot source of a ``[robot]`` table, ``(key, value)``: a built-in
        ``model``, a ``urdf`` or ``mjcf`` path, or a ``menagerie`` arm (:data:`ROBOT_SOURCES`).

        Raises:
            The reader's error: none of them, or more than one.
        """
        given = {key: self.get(key, "string", None) for key in ROBOT_SOURCES}
        named = [key for key, value in given.items() if value is not None]
        if len(named) != 1:
            got = f"; got {' and '.join(named)}" if named else ""
            raise self.fail(
                named[1] if len(named) > 1 else "model",
                'give exactly one of model = "<built-in name>", urdf = "<path>", mjcf = '
                f'"<path>" or menagerie = "<arm>"{got}',
            )
        return named[0], given[named[0]]

    def file_text(self, key: str, file: Path) -> str:
        """The text of the file that ``key`` names: a regular file (not ``/dev/zero`` or a
        pipe, which would be read until memory runs out) of at most :data:`MAX_FILE_BYTES`,
        in UTF-8; else the reader's error naming the key and the file."""
        try:
            if not file.is_file():
                what = "not found" if not file.exists() else "not a regular file"
                raise self.fail(key, f"cannot read {shown_path(file)}: {what}")
            size = file.stat().st_size
            if size > MAX_FILE_BYTES:
                limit = f"{size} bytes, more than the {MAX_FILE_BYTES} a spec's file may have"
                raise self.fail(key, f"cannot read {shown_path(file)}: {limit}")
            return file.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            why = describe_os_error(exc) if isinstance(exc, OSError) else "not UTF-8 text"
            raise self.fail(key, f"cannot read {shown_path(file)}: {why}") from None

    def sub(self, key: str) -> Reader:
        """The reader of the sub-table ``[key]`` (empty when absent)."""
        self.used.add(key)
        return Reader(self.table.get(key, {}), f"[{key}]", self.file, self.error)

    def bounds(self, key: str) -> list[list[float]] | None:
        """``[[x_min, x_max], [y_min, y_max], [z_min, z_max]]`` (m), or None if absent."""
        self.used.add(key)
        value = self.table.get(key)
        if value is None:
            return None
        ok = isinstance(value, list) and len(value) == 3 and all(
            isinstance(v, list) and len(v) == 2
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
            for v in value
        )  # fmt: skip
        if not ok:
            raise self.fail(key, "expected [[x_min, x_max], [y_min, y_max], [z_min, z_max]] (m)")
        out = [[self._float(key, x) for x in v] for v in value]
        if any(lo >= hi for lo, hi in out):
            raise self.fail(key, "each range must have min < max")
        return out


class ScenarioParams(Protocol):
    """Typed, validated access to one ``[[schemes]]`` table of a scenario file.

    Every read marks the key as valid for this table; a key nobody reads is reported
    as unknown, with the valid ones. Reading twice gives the same values, so a builder
    may be called once per run.

    Attributes:
        type: the scheme type the table names (``"pinv"``, ``"dls"``, ...).
        dt: the run's control period, s.
    """

    type: str
    dt: float

    def number(self, key: str, default: float) -> float:
        """A finite number (``default`` when the key is absent)."""
        ...

    def nonnegative(self, key: str, default: float) -> float:
        """A number ≥ 0, e.g. a gain."""
        ...

    def positive(self, key: str, default: float) -> float:
        """A number > 0."""
        ...

    def string(self, key: str, default: str) -> str:
        """A string."""
        ...

    # The three below return objects of higher layers (typed Any here: this module is at
    # the bottom): redres.objectives.Objective, redres.tasks.Task, redres.resolution.Inverse.

    def objectives(self) -> list[tuple[Any, float]]:
        """The ``objectives = [...]`` list as ``(Objective, weight)`` pairs (may be empty)."""
        ...

    def levels(self) -> list[Any]:
        """The ``levels = [...]`` list as fresh tasks, highest priority first (≥ 1)."""
        ...

    def inverse(self, default_damping: float | None = None) -> Any:
        """The inverse from ``damping = λ``, or ``max_damping`` and ``threshold`` (the
        adaptive law), or ``rcond``; ``None`` when none is given and there is no
        ``default_damping`` (the scheme's own default applies)."""
        ...

    def fail(self, key: str, message: str) -> Exception:
        """The error for ``key`` of this table, naming the file and key path."""
        ...


#: Builds one scheme (or torque law) from its table; called once per run.
ScenarioBuilder = Callable[[ScenarioParams], Any]
