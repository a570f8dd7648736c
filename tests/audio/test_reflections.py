"""First reflections off furniture faces (audio.reflections): where a table top is a mirror,
how much of each band it returns, and the pressure doubling of a source resting on it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallgen.audio.furnished import Furnishing
from fallgen.audio.reflections import furniture_images
from fallgen.audio.room import RoomAcoustics, arrivals
from fallgen.world.materials import OCTAVE_BANDS_HZ

BANDS = np.asarray(OCTAVE_BANDS_HZ)
SIZE = (6.0, 5.0, 2.8)
ALPHA = 0.06


def _table(w=2.0, d=1.0):
    """A w x d table top (4 cm thick, 0.75 m up) at (3, 2.5), absorbing ALPHA."""
    return Furnishing(("table/top",), np.array([[3.0, 2.5, 0.73]]),
                      np.array([[w / 2, d / 2, 0.02]]), np.zeros(1), np.full((1, 7), ALPHA),
                      np.full(1, 0.1), np.ones(1), np.ones((1, 3)), np.zeros(6))


def test_a_table_top_is_a_mirror_above_its_fresnel_limit():
    """A source 0.5 m above the top, the listener 0.5 m above it 1 m along: the image is the
    source mirrored in the top's plane, heard at its distance; the high bands keep
    sqrt(1 - alpha); below Rindel's f_g (243 Hz along the top's 1 m side here, 61 Hz along
    its 2 m side) the reflection keeps f / f_g of its energy per side, 3 dB per octave
    (Rindel, Applied Acoustics 19, 1986, as Odeon and Arup's Strutt apply it: Delta L =
    10 lg(K_a K_b)); a listener under the top hears no reflection off it."""
    f = _table()
    s, lis = np.array([2.5, 2.5, 1.25]), np.array([3.5, 2.5, 1.25])
    pos, g = furniture_images(s, lis, f, SIZE, BANDS)
    assert len(pos) == 1
    np.testing.assert_allclose(pos[0], [2.5, 2.5, 0.25], atol=1e-9)
    np.testing.assert_allclose(g[0, -3:], math.sqrt(1 - ALPHA), rtol=1e-9)
    d1 = d2 = math.hypot(0.5, 0.5)
    cos_t = 0.5 / d2
    fg = [343.0 * d1 / (2 * (w * cos_t) ** 2) for w in (2.0, 1.0)]  # a* = d1 (d1 = d2)
    k_a, k_b = np.minimum(1, BANDS / fg[0]), np.minimum(1, BANDS / fg[1])
    np.testing.assert_allclose(g[0] ** 2, (1 - ALPHA) * k_a * k_b, rtol=1e-9)
    # 125 Hz: 10 lg(125 / 243) = -2.9 dB (an amplitude law f / f_g would give -5.8)
    assert 20 * math.log10(g[0, 0] / g[0, -1]) == pytest.approx(-2.89, abs=0.02)
    below = np.array([3.5, 2.5, 0.4])
    assert len(furniture_images(s, below, f, SIZE, BANDS)[0]) == 0
    # the reflection point off the top's edge: no mirror there
    assert len(furniture_images(s, np.array([5.8, 2.5, 1.25]), f, SIZE, BANDS)[0]) == 0


def test_a_source_on_the_table_is_doubled():
    """An object resting on the top radiates into the half space above it: its image in the
    top coincides with it, so at a listener above the table the direct sound and the top's
    reflection arrive together and the high bands' pressure is ~doubled (+6 dB), as a
    source on the floor is by the floor's image."""
    room = RoomAcoustics(SIZE, np.full((6, 7), 0.05), furniture=_table())
    bare = RoomAcoustics(SIZE, np.full((6, 7), 0.05))
    on_top, lis = np.array([3.0, 2.5, 0.75]), np.array([4.5, 2.5, 1.5])
    a = arrivals(room, on_top, lis, 0)
    b = arrivals(bare, on_top, lis, 0)
    first = a.delay_s < b.delay_s[0] + 1e-4
    assert first.sum() == 2  # the direct sound and the top's image, at the same instant
    assert np.ptp(a.delay_s[first]) < 1e-9
    gain_db = 20 * np.log10(a.amplitude[first].sum(0) / b.amplitude[0])
    want = 20 * math.log10(1 + math.sqrt(1 - ALPHA))  # no finite-size loss at the source
    np.testing.assert_allclose(gain_db, want, atol=0.01)
