"""Appearance randomisation: the same room drawn with other textures, colours and light.

For studying visual generalisation, an episode's views may be drawn with a look of
their own: every texture redrawn from another seed (other boards, tiles, stains, pictures), every
surface finish and every furniture piece's colours shifted in lightness and hue, and the ceiling
lights brighter or dimmer, warmer or cooler. Everything is drawn from one seed
(:func:`fallgen.pipeline.episode.appearance_seed`: the episode's own, so the episode and the
environment that replays it draw the same look), lazily in the order the scene is built (which
is fixed), and what the look changes is only how surfaces are drawn: geometry, segmentation,
depth, physics and sound are the room's own.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Hashable, Sequence

import numpy as np

from fallgen.world.appearance import TextureSpec

#: Spread of a colour's lightness (log-normal: a factor of exp(N(0, sigma)))...
LIGHTNESS_SIGMA = 0.15
#: ... and of each channel against the others (its hue).
HUE_SIGMA = 0.06
#: How much brighter or dimmer the lights are (a uniform factor in this range)...
LIGHT_GAIN = (0.75, 1.25)
#: ... and how much warmer or cooler (red up and blue down by up to this share, or the reverse).
LIGHT_TINT = 0.08


class LookDraw:
    """One look, drawn from ``seed``: the same key always gets the same draw."""

    def __init__(self, seed: int) -> None:
        self._rng = np.random.default_rng(np.random.SeedSequence(int(seed)))
        self.light_gain = float(self._rng.uniform(*LIGHT_GAIN))
        t = float(self._rng.uniform(-LIGHT_TINT, LIGHT_TINT))
        self.light_tint = (1.0 + t, 1.0, 1.0 - t)
        self._seeds: dict[str, int] = {}
        self._colours: dict[Hashable, np.ndarray] = {}

    def texture(self, texture: TextureSpec) -> TextureSpec:
        """``texture`` with a seed of this look's (the same one wherever it is used)."""
        key = texture.key()
        if key not in self._seeds:
            self._seeds[key] = int(self._rng.integers(0, 2 ** 31))
        return dataclasses.replace(texture, seed=self._seeds[key])

    def colour(self, key: Hashable, rgba: Sequence[float]) -> list[float]:
        """``rgba`` shifted in lightness and hue by the draw of ``key`` (a surface finish, a
        furniture piece's role), its alpha kept."""
        if key not in self._colours:
            self._colours[key] = math.exp(self._rng.normal(0.0, LIGHTNESS_SIGMA)) \
                * np.exp(self._rng.normal(0.0, HUE_SIGMA, 3))
        c = np.clip(np.asarray(rgba[:3], float) * self._colours[key], 0.02, 1.0)
        return [*map(float, c), float(rgba[3])]

    def light(self, diffuse: Sequence[float]) -> list[float]:
        """A light's diffuse colour in this look."""
        return [float(min(1.0, d * self.light_gain * t)) for d, t in zip(diffuse, self.light_tint)]
