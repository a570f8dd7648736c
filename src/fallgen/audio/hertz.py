"""Hertz contact between two elastic bodies: how long an impact lasts and how hard it pushes.

Effective quantities: 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2, 1/R* = 1/R1 + 1/R2 (a flat
surface has R = inf), 1/m* = 1/m1 + 1/m2 (a fixed surface has m = inf). Force
F = (4/3) E* sqrt(R*) delta^(3/2); at approach speed v the deepest compression is
delta_m = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5) and the contact lasts t_c = 2.9432 delta_m / v
(Johnson, Contact Mechanics, 1985, sec. 11.4). The force pulse's spectrum falls off above
~1.5 / t_c: hard pairs click, soft pairs thud.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

#: t_c = HERTZ_TIME_FACTOR * delta_m / v for the Hertz impact (integral of the energy equation).
HERTZ_TIME_FACTOR = 2.9432


@dataclass(frozen=True)
class HertzImpact:
    duration_s: float
    peak_force_n: float
    max_compression_m: float
    e_star_pa: float
    r_star_m: float
    m_star_kg: float


def effective(E1: float, nu1: float, E2: float, nu2: float, R1: float, R2: float,
              m1: float, m2: float) -> tuple[float, float, float]:
    e = 1.0 / ((1 - nu1 ** 2) / E1 + (1 - nu2 ** 2) / E2)
    r = 1.0 / (1.0 / R1 + (0.0 if math.isinf(R2) else 1.0 / R2))
    m = 1.0 / (1.0 / m1 + (0.0 if math.isinf(m2) else 1.0 / m2))
    return e, r, m


def hertz_impact(E1: float, nu1: float, E2: float, nu2: float, R1: float, R2: float,
                 m1: float, m2: float, speed_mps: float) -> HertzImpact:
    """Closed-form Hertz impact of body 1 on body 2 at relative normal speed ``speed_mps``."""
    if speed_mps <= 0:
        raise ValueError("impact speed must be positive")
    e, r, m = effective(E1, nu1, E2, nu2, R1, R2, m1, m2)
    dm = (15 * m * speed_mps ** 2 / (16 * e * math.sqrt(r))) ** 0.4
    return HertzImpact(HERTZ_TIME_FACTOR * dm / speed_mps, 4 / 3 * e * math.sqrt(r) * dm ** 1.5,
                       dm, e, r, m)


def integrate_hertz(e_star: float, r_star: float, m_star: float, speed_mps: float
                    ) -> tuple[float, float]:
    """Contact time and peak force by integrating m* d2(delta)/dt2 = -F(delta) numerically (a
    reference for tests)."""
    k = 4 / 3 * e_star * math.sqrt(r_star)

    def f(t, y):
        d = max(y[0], 0.0)
        return [y[1], -k * d ** 1.5 / m_star]

    def leave(t, y):
        return y[0]

    leave.terminal, leave.direction = True, -1
    t_guess = 10 * (m_star ** 2 / (r_star * e_star ** 2 * speed_mps)) ** 0.2
    sol = solve_ivp(f, (0.0, t_guess), [0.0, speed_mps], events=leave, rtol=1e-10, atol=1e-16,
                    max_step=t_guess / 2000, dense_output=True)
    tc = float(sol.t_events[0][0])
    ts = np.linspace(0, tc, 2001)
    d = np.maximum(sol.sol(ts)[0], 0)
    return tc, float(k * d.max() ** 1.5)


def half_sine_spectrum(omega: np.ndarray, duration_s: float) -> np.ndarray:
    """|F(omega)| / J of a half-sine force pulse of impulse J lasting ``duration_s``: 1 at low
    frequency, falling as 1 / omega^2 above ~1.5 / duration."""
    x = np.asarray(omega, float) * duration_s / np.pi  # omega t_c / pi
    out = np.empty_like(x)
    near = np.abs(x - 1.0) < 1e-6
    out[near] = np.pi / 4
    xx = x[~near]
    out[~near] = np.abs(np.cos(np.pi * xx / 2) / (1 - xx ** 2))
    return out


@dataclass(frozen=True)
class PlateContact:
    """An impact on a large plate (Zener 1941, "The intrinsic inelasticity of large plates",
    Phys. Rev. 59, linearised): the impactor meets the contact spring k = m (pi / t_c)^2 (its
    rigid Hertz time t_c) in series with the plate's point impedance Z, a dashpot (an infinite
    thin plate's point mobility is real, 1 / (8 sqrt(B m''))), so the force obeys
    F'' + (k / Z) F' + (k / m) F = 0, F(0) = 0, F'(0) = k v. With zeta = pi m / (2 Z t_c):

    - the rebound's share of the approach speed ``restitution`` = exp(-pi zeta /
      sqrt(1 - zeta^2)) (0 from zeta = 1: the plate takes the whole impact);
    - the impulse m v (1 + restitution); the energy the plate carries away, which is
      the integral of F^2 / Z, m v^2 (1 - restitution^2) / 2;
    - ``duration_s``: the half-sine pulse of the same impulse and the same integral of F^2 (a
      plate's forced sound is proportional to F, so it radiates the same energy):
      pi^2 m (1 + e) / (4 Z (1 - e)), the rigid Hertz time t_c when Z is infinite, and
      pi^2 m / (4 Z) (a peak of 2 Z v / pi, under the plate's Z v) when it is small."""

    zeta: float
    restitution: float
    duration_s: float


def plate_contact(mass_kg: float, contact_time_s: float, point_impedance_n_s_m: float
                  ) -> PlateContact:
    """The impact of ``mass_kg`` through a contact of rigid Hertz time ``contact_time_s`` on a
    large plate of point impedance ``point_impedance_n_s_m`` (:class:`PlateContact`)."""
    if mass_kg <= 0 or contact_time_s <= 0 or point_impedance_n_s_m <= 0:
        raise ValueError("mass, contact time and impedance must be positive")
    if math.isinf(point_impedance_n_s_m):
        return PlateContact(0.0, 1.0, contact_time_s)
    zeta = math.pi * mass_kg / (2.0 * point_impedance_n_s_m * contact_time_s)
    e = math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta * zeta)) if zeta < 1.0 else 0.0
    if e > 1.0 - 1e-9:  # a stiff plate: the Hertz pulse itself (the limit, without round-off)
        return PlateContact(zeta, e, contact_time_s)
    t = math.pi ** 2 * mass_kg * (1.0 + e) / (4.0 * point_impedance_n_s_m * (1.0 - e))
    return PlateContact(zeta, e, max(t, contact_time_s))
