"""Audio test helpers: fall events recorded like the rehearsal records them."""

from __future__ import annotations

import numpy as np
import pytest

from fallgen.physics.drop import record_drop
from fallgen.physics.events import FallEvent, ObjectSpec

VARIANT = "study_loft-l1-m1"


def _drop_event(world, category, variant, material, height, steps=900, zone_kind="floor",
                distractors=()) -> FallEvent:
    """A fall event recorded like the rehearsal does (physics-only scene, contact recorder):
    dropped from ``height`` above the floor over the centre of the variant's largest zone of
    ``zone_kind``, with static ``distractors`` (Placements) in the room."""
    v = world.variant(VARIANT)
    z = max((z for z in v.zones if z.kind == zone_kind),
            key=lambda z: z.volume.half[0] * z.volume.half[1])
    pos = (float(z.volume.center[0]), float(z.volume.center[1]), height)
    quat = np.asarray((0.96, 0.2, 0.1, 0.15))
    return record_drop(world, VARIANT, z, ObjectSpec(category, variant, material, 1.0), pos,
                       quat / np.linalg.norm(quat), steps, tuple(distractors), "test")


@pytest.fixture(scope="session")
def drop_event():
    """``drop_event(world, category, variant, material, height, steps=900)`` -> FallEvent."""
    return _drop_event
