"""Confidence intervals of the scores (fallgen.evaluation.scores.bootstrap_ci): SciPy's
percentile bootstrap of the mean, reproducible from its seed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallgen.evaluation.scores import bootstrap_ci


def test_interval_of_a_success_rate_is_the_binomial_one():
    """400 episodes, 120 successes: the bootstrap's 95 % interval of the mean is the normal
    approximation's p +- 1.96 sqrt(p (1 - p) / n) = 0.300 +- 0.045 (to within the resampling's
    and the approximation's error, 0.006)."""
    x = np.r_[np.ones(120), np.zeros(280)]
    lo, hi = bootstrap_ci(x)
    half = 1.96 * math.sqrt(0.3 * 0.7 / 400)
    assert lo == pytest.approx(0.3 - half, abs=0.006)
    assert hi == pytest.approx(0.3 + half, abs=0.006)


def test_intervals_are_reproducible_from_the_seed():
    x = np.random.default_rng(3).uniform(size=37)
    assert bootstrap_ci(x) == bootstrap_ci(x) == bootstrap_ci(list(x), seed=0)
    assert bootstrap_ci(x, seed=1) != bootstrap_ci(x)  # the seed does choose the resamples
    lo, hi = bootstrap_ci(x)
    assert lo < x.mean() < hi


def test_degenerate_samples():
    assert bootstrap_ci([1.0, 1.0, 1.0]) == (1.0, 1.0)
    assert bootstrap_ci([0.25]) == (0.25, 0.25)
    assert all(math.isnan(v) for v in bootstrap_ci([]))
