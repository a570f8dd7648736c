"""Audio test helpers: fall events recorded like the rehearsal records them."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from fallgen.physics.contacts import ContactRecorder
from fallgen.physics.drop import PHYSICS
from fallgen.physics.events import FallEvent, ObjectSpec
from fallgen.world.scene import PlacedObject, build_scene

VARIANT = "study_loft-l1-m1"


def _drop_event(world, category, variant, material, height, steps=900, zone_kind="floor",
                distractors=()) -> FallEvent:
    """A fall event recorded like the rehearsal does (physics-only scene, contact recorder):
    dropped from ``height`` above the floor over the centre of the variant's largest zone of
    ``zone_kind``, with static ``distractors`` (Placements) in the room."""
    v = world.variant(VARIANT)
    z = max((z for z in v.zones if z.kind == zone_kind),
            key=lambda z: z.volume.half[0] * z.volume.half[1])
    inst = world.categories.instance(category, variant, material, 1.0)
    pos = (float(z.volume.center[0]), float(z.volume.center[1]), height)
    quat = (0.96, 0.2, 0.1, 0.15)
    quat = tuple(float(q) for q in np.asarray(quat) / np.linalg.norm(quat))
    statics = [PlacedObject(f"d{k}", world.categories.instance(p.object.category,
                                                                 p.object.variant,
                                                                 p.object.material,
                                                                 p.object.scale),
                            p.pos, p.quat, free=False) for k, p in enumerate(distractors)]
    scene = build_scene(v, world.materials, [PlacedObject("target", inst, pos, quat)] + statics,
                        settings=PHYSICS)
    m, d = scene.model, scene.data()
    mujoco.mj_forward(m, d)
    rec = ContactRecorder(m, scene.object_body["target"], scene.geom_owner, scene.geom_material)
    rec.step(d, steps)
    return FallEvent(
        event_id="test", room_variant=VARIANT, room_kind=v.kind, zone=z.id, zone_kind=z.kind,
        trial=0, root_seed=0, target=ObjectSpec(category, variant, material, 1.0),
        audio_material=inst.material.audio, mass_kg=inst.mass_kg, start_pos=pos,
        start_quat=quat, start_linvel=(0.0, 0.0, 0.0), start_angvel=(0.0, 0.0, 0.0),
        settle_pos=tuple(map(float, d.qpos[:3])), settle_quat=tuple(map(float, d.qpos[3:7])),
        settle_com=tuple(map(float, d.xipos[scene.object_body["target"]])),
        settle_time_s=steps * m.opt.timestep,
        steps=steps, distractors=tuple(distractors), occluders=(),
        contacts=tuple(rec.finish()))


@pytest.fixture(scope="session")
def drop_event():
    """``drop_event(world, category, variant, material, height, steps=900)`` -> FallEvent."""
    return _drop_event
