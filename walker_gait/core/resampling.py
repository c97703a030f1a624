"""Resampling schemes for particle filters, all in log-weight space.

Follows the structure of ``nchopin/particles`` (``particles.resampling``): every scheme has
the same signature and returns ancestor indices; weights are handled as unnormalised
log weights and normalised with a stable log-sum-exp.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

Scheme = Literal["systematic", "stratified", "multinomial", "residual"]
SCHEMES: tuple[str, ...] = ("systematic", "stratified", "multinomial", "residual")


class WeightError(ValueError):
    """Log weights are empty, contain NaN/+inf, or are all -inf."""


def log_sum_exp(log_weights: FloatArray) -> float:
    """Stable ``log(sum(exp(lw)))`` of a 1-D array (``-inf`` entries allowed)."""
    lw = np.asarray(log_weights, dtype=np.float64)
    m = np.max(lw)
    if not np.isfinite(m):
        return float(m)
    return float(m + np.log(np.sum(np.exp(lw - m))))


def normalise_log_weights(log_weights: FloatArray) -> FloatArray:
    """Normalised linear weights (sum 1) from unnormalised log weights.

    Raises :class:`WeightError` for empty input, NaN or +inf entries, or all ``-inf``.
    """
    lw = np.asarray(log_weights, dtype=np.float64).ravel()
    if lw.size == 0:
        raise WeightError("no log weights")
    if np.any(np.isnan(lw)) or np.any(lw == np.inf):
        raise WeightError("log weights contain NaN or +inf")
    m = np.max(lw)
    if m == -np.inf:
        raise WeightError("all log weights are -inf")
    w = np.exp(lw - m)
    return w / w.sum()


def effective_sample_size(log_weights: FloatArray) -> float:
    """Kish effective sample size ``1 / sum(w_i^2)`` of normalised weights (1..N)."""
    w = normalise_log_weights(log_weights)
    return float(1.0 / np.sum(w * w))


def _inverse_cdf(su: FloatArray, w: FloatArray) -> IntArray:
    """Indices for sorted uniforms ``su`` in [0, 1) against weights ``w`` (sum 1)."""
    cdf = np.cumsum(w)
    cdf[-1] = 1.0  # guard against round-off
    idx = np.searchsorted(cdf, su, side="right")
    return np.minimum(idx, w.size - 1).astype(np.intp)


def resample(
    log_weights: FloatArray,
    *,
    rng: np.random.Generator,
    scheme: Scheme | str = "systematic",
    n: int | None = None,
) -> IntArray:
    """Ancestor indices ``(n,)`` (default ``n = len(log_weights)``) drawn with ``scheme``.

    ``systematic``: one uniform, evenly spaced (lowest variance, used by the tracker);
    ``stratified``: one uniform per stratum; ``multinomial``: i.i.d. draws (sorted);
    ``residual``: deterministic floor(N w) copies plus multinomial on the residuals.
    """
    w = normalise_log_weights(log_weights)
    m = w.size if n is None else int(n)
    if m <= 0:
        raise ValueError(f"number of draws must be positive, got {m}")
    if scheme == "systematic":
        su = (rng.random() + np.arange(m)) / m
        return _inverse_cdf(su, w)
    if scheme == "stratified":
        su = (rng.random(m) + np.arange(m)) / m
        return _inverse_cdf(su, w)
    if scheme == "multinomial":
        su = np.sort(rng.random(m))
        return _inverse_cdf(su, w)
    if scheme == "residual":
        nw = m * w
        counts = np.floor(nw).astype(np.intp)
        det = np.repeat(np.arange(w.size, dtype=np.intp), counts)
        r = m - det.size
        if r == 0:
            return det
        res = nw - counts
        res /= res.sum()
        extra = _inverse_cdf(np.sort(rng.random(r)), res)
        return np.sort(np.concatenate([det, extra]))
    raise ValueError(f"unknown resampling scheme {scheme!r}; choose one of {SCHEMES}")
