"""Struck objects ring as long as measured ones do: the decay of a wine glass's and a steel
bowl's lowest sounding mode, measured in the rendered sound, against published damping.

Published values (loss factor eta = 2 zeta = 1 / Q; T60 = 3 ln(10) / (pi f eta) ~ 2.2 / (f eta)):

- glass: material loss factor 6e-4, 0.02 as installed (Bies, Hansen & Howard, Engineering Noise
  Control, 5th ed. 2017, table C.1); flexural loss factor of glass 0.003-0.006 (Hopkins, Sound
  Insulation, 2007, table A2); a recorded glass object fitted with Rayleigh damping
  alpha = 18.3 1/s, beta = 1.434e-7 s (Ren, Yeh & Lin, "Example-guided physically based modal
  sound synthesis", ACM TOG 32(1), 2013, table 1): eta(f) = alpha / w + beta w, 0.0068 at
  452 Hz, 0.0045 at 700 Hz. A wine glass's lowest mode, the (2,0) bell mode, lies at
  ~400-1000 Hz (e.g. 529 Hz for the glass of Harvard's lecture demonstration "Wineglass normal
  modes"; French, "In vino veritas", Am. J. Phys. 51, 1983).
- metal bowls: bronze singing bowls resting freely have modal damping ratios zeta =
  0.002-0.015 % (eta 4e-5 to 3e-4), "one order of magnitude, or more" higher as supported or
  handled (Inacio, Henrique & Antunes, "The dynamics of Tibetan singing bowls", Acta Acustica
  united with Acustica 92, 2006): eta >= 3e-3 for the most damped; steel as installed 0.01,
  material 1e-4 (Bies et al., table C.1).

Each measured loss factor is held within a factor 2 of the source values that describe such an
object (Hopkins' glass; a handled bowl, installed steel), and the material's own (lowest) value
is rejected by the same check. Ren et al.'s recorded glass object is not such a source for a
wine glass's (2,0) mode (see the expected failure below): a resting glass's (2,0) mode loses
what the glass itself loses. Its cos(2 theta) motion puts no net force or moment on the stem of
an axisymmetric glass (the stem moves in orders 0 and 1 only), so the foot and the table take
next to nothing; it radiates as a quadrupole at ka ~ 0.35 (a sphere's n = 2 efficiency
(ka)^6 / 81 ~ 2e-5: eta_rad ~ 1e-6 for the 1.4 mm wall, 3.5 kg/m^2, at 452 Hz). Ren et al.'s
alpha, a decay rate of 9.2 1/s at every frequency (T60 0.75 s), is their recording's support
or handling loss, which a wine glass standing on its foot does not have.

The decay is measured as the slope of the mode's amplitude (a Hann-windowed single-frequency
transform, 0.1 s frames) over its first 20 dB: the renderer drops a mode 80 dB below the body's
loudest peak, and the glass's (2,0) mode starts 38 dB below its loudest partial, so after
~40 dB of decay the band holds the other modes' truncation; Schroeder's integral of the band-passed signal over -5..-25 dB, used
here before, read those in and gave T60 2.1 s (eta 0.0023) for a mode that decays with 1.65 s
(eta 0.0030, the material's loss factor).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fallgen.audio.fall import AudioSettings, FallRenderer
from fallgen.audio.impact import ModalHit, render
from fallgen.world.objects import Category, ObjectInstance, Variant, build_geometry

FS = 44100
LENGTH_S = 4.0
#: Ren, Yeh & Lin (2013), table 1: Rayleigh damping of their recorded glass object
REN_GLASS_ALPHA, REN_GLASS_BETA = 18.3, 1.434e-7
#: Hopkins (2007), table A2: flexural loss factor of glass
HOPKINS_GLASS = (0.003, 0.006)
#: Bies, Hansen & Howard (2017), table C.1: steel as installed; glass and steel materials
BIES_STEEL_INSTALLED, BIES_GLASS_MATERIAL, BIES_STEEL_MATERIAL = 0.01, 6e-4, 1e-4
#: Inacio et al. (2006): freely resting bowls up to zeta 0.015 %, ten times that and more when
#: supported or handled
INACIO_HANDLED = 10 * 2 * 0.00015
#: how far a rendered loss factor may lie from a source's value (the sources' own spread:
#: Hopkins' range is 2x wide, Ren's fit is one recorded object)
FACTOR = 2.0


@pytest.fixture(scope="module")
def renderer(world, tmp_path_factory):
    # the build's modal settings (the frequencies depend on the mesh resolution)
    return FallRenderer(world, AudioSettings(length_s=LENGTH_S,
                                             cache_dir=tmp_path_factory.mktemp("modes")))


def _sounding(renderer, inst: ObjectInstance):
    return renderer._object_body(inst, np.zeros(3), np.eye(3)).sounding


def _mode_decay(p: np.ndarray, f0: float, span_db: float = 20.0) -> float:
    """T60 (s) of the partial at ``f0`` in ``p``: the amplitude of Hann-windowed frames'
    transform at f0 (frames a quarter apart), fitted from its first frame after the hit until
    it first falls ``span_db`` below it; 0.1 s frames (10 Hz apart from a neighbour is
    resolved), shorter ones for a decay too fast to give them 6 frames."""
    t0 = int(np.flatnonzero(p)[0])
    for frame_s in (0.1, 0.05, 0.025, 0.0125):
        n = int(frame_s * FS)
        ker = np.hanning(n) * np.exp(-2j * math.pi * f0 * np.arange(n) / FS)
        starts = np.arange(t0, len(p) - n, n // 4)
        amp = np.abs(np.array([np.dot(p[s:s + n], ker) for s in starts]))
        db = 20 * np.log10(np.maximum(amp, 1e-300))
        k0 = int(np.argmax(db[:8]))  # the loudest of the first frames after the onset
        below = np.flatnonzero(db[k0:] < db[k0] - span_db)
        k = np.arange(k0, k0 + (int(below[0]) if len(below) else len(db) - k0))
        if len(k) >= 6:
            slope = np.polyfit((starts[k] + n / 2) / FS, db[k], 1)[0]
            return -60.0 / slope
    raise AssertionError(f"no decay measured at {f0:.0f} Hz")


def _lowest_sounding(body) -> tuple[float, float, float]:
    """(f, T60, eta) of the lowest mode the rim hit makes audible (within 40 dB of the
    loudest partial), measured in the rendered sound."""
    m = body.modes
    rim = int(np.argmax(m.points[:, 2]))  # the highest surface node: the rim, hit on its normal
    p = render(body, [ModalHit(0.01, m.points[rim], 0.02 * body.mass_kg, 2e-4)], LENGTH_S, FS,
               volume_m3=None)
    spec = np.abs(np.fft.rfft(p))
    f = np.fft.rfftfreq(len(p), 1 / FS)
    band = (f > 100) & (f < 8000)
    loud = spec[band].max()
    modes = m.omega / (2 * math.pi)
    f0 = next(fm for fm in modes if fm > 100 and
              spec[int(round(fm * len(p) / FS))] > loud * 10 ** (-40 / 20))
    t60 = _mode_decay(p, f0)
    return f0, t60, 3 * math.log(10) / (math.pi * f0 * t60)


def _within(eta: float, ref: float, factor: float = FACTOR) -> bool:
    return ref / factor <= eta <= ref * factor


def ren_glass_eta(f_hz: float) -> float:
    """The recorded glass object's loss factor at ``f_hz`` (Rayleigh damping: 2 zeta =
    alpha / w + beta w)."""
    w = 2 * math.pi * f_hz
    return REN_GLASS_ALPHA / w + REN_GLASS_BETA * w


def _check_glass_like_hopkins(eta: float) -> None:
    lo, hi = HOPKINS_GLASS
    assert lo / FACTOR <= eta <= hi * FACTOR, eta


def _check_handled_steel(eta: float) -> None:
    """Within 2x of installed steel (Bies) and at least a handled bowl's (Inacio)."""
    assert _within(eta, BIES_STEEL_INSTALLED), eta
    assert eta >= INACIO_HANDLED / FACTOR, eta


