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


def _pulse_spectrum(w, duration_s):
    """|F(w)| / J of a half-sine force pulse (its Fourier transform, textbook form)."""
    x = np.asarray(w, float) * duration_s / math.pi
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.abs(np.cos(math.pi * x / 2) / (1 - x * x))
    return np.where(np.abs(x - 1) < 1e-9, math.pi / 4, s)


def _mode_velocities(body, hit, fs=FS):
    """(v_i, kept): the velocity one hit gives each mode, written out from the modal model
    (mass-normalised shapes: an impulse J gives a mode the velocity (phi . n) J) and the
    pulse's spectrum, and which modes the renderer keeps (20 Hz to 0.45 fs)."""
    m = body.modes
    w = m.omega
    keep = (w > 2 * math.pi * 20) & (w < 0.45 * fs * 2 * math.pi)
    node = int(np.argmin(np.linalg.norm(m.points - np.asarray(hit.point), axis=1)))
    normal = m.area[node] / np.linalg.norm(m.area[node])
    phi = m.shapes[node].astype(float) * m.shape_factor
    return (normal @ phi) * hit.impulse_ns * _pulse_spectrum(w, hit.duration_s), keep


def _mode_amplitudes(body, hit, fs=FS):
    """Each rendered mode's pressure amplitude at 1 m for one hit:
    (A_i, d_i) with p(t) = sum A_i e^(-d_i t) sin(w_d,i t)."""
    w = body.modes.omega
    eta = body.loss_factors()
    d, wd = eta * w / 2, w * np.sqrt(1 - (eta / 2) ** 2)
    v, keep = _mode_velocities(body, hit, fs)
    a = v * body.radiation() / wd
    return a[keep], d[keep]


def _closed_form_energy(body, hit):
    """integral of p^2 dt of one hit's ringing: sum over modes of A_i^2 / (4 d_i) (well
    separated, lightly damped modes: the cross terms average out)."""
    a, d = _mode_amplitudes(body, hit)
    return float(np.sum(a * a / (4 * d)))


def _check_rendered_energy(p, body, hit, rel):
    """The rendered signal's energy is the closed form's, within ``rel``."""
    got = float(np.dot(p, p)) / FS
    want = _closed_form_energy(body, hit)
    assert got == pytest.approx(want, rel=rel), (got, want)


def test_louder_with_impulse_no_normalisation(bar_ref):
    b = _body(bar_ref, STEEL)
    # same pulse, twice the impulse: exactly twice the pressure
    h = _hit(b, 2.0)
    p1 = render(b, [h], 0.5)
    p2 = render(b, [ModalHit(h.time_s, h.point, 2 * h.impulse_ns, h.duration_s)], 0.5)
    assert np.allclose(p2, 2 * p1)
    # absolute units: the rendered energy is the modes' closed form (impulse J, mass-normalised
    # shapes, the pulse's spectrum, each mode's decay) to 0.1 %, for a slow and a fast impact
    slow_hit, fast_hit = _hit(b, 1.0), _hit(b, 4.0)
    slow, fast = render(b, [slow_hit], 2.0), render(b, [fast_hit], 2.0)
    _check_rendered_energy(slow, b, slow_hit, 1e-3)
    _check_rendered_energy(fast, b, fast_hit, 1e-3)
    # a faster impact (4x the impulse, a shorter Hertz pulse): louder as the closed form says
    ratio = np.sqrt((fast ** 2).mean() / (slow ** 2).mean())
    want = math.sqrt(_closed_form_energy(b, fast_hit) / _closed_form_energy(b, slow_hit))
    assert ratio == pytest.approx(want, rel=1e-3) and ratio > 4.0
    # the check rejects a normalised renderer (the fast impact's loudness whatever the
    # impulse) and one whose pressure is 6 dB off
    with pytest.raises(AssertionError):
        _check_rendered_energy(slow * np.abs(fast).max() / np.abs(slow).max(), b, slow_hit, 0.1)
    with pytest.raises(AssertionError):
        _check_rendered_energy(2 * slow, b, slow_hit, 0.1)


