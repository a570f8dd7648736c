"""A GL context lends one MuJoCo render context to the scenes drawn in it one after another
(fallgen.vision.gl): made over for each scene (its textures, materials and meshes uploaded),
it holds what a render context made for that scene holds, and draws the same pixels."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from fallgen.nav.agent import Pose
from fallgen.vision import contexts as C
from fallgen.vision import gl as G
from fallgen.vision.camera import EgoCamera
from fallgen.world.scene import LOOK, PlacedObject, build_scene

#: (variant, [(category, position)]): two rooms of other materials and furniture, one object
#: then two (a mesh more than the first context holds), then fewer again
SCENES = [
    ("kitchen_dining-l1-m2", [("toaster", (2.6, 1.8, 0.05))]),
    ("study_office-l1-m1", [("bowl", (2.0, 1.5, 0.05)), ("wineglass", (2.3, 1.6, 0.05))]),
    ("kitchen_dining-l1-m2", [("cup", (2.4, 1.7, 0.05))]),
    ("study_office-l1-m1", [("vase", (2.1, 1.4, 0.05)), ("pen", (2.2, 1.8, 0.02))]),
    ("kitchen_island-l2-m1", [("soda_can", (2.5, 1.5, 0.05))]),
]


def _scene(world, variant: str, objects, seed: int):
    rng = np.random.default_rng(seed)
    placed = [PlacedObject(f"o{i}", world.categories.sample(rng, cid), pos)
              for i, (cid, pos) in enumerate(objects)]
    scene = build_scene(world.variant(variant), world.materials, placed, settings=LOOK)
    d = scene.data()
    mujoco.mj_forward(scene.model, d)
    return scene, d, objects[0][1]


def _poses(at, seed: int, n: int = 4) -> list[Pose]:
    """Eyes 1-2 m from ``at``, facing it (the nearest heading), level or looking down."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        a, r = rng.uniform(0, 2 * math.pi), rng.uniform(1.0, 2.0)
        x, y = at[0] + r * math.cos(a), at[1] + r * math.sin(a)
        heading = int(round(math.degrees(math.atan2(at[1] - y, at[0] - x)) / 30)) % 12
        out.append(Pose(x, y, heading, int(rng.choice([-30, 0]))))
    return out


def _pixels(cam: EgoCamera, d, pose: Pose) -> list[np.ndarray]:
    c = cam.camera(pose)
    f = cam.frames
    rgb = f.rgb(d, c)
    depth, geoms = f.depth_and_geoms(d, c)
    window = f.geoms(d, c, (100, 200, 100, 200), crop=True)
    return [rgb, f.rgb(d, c), depth, geoms, window]  # the second colour draw keeps the map


def test_a_lent_context_draws_the_pixels_of_a_context_made_for_the_scene(world, monkeypatch):
    made_over = []
    real = G.make_over
    monkeypatch.setattr(G, "make_over", lambda con, model, textures:
                        made_over.append(model.nmesh) or real(con, model, textures))
    shared = G.GLContext(300)
    try:
        for i, (variant, objects) in enumerate(SCENES):
            scene, d, at = _scene(world, variant, objects, i)
            cam = EgoCamera(scene, context=shared)
            ours = [_pixels(cam, d, p) for p in _poses(at, i)]
            cam.close()
            ref = EgoCamera(scene)  # its own GL context, its first render context made anew
            try:
                theirs = [_pixels(ref, d, p) for p in _poses(at, i)]
            finally:
                ref.close()
            for a, b in zip(ours, theirs):
                for x, y in zip(a, b):
                    assert np.array_equal(x, y), (variant, objects)
            assert any(len(np.unique(v[3])) > 5 for v in ours)  # views of furnished rooms
        held = len(shared._textures)
    finally:
        shared.close()
    assert 0 < held < sum(len(o) for _, o in SCENES) * 40  # textures held once each
    # made for the first, then made over for every other (rooms of other sizes and
    # textures, a mesh more than it held, fewer again)
    assert made_over == [2, 1, 2, 1], made_over


