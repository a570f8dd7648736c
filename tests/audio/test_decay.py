"""Struck objects ring as long as measured ones do: the decay of a wine glass's and a steel
bowl's lowest sounding mode, measured in the rendered sound, against published damping.

Published values (loss factor eta = 2 zeta = 1 / Q; T60 = 3 ln(10) / (pi f eta) ~ 2.2 / (f eta)):

- glass: material loss factor 6e-4, 0.02 as installed (Bies, Hansen & Howard, Engineering Noise
  Control, 5th ed. 2017, table C.1); flexural loss factor of glass 0.003-0.006 (Hopkins, Sound
  Insulation, 2007, table A2); a recorded glass object fitted with Rayleigh damping
  alpha = 18.3 1/s, beta = 1.434e-7 s (Ren, Yeh & Lin, "Example-guided physically based modal
  sound synthesis", ACM TOG 32(1), 2013, table 1): eta ~0.0045 at 700 Hz. A wine glass's
  lowest mode, the (2,0) bell mode, lies at ~400-1000 Hz (e.g. 529 Hz for the glass of Harvard's
  lecture demonstration "Wineglass normal modes"; French, "In vino veritas", Am. J. Phys. 51,
  1983).
- metal bowls: bronze singing bowls resting freely have modal damping ratios zeta =
  0.002-0.015 % (eta 4e-5 to 3e-4), "one order of magnitude, or more" higher as supported or
  handled (Inacio, Henrique & Antunes, "The dynamics of Tibetan singing bowls", Acta Acustica
  united with Acustica 92, 2006); steel as installed 0.01, material 1e-4 (Bies et al., table C.1).

A fallen object rests on a floor or lies in a hand's reach: its decay belongs between the
material's own (lowest) and an installed structure's (highest); these tests check that the
rendered decay, not only the material table, falls there, and that glass rings longer than steel
objects with their supports' losses do not (the catalogue's steel carries support losses).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from fallgen.audio.fall import AudioSettings, FallRenderer
from fallgen.audio.impact import ModalHit, render
from fallgen.world.objects import Category, ObjectInstance, Variant, build_geometry

FS = 44100
LENGTH_S = 4.0


@pytest.fixture(scope="module")
def renderer(world, tmp_path_factory):
    # the build's modal settings (the frequencies depend on the mesh resolution)
    return FallRenderer(world, AudioSettings(length_s=LENGTH_S,
                                             cache_dir=tmp_path_factory.mktemp("modes")))


def _lowest_sounding(renderer, inst: ObjectInstance) -> tuple[float, float, float]:
    """(f, T60, eta) of the lowest mode the rim hit makes audible (within 40 dB of the
    loudest partial), measured in the rendered sound: band-passed around the mode, Schroeder's
    backward-integrated energy fitted from -5 to -25 dB."""
    body = renderer._object_body(inst, np.zeros(3), np.eye(3)).sounding
    m = body.modes
    rim = int(np.argmax(m.points[:, 2]))  # the highest surface node: the rim, hit on its normal
    p = render(body, [ModalHit(0.01, m.points[rim], 0.02 * inst.mass_kg, 2e-4)], LENGTH_S, FS,
               volume_m3=None)
    spec = np.abs(np.fft.rfft(p))
    f = np.fft.rfftfreq(len(p), 1 / FS)
    band = (f > 100) & (f < 8000)
    loud = spec[band].max()
    modes = m.omega / (2 * math.pi)
    f0 = next(fm for fm in modes if fm > 100 and
              spec[int(round(fm * len(p) / FS))] > loud * 10 ** (-40 / 20))
    sos = butter(4, [f0 * 0.97, f0 * 1.03], "bandpass", fs=FS, output="sos")
    q = sosfiltfilt(sos, p)
    edc = np.cumsum((q ** 2)[::-1])[::-1]
    db = 10 * np.log10(edc / edc[0] + 1e-300)
    k = np.nonzero((db <= -5) & (db >= -25))[0]
    t60 = -60 / np.polyfit(k / FS, db[k], 1)[0]
    return f0, t60, 3 * math.log(10) / (math.pi * f0 * t60)


def test_wine_glass_rings_like_glass(world, renderer):
    glass = world.categories.instance("wineglass", "red_wine", "glass")
    f0, t60, eta = _lowest_sounding(renderer, glass)
    assert 350 < f0 < 1000, f0  # the (2,0) bell mode of a red wine glass
    # between the material's own loss (Bies: 6e-4) and an installed pane's (0.02) ...
    assert 6e-4 <= eta <= 0.02, (f0, t60, eta)
    # ... and within a factor 3 of the recorded glass object's Rayleigh fit there (Ren et al.)
    w = 2 * math.pi * f0
    ren_t60 = 3 * math.log(10) / ((18.3 + 1.434e-7 * w ** 2) / 2)
    assert ren_t60 / 3 <= t60 <= 3 * ren_t60, (f0, t60, ren_t60)


def test_steel_bowl_rings_like_a_supported_metal_bowl(world, renderer):
    # a stainless kitchen bowl, 20 cm across, 0.8 mm sheet (not in the catalogue: a bowl
    # variant in the catalogue's steel)
    cat = world.categories["bowl"]
    v = Variant("steel_mixing", "bowl", {"diameter_m": 0.20, "height_m": 0.08,
                                         "foot_diameter_m": 0.09, "wall_m": 0.0008,
                                         "bottom_m": 0.0008}, None, None, "procedural",
                {"metal": 1.0})
    cat = Category(cat.id, cat.description, cat.role, cat.scale, (v,), cat.file)
    bowl = ObjectInstance("bowl", "steel_mixing", world.materials.object("metal"), 1.0,
                          build_geometry(cat, v))
    f0, t60, eta = _lowest_sounding(renderer, bowl)
    assert 100 < f0 < 2000, f0
    # freely resting bronze bowls: eta >= 4e-5 (Inacio et al.); a supported one up to ten
    # times their highest, 3e-3 and more; installed steel 0.01 (Bies et al.)
    assert 4e-5 <= eta <= 0.01, (f0, t60, eta)
    # a steel bowl rings for seconds, not tenths of a second
    assert t60 > 0.3, t60
