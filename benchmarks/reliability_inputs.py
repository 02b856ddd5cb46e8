"""The inputs and the classification of the reliability campaign on the new surfaces
(:mod:`reliability_surfaces`): value generators no parameter of their kind accepts, bad
tokens for the numbers of model files, and :func:`classify`."""

from __future__ import annotations

import re
import signal
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

import redres as rr
from redres.errors import RedresError

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures"
TIME_LIMIT = 30  # s per input
#: (surface, name, call, valid input? (None: an error or an answer are both right),
#: check of a valid answer)
Case = tuple[str, str, Callable[[], Any], bool | None, Callable[[Any], bool] | None]
# (surface, name, call, valid input?, check of a valid answer)


class _HangError(Exception):
    pass


def _alarm(signum: int, frame: Any) -> None:
    raise _HangError


def classify(
    call: Callable[[], Any], valid: bool | None, check: Callable[[Any], bool] | None
) -> str:
    """The class of one input (module docstring); ``valid`` None: a clear error and a
    checked answer are both right (a huge but legal size), and a child process's own
    class (``call`` returns it as a string) is taken as it is."""
    if valid is None:
        return str(call())
    signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(TIME_LIMIT)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            value = call()
    except _HangError:
        return "hang"
    except RedresError:
        return "clear error" if not valid else "wrong (valid input refused)"
    except Exception as exc:  # counting them is the point
        return f"raw {type(exc).__name__}"
    finally:
        signal.alarm(0)
    if not valid:
        return "silent accept"
    if not _finite(value):
        return "non-finite"
    if check is not None and not check(value):
        return "wrong"
    return "valid"


def _finite(value: Any) -> bool:
    items = value if isinstance(value, tuple) else (value,)
    for item in items:
        try:
            arr = np.asarray(item, dtype=float)
        except (TypeError, ValueError):
            continue
        if (
            arr.dtype.kind == "f"
            and not np.isfinite(arr[~np.isnan(arr)] if arr.ndim else arr).all()
        ):
            return False
    return True


# ---------------------------------------------------------------------- value generators

#: Values no numeric parameter accepts (name -> value).
NOT_NUMBERS: dict[str, Any] = {
    "string": "abc",
    "empty string": "",
    "None": None,
    "complex": 1 + 2j,
    "dict": {},
    "set": {1.0},
    "bytes": b"1",
    "object": object(),
    "function": len,
    "ragged list": [[1, 2], [3]],
    "list of strings": ["a", "b"],
    "10**400": 10**400,
    "-10**400": -(10**400),
    "nan": float("nan"),
    "inf": float("inf"),
    "-inf": float("-inf"),
}
#: The same, for a parameter whose default is None (None is valid there).
NOT_NUMBERS_OR_NONE: dict[str, Any] = {k: v for k, v in NOT_NUMBERS.items() if v is not None}
#: Integers no count accepts (a count is an integer from 1 up to a bound).
BAD_COUNTS: dict[str, Any] = {
    **NOT_NUMBERS,
    "True": True,
    "0": 0,
    "-1": -1,
    "2**63": 2**63,
    "2**70": 2**70,
    "1.5": 1.5,
    "1e9 float": 1e9,
    "numpy nan": np.float64("nan"),
}
#: Positive reals no tolerance or gain accepts.
BAD_POSITIVE: dict[str, Any] = {
    **NOT_NUMBERS,
    "0": 0.0,
    "-1": -1.0,
    "-1e-300": -1e-300,
    "True": True,
    "array": np.ones(3),
}
#: Thread counts no call accepts (None: all threads; above the machine's: all of them).
THREAD_COUNTS: dict[str, Any] = {
    k: v
    for k, v in {**BAD_COUNTS, "0": 0}.items()
    if v is not None and not (isinstance(v, int) and not isinstance(v, bool) and v > 1)
}
#: Seeds no call accepts (None: fresh entropy; any integer >= 0 is a seed).
BAD_SEEDS: dict[str, Any] = {
    **{k: v for k, v in NOT_NUMBERS.items() if v is not None and k != "10**400"},
    "-1": -1,
    "1.5": 1.5,
    "True": True,
}


def random_q(robot: rr.Robot, rng: np.random.Generator, count: int) -> np.ndarray:
    return np.array([robot.random_configuration(rng) for _ in range(count)])


def bad_arrays(n: int, width: int) -> dict[str, Any]:
    """Arrays of rows of ``width`` that no batch input accepts."""
    return {
        **NOT_NUMBERS,
        "wrong width": np.zeros((3, width + 1)),
        "3-D": np.zeros((2, 3, width)),
        "scalar": 1.0,
        "NaN row": np.vstack([np.zeros(width), np.full(width, np.nan)]),
        "inf entry": np.where(np.eye(2, width) > 0, np.inf, 0.0),
        "complex rows": np.zeros((2, width), complex),
        "object rows": np.array([[None] * width]),
        "ragged rows": [[0.0] * width, [0.0] * (width - 1)],
        "strings": [["a"] * width],
        "10**9 rows (a view)": np.broadcast_to(np.zeros(width), (10**9, width)),
    }


# ---------------------------------------------------------------------- surfaces


#: Bad tokens for a numeric attribute of a file (each makes the file invalid).
BAD_TOKENS = {
    "letters": "a b c",
    "empty": "",
    "nan": "nan",
    "inf": "inf",
    "1e400": "1e400",
    "too few": "FEW",
    "too many": "MANY",
    "comma": "1,2,3",
}


def attribute_mutations(text: str, names: tuple[str, ...]) -> Iterator[tuple[str, str]]:
    """``(label, text)``: each occurrence of each numeric attribute in ``names`` replaced
    by each bad token (``FEW``/``MANY``: one number fewer or more than it holds)."""
    for match in re.finditer(r"\b(" + "|".join(names) + r')="([^"]*)"', text):
        attribute, value = match.group(1), match.group(2)
        count = len(value.split())
        for label, token in BAD_TOKENS.items():
            if token == "FEW":
                if count <= 1:
                    continue
                token = " ".join(value.split()[:-1])
            elif token == "MANY":
                if attribute == "size":
                    continue  # a geom's size holds up to 3 numbers whatever its type
                token = value + " 1"
            new = text[: match.start(2)] + token + text[match.end(2) :]
            yield f"{attribute}@{match.start()} = {label}", new
