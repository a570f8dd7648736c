"""Procedural textures (vision.textures): deterministic from their spec, tileable, at their
physical scale, and refused with a named field when their parameters are bad."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from fallgen.vision.textures import MEAN_LEVEL, detail_share, render_texture, texture_file
from fallgen.world.appearance import KINDS, TextureSpec


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_deterministic_and_seeded(kind):
    a = render_texture(TextureSpec.make(kind, seed=3))
    b = render_texture(TextureSpec.make(kind, seed=3))
    c = render_texture(TextureSpec.make(kind, seed=4))
    assert a.shape == (256, 256, 3) and a.dtype == np.uint8
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    if kind != "print":  # a picture is in colour, at its own brightness
        # a luminance pattern around the mean level: the surface's colour sets the hue
        assert abs(a.mean() / 255 - MEAN_LEVEL) < 0.08, a.mean() / 255
    # every kind has detail: none is a flat colour (a cabinet's doors, a window's panes and a
    # cooker's top are flat between their gaps, handles, bars and burners)
    assert detail_share(a) > (0.15 if kind in ("doors", "window", "hob") else 0.3)


@pytest.mark.parametrize("kind", ["plaster", "concrete", "carpet", "stone", "metal", "veneer"])
def test_tiles_without_a_seam(kind):
    """Repeated, the image shows no edge where it wraps: the jump across the wrap is no larger
    than between neighbouring columns (rows) inside it."""
    img = render_texture(TextureSpec.make(kind)).astype(float)
    inner_x = np.abs(np.diff(img, axis=1)).mean()
    inner_y = np.abs(np.diff(img, axis=0)).mean()
    assert np.abs(img[:, 0] - img[:, -1]).mean() < 1.5 * inner_x + 0.5
    assert np.abs(img[0] - img[-1]).mean() < 1.5 * inner_y + 0.5


def _dark_lines(profile: np.ndarray, depth: float = 10.0) -> np.ndarray:
    """Indices (wrapping) where the profile dips at least ``depth`` grey levels below the
    mean of the 3 values either side of it."""
    around = np.mean([np.roll(profile, k) for k in (-4, -3, -2, 2, 3, 4)], axis=0)
    return np.flatnonzero(profile < around - depth)


def test_boards_and_tiles_at_their_real_size():
    """A planks texture of 14 cm boards spanning 1.12 m shows 8 boards (seams every 32 of 256
    pixels); 30 cm tiles over 1.2 m show a grout line every 64 pixels."""
    img = render_texture(TextureSpec.make("planks", 1.12, board_width_m=0.14, grain=0.0))
    seams = _dark_lines(img.mean(axis=(0, 2)).astype(float), depth=40.0)
    assert np.array_equal(seams, np.arange(8) * 32), seams
    tiles = render_texture(TextureSpec.make("tiles", 1.2, tile_m=0.3, grout_m=0.006))
    rows = _dark_lines(tiles.mean(axis=(1, 2)).astype(float))
    assert len(rows) and np.all(np.minimum(rows % 64, 64 - rows % 64) <= 1), rows
    assert set(np.round(rows / 64).astype(int) % 4) == {0, 1, 2, 3}, rows


def test_bad_parameter_values():
    for kind, kw, field in [("linocut", {}, "kind"),
                            ("planks", {"board_width_m": 2.0}, "board_width_m"),
                            ("tiles", {"spacing": 0.1}, "spacing"),
                            ("carpet", {"pile": "thick"}, "pile"),
                            ("plaster", {"size_m": 50.0}, "size_m"),
                            ("plaster", {"seed": -1}, "seed")]:
        with pytest.raises(ValueError) as e:
            TextureSpec.make(kind, **kw)
        assert str(e.value).startswith(field), str(e.value)


def test_cached_png(tmp_path):
    spec = TextureSpec.make("tiles", seed=1)
    p = texture_file(spec, tmp_path)
    mtime = p.stat().st_mtime_ns
    assert texture_file(spec, tmp_path) == p and p.stat().st_mtime_ns == mtime  # made once
    back = cv2.cvtColor(cv2.imread(str(p)), cv2.COLOR_BGR2RGB)
    assert np.array_equal(back, render_texture(spec))  # lossless
    assert texture_file(TextureSpec.make("tiles", seed=2), tmp_path) != p


def test_detail_share():
    flat = np.full((64, 64, 3), 128, np.uint8)
    assert detail_share(flat) == 0.0
    noisy = np.random.default_rng(0).integers(0, 255, (64, 64, 3)).astype(np.uint8)
    assert detail_share(noisy) > 0.95
