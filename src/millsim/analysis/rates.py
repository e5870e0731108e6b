"""Steady-state event rates with confidence intervals from block averages (pure numpy)."""

import numpy as np
from scipy import stats


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
