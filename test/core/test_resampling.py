"""Tests of walker_gait.core.resampling."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from walker_gait.core.resampling import (
    SCHEMES,
    WeightError,
    effective_sample_size,
    log_sum_exp,
    normalise_log_weights,
    resample,
)


@given(st.lists(st.floats(-50, 50), min_size=1, max_size=60))
@settings(max_examples=60, deadline=None)
def test_normalised_weights_sum_to_one(lw: list[float]) -> None:
    w = normalise_log_weights(np.array(lw))
    assert np.all(w >= 0)
    assert abs(w.sum() - 1.0) < 1e-12


def test_log_weights_stable_with_large_offsets() -> None:
    lw = np.array([0.0, -1.0, -2.0, -3.0])
    for off in (-1e4, 1e4, -1e6):
        np.testing.assert_allclose(normalise_log_weights(lw + off), normalise_log_weights(lw), rtol=1e-12)
    assert np.isfinite(log_sum_exp(lw - 1e4))
    assert abs(log_sum_exp(lw - 1e4) - (log_sum_exp(lw) - 1e4)) < 1e-9


@pytest.mark.parametrize("scheme", SCHEMES)
def test_degenerate_weights_pick_the_one(scheme: str) -> None:
    lw = np.full(50, -np.inf)
    lw[17] = -1e4
    idx = resample(lw, rng=np.random.default_rng(0), scheme=scheme)
    assert idx.shape == (50,)
    assert np.all(idx == 17)


def test_systematic_equal_weights_each_index_once() -> None:
    for seed in range(5):
        idx = resample(np.zeros(37), rng=np.random.default_rng(seed), scheme="systematic")
        np.testing.assert_array_equal(np.sort(idx), np.arange(37))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_unbiased_counts(scheme: str) -> None:
    rng = np.random.default_rng(1)
    w = np.array([0.1, 0.2, 0.3, 0.4])
    counts = np.zeros(4)
    for _ in range(400):
        idx = resample(np.log(w), rng=rng, scheme=scheme, n=100)
        counts += np.bincount(idx, minlength=4)
    np.testing.assert_allclose(counts / counts.sum(), w, atol=0.01)


def test_ess_bounds() -> None:
    assert effective_sample_size(np.zeros(10)) == pytest.approx(10.0)
    lw = np.full(10, -1e9)
    lw[3] = 0.0
    assert effective_sample_size(lw) == pytest.approx(1.0)


def test_bad_weights_raise() -> None:
    with pytest.raises(WeightError):
        normalise_log_weights(np.array([np.nan, 0.0]))
    with pytest.raises(WeightError):
        normalise_log_weights(np.full(3, -np.inf))
    with pytest.raises(ValueError):
        resample(np.zeros(3), rng=np.random.default_rng(0), scheme="bogus")


def test_deterministic_with_seed() -> None:
    lw = np.random.default_rng(5).normal(size=100)
    a = resample(lw, rng=np.random.default_rng(9), scheme="residual")
    b = resample(lw, rng=np.random.default_rng(9), scheme="residual")
    np.testing.assert_array_equal(a, b)
