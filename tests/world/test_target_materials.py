"""The targets come in all 14 of the paper's audio materials (leather and paper included), each
a real share of the draws."""

from __future__ import annotations

from collections import defaultdict

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
                inst = c.instance(cid, v.name, m)
                assert 1e-4 < inst.mass_kg < 3.0, (cid, v.name, m, inst.mass_kg)
    assert set(share) == set(AUDIO_MATERIALS)
    # each at least ~0.8 % of the draws (a paper-size build: ~60+ episodes of each)
    assert min(share.values()) > 0.008, dict(share)
