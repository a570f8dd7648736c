"""Furniture in the sound's way (audio.occlusion): a path that crosses a part bends around its
nearest edge and loses Maekawa's screen attenuation per octave band; what a listener hears of
a source under a table."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fallgen.audio.furnished import Furnishing
from fallgen.audio.occlusion import crossings, leg_attenuation_db, maekawa_db
from fallgen.audio.room import RoomAcoustics, arrivals
from fallgen.world.materials import OCTAVE_BANDS_HZ

BANDS = np.asarray(OCTAVE_BANDS_HZ)


def _parts(*boxes):
    """Furnishing of axis-aligned boxes given as (centre, half) pairs, rotated by ``yaw``."""
    n = len(boxes)
    c = np.array([b[0] for b in boxes], float)
    h = np.array([b[1] for b in boxes], float)
    yaw = np.array([b[2] if len(b) > 2 else 0.0 for b in boxes], float)
    return Furnishing(tuple(f"p{i}" for i in range(n)), c, h, yaw, np.full((n, 7), 0.1),
                      np.full(n, 0.1), np.ones(n), np.ones((n, 3)), np.zeros(6))


def test_screen_attenuation_is_maekawas():
    """A 1 m high, 2 m wide, 2 cm thin screen between a source and a listener 0.3 m above the
    floor, 1 m either side (in a 4 x 4 x 2.5 m room: not under it, through the floor): the
    path bends over the top edge, delta = 2 sqrt(1 + 0.7^2) - 2,
    and each octave band loses Maekawa's 10 log10(3 + 20 N) (his chart's usual
    approximation, independent of the Kurze-Anderson fit the model uses) within 3 dB; turned
    by 30 degrees about the vertical the screen gives the same (its top edge is as far)."""
    delta = 2 * math.sqrt(1 + 0.7 ** 2) - 2
    want = 10 * np.log10(3 + 20 * 2 * delta * BANDS / 343.0)
    a, b = np.array([[0.5, 2.0, 0.3]]), np.array([[2.5, 2.0, 0.3]])
    for yaw in (0.0, math.radians(30)):
        screen = _parts(((1.5, 2.0, 0.5), (0.01, 1.0, 0.5), yaw))
        got = leg_attenuation_db(a, b, screen, BANDS, size_m=(4.0, 4.0, 2.5))[0]
        np.testing.assert_allclose(got, np.minimum(want, 24), atol=3.0, err_msg=str(yaw))
    assert maekawa_db(np.array([0.0]))[0] == pytest.approx(5.0, abs=0.1)  # grazing


def test_unblocked_paths_are_untouched():
    screen = _parts(((1.0, 0.0, 0.5), (0.01, 1.0, 0.5)))
    a = np.array([[0.0, 0.0, 1.5], [0.0, 2.0, 0.3], [0.0, 0.0, 0.3]])
    b = np.array([[2.0, 0.0, 1.5], [2.0, 2.0, 0.3], [0.9, 0.0, 0.3]])
    assert not crossings(a, b, screen).any()  # over it, beside it, short of it
    assert not leg_attenuation_db(a, b, screen, BANDS).any()


def _table_room():
    """A 5 x 4 x 2.6 m room of plaster-like walls with a 1.6 x 0.9 m table top (4 cm thick,
    its top 0.75 m above the floor) at (2, 2)."""
    top = _parts(((2.0, 2.0, 0.73), (0.8, 0.45, 0.02)))
    return RoomAcoustics((5.0, 4.0, 2.6), np.full((6, 7), 0.05), furniture=top)


def test_a_source_under_a_table_is_quieter_and_duller():
    """Under the table the direct sound and the early reflections that cross the top lose
    energy, the more the higher the band: heard from 1.6 m up, 1 m away, the direct and
    first-order arrivals of a source 5 cm above the floor under the table carry less energy
    in every band than beside it (here 4-7 dB: reflections off the far walls pass under the
    table's edges), and the 4 kHz band loses more than the 250 Hz one."""
    room = _table_room()
    lis = np.array([3.0, 2.0, 1.6])
    under, beside = np.array([2.0, 2.0, 0.05]), np.array([2.0, 3.4, 0.05])

    def early(src):
        arr = arrivals(room, src, lis, 1)
        return (arr.amplitude ** 2).sum(0)

    e_under, e_beside = early(under), early(beside)
    # the same source without the table: the geometry alone (distances) barely differs
    bare = RoomAcoustics(room.size_m, room.absorption)
    geo = (arrivals(bare, under, lis, 1).amplitude ** 2).sum(0) / \
        (arrivals(bare, beside, lis, 1).amplitude ** 2).sum(0)
    loss_db = 10 * np.log10(e_beside * geo / e_under)
    assert np.all(loss_db > 1.0), loss_db
    b250, b4k = list(OCTAVE_BANDS_HZ).index(250.0), list(OCTAVE_BANDS_HZ).index(4000.0)
    assert loss_db[b4k] > loss_db[b250] + 1.5, loss_db
    # its direct sound alone: Maekawa's 10 log10(3 + 20 N) over the table's near edge (the
    # path under the top's x = 2.8 m edge, 4 cm up its thickness and on to the listener),
    # within 2 dB in every band
    direct = arrivals(room, under, lis, 0).amplitude[0]
    free = arrivals(bare, under, lis, 0).amplitude[0]
    att = -20 * np.log10(direct / free)
    bottom, top = np.array([2.8, 2.0, 0.71]), np.array([2.8, 2.0, 0.75])
    delta = np.linalg.norm(bottom - under) + 0.04 + np.linalg.norm(lis - top) \
        - np.linalg.norm(lis - under)
    want = 10 * np.log10(3 + 20 * 2 * delta * BANDS / 343.0)
    np.testing.assert_allclose(att, want, atol=2.0)
    with pytest.raises(AssertionError):  # a screen that blocks 5 dB whatever the band
        np.testing.assert_allclose(np.full_like(att, 5.0), want, atol=2.0)
