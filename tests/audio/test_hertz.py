"""Hertz impact: the closed form against integrating the force law, and its trends."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallgen.audio.hertz import half_sine_spectrum, hertz_impact, integrate_hertz

INF = math.inf
CASES = [  # E1, nu1, E2, nu2, R1, R2, m1, m2, v
    (2.0e11, 0.29, 7.0e10, 0.19, 0.002, INF, 0.05, INF, 3.0),      # steel fork tip on tile
    (2.4e9, 0.37, 1.1e10, 0.25, 0.004, INF, 0.01, INF, 5.0),       # pen on a wooden table
    (1.2e8, 0.45, 1.25e10, 0.30, 0.021, INF, 0.0459, INF, 4.0),    # golf ball on hardwood
    (7.0e10, 0.2, 7.0e10, 0.2, 0.01, 0.02, 0.2, 0.3, 1.0),         # two glass bodies, both free
]


@pytest.mark.parametrize("case", CASES)
def test_closed_form_matches_numerical_integration(case):
    h = hertz_impact(*case)
    tc, fmax = integrate_hertz(h.e_star_pa, h.r_star_m, h.m_star_kg, case[-1])
    assert h.duration_s == pytest.approx(tc, rel=0.05)
    assert h.peak_force_n == pytest.approx(fmax, rel=0.05)


def test_trends():
    fork = hertz_impact(*CASES[0])
    ball = hertz_impact(*CASES[2])
    assert 80e-6 < fork.duration_s < 200e-6  # hard pair: a click
    assert ball.duration_s > 4 * fork.duration_s  # soft pair: a thud
    slow = hertz_impact(*CASES[0][:-1], 0.5)
    assert slow.duration_s == pytest.approx(fork.duration_s * (3.0 / 0.5) ** 0.2, rel=1e-9)


def test_half_sine_spectrum():
    tc = 1e-3
    w = np.array([0.0, 10.0, math.pi / tc, 3 * math.pi / tc, 20 * math.pi / tc])
    s = half_sine_spectrum(w, tc)
    assert s[0] == pytest.approx(1.0) and s[1] == pytest.approx(1.0, abs=1e-5)
    assert s[2] == pytest.approx(math.pi / 4)
    assert s[3] == pytest.approx(0.0, abs=1e-12)  # first spectral zero at w t_c = 3 pi
    assert s[4] < 0.01
