"""The interval statistics of millsim.util.stats against independent numbers: a textbook
t-interval, Monte Carlo coverage on series whose true mean is known, and the normal-theory
interval that the bootstrap of a large sample approaches."""

import math

import numpy as np
import pytest
from scipy import stats

from millsim.util.stats import block_mean_ci, block_mean_interval, bootstrap_interval, steady_rate


def test_block_mean_interval_is_the_textbook_t_interval():
    """1..5: mean 3, s = sqrt(2.5), t_{0.975, 4} = 2.776445 (printed t tables), so the 95 %
    half-width is 2.776445 sqrt(2.5 / 5) = 1.963243; t_{0.95, 4} = 2.131847 for 90 %."""
    mean, half = block_mean_interval([1.0, 2.0, 3.0, 4.0, 5.0])
    assert mean == 3.0
    assert half == pytest.approx(2.776445 * math.sqrt(0.5), rel=1e-6)
    _, half90 = block_mean_interval([1.0, 2.0, 3.0, 4.0, 5.0], confidence=0.90)
    assert half90 == pytest.approx(2.131847 * math.sqrt(0.5), rel=1e-6)
    assert block_mean_interval([4.0])[0] == 4.0 and math.isnan(block_mean_interval([4.0])[1])


def test_one_interval_serves_series_and_event_rates():
    """block_mean_ci and steady_rate are block_mean_interval of their block means: series
    split into equal blocks by hand, Poisson-like event times counted per block by hand."""
    rng = np.random.default_rng(5)
    x = rng.normal(2.0, 1.0, 96)
    mean, half = block_mean_ci(x, 8)
    blocks = x.reshape(8, 12).mean(axis=1)
    assert mean == pytest.approx(x.mean(), rel=1e-14)
    assert half == pytest.approx(block_mean_interval(blocks)[1], rel=1e-12)
    t = np.sort(rng.uniform(0.0, 4.0, 300))
    rate, half, rates = steady_rate(t, 1.0, 3.0, blocks=4)
    by_hand = [((t >= a) & (t < a + 0.5)).sum() / 0.5 for a in (1.0, 1.5, 2.0)]
    by_hand.append(((t >= 2.5) & (t <= 3.0)).sum() / 0.5)  # the last bin includes its end
    np.testing.assert_allclose(rates, by_hand, rtol=1e-12)
    assert (rate, half) == pytest.approx(block_mean_interval(by_hand), rel=1e-12)


@pytest.mark.parametrize("confidence", [0.95, 0.80])
def test_iid_normal_intervals_cover_the_mean_at_their_confidence(confidence):
    """iid normal data: block means of iid normal samples are iid normal, so the block-mean
    interval is exact and covers the true mean in a fraction ``confidence`` of 1000 replicas
    (99.9 % binomial acceptance region, about +-2.3 %)."""
    rng = np.random.default_rng(14)
    n_rep = 1000
    data = rng.normal(10.0, 3.0, size=(n_rep, 60))
    covered = 0
    for x in data:
        mean, half = block_mean_ci(x, 6, confidence)
        covered += abs(mean - 10.0) <= half
    lo, hi = stats.binom.ppf([0.0005, 0.9995], n_rep, confidence)
    assert lo <= covered <= hi, covered / n_rep


def test_block_means_cover_the_mean_of_a_correlated_series():
    """AR(1) with phi = 0.9 (correlation time ~ 19 samples) around a known mean: 8 blocks of
    1000 samples cover it at about 95 % (1000 replicas, 99.9 % acceptance region), while the
    interval that takes the samples as independent covers about 35 % (the variance of the mean
    is (1 + phi)/(1 - phi) = 19 times theirs: P(|Z| < 1.96 / sqrt(19)) = 0.35): the blocks are
    what makes the interval hold."""
    rng = np.random.default_rng(7)
    n_rep, n, phi = 1000, 8000, 0.9
    noise = rng.normal(0.0, 1.0, size=(n_rep, n))
    x = np.empty_like(noise)
    x[:, 0] = noise[:, 0] / math.sqrt(1 - phi**2)  # stationary start
    for k in range(1, n):
        x[:, k] = phi * x[:, k - 1] + noise[:, k]
    x += 5.0
    covered = naive = 0
    t_naive = stats.t.ppf(0.975, n - 1)
    for row in x:
        mean, half = block_mean_ci(row, 8)
        covered += abs(mean - 5.0) <= half
        naive += abs(mean - 5.0) <= t_naive * row.std(ddof=1) / math.sqrt(n)
    lo, hi = stats.binom.ppf([0.0005, 0.9995], n_rep, 0.95)
    assert lo <= covered <= hi, covered / n_rep
    assert naive < 0.5 * n_rep


def test_bootstrap_of_a_large_sample_approaches_the_t_interval():
    """The percentile bootstrap of the mean of 400 iid normal values approaches the t-interval
    mean +- t s / sqrt(n) (both ends within 3 % of its half-width: resampling error of 9999
    resamples and the bootstrap's own O(1/n) differences)."""
    x = np.random.default_rng(3).normal(7.0, 2.0, 400)
    half = stats.t.ppf(0.975, 399) * x.std(ddof=1) / 20.0
    lo, hi = bootstrap_interval(x, seed=11)
    assert lo == pytest.approx(x.mean() - half, abs=0.03 * half)
    assert hi == pytest.approx(x.mean() + half, abs=0.03 * half)
    lo90, hi90 = bootstrap_interval(x, level=0.90, seed=11)
    assert lo < lo90 < x.mean() < hi90 < hi


def test_bootstrap_is_seeded_and_needs_two_values():
    """Same seed, same interval; another seed moves the ends only at the resampling level
    (< 2 % of the width here); a constant sample has a zero-width interval at its value; fewer
    than two values have none."""
    x = np.random.default_rng(8).exponential(3.0, 40)
    a = bootstrap_interval(x, seed=2)
    assert bootstrap_interval(x, seed=2) == a
    b = bootstrap_interval(x, seed=3)
    assert a != b
    np.testing.assert_allclose(b, a, atol=0.02 * (a[1] - a[0]))
    assert bootstrap_interval([2.5, 2.5, 2.5]) == (2.5, 2.5)
    assert all(math.isnan(v) for v in bootstrap_interval([1.0]))
    assert all(math.isnan(v) for v in bootstrap_interval([]))
