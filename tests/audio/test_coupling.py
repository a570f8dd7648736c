"""The impact as a contact with the bodies' modes (audio/coupling.py): energy is conserved, a
rigid wall gives the spring's own half period and a full rebound, and a thin wall takes
energy from the impact instead of more than it has."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallgen.audio.coupling import coupled_impact


def test_rigid_wall_is_the_springs_half_period_and_an_elastic_rebound():
    r = coupled_impact(0.2, 1.5, 3e-4, [])
    assert r.duration_s == pytest.approx(3e-4, rel=1e-6)
    assert r.rebound_mps == pytest.approx(-1.5, rel=1e-6)
    assert r.vibration_j == 0.0 and r.incoming_j == pytest.approx(0.5 * 0.2 * 1.5 ** 2)
    # one contact, from 0 to the half period, with the elastic impulse 2 m v
    (start, length, impulse), = r.contacts
    assert start == 0.0 and length == pytest.approx(3e-4, rel=1e-6)
    assert impulse == pytest.approx(2 * 0.2 * 1.5, rel=1e-6)
    assert r.parting_s == pytest.approx(3e-4, rel=1e-6)


def _verlet_contacts(m, v, tc, w0, b, per_tc=10000):
    """Impactor, spring, one mode by velocity Verlet (the spring pushing only while
    compressed), until the impactor flies away beyond any motion of the wall: each interval
    where the spring is compressed, as (start, length, impulse = integral of the force)."""
    k = m * (math.pi / tc) ** 2
    dt = tc / per_tc
    x, xd, q, qd = 0.0, v, 0.0, 0.0
    out, start, impulse = [], 0.0, 0.0
    f = 0.0
    for i in range(int(60 * per_tc)):
        t = i * dt
        xd -= 0.5 * dt * f / m
        qd += 0.5 * dt * (b * f - w0 * w0 * q)
        x += dt * xd
        q += dt * qd
        d = x - b * q
        f_new = k * d if d > 0 else 0.0
        if f_new > 0 and f == 0:  # a contact starts within this step
            start, impulse = t + dt * (1 - d / (dt * (xd - b * qd))), 0.0
        elif f_new == 0 and f > 0:  # ... or ends
            out.append((start, t + dt * (1 - d / (dt * (xd - b * qd))) - start, impulse))
        impulse += 0.5 * dt * (f + f_new)
        f = f_new
        xd -= 0.5 * dt * f / m
        qd += 0.5 * dt * (b * f - w0 * w0 * q)
        if xd < 0 and f == 0 and x < -abs(b) * math.hypot(q, qd / w0):
            break
    return out


def test_a_chattering_contact_is_its_contact_intervals():
    """A light, soft mode at the contact (a slender body struck near its tip: its modal mass
    at the contact, 1 / b^2 = 28 g, a tenth of the impactor's) leaves the impactor and meets
    it again: seven contacts over ten rigid contact times (bars dropped at an angle bounce so,
    Stoianovici & Hurmuzlu 1996). Each contact interval (start, length, impulse) is a fine
    direct integration's within 0.1 % of the rigid contact time (its step is 1e-4 of it) and
    1 % of the impulse; how long they touched is the intervals' sum, which the time to the last
    parting (mostly flight) is not."""
    m, v, tc, w0, b = 0.3, 2.0, 5e-4, 2 * math.pi * 300.0, 6.0
    r = coupled_impact(m, v, tc, [(np.array([w0]), np.array([b]))])
    ref = _verlet_contacts(m, v, tc, w0, b)
    assert len(r.contacts) == len(ref) == 7
    for (s, ln, j), (s0, ln0, j0) in zip(r.contacts, ref):
        assert s == pytest.approx(s0, abs=1e-3 * tc)
        assert ln == pytest.approx(ln0, abs=1e-3 * tc)
        assert j == pytest.approx(j0, rel=0.01)
    # the impulses sum to the impactor's change of momentum
    assert sum(j for _, _, j in r.contacts) == pytest.approx(m * (v - r.rebound_mps), rel=1e-9)
    assert r.duration_s == pytest.approx(sum(ln for _, ln, _ in ref), abs=1e-3 * tc)
    assert r.parting_s == pytest.approx(ref[-1][0] + ref[-1][1], abs=1e-3 * tc)
    # the time they touched is about twice the rigid contact's; to the last parting, ten times
    assert 1.5 * tc < r.duration_s < 3 * tc < 8 * tc < r.parting_s


def test_single_mode_against_a_direct_integration():
    """Impactor, spring, one mode: the parting state matches a fine explicit integration."""
    m, v, tc, w0, b = 0.3, 2.0, 5e-4, 2 * math.pi * 900.0, 1.7
    k = m * (math.pi / tc) ** 2
    r = coupled_impact(m, v, tc, [(np.array([w0]), np.array([b]))])
    # velocity Verlet, the spring pushing only while compressed (contacts again allowed),
    # until the impactor flies away beyond any motion of the wall
    dt = tc / 20000
    x, xd, q, qd = 0.0, v, 0.0, 0.0
    for _ in range(int(40 * tc / dt)):
        for half in (0, 1):
            d = x - b * q
            f = k * d if d > 0 else 0.0
            xd += 0.5 * dt * (-f / m)
            qd += 0.5 * dt * (b * f - w0 * w0 * q)
            if half == 0:
                x += dt * xd
                q += dt * qd
        if xd < 0 and x < -abs(b) * math.hypot(q, qd / w0):
            break
    e_vib = 0.5 * (qd ** 2 + (w0 * q) ** 2)
    assert r.vibration_j == pytest.approx(e_vib, rel=0.02)
    assert r.rebound_mps == pytest.approx(xd, rel=0.02)


@pytest.mark.parametrize("seed", range(4))
def test_energy_is_conserved_and_bounded(seed):
    rng = np.random.default_rng(seed)
    bodies = [(2 * np.pi * np.sort(rng.uniform(80, 15000, 40)), rng.normal(0, s, 40))
              for s in (0.5, 4.0)]
    m, v = float(rng.uniform(0.05, 1.5)), float(rng.uniform(0.5, 5))
    r = coupled_impact(m, v, float(rng.uniform(5e-5, 1e-3)), bodies)
    assert r.vibration_j + 0.5 * m * r.rebound_mps ** 2 == pytest.approx(r.incoming_j, rel=1e-6)
    assert 0 < r.vibration_j < r.incoming_j
    # what a prescribed rigid-wall impulse 2 m v would hand the same modes: far more
    prescribed = 0.5 * (2 * m * v) ** 2 * sum(float(np.sum(b ** 2)) for _, b in bodies)
    assert prescribed > r.vibration_j


def test_stiff_light_modes_take_little_and_gains_reproduce_the_state():
    w = 2 * np.pi * np.array([5e3, 9e3, 14e3])
    b = np.array([0.05, 0.03, 0.02])  # a heavy, stiff body: the wall barely yields
    r = coupled_impact(0.1, 1.0, 2e-4, [(w, b)])
    assert r.vibration_j < 1e-3 * r.incoming_j
    d = np.full(3, 10.0)
    wd = w * 0.999
    g = r.gains(0, wd, d)
    # q(0) = Im(G) / w_d, q'(0) = Re(G) - d q(0)
    assert np.allclose(g.imag / wd, r.displacement[0])
    assert np.allclose(g.real - d * r.displacement[0], r.velocity[0])
    half = r.scaled(0.5)
    assert half.vibration_j == pytest.approx(0.25 * r.vibration_j)