def test_a_mode_radiates_its_radiation_loss_share_of_what_it_is_given(bar_ref):
    """Energy balance: an impulse gives mode i the energy (b_i J S_i)^2 / 2 (mass-normalised
    shapes, b_i = phi_i . n, S_i the pulse's spectrum); a mode whose radiation loss factor is
    3 times its material's radiates 3/4 of it (eta_rad / (eta + eta_rad)), summed over the
    bar's well separated modes within 2 %. Damped by its material alone it would radiate 3
    times what it held; the check rejects that."""
    b = _body(bar_ref, STEEL)
    w = b.modes.omega
    loud = np.sqrt(3 * b.loss_factor * RHO_AIR * C_AIR * w ** 3 / (4 * math.pi))
    b.__dict__["_radiation"] = loud  # the cached radiation factors, replaced
    assert b.loss_factors() == pytest.approx(4 * b.loss_factor, rel=1e-12)
    hit = _hit(b, 1.0)
    v, keep = _mode_velocities(b, hit)
    given = float(np.sum(v[keep] ** 2) / 2)
    radiated = radiated_energy_j(render(b, [hit], 4.0, FS), FS)

    def check(r):
        assert r == pytest.approx(0.75 * given, rel=0.02), (r, given)

    check(radiated)
    with pytest.raises(AssertionError):
        check(3 * given)


def test_bigger_object_rings_lower(bar_ref):
    """Twice the size, the same material: every mode an octave lower (f ~ c / L), so the
    loudest partial of the rendered sound too (within the spectrum's 1 Hz resolution), and
    it is one of the modes."""
    small, big = _body(bar_ref, STEEL, 1.0), _body(bar_ref, STEEL, 2.0)
    assert np.allclose(big.modes.omega, small.modes.omega / 2, rtol=1e-12)
    f_small = _fundamental(render(small, [_hit(small, 2.0)], 1.0))
    f_big = _fundamental(render(big, [_hit(big, 2.0)], 1.0))
    assert f_big == pytest.approx(f_small / 2, abs=1.0), (f_small, f_big)
    assert np.min(np.abs(small.modes.omega / (2 * math.pi) - f_small)) < 1.0


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
    # no blow-up: never above every mode of every hit adding up in phase (the triangle
    # inequality over the closed-form amplitudes), and the first hit alone reaches a good part
    # of its own sum before the second
    bound = sum(float(np.abs(_mode_amplitudes(b, h)[0]).sum()) for h in hits)
    assert np.isfinite(a).all() and np.abs(a).max() <= bound
    first = float(np.abs(a[: int(0.3 * FS)]).max())
    assert first >= 0.1 * float(np.abs(_mode_amplitudes(b, hits[0])[0]).sum())
    assert np.abs(a[: int(0.01 * FS) - 1]).max() == 0.0  # silent before the first hit


def _twist_share(m):
    """Per mode, the share of its surface motion that is a twist about the bar's long (x)
    axis: the projection of each node's displacement on the local rotation field
    (0, -z, y) / |(y, z)| about the cross-section's centre."""
    c = m.points.mean(axis=0)
    y, z = m.points[:, 1] - c[1], m.points[:, 2] - c[2]
    rot = np.stack([np.zeros_like(y), -z, y], axis=1)
    rot /= np.maximum(np.linalg.norm(rot, axis=1, keepdims=True), 1e-12)
    s = m.shapes.astype(float)
    return (np.einsum("scn,sc->sn", s, rot) ** 2).sum(0) / (s ** 2).sum((0, 1))


