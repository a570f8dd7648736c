"""The compiled contact phases (audio/coupling_kernel.py): the first zero of a sum of waves
against SciPy's root finder on the same bracket and against closed forms, and none reported
past the horizon."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from fallgen.audio.coupling_kernel import first_crossing


def _f(c0, c1, w, a, b, t):
    return c0 + c1 * t + float(np.sum(a * np.cos(w * t) + b * np.sin(w * t)))


def test_a_cosine_first_vanishes_at_a_quarter_period():
    w = np.array([2 * math.pi * 440.0])
    t = first_crossing(0.0, 0.0, w, np.ones(1), np.zeros(1), 1.0, 1e-5, 1.0)
    assert t == pytest.approx(1 / (4 * 440.0), rel=1e-9)


def test_a_flight_lands_where_its_parabola_would_if_the_wall_stood_still():
    # the gap x0 + v t closes at x0 / -v; a still wall adds nothing (zero amplitudes), and
    # the gap enters with sign -1 (the phase lasts while -gap > 0: it starts inside, x0 < 0
    # is apart)
    w = np.array([1000.0, 3000.0])
    t = first_crossing(-0.002, 0.5, w, np.zeros(2), np.zeros(2), -1.0, 1e-5, 1.0)
    assert t == pytest.approx(0.004, rel=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_random_waves_agree_with_scipy_on_the_first_sign_change(seed):
    rng = np.random.default_rng(seed)
    m = 40
    w = np.sort(rng.uniform(2e3, 2e5, m))
    a, b = rng.normal(0, 1, m) / m, rng.normal(0, 1, m) / m
    c0, c1 = 1.0, -float(rng.uniform(50, 500))  # positive at 0, drifting down
    dt = 2 * math.pi / w.max() / 6
    t = first_crossing(c0, c1, w, a, b, 1.0, dt, 1.0)
    # the first grid point where it is not positive, then SciPy's brentq on that step
    grid = dt * np.arange(1, int(1.0 / dt) + 1)
    vals = np.array([_f(c0, c1, w, a, b, x) for x in grid])
    j = int(np.flatnonzero(vals <= 0)[0])
    want = brentq(lambda x: _f(c0, c1, w, a, b, x), grid[j - 1], grid[j], xtol=dt * 1e-9)
    assert t == pytest.approx(want, abs=dt * 1e-8)
    assert _f(c0, c1, w, a, b, t - dt * 1e-6) > 0


def test_no_crossing_within_the_horizon_is_none():
    w = np.array([100.0])
    # 2 + cos(100 t) never vanishes; 1 - t does only after the horizon
    assert first_crossing(2.0, 0.0, w, np.ones(1), np.zeros(1), 1.0, 1e-3, 0.5) == -1.0
    assert first_crossing(1.0, -1.0, w, np.zeros(1), np.zeros(1), 1.0, 1e-3, 0.5) == -1.0
