"""The compiled settle loop (fallgen.physics.settle_kernel) against the Python loop of
fallgen.physics.settle: a recorded fall settles, gives up or runs out its replay at the same
step, with the same result and the same contact events, whichever loop runs it."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from fallgen.physics.contacts import ContactRecorder
from fallgen.physics.drop import PHYSICS, _below_for_good
from fallgen.physics.settle import SettleCriteria, simulate_until_settled
from fallgen.world.scene import PlacedObject, build_scene

ROOM = "kitchen_galley-l1-m1"


def _fall(world, pos, linvel=(0.0, 0.0, 0.0), angvel=(0.0, 0.0, 0.0), obj=("cup", "mug",
                                                                          "ceramic")):
    inst = world.categories.instance(*obj)
    quat = (0.9238795, 0.3826834, 0.0, 0.0)  # tipped 45 degrees: it bounces and rolls
    scene = build_scene(world.variant(ROOM), world.materials,
                        [PlacedObject("target", inst, tuple(pos), quat)], settings=PHYSICS)
    m, b = scene.model, scene.object_body["target"]
    return scene, m, b, linvel, angvel


def _run(scene, m, b, linvel, angvel, compiled: bool, floor_z: float | None,
         max_steps: int | None = None, criteria: SettleCriteria = SettleCriteria()):
    d = scene.data()
    vadr = m.jnt_dofadr[m.body_jntadr[b]]
    d.qvel[vadr:vadr + 3], d.qvel[vadr + 3:vadr + 6] = linvel, angvel
    mujoco.mj_forward(m, d)
    rec = ContactRecorder(m, b, scene.geom_owner, scene.geom_material)
    bound = None if floor_z is None else _below_for_good(m, b, floor_z)
    if compiled:
        give_up = bound
    else:  # any other callable takes the Python loop; the same verdicts
        give_up = (lambda dd: False) if bound is None else (lambda dd: bound(dd))
    res = simulate_until_settled(m, d, b, criteria, recorder=rec, max_steps=max_steps,
                                 chunk=10, give_up=give_up)
    return res, rec.finish(), d.qpos.copy(), d.qvel.copy()


def _same(a, b):
    ra, ea, qa, va = a
    rb, eb, qb, vb = b
    for f in dataclasses.fields(ra):
        x, y = getattr(ra, f.name), getattr(rb, f.name)
        if isinstance(x, np.ndarray):
            assert np.array_equal(x, y), f.name
        else:
            assert x == y, f.name
    assert ea == eb
    assert np.array_equal(qa, qb) and np.array_equal(va, vb)


@pytest.mark.parametrize("case", ["settles", "gives_up", "gives_up_rolling", "replay",
                                  "times_out", "spinning_fork"])
def test_the_compiled_loop_is_the_python_loop(world, case):
    # onto the floor from 1 m, thrown sideways and spun: bounces, rolls, then rests
    obj, spin = ("cup", "mug", "ceramic"), (3.0, -2.0, 1.0)
    if case == "spinning_fork":  # a slender body spun fast about each axis, given up
        obj, spin = ("fork", "dinner", "metal"), (9.0, 14.0, 25.0)
    scene, m, b, lin, ang = _fall(world, (1.5, 1.2, 1.0), (0.6, -0.3, 0.0), spin, obj)
    floor_z, max_steps, criteria = None, None, SettleCriteria()
    if case == "gives_up":
        floor_z = 0.9  # a zone 0.9 m up: given up once it can no longer climb back there
    elif case in ("gives_up_rolling", "spinning_fork"):
        floor_z = 0.15  # a low zone: given up while it still rolls on the floor
    elif case == "replay":
        max_steps = 1234  # exactly that many steps, settled or not
    elif case == "times_out":
        criteria = SettleCriteria(timeout_s=0.5)  # still bouncing when time runs out
    compiled = _run(scene, m, b, lin, ang, True, floor_z, max_steps, criteria)
    python = _run(scene, m, b, lin, ang, False, floor_z, max_steps, criteria)
    _same(compiled, python)
    res = compiled[0]
    assert res.gave_up == (case.startswith("gives_up") or case == "spinning_fork")
    assert res.settled == (case == "settles"), res
    if case == "replay":
        assert res.steps == 1234
    # it bounced and rolled (given up when it first lands below the zone)
    assert len(compiled[1]) >= (1 if case in ("gives_up", "times_out") else 4)
    if case in ("gives_up_rolling", "spinning_fork"):  # given up while moving: energy counted
        vadr = m.jnt_dofadr[m.body_jntadr[b]]
        assert np.linalg.norm(compiled[3][vadr:vadr + 3]) > 0.05