@pytest.fixture(scope="module")
def glass(world, renderer):
    inst = world.categories.instance("wineglass", "red_wine", "glass")
    body = _sounding(renderer, inst)
    return body, _lowest_sounding(body)


def test_the_decay_is_measured_right(world, glass):
    """The measurement itself: a mode rendered with loss factor eta decays with
    T60 = 3 ln 10 / (pi f eta) (a damped sinusoid), so it reads back the loss factor the glass
    was rendered with, within 5 %; and twice the loss factor reads twice."""
    body, (f0, t60, eta) = glass
    assert eta == pytest.approx(body.loss_factor, rel=0.05), (f0, t60, eta)
    damp = dataclasses.replace(body, loss_factor=2 * body.loss_factor)
    assert _lowest_sounding(damp)[2] == pytest.approx(2 * body.loss_factor, rel=0.05)


def test_wine_glass_rings_like_glass(world, glass):
    body, (f0, t60, eta) = glass
    assert 350 < f0 < 1000, f0  # the (2,0) bell mode of a red wine glass
    # above the material's own loss (Bies: 6e-4), within 2x of Hopkins' glass ...
    assert eta > BIES_GLASS_MATERIAL * FACTOR, eta
    _check_glass_like_hopkins(eta)
    # ... and the check rejects the material's own loss factor and an installed pane's
    for wrong in (BIES_GLASS_MATERIAL / 2, 0.02 * 2):
        with pytest.raises(AssertionError):
            _check_glass_like_hopkins(_lowest_sounding(
                dataclasses.replace(body, loss_factor=wrong))[2])


@pytest.mark.xfail(strict=True, reason=(
    "the glass's (2,0) mode (452 Hz) decays with eta 0.0030 (T60 1.65 s), the glass's own "
    "loss factor (Hopkins 0.003-0.006), as a resting glass's (2,0) mode does: no net force "
    "on its stem, a quadrupole's radiation (eta_rad ~1e-6). Ren et al.'s recorded glass "
    "object has 0.0068 there (T60 0.71 s), 2.3x more, mostly its alpha term (a decay rate "
    "of 9.2 1/s at every frequency: that recording's support or handling), outside a "
    "factor 2"))
def test_wine_glass_decays_like_the_recorded_glass(world, glass):
    _, (f0, t60, eta) = glass
    ref = ren_glass_eta(f0)
    assert _within(eta, ref), (f0, t60, eta, ref)


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
    body = _sounding(renderer, bowl)
    f0, t60, eta = _lowest_sounding(body)
    assert 100 < f0 < 2000, f0
    assert eta == pytest.approx(body.loss_factor, rel=0.05), (f0, t60, eta)
    _check_handled_steel(eta)
    # a steel bowl rings for tenths of a second at least: 2.2 / (f eta) of installed steel
    assert t60 > 0.5 * 3 * math.log(10) / (math.pi * f0 * BIES_STEEL_INSTALLED), t60
    # the check rejects the bowl ringing with steel's own loss factor (a freely hung bowl) and
    # with three times installed steel's
    for wrong in (BIES_STEEL_MATERIAL, 3 * BIES_STEEL_INSTALLED):
        with pytest.raises(AssertionError):
            _check_handled_steel(_lowest_sounding(dataclasses.replace(body,
                                                                      loss_factor=wrong))[2])
