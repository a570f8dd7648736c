"""Impact sounds: loudness follows the impulse, size sets pitch, loss factors set decay; no NaN,
no normalisation, deterministic."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from fallgen.audio.hertz import hertz_impact
from fallgen.audio.impact import (C_AIR, RHO_AIR, ModalHit, SoundingBody, radiated_energy_j,
                                 radiation_factors, render, rigid_body_pressure)
from fallgen.audio.modes import ModalSettings, modal_model

FS = 44100


@pytest.fixture(scope="module")
def bar_ref(tmp_path_factory):
    box = trimesh.creation.box((0.1, 0.02, 0.008))
    return modal_model(box.vertices, box.faces, 0.3, ModalSettings(target_voxels=800, n_modes=16),
                       tmp_path_factory.mktemp("modes"))


def _body(ref, mat, scale=1.0):
    E, rho, nu, eta = mat
    m = ref.scaled(E, rho, scale)
    return SoundingBody(m, eta, E, nu, rho * 0.1 * 0.02 * 0.008 * scale ** 3, 0.004 * scale)


STEEL = (2.0e11, 7850.0, 0.29, 0.004)
GLASS = (7.0e10, 2500.0, 0.22, 0.003)
WOOD = (1.1e10, 700.0, 0.3, 0.03)
RUBBER = (5.0e6, 1100.0, 0.49, 0.3)
TIP = np.array([0.05, 0.01, 0.004])  # a corner


def _hit(body, speed, t=0.01):
    h = hertz_impact(body.contact_modulus_pa, body.poisson_ratio, 6e10, 0.2,
                     body.contact_radius_m, math.inf, body.mass_kg, math.inf, speed)
    return ModalHit(t, TIP, body.mass_kg * speed, h.duration_s)


def _fundamental(p):
    spec = np.abs(np.fft.rfft(p * np.hanning(len(p))))
    f = np.fft.rfftfreq(len(p), 1 / FS)
    return f[np.argmax(spec * (f > 50))]


def _t60(p, f0=None):
    """Decay time from Schroeder's backward-integrated energy curve, fitted from -5 to -35 dB
    (T30 extrapolated to 60 dB)."""
    edc = np.cumsum((p ** 2)[::-1])[::-1]
    db = 10 * np.log10(edc / edc[0] + 1e-300)
    k = np.nonzero((db <= -5) & (db >= -35))[0]
    slope = np.polyfit(k / FS, db[k], 1)[0]
    return -60 / slope


def test_louder_with_impulse_no_normalisation(bar_ref):
    b = _body(bar_ref, STEEL)
    # same pulse, twice the impulse: exactly twice the pressure
    h = _hit(b, 2.0)
    p1 = render(b, [h], 0.5)
    p2 = render(b, [ModalHit(h.time_s, h.point, 2 * h.impulse_ns, h.duration_s)], 0.5)
    assert np.allclose(p2, 2 * p1)
    # a faster impact (impulse and a shorter Hertz pulse): louder, about as the impulse
    slow, fast = render(b, [_hit(b, 1.0)], 0.5), render(b, [_hit(b, 4.0)], 0.5)
    ratio = np.sqrt((fast ** 2).mean() / (slow ** 2).mean())
    assert 3.5 < ratio < 6.0
    # heavier (same shape, denser) -> more impulse at the same speed -> louder in pascals
    assert np.abs(p1).max() > 1e-4  # audible: > 14 dB SPL peak at 1 m


def test_bigger_object_rings_lower(bar_ref):
    small, big = _body(bar_ref, STEEL, 1.0), _body(bar_ref, STEEL, 2.0)
    assert big.modes.omega[0] == pytest.approx(small.modes.omega[0] / 2)
    f_small = _fundamental(render(small, [_hit(small, 2.0)], 1.0))
    f_big = _fundamental(render(big, [_hit(big, 2.0)], 1.0))
    assert f_big < 0.75 * f_small


def test_decay_follows_loss_factor(bar_ref):
    # The same modes with the loss factors of glass, steel, wood and rubber: decay times in
    # the inverse order of the loss factors (T60 = 2 ln(1000) / (eta w) per mode).
    t60 = {}
    for name, eta in (("glass", GLASS[3]), ("steel", STEEL[3]), ("wood", WOOD[3]),
                      ("rubber", RUBBER[3])):
        b = _body(bar_ref, STEEL[:3] + (eta,))
        p = render(b, [_hit(b, 2.0)], 2.0)
        assert np.isfinite(p).all()
        t60[name] = _t60(p, None)
    assert t60["glass"] > t60["steel"] > t60["wood"] > t60["rubber"], t60
    # every decay rate is proportional to eta, so the decay time is inversely proportional
    assert t60["steel"] / t60["wood"] == pytest.approx(WOOD[3] / STEEL[3], rel=0.1)


def test_library_materials_ring_in_loss_factor_order(world):
    # At a common pitch (1 kHz), glass and metal ring longer than wood, wood longer than rubber.
    t60 = {n: 6 * math.log(10) / (world.materials.object(n).loss_factor * math.pi * 1000)
           for n in ("glass", "metal", "ceramic", "wood_medium", "wood_hard", "rubber")}
    assert min(t60["glass"], t60["metal"]) > max(t60["wood_medium"], t60["wood_hard"])
    assert min(t60["wood_medium"], t60["wood_hard"]) > t60["rubber"]


def test_library_loss_factors_are_ordered(world):
    eta = {n: world.materials.object(n).loss_factor for n in
           ("glass", "metal", "ceramic", "wood_medium", "wood_hard", "rubber", "fabric")}
    assert max(eta["glass"], eta["metal"], eta["ceramic"]) < min(eta["wood_medium"], eta["wood_hard"])
    assert max(eta["wood_medium"], eta["wood_hard"]) < min(eta["rubber"], eta["fabric"])


def test_deterministic_finite_and_bounded(bar_ref):
    b = _body(bar_ref, STEEL)
    hits = [_hit(b, 3.0, 0.01), _hit(b, 1.0, 0.3), _hit(b, 0.3, 0.5)]
    a, c = render(b, hits, 2.0), render(b, hits, 2.0)
    assert np.array_equal(a, c)
    assert np.isfinite(a).all() and np.abs(a).max() < 200.0  # < 140 dB SPL: no blow-up
    assert np.abs(a[: int(0.01 * FS) - 1]).max() == 0.0  # silent before the first hit


def test_torsion_does_not_radiate_more_than_bending(bar_ref):
    r = radiation_factors(bar_ref)
    assert np.isfinite(r).all() and (r >= 0).all()


def test_block_synthesis_equals_recursive_filters():
    """modal_sum against one scipy two-pole resonator per mode (the textbook form)."""
    from scipy.signal import lfilter

    from fallgen.audio.impact import modal_sum

    rng = np.random.default_rng(3)
    M, H, N = 12, 40, 20000
    w = rng.uniform(2 * np.pi * 50, 2 * np.pi * 15000, M)
    d = rng.uniform(1.0, 3000.0, M)
    c = rng.uniform(-2, 2, M)
    idx = np.sort(rng.integers(0, N - 10, H))
    g = rng.normal(size=(H, M))
    T = 1 / FS
    got = modal_sum(np.exp((-d + 1j * w) * T), c, idx, g, N)
    want = np.zeros(N)
    for i in range(M):
        x = np.zeros(N)
        np.add.at(x, idx, g[:, i])
        e = np.exp(-d[i] * T)
        want += c[i] * lfilter([0.0, e * np.sin(w[i] * T)], [1.0, -2 * e * np.cos(w[i] * T), e * e], x)
    # equal up to the -80 dB truncation of dead modes
    assert np.allclose(got, want, atol=2e-4 * np.abs(want).max())


def test_radiation_moments_survive_scaling(bar_ref):
    """Radiation of a rescaled model from carried moments equals recomputing from its shapes."""
    import dataclasses

    m = bar_ref.scaled(*STEEL[:2], 1.7)
    fresh = dataclasses.replace(m, moments=None)
    r1, r2 = radiation_factors(m), radiation_factors(fresh)
    # equal, up to float32 rounding in modes that cancel to ~0 (torsion: no net motion)
    assert np.allclose(r1, r2, rtol=1e-4, atol=1e-5 * r2.max())


def _sphere_click(a, mass, dv, tc, n=8820):
    """Rigid-body noise of a sphere of radius ``a`` whose velocity changes by ``dv`` in a
    half-sine force pulse of ``tc``."""
    vol = 4 / 3 * math.pi * a ** 3
    return rigid_body_pressure(vol, mass, [ModalHit(0.01, np.zeros(3), mass * dv, tc)], n, FS)


def test_rigid_body_noise_is_the_compact_dipole_for_a_slow_pulse():
    """ka << 1 over the pulse's spectrum: p = rho0 (1.5 V) / (4 pi c r) da/dt / sqrt(3), with
    da/dt of the half-sine force: the same spectrum below 500 Hz and the same energy."""
    a, m, dv, tc = 0.01, 0.05, 5.0, 2e-3  # corner 7.7 kHz, the pulse's spectrum below ~500 Hz
    p = _sphere_click(a, m, dv, tc)
    vol = 4 / 3 * math.pi * a ** 3
    t = (np.arange(len(p)) - round(0.01 * FS)) / FS
    ref = np.where((t >= 0) & (t <= tc), RHO_AIR * 1.5 * vol / (4 * math.pi * C_AIR)
                   / math.sqrt(3) * math.pi ** 2 * dv / (2 * tc ** 2) * np.cos(math.pi * t / tc),
                   0.0)
    f = np.fft.rfftfreq(len(p), 1 / FS)
    band = (f > 50) & (f < 500)  # below the pulse spectrum's first zero (750 Hz)
    ratio = np.abs(np.fft.rfft(p))[band] / np.abs(np.fft.rfft(ref))[band]
    assert np.all(np.abs(ratio - 1) < 0.05)
    assert radiated_energy_j(p, FS) == pytest.approx(radiated_energy_j(ref, FS), rel=0.05)
    assert abs(p.sum()) < 1e-3 * np.abs(p).sum()  # a jolt, no net pressure


def test_rigid_body_noise_follows_the_velocity_of_a_large_sphere():
    """ka >> 1 (a 0.2 m sphere stopped in 20 us): the exact rigid sphere's pressure starts at
    rho0 c a dU / (r sqrt(3)) and decays as e^(-t/tau) (cos - sin)(t/tau), tau = a / c; it
    radiates rho0 V dU^2 / 4, the kinetic energy of the sphere's added mass. The compact
    dipole would give (tau / tc)^2 ~ 800 times more pressure."""
    a, m, dv = 0.2, 3.0, 4.0
    p = _sphere_click(a, m, dv, 2e-5)
    limit = RHO_AIR * C_AIR * a * dv / math.sqrt(3)
    assert np.abs(p).max() <= limit * 1.001
    i0 = round(0.01 * FS) + 1  # the first sample holds half the step (bilinear): skip it
    x = np.arange(1, len(p) - i0 + 1) / FS / (a / C_AIR)
    ref = limit * np.exp(-x) * (np.cos(x) - np.sin(x))
    assert np.linalg.norm(p[i0:] - ref) < 0.05 * np.linalg.norm(ref)
    vol = 4 / 3 * math.pi * a ** 3
    assert radiated_energy_j(p, FS) == pytest.approx(RHO_AIR * vol * dv ** 2 / 4, rel=0.06)


def test_rigid_body_noise_energy_never_exceeds_the_instant_stop():
    """Whatever the pulse, a sphere radiates at most what an instant change of velocity
    would (its added mass's kinetic energy, rho0 V dU^2 / 4), and less the longer the
    pulse."""
    a, m, dv = 0.06, 1.0, 9.0
    vol = 4 / 3 * math.pi * a ** 3
    energies = [radiated_energy_j(_sphere_click(a, m, dv, tc), FS)
                for tc in (1e-5, 5e-5, 2e-4, 1e-3, 5e-3)]
    assert max(energies) <= RHO_AIR * vol * dv ** 2 / 4 * 1.02
    assert all(e1 > e2 for e1, e2 in zip(energies, energies[1:]))
