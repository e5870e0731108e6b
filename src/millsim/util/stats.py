"""Interval statistics shared by scene summaries and analysis (pure numpy/scipy).

- ``binomial_interval``: a proportion k/n (Clopper-Pearson, exact; or Wilson);
- ``bootstrap_interval``: the mean of values, percentile bootstrap (``scipy.stats.bootstrap``);
- ``block_mean_interval``: the mean of block means, Student t: the one interval of correlated
  records, used by
- ``block_mean_ci``: the mean of a correlated time series, from its block means, and
- ``steady_rate``: an event rate over a window, from the rates of its blocks;
- ``slope_interval``: a least-squares slope and the half-width of its Student-t interval;
- ``mser5``: where the steady state of a time series starts (MSER-5 truncation).
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


def bootstrap_interval(values, level=LEVEL, resamples=9999, seed=0):
    """Percentile bootstrap interval of the mean of ``values``: (lo, hi).

    ``scipy.stats.bootstrap`` with a generator seeded by ``seed``, so a case gives the same
    interval every run. Fewer than two values give no interval: (NaN, NaN).
    """
    values = np.asarray(values, dtype=float)
    if values.size < 2:
        return math.nan, math.nan
    ci = stats.bootstrap((values,), np.mean, n_resamples=resamples, confidence_level=level,
                         method="percentile", rng=np.random.default_rng(seed)).confidence_interval
    return float(ci.low), float(ci.high)


def block_mean_interval(block_means, confidence=LEVEL):
    """Mean of ``block_means`` and the half-width of its Student-t interval.

    The blocks are taken as independent samples, which holds when each is much longer than the
    correlation time of the record they cut. Fewer than two blocks give a NaN half-width.
    """
    b = np.asarray(block_means, dtype=float)
    if b.size < 2:
        return float(b.mean()) if b.size else math.nan, math.nan
    return float(b.mean()), float(stats.t.ppf(0.5 + confidence / 2, b.size - 1) * stats.sem(b))


def block_mean_ci(series, blocks, confidence=LEVEL):
    """Mean of a time series and the half-width of its interval from ``blocks`` block means
    (:func:`block_mean_interval`; blocks of unequal length by one sample when ``blocks`` does
    not divide the series)."""
    x = np.asarray(series, dtype=float)
    blocks = max(2, min(blocks, len(x)))
    _, half = block_mean_interval([c.mean() for c in np.array_split(x, blocks)], confidence)
    return float(x.mean()), half


def steady_rate(event_times, t_start, t_end, blocks=10, confidence=LEVEL):
    """Mean event rate over [t_start, t_end] and the half-width of its confidence interval.

    The window is cut into ``blocks`` equal blocks; the interval is :func:`block_mean_interval`
    of the block rates (blocks much longer than the correlation time of the charge motion).

    Returns:
        (rate [1/s], half_width [1/s], block_rates)
    """
    if t_end <= t_start:
        raise ValueError(f"steady_rate: empty window [{t_start}, {t_end}]")
    edges = np.linspace(t_start, t_end, blocks + 1)
    counts, _ = np.histogram(np.asarray(event_times, dtype=float), bins=edges)
    block_rates = counts / np.diff(edges)
    mean, half = block_mean_interval(block_rates, confidence)
    return mean, half, block_rates


def slope_interval(x, y, level=LEVEL):
    """Least-squares slope of ``y`` over ``x`` and the half-width of its Student-t interval
    (n - 2 degrees of freedom; at least three points)."""
    fit = stats.linregress(x, y)
    return fit.slope, stats.t.ppf(0.5 + level / 2, len(x) - 2) * fit.stderr


def mser5(series):
    """Index where the steady state starts: MSER-5 truncation (White 1997) on batch means of 5.

    Minimises the squared standard error of the mean of what is kept, truncating at most half.
    """
    x = np.asarray(series, dtype=float)
    nb = len(x) // 5
    if nb < 4:
        return 0
    b = x[: 5 * nb].reshape(nb, 5).mean(1)
    best, arg = math.inf, 0
    for d in range(nb // 2 + 1):
        kept = b[d:]
        val = kept.var() / len(kept)
        if val < best:
            best, arg = val, d
    return 5 * arg