def _check_torsion_quieter(r, m):
    """A twisting bar moves no net volume and has no first moment of it (the rotation field
    is divergence-free and mass-orthogonal to the rigid motions: Q = D = 0 exactly), so it
    radiates at most as a quadrupole, while a bending mode whose dipole does not cancel
    radiates as a dipole: every torsional mode's R below 1e-3 of the loudest bending mode's
    within an octave of it, and below 1e-3 of its own efficiency-1 value
    rho c w sqrt(sum |a| (n . phi)^2 / 4 pi) (the large-source limit), computed here from the
    shapes."""
    twist = _twist_share(m)
    torsion = np.flatnonzero(twist > 0.85)
    bending = np.flatnonzero(twist < 0.7)
    assert len(torsion) >= 3 and len(bending) >= 6, (torsion, bending)
    a = m.area.astype(float)
    an = np.einsum("sc,scn->sn", a, m.shapes.astype(float)) * m.shape_factor
    area = np.linalg.norm(a, axis=1)
    efficiency_one = RHO_AIR * C_AIR * m.omega * np.sqrt((an ** 2 / area[:, None]).sum(0)
                                                         / (4 * math.pi))
    for i in torsion:
        near = [j for j in bending if 0.5 < m.omega[j] / m.omega[i] < 2.0]
        assert near, i
        assert r[i] < 1e-3 * max(r[j] for j in near), (i, r[i], [r[j] for j in near])
        assert r[i] < 1e-3 * efficiency_one[i], (i, r[i], efficiency_one[i])


def test_torsion_does_not_radiate_more_than_bending(bar_ref):
    r = radiation_factors(bar_ref)
    _check_torsion_quieter(r, bar_ref)
    # the check rejects radiation that ignores the mode's shape (a constant), and the
    # efficiency-1 estimate alone (what every element of a large body's surface radiates)
    with pytest.raises(AssertionError):
        _check_torsion_quieter(np.full_like(r, r.max()), bar_ref)
    _, _, A = bar_ref.surface_moments()
    with pytest.raises(AssertionError):
        _check_torsion_quieter(RHO_AIR * C_AIR * bar_ref.omega * np.sqrt(A / (4 * math.pi)),
                               bar_ref)


@pytest.mark.parametrize("hits_until, N", [(19990, 20000), (1500, 44100)])
def test_block_synthesis_equals_recursive_filters(hits_until, N):
    """modal_sum against one scipy two-pole resonator per mode (the textbook form): hits all
    along the clip, and hits in its first 34 ms only (then the modes ring on for a second,
    many blocks freely, some dropped after their -80 dB)."""
    from scipy.signal import lfilter

    from fallgen.audio.impact import modal_sum

    rng = np.random.default_rng(3)
    M, H = 12, 40
    w = rng.uniform(2 * np.pi * 50, 2 * np.pi * 15000, M)
    d = rng.uniform(1.0, 3000.0, M)
    c = rng.uniform(-2, 2, M)
    idx = np.sort(rng.integers(0, hits_until, H))
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