def test_a_context_made_over_holds_what_one_made_for_the_model_holds(world):
    """From every scene's context to every other's: fewer and more textures and meshes,
    rooms of other sizes."""
    from OpenGL import GL

    ctx = G.GLContext(300)
    try:
        models = []
        for i, (variant, objects) in enumerate(SCENES):
            scene, _, _ = _scene(world, variant, objects, i)
            EgoCamera(scene, context=ctx)  # the camera's offscreen size and shadow map
            models.append(scene.model)
        assert len({G.context_inputs(m) for m in models}) == 1
        assert len({m.stat.extent for m in models}) > 1
        assert len({m.ntex for m in models}) > 1 and len({m.nmesh for m in models}) > 1
        for a in models:
            for m in models:
                if m is a:
                    continue
                ctx.make_current()
                con = mujoco.MjrContext(a, G.FONT_SCALE)
                names = C.TextureNames()
                names.adopt(con, a)
                fresh = mujoco.MjrContext(m, G.FONT_SCALE)
                mujoco.MjrContext(a, G.FONT_SCALE).free()  # the GL fog range: a's again
                try:
                    C.make_over(con, m, names)
                    fog = [float(GL.glGetFloatv(e)) for e in (GL.GL_FOG_START, GL.GL_FOG_END)]
                    assert fog == [fresh.fogStart, fresh.fogEnd] != [0.0, 1.0]
                    assert con.ntexture == fresh.ntexture == m.ntex
                    n = m.ntex
                    assert np.array_equal(con.textureType[:n], fresh.textureType[:n])
                    for name in ("mat_texid", "mat_texuniform", "mat_texrepeat", "fogRGBA"):
                        assert np.array_equal(getattr(con, name), getattr(fresh, name)), name
                    for name in ("shadowClip", "shadowScale", "shadowSize", "offWidth",
                                 "offHeight", "offSamples", "fogStart", "fogEnd", "lineWidth",
                                 "rangePlane", "rangeBuiltin", "rangeFont", "nskin"):
                        assert getattr(con, name) == getattr(fresh, name), name
                    assert con.rangeMesh >= fresh.rangeMesh == 2 * m.nmesh
                finally:
                    con.ntexture = 0
                    con.free()
                    fresh.free()
                    names.clear()
    finally:
        ctx.close()


def test_a_second_scene_asking_before_the_first_gave_it_back_gets_its_own(world):
    ctx = G.GLContext(300)
    try:
        scene, _, _ = _scene(world, *SCENES[0], 0)
        EgoCamera(scene, context=ctx)
        first = ctx.lend(scene.model)
        second = ctx.lend(scene.model)
        assert second is not first
        ctx.give_back(second)  # freed, not kept
        ctx.give_back(first)
        assert ctx.lend(scene.model) is first
        ctx.give_back(first)
    finally:
        ctx.close()


@pytest.mark.parametrize("what", ["plane", "hfield"])
def test_a_model_whose_context_holds_more_is_never_made_over(what):
    xml = {"plane": "<worldbody><geom type='plane' size='1 1 0.1'/></worldbody>",
           "hfield": "<asset><hfield name='h' nrow='3' ncol='3' size='1 1 0.1 0.1'/></asset>"
                     "<worldbody><geom type='hfield' hfield='h'/></worldbody>"}[what]
    m = mujoco.MjModel.from_xml_string(f"<mujoco>{xml}</mujoco>")
    assert G.context_inputs(m) is None


def test_textures_are_held_once_by_content_and_all_deleted_past_the_limit(world):
    """Two scenes of one room share its textures' names; another colour space is another
    texture; past the limit every name is deleted and the scene's uploaded again."""
    from OpenGL import GL

    ctx = G.GLContext(300)
    try:
        a, _, _ = _scene(world, *SCENES[0], 0)
        b, _, _ = _scene(world, *SCENES[2], 2)  # the same room, another object
        ctx.make_current()
        con = mujoco.MjrContext(a.model, G.FONT_SCALE)
        names = C.TextureNames()
        names.adopt(con, a.model)
        first = {C.TextureNames._content(a.model, i)[1]: int(con.texture[i])
                 for i in range(a.model.ntex)}
        assert len(names) == len(first)  # a texture drawn by two materials is held once
        C.make_over(con, b.model, names)
        shared = [i for i in range(b.model.ntex)
                  if C.TextureNames._content(b.model, i)[1] in first]
        assert len(shared) >= 10
        assert all(int(con.texture[i]) == first[C.TextureNames._content(b.model, i)[1]]
                   for i in shared)
        assert len(names) < len(first) + b.model.ntex - len(shared) + 1
        key, data = C.TextureNames._content(a.model, 0)
        other = (*key[:4], 1 - key[4], key[5])  # the other colour space
        assert names._find(key, data) is not None and names._find(other, data) is None
        held = list(names._names.values())
        names.limit = len(names) + 1  # the next scene's textures do not fit
        C.make_over(con, a.model, names)
        assert len(names) == len({C.TextureNames._content(a.model, i)[1]
                                  for i in range(a.model.ntex)})
        assert not GL.glIsTexture(held[0][0][1]) or held[0][0][1] in {
            n for h in names._names.values() for _, n in h}
        con.ntexture = 0
        con.free()
        names.clear()
        assert len(names) == 0
    finally:
        ctx.close()
