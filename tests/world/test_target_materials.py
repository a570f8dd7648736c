"""The targets come in all 14 of the paper's audio materials (leather and paper included), each
a real share of the draws."""

from __future__ import annotations

import math
from collections import Counter, defaultdict

import numpy as np
import pytest
import trimesh

from fallgen.world.materials import AUDIO_MATERIALS


def test_every_audio_material_is_a_targets(world):
    c = world.categories
    share: dict[str, float] = defaultdict(float)
    targets = c.ids("target")
    for cid in targets:
        cat = c.categories[cid]
        for v in cat.variants:
            total = sum(v.materials.values())
            for m, w in v.materials.items():
                # a category, then a variant, then a material by weight (ObjectLibrary.sample)
                share[world.materials.object(m).audio] += w / total / len(cat.variants) \
                    / len(targets)
                # an instance weighs its mesh's volume times its material's density
                inst = c.instance(cid, v.name, m)
                mesh = trimesh.Trimesh(inst.geometry.vertices, inst.geometry.faces,
                                       process=False)
                assert inst.mass_kg == pytest.approx(
                    mesh.volume * world.materials.object(m).density_kg_m3, rel=1e-9), (cid, m)
    assert set(share) == set(AUDIO_MATERIALS)
    # each at least ~0.8 % of the draws (a paper-size build: ~60+ episodes of each)
    assert min(share.values()) > 0.008, dict(share)
    # the shares are those of the sampler's own draws (20000 of them: within 5 standard
    # errors, ~0.35 % for a 1 % share)
    rng = np.random.default_rng(11)
    n = 20000
    drawn = Counter(c.sample(rng, targets[int(rng.integers(len(targets)))]).material.audio
                    for _ in range(n))
    for audio, p in share.items():
        assert drawn[audio] / n == pytest.approx(p, abs=5 * math.sqrt(p * (1 - p) / n)), audio