def test_second_order_bilinear_transform_is_scipys():
    """The closed-form bilinear transform of the rigid-body noise's filter against
    scipy.signal.bilinear's polynomial one, from a 3 mm to a 0.3 m body, at 44.1 and 48 kHz."""
    from scipy.signal import bilinear

    from fallgen.audio.impact import bilinear_2nd_order

    for tau in (8.7e-6, 8.7e-5, 8.7e-4):
        for fs in (44100.0, 48000.0):
            b, a = (3.0 * tau, 0.5), (tau ** 2, 2.0 * tau, 2.0)
            want_b, want_a = bilinear(list(b), list(a), fs)
            got_b, got_a = bilinear_2nd_order(b, a, fs)
            assert np.allclose(got_b, want_b, rtol=1e-13, atol=1e-15 * np.abs(want_b).max())
            assert np.allclose(got_a, want_a, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("radius_m", [0.003, 0.03, 0.3])
def test_rigid_body_noise_stops_only_far_below_float_resolution(radius_m):
    """The rigid-body noise is filtered only over its pulses and their 600 dB decay: the same
    samples as the filter run over the whole clip (scipy's lfilter), within 1e-12 of the peak,
    and what it leaves at zero is below 1e-30 of it there."""
    from scipy.signal import bilinear, lfilter

    from fallgen.audio.impact import force_signal

    vol, mass, n = 4 / 3 * math.pi * radius_m ** 3, 0.2, FS
    hits = [ModalHit(0.01, np.zeros(3), 0.3, 1e-4), ModalHit(0.3, np.zeros(3), 0.1, 3e-4)]
    got = rigid_body_pressure(vol, mass, hits, n, FS)
    tau = radius_m / C_AIR
    gain = RHO_AIR * radius_m ** 3 / (2.0 * C_AIR * math.sqrt(3.0)) / mass
    w0 = math.sqrt(2.0) / tau
    warp = w0 / (2 * FS * math.tan(w0 / (2 * FS))) if w0 < 0.9 * math.pi * FS else 1.0
    tw = tau * warp
    want = lfilter(*bilinear([2.0 * gain, 0.0], [tw ** 2, 2.0 * tw, 2.0], FS),
                   force_signal(hits, n, FS))
    peak = np.abs(want).max()
    assert np.abs(got - want).max() < 1e-12 * peak
    assert np.abs(want[got == 0]).max(initial=0.0) < 1e-30 * peak
    assert (got[int(0.3 * FS) + 40:] == 0).any()  # it did stop


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


def test_a_chattering_contacts_force_is_its_pulses():
    """A contact that chatters (:func:`fallgen.audio.coupling.coupled_impact`'s contact
    intervals) pushes in one half-sine pulse per interval: each interval of the sampled force
    carries its pulse's impulse exactly (the force is the impulse each sample receives), the
    peak is pi J / (2 T) (a half-sine's) within a sample's change, and nothing pushes between
    the pulses. One pulse spread over the time to the last parting has a fifth of the peak."""
    from fallgen.audio.impact import force_signal

    fs = 44100
    pulses = ((0.0, 0.5, 1e-3), (4e-3, 0.3, 6e-4), (9e-3, 0.2, 8e-4))
    hit = ModalHit(0.01, np.zeros(3), 1.0, 2.4e-3, pulses=pulses)
    f = force_signal([hit], fs // 10, fs)
    assert f.sum() / fs == pytest.approx(1.0, rel=1e-12)
    for k, (t0, j, d) in enumerate(pulses):
        i0 = int(round((0.01 + t0) * fs))
        i1 = i0 + int(np.ceil(d * fs)) + 1
        assert f[i0:i1].sum() / fs == pytest.approx(j, rel=1e-12)
        peak = math.pi * j / (2 * d)
        assert f[i0:i1].max() == pytest.approx(peak, rel=0.15)  # samples of 23 us
        if k + 1 < len(pulses):
            assert not f[i1:int(round((0.01 + pulses[k + 1][0]) * fs))].any()
    spread = force_signal([ModalHit(0.01, np.zeros(3), 1.0, 9.8e-3)], fs // 10, fs)
    assert spread.max() < 0.25 * f.max()


def test_a_hit_train_sounds_as_its_hits_one_by_one(bar_ref):
    """A scrape's bumps kept as one train of arrays (:class:`fallgen.audio.hits.HitTrain`)
    ring the modes, jerk the body and push a plate exactly as the same bumps as single hits
    do, those without impulse or past the output's end left out alike; a train with fewer
    impulses than times is refused."""
    from fallgen.audio.hits import HitTrain
    from fallgen.audio.impact import plate_pressure

    body = _body(bar_ref, STEEL)
    rng = np.random.default_rng(3)
    times = 0.02 + np.sort(rng.uniform(0.0, 0.01, 40))
    times[-1] = 0.6  # after the 0.5 s rendered
    impulses = np.abs(rng.normal(0.0, 1e-4, 40))
    impulses[5] = 0.0
    train = HitTrain(times, TIP, impulses, 2e-4, np.array([0.0, 0.0, -1.0]))
    impact = _hit(body, 1.5)
    whole = render(body, [impact, train], 0.5, FS, volume_m3=1.6e-5)
    assert np.array_equal(whole, render(body, [impact, *train.hits()], 0.5, FS, volume_m3=1.6e-5))
    alone = render(body, [train], 0.5, FS, volume_m3=1.6e-5)
    assert np.array_equal(alone, render(body, train.hits(), 0.5, FS, volume_m3=1.6e-5))
    assert np.abs(alone).max() > 0 and not np.array_equal(whole, render(body, [impact], 0.5, FS,
                                                                         volume_m3=1.6e-5))
    n = FS // 2
    assert np.array_equal(plate_pressure(20.0, [train], n, FS),
                          plate_pressure(20.0, train.hits(), n, FS))
    with pytest.raises(ValueError, match="one impulse per time"):
        HitTrain(times, TIP, impulses[:3], 2e-4)
