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


def _effective(E1, nu1, E2, nu2, R1, R2, m1, m2):
    """Johnson's effective modulus, radius and mass, written out here (a flat or fixed body:
    infinite radius or mass)."""
    e = 1.0 / ((1 - nu1 ** 2) / E1 + (1 - nu2 ** 2) / E2)
    r = 1.0 / (1.0 / R1 + (0.0 if math.isinf(R2) else 1.0 / R2))
    m = 1.0 / (1.0 / m1 + (0.0 if math.isinf(m2) else 1.0 / m2))
    return e, r, m


def johnson_contact_time(case) -> float:
    """Johnson, Contact Mechanics (1985), eq. 11.24: t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5)."""
    e, r, m = _effective(*case[:-1])
    return 2.87 * (m * m / (r * e * e * case[-1])) ** 0.2


def johnson_peak_force(case) -> float:
    """Johnson (1985), 11.4: F_max = (4/3) E* R*^(1/2) delta_m^(3/2), with the deepest
    compression delta_m = (15 m* v^2 / (16 E* R*^(1/2)))^(2/5) (all the kinetic energy
    stored)."""
    e, r, m = _effective(*case[:-1])
    dm = (15 * m * case[-1] ** 2 / (16 * e * math.sqrt(r))) ** 0.4
    return 4 / 3 * e * math.sqrt(r) * dm ** 1.5


@pytest.mark.parametrize("case", CASES)
def test_closed_form_matches_numerical_integration(case):
    """The closed form against Johnson's formulas (effective quantities computed here) and
    against integrating the force law from those effective quantities."""
    h = hertz_impact(*case)
    e, r, m = _effective(*case[:-1])
    assert (h.e_star_pa, h.r_star_m, h.m_star_kg) == pytest.approx((e, r, m), rel=1e-12)
    assert h.duration_s == pytest.approx(johnson_contact_time(case), rel=0.005)  # 2.87 ~ 2.868
    assert h.peak_force_n == pytest.approx(johnson_peak_force(case), rel=1e-9)
    tc, fmax = integrate_hertz(e, r, m, case[-1])
    assert h.duration_s == pytest.approx(tc, rel=0.005)
    assert h.peak_force_n == pytest.approx(fmax, rel=0.005)


def test_trends():
    """Hard pairs click, soft pairs thud, t_c ~ v^(-1/5): a steel fork tip on tile lasts
    122 us (shared/design/physics-and-audio.md, by Johnson's formula), a golf ball on
    hardwood over 4 times as long."""
    fork, ball = hertz_impact(*CASES[0]), hertz_impact(*CASES[2])
    assert fork.duration_s * 1e6 == pytest.approx(122, rel=0.005)
    assert ball.duration_s > 4 * fork.duration_s  # soft pair: a thud
    slow = hertz_impact(*CASES[0][:-1], 0.5)
    assert slow.duration_s == pytest.approx(fork.duration_s * (3.0 / 0.5) ** 0.2, rel=1e-9)
    # Johnson's formula tells a contact time 5 % off
    with pytest.raises(AssertionError):
        assert 1.05 * fork.duration_s == pytest.approx(johnson_contact_time(CASES[0]), rel=0.005)


def test_half_sine_spectrum():
    tc = 1e-3
    w = np.array([0.0, 10.0, math.pi / tc, 3 * math.pi / tc, 20 * math.pi / tc])
    s = half_sine_spectrum(w, tc)
    assert s[0] == pytest.approx(1.0) and s[1] == pytest.approx(1.0, abs=1e-5)
    assert s[2] == pytest.approx(math.pi / 4)
    assert s[3] == pytest.approx(0.0, abs=1e-12)  # first spectral zero at w t_c = 3 pi
    assert s[4] < 0.01


@pytest.mark.parametrize("zeta", [0.02, 0.3, 0.8, 1.0, 1.5, 6.0])
def test_plate_contact_against_its_differential_equation(zeta):
    """Zener's impact on a large plate (linearised): the rebound, the impulse, the energy
    the plate takes and the energy-equivalent pulse, against an explicit integration of
    m x'' = -F, F = k (x - w), Z w' = F, while F > 0."""
    from fallgen.audio.hertz import plate_contact

    m, v, tc = 0.4, 3.0, 4e-4
    k = m * (math.pi / tc) ** 2
    z = math.pi * m / (2 * zeta * tc)
    r = plate_contact(m, tc, z)
    assert r.zeta == pytest.approx(zeta, rel=1e-12)
    dt = min(tc, m / z) / 4000
    x, xd, w, imp, f2 = 0.0, v, 0.0, 0.0, 0.0
    for _ in range(int(200 * max(tc, m / z) / dt)):
        f = k * (x - w)
        if f < 0 or (f < 1e-9 * k * v * tc and xd < 0 and imp > 0):
            break
        imp += f * dt
        f2 += f * f * dt
        # explicit steps, thousands per contact time and per m / Z
        xd -= f / m * dt
        x += xd * dt
        w += f / z * dt
    e = -xd / v
    assert max(e, 0.0) == pytest.approx(r.restitution, abs=0.01)
    assert imp == pytest.approx(m * v * (1 + r.restitution), rel=0.01)
    assert f2 / z == pytest.approx(0.5 * m * v * v * (1 - r.restitution ** 2), rel=0.02)
    # the half-sine of the same impulse and integral of F^2
    j = m * v * (1 + r.restitution)
    assert math.pi ** 2 * j * j / (8 * r.duration_s) == pytest.approx(f2, rel=0.02)
    # never above the plate's Z v, never shorter than the rigid contact
    assert math.pi * j / (2 * r.duration_s) <= z * v * (1 + 1e-9)
    assert r.duration_s >= tc


def test_plate_contact_limits():
    from fallgen.audio.hertz import plate_contact

    rigid = plate_contact(0.3, 2e-4, math.inf)
    assert rigid.restitution == 1.0 and rigid.duration_s == 2e-4
    stiff = plate_contact(0.3, 2e-4, 1e9)  # a slab: the Hertz pulse itself
    assert stiff.duration_s == pytest.approx(2e-4, rel=1e-3) and stiff.restitution > 0.99
    with pytest.raises(ValueError):
        plate_contact(0.3, 2e-4, 0.0)
