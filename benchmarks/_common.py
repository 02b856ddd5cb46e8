"""Shared helpers of the benchmarks: timing with interleaved repetitions, tables."""

from __future__ import annotations

import platform
import statistics
import time
from collections.abc import Callable, Sequence

import numpy as np


def time_calls(fn: Callable[[], object], *, batch: int = 200, batches: int = 30) -> np.ndarray:
    """Per-call times (µs) of ``batches`` batches of ``batch`` calls (after a warm-up)."""
    for _ in range(batch):
        fn()
    out = np.empty(batches)
    for b in range(batches):
        t0 = time.perf_counter_ns()
        for _ in range(batch):
            fn()
        out[b] = (time.perf_counter_ns() - t0) / batch / 1e3
    return out


def interleaved(
    contenders: dict[str, Callable[[], object]],
    *,
    rounds: int = 7,
    batch: int = 200,
    batches: int = 5,
) -> dict[str, np.ndarray]:
    """Time every contender in turn, ``rounds`` times, so machine noise hits all alike."""
    samples: dict[str, list[float]] = {name: [] for name in contenders}
    for _ in range(rounds):
        for name, fn in contenders.items():
            samples[name].extend(time_calls(fn, batch=batch, batches=batches))
    return {name: np.asarray(v) for name, v in samples.items()}


def table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A Markdown table."""
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def machine() -> str:
    """One line describing the machine."""
    import os

    return (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, numpy {np.__version__}"
    )


def median(values: np.ndarray) -> float:
    return float(statistics.median(values.tolist()))


def load_text(before: Sequence[float], after: Sequence[float]) -> str:
    """``load average (1/5/15 min) a/b/c before, d/e/f after``: the machine's load."""

    def three(values: Sequence[float]) -> str:
        return "/".join(f"{v:.2f}" for v in values)

    return f"load average (1/5/15 min) {three(before)} before, {three(after)} after"
