"""Thinning of time series: extremes survive, sizes are bounded."""

from __future__ import annotations

import numpy as np
import pytest

from redres.errors import InvalidParameterError
from redres.report.series import envelope_indices, even_indices


def test_short_series_are_kept_whole() -> None:
    assert np.array_equal(envelope_indices(np.arange(50.0), 2000), np.arange(50))


@pytest.mark.parametrize("count", [2001, 4999, 10_000, 123_457])
def test_envelope_is_bounded_sorted_and_keeps_the_ends(count: int) -> None:
    rng = np.random.default_rng(count)
    y = np.cumsum(rng.normal(size=count))
    idx = envelope_indices(y, 2000)
    assert idx.size <= 2000
    assert np.all(np.diff(idx) > 0)
    assert idx[0] == 0 and idx[-1] == count - 1
    assert np.argmax(y) in idx and np.argmin(y) in idx


def test_a_one_step_spike_survives_anywhere() -> None:
    count = 10_000
    for k in (0, 1, 4999, 5000, 7777, count - 2, count - 1):
        y = np.sin(np.linspace(0, 20, count))
        y[k] = 50.0
        idx = envelope_indices(y, 500)
        assert k in idx
        assert y[idx].max() == 50.0


def test_every_window_keeps_its_extremes() -> None:
    # Brute-force oracle: in every window of the thinned series' bucket width, the
    # largest and smallest original samples are among the kept ones.
    rng = np.random.default_rng(7)
    y = rng.normal(size=9_000)
    idx = envelope_indices(y, 302)  # 150 buckets of 60 samples
    kept = set(idx.tolist())
    for start in range(0, 9_000, 60):
        window = y[start : start + 60]
        assert start + int(np.argmax(window)) in kept
        assert start + int(np.argmin(window)) in kept


def test_non_finite_samples_do_not_break_the_choice() -> None:
    y = np.linspace(0.0, 1.0, 5000)
    y[100] = np.nan
    idx = envelope_indices(y, 100)
    assert idx.size <= 100 and idx[-1] == 4999


def test_even_indices() -> None:
    idx = even_indices(10_000, 80)
    assert idx.size == 80 and idx[0] == 0 and idx[-1] == 9_999
    gaps = np.diff(idx)
    assert gaps.max() - gaps.min() <= 1
    assert np.array_equal(even_indices(5, 80), np.arange(5))
    assert np.array_equal(even_indices(1, 80), [0])


def test_bad_parameters() -> None:
    with pytest.raises(InvalidParameterError, match="max_points"):
        envelope_indices(np.zeros(10), 3)
    with pytest.raises(InvalidParameterError):
        even_indices(0, 10)
    with pytest.raises(InvalidParameterError):
        even_indices(10, 1)
