"""Room variants compile in MuJoCo; objects get the right mass; MJCF export round-trips."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from fallgen.world import scene as scene_module
from fallgen.world.scene import (AgentBody, PhysicsSettings, PlacedObject, build_scene, room_spec,
                                 to_mjcf)


def _all(world):
    return [v for r in world.rooms.values() for v in r.variants]


def test_all_variants_compile(world):
    for v in _all(world):
        scene = build_scene(v, world.materials)
        m = scene.model
        n_parts = sum(len(it.parts) for it in v.furniture)
        assert m.ngeom == n_parts + 6, v.id  # floor, ceiling, 4 walls
        assert m.opt.timestep == pytest.approx(0.002)
        assert m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
        assert m.opt.impratio == pytest.approx(10.0)
        assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        assert (m.geom_margin == 0).all()
        # Contact labels: every geom has an owner and a known material.
        assert len(scene.geom_owner) == m.ngeom
        for mat in scene.geom_material:
            world.materials.object(mat)


def _saved(m: mujoco.MjModel) -> bytes:
    buf = np.zeros(mujoco.mj_sizeModel(m), np.uint8)
    mujoco.mj_saveModel(m, None, buf)
    return buf.tobytes()


def test_kept_room_spec_makes_the_same_model_and_is_never_changed(world, monkeypatch):
    v = world.variant("kitchen_galley-l1-m1")
    lib = world.categories
    inst = lib.instance("fork", lib["fork"].variants[0].name,
                        next(iter(lib["fork"].variants[0].materials)))
    objs = [PlacedObject("target", inst, (1.5, 1.5, 1.0)),
            PlacedObject("d0", inst, (1.0, 1.2, 0.5), free=False)]
    settings = PhysicsSettings(visual_meshes=False)
    first = build_scene(v, world.materials, objs, AgentBody(3.0, 1.8, 0.3), settings)
    room, _ = room_spec(v, world.materials, settings)
    n_geoms = len(room.geoms)
    again = build_scene(v, world.materials, objs, AgentBody(3.0, 1.8, 0.3), settings)
    assert room_spec(v, world.materials, settings)[0] is room  # kept, and not grown by users
    assert len(room.geoms) == n_geoms == first.model.ngeom - first.model.body_geomnum[1:].sum()
    monkeypatch.setattr(scene_module, "_ROOM_SPECS", type(scene_module._ROOM_SPECS)())
    fresh = build_scene(v, world.materials, objs, AgentBody(3.0, 1.8, 0.3), settings)
    assert room_spec(v, world.materials, settings)[0] is not room
    assert _saved(first.model) == _saved(again.model) == _saved(fresh.model)
    assert first.geom_owner == fresh.geom_owner and first.geom_material == fresh.geom_material
    # another settings object is another room: the key is the whole settings, not the options
    assert room_spec(v, world.materials, PhysicsSettings())[0] is not \
        room_spec(v, world.materials, settings)[0]


def test_labels_follow_surfaces_and_furniture(world):
    v = world.variant("kitchen_galley-l1-m2")
    scene = build_scene(v, world.materials)
    gid = scene.model.geom("floor").id
    assert scene.geom_material[gid] == v.surfaces["floor"].impact_material
    stove = next(i for i, o in enumerate(scene.geom_owner) if o == "stove")
    assert scene.geom_material[stove] == "metal"


def test_object_mass_and_inertia(world):
    v = world.variant("kitchen_galley-l1-m1")
    lib = world.categories
    inst = lib.instance("golf_ball", lib["golf_ball"].variants[0].name,
                        next(iter(lib["golf_ball"].variants[0].materials)))
    obj = PlacedObject("target", inst, (1.5, 1.5, 1.0))
    scene = build_scene(v, world.materials, [obj], agent=AgentBody(3.0, 1.8, 0.3))
    m = scene.model
    bid = scene.object_body["target"]
    assert m.body_mass[bid] == pytest.approx(inst.mass_kg, rel=1e-9)
    # A solid sphere: I = 2/5 m r^2 about any axis.
    r = inst.extents_m.max() / 2
    assert m.body_inertia[bid] == pytest.approx([0.4 * inst.mass_kg * r**2] * 3, rel=0.03)
    assert 0.0445 < inst.mass_kg < 0.0460  # 45.9 g by the rules of golf
    names = [m.geom(i).name for i in range(m.ngeom)]
    assert "obj:target/visual" in names and "agent/body" in names
    vis = m.geom("obj:target/visual").id
    assert m.geom_contype[vis] == 0 and m.geom_conaffinity[vis] == 0
    coll = [i for i, n in enumerate(names) if n.startswith("obj:target/c")]
    assert coll and all(m.geom_condim[i] == 6 for i in coll)


def test_scaled_object(world):
    lib = world.categories
    cat = lib["cup"]
    var = cat.variants[0]
    mat = sorted(var.materials)[0]
    a = lib.instance("cup", var.name, mat, 1.0)
    b = lib.instance("cup", var.name, mat, 1.2)
    assert b.mass_kg == pytest.approx(a.mass_kg * 1.2**3)
    assert np.allclose(b.inertia, a.inertia * 1.2**5)
    assert np.allclose(b.extents_m, a.extents_m * 1.2)


def test_mjcf_export_round_trip(world, tmp_path):
    v = world.variant("study_library-l2-m1") if "study_library" in world.rooms else \
        next(iter(world.rooms.values())).variants[0]
    xml = to_mjcf(v, world.materials)
    path = tmp_path / "room.xml"
    path.write_text(xml)
    loaded = mujoco.MjModel.from_xml_path(str(path))
    direct = build_scene(v, world.materials).model
    assert loaded.ngeom == direct.ngeom
    assert np.allclose(loaded.geom_size, direct.geom_size, atol=1e-5)
    assert np.allclose(loaded.geom_pos, direct.geom_pos, atol=1e-5)
    assert np.allclose(loaded.geom_friction, direct.geom_friction, atol=1e-6)
    assert loaded.opt.cone == direct.opt.cone


def test_rendering_smoke(world):
    """The scene renders headless (EGL/OSMesa) with the object visible and collision hidden."""
    v = world.variant("kitchen_galley-l1-m1")
    lib = world.categories
    var = lib["bowl"].variants[0]
    inst = lib.instance("bowl", var.name, sorted(var.materials)[0])
    scene = build_scene(v, world.materials, [PlacedObject("target", inst, (2.0, 1.8, 0.05),
                                                          free=False)])
    data = scene.data()
    mujoco.mj_forward(scene.model, data)
    try:
        r = mujoco.Renderer(scene.model, 120, 160)
    except Exception as e:  # no GL on this machine
        pytest.skip(f"no headless GL: {e}")
    try:
        cam = mujoco.MjvCamera()
        cam.lookat[:] = (2.0, 1.8, 0.05)
        cam.distance, cam.azimuth, cam.elevation = 0.8, 90.0, -45.0
        r.update_scene(data, cam)
        r.enable_segmentation_rendering()
        seg = r.render()
        r.disable_segmentation_rendering()
    finally:
        r.close()
    ids = set(np.unique(seg[..., 0]).tolist())
    vis = scene.model.geom("obj:target/visual").id
    assert vis in ids
    coll = {i for i in range(scene.model.ngeom) if scene.model.geom(i).name.startswith("obj:target/c")}
    assert not (coll & ids)
    # the camera looks at the bowl: the image's centre shows it
    assert seg[60, 80, 0] == vis
