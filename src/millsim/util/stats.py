"""Interval statistics shared by scene summaries and analysis (pure numpy/scipy).

- ``binomial_interval``: a proportion k/n (Clopper-Pearson, exact; or Wilson);
- ``bootstrap_interval``: the (weighted) mean of values, percentile bootstrap;
- ``block_mean_ci``: the mean of a correlated time series from block means (Student t);
- ``steady_rate``: an event rate over a window from block counts (Student t).
"""

import math

import numpy as np
from scipy import stats

LEVEL = 0.95


def binomial_interval(k, n, level=LEVEL, method="clopper_pearson"):
    """Two-sided interval of a binomial proportion k/n: (lo, hi), vectorised.

    ``clopper_pearson`` (exact, coverage >= level) or ``wilson`` (score interval).
    """
    k = np.asarray(k, dtype=float)
    n = np.asarray(n, dtype=float)
    a = 1.0 - level
    if method == "clopper_pearson":
        with np.errstate(invalid="ignore", divide="ignore"):
            lo = np.where(k > 0, stats.beta.ppf(a / 2, k, n - k + 1), 0.0)
            hi = np.where(k < n, stats.beta.ppf(1 - a / 2, k + 1, n - k), 1.0)
        return lo, hi
    if method == "wilson":
        z = stats.norm.ppf(1 - a / 2)
        p = k / n
        centre = (p + z * z / (2 * n)) / (1 + z * z / n)
        half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
        return centre - half, centre + half
    raise ValueError(f"method: {method!r} is not clopper_pearson or wilson")


def bootstrap_interval(values, weights=None, level=LEVEL, resamples=2000, seed=0):
    """Percentile bootstrap interval of the (weighted) mean of ``values``: (lo, hi)."""
    values = np.asarray(values, dtype=float)
    if values.size == 0:
        return math.nan, math.nan
    w = np.ones_like(values) if weights is None else np.asarray(weights, dtype=float)
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, values.size, size=(resamples, values.size))
    means = (values[idx] * w[idx]).sum(1) / w[idx].sum(1)
    a = 1.0 - level
    return float(np.quantile(means, a / 2)), float(np.quantile(means, 1 - a / 2))


def block_mean_ci(series, blocks, confidence=0.95):
    """Mean of a time series and the Student-t half-width from ``blocks`` block means."""
    x = np.asarray(series, dtype=float)
    blocks = max(2, min(blocks, len(x)))
    means = np.array([c.mean() for c in np.array_split(x, blocks)])
    sem = means.std(ddof=1) / math.sqrt(blocks)
    return float(x.mean()), float(stats.t.ppf(0.5 + confidence / 2, blocks - 1) * sem)


def steady_rate(event_times, t_start, t_end, blocks=10, confidence=0.95):
    """Mean event rate over [t_start, t_end] and the half-width of its confidence interval.

    The window is cut into ``blocks`` equal blocks; the block rates are treated as independent
    samples (blocks much longer than the correlation time of the charge motion), and the interval
    is Student-t on their mean.

    Returns:
        (rate [1/s], half_width [1/s], block_rates)
    """
    if t_end <= t_start:
        raise ValueError(f"steady_rate: empty window [{t_start}, {t_end}]")
    edges = np.linspace(t_start, t_end, blocks + 1)
    counts, _ = np.histogram(np.asarray(event_times, dtype=float), bins=edges)
    block_rates = counts / np.diff(edges)
    mean = float(block_rates.mean())
    if blocks < 2:
        return mean, float("nan"), block_rates
    sem = float(block_rates.std(ddof=1)) / np.sqrt(blocks)
    half = float(stats.t.ppf(0.5 + confidence / 2, blocks - 1)) * sem
    return mean, half, block_rates
