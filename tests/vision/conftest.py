"""The vision tests' scenes: an object placed in a fall zone of a room variant, with the faces
that can hide it."""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import pytest


@pytest.fixture(scope="session")
def zone_scene(world):
    """``make(variant, zone, target, lift=0.03, beside=())``: the textured scene of
    ``variant`` with the ``target`` instance at rest ``lift`` m above the centre of ``zone``'s
    floor and each (name, instance, offset) of ``beside`` at the target's position plus its
    offset; as ``scene``, ``data`` (forwarded), ``pos`` (the target's), ``points`` (whose hull
    holds the target) and ``faces`` (every drawn geom's but the target's)."""
    from fallgen.pipeline.settled import target_points
    from fallgen.vision.faces import SceneFaces
    from fallgen.world.scene import LOOK, PlacedObject, build_scene

    def make(variant, zone, target, lift: float = 0.03, beside=()) -> SimpleNamespace:
        c = zone.volume.center
        pos = (float(c[0]), float(c[1]), float(zone.volume.zmin) + lift)
        objs = [PlacedObject("target", target, pos, free=False)]
        objs += [PlacedObject(name, inst, tuple(p + o for p, o in zip(pos, offset)), free=False)
                 for name, inst, offset in beside]
        scene = build_scene(variant, world.materials, objs, settings=LOOK)
        data = scene.data()
        mujoco.mj_forward(scene.model, data)
        faces = SceneFaces(scene.model, data, [g for g in range(scene.model.ngeom)
                                               if scene.geom_owner[g] != "obj:target"])
        return SimpleNamespace(scene=scene, data=data, pos=pos,
                               points=target_points(scene, data), faces=faces)

    return make
