"""How the rooms look: textured surfaces and furniture at their real size and a
shadow-casting ceiling light in the scenes that are rendered, with the segmentation and depth
of the flat scene, deterministic, and more detail than flat colours."""

from __future__ import annotations

import gc

import mujoco
import numpy as np
import pytest

from fallgen.nav.agent import Pose
from fallgen.vision.camera import EgoCamera
from fallgen.vision.textures import detail_share
from fallgen.world.scene import LOOK, PhysicsSettings, build_scene

FLAT = PhysicsSettings(collision_meshes=False)
VARIANT = "kitchen_dining-l1-m2"  # tiles, concrete, a rug, curtains, veneer and stone
POSES = [Pose(3.0, 2.0, k, t) for k in (0, 3, 6, 9) for t in (0, -30)]


def _views(world, settings, what="all"):
    scene = build_scene(world.variant(VARIANT), world.materials, settings=settings)
    d = scene.data()
    mujoco.mj_forward(scene.model, d)
    cam = EgoCamera(scene)
    try:
        return [cam.render(d, p, what) for p in POSES]
    finally:
        cam.close()


@pytest.fixture(scope="module")
def flat_and_look(world):
    return _views(world, FLAT), _views(world, LOOK)


def test_segmentation_and_depth_are_the_flat_scenes(flat_and_look):
    for a, b in zip(*flat_and_look):
        assert a.instances == b.instances
        assert np.array_equal(a.instance, b.instance)
        assert np.array_equal(a.category, b.category)
        # the same depth up to float rounding (a textured box is the same box in another
        # local frame: see world.dressing.face_frame)
        np.testing.assert_allclose(a.depth, b.depth, atol=1e-4)


def test_textured_views_have_detail_and_are_deterministic(world, flat_and_look):
    flat, look = flat_and_look
    d_flat = np.mean([detail_share(v.rgb) for v in flat])
    d_look = np.mean([detail_share(v.rgb) for v in look])
    assert d_look > 2 * d_flat and d_look > 0.25, (d_flat, d_look)
    again = _views(world, LOOK, "rgb")
    assert all(np.array_equal(a.rgb, b.rgb) for a, b in zip(look, again))


def test_a_shadow_darkens_the_floor_under_the_table(world):
    """The dining table seen from beside it, the ceiling light casting shadows or not (the same
    textures): with shadows, rug pixels darken, only darken, and the darkened ones lie under
    the table top (seen between its legs: nearer the top of the image than the rug in front)."""
    from fallgen.world.scene import Scene, build_spec

    v = world.variant(VARIANT)
    table = next(it for it in v.furniture if it.id == "table")
    pose = Pose(table.pose[0], table.pose[1] - 1.6, 3, -45)  # south of it, facing north

    def view(shadows: bool):
        spec, info = build_spec(v, world.materials, settings=LOOK)
        for light in spec.lights:
            light.castshadow = light.castshadow and shadows
        m = spec.compile()
        names = [m.geom(i).name for i in range(m.ngeom)]
        scene = Scene(m, spec, v, tuple(info[n][0] for n in names),
                      tuple(info[n][1] for n in names), {})
        d = scene.data()
        mujoco.mj_forward(m, d)
        cam = EgoCamera(scene)
        try:
            return cam.render(d, pose)
        finally:
            cam.close()

    lit, shaded = view(False), view(True)
    rug = lit.instance == lit.instances.index("rug")
    a = lit.rgb.astype(float).mean(axis=2)
    b = shaded.rgb.astype(float).mean(axis=2)
    dark = rug & (b < 0.8 * a)
    assert dark.sum() > 0.05 * rug.sum(), (dark.sum(), rug.sum())
    # a shadow never brightens (but a few pixels on the rug's edges, which the depth pass of
    # the shadow map shifts by a rounding: 12 of 26028)
    assert (b[rug] > a[rug] + 1).mean() < 0.002
    rows = np.nonzero(rug)[0]
    assert np.nonzero(dark)[0].mean() < rows.mean()  # beyond the rug's near edge: under it


def test_a_dropped_camera_frees_its_gl_objects_in_its_own_context(world):
    """Two cameras, each with its own GL context: the first dropped without close() (the
    garbage collector frees it) must not free the second's textures and buffers, whose
    segmentation would then read texture colours."""
    v = world.variant(VARIANT)
    first = build_scene(v, world.materials, settings=FLAT)
    cam = EgoCamera(first)
    d = first.data()
    mujoco.mj_forward(first.model, d)
    cam.render(d, POSES[0])
    second = build_scene(v, world.materials, settings=LOOK)
    cam2 = EgoCamera(second)
    d2 = second.data()
    mujoco.mj_forward(second.model, d2)
    want = cam2.render(d2, POSES[0])
    del cam
    gc.collect()
    for p in POSES[:4]:
        cam2.render(d2, p, "rgb")
    got = cam2.render(d2, POSES[0])
    cam2.close()
    assert np.array_equal(got.instance, want.instance)


#: a frame with x across and z up, looking along +y (world -y toward the viewer)
_FACING = np.column_stack([[1, 0, 0], [0, 0, 1], [0, -1, 0]]).ravel().astype(float)


def _flat_lit_spec() -> mujoco.MjSpec:
    """An empty scene lit by an ambient headlight only (a texture's own grey levels)."""
    spec = mujoco.MjSpec()
    spec.visual.headlight.ambient = [1.0, 1.0, 1.0]
    spec.visual.headlight.diffuse = [0.0, 0.0, 0.0]
    return spec


def _orthographic_grey(spec: mujoco.MjSpec, px: int = 300, view_m: float = 1.0) -> np.ndarray:
    """The grey levels of an orthographic view, ``view_m`` high, of ``spec`` from 2 m along
    world -y (x across, z up)."""
    import cv2

    cam = spec.worldbody.add_camera()
    cam.name, cam.pos, cam.fovy = "ortho", [0.0, -2.0, 0.0], view_m
    cam.proj = mujoco.mjtProjection.mjPROJ_ORTHOGRAPHIC
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, _FACING)
    cam.quat = q
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with mujoco.Renderer(model, px, px) as r:
        r.update_scene(data, "ortho")
        rgb = r.render()
    return cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).astype(float)


def _dark_line_centres(profile: np.ndarray) -> np.ndarray:
    """Centres (pixels) of the runs of a profile darker than its mean by half its spread."""
    dark = np.flatnonzero(profile < profile.mean() - 0.5 * profile.std())
    runs = np.split(dark, np.flatnonzero(np.diff(dark) > 1) + 1)
    return np.array([r.mean() for r in runs if len(r)])


def _face_on(texture, half_x, half_y, repeat=None, px=300, view_m=1.0):
    """An orthographic view, ``view_m`` high, of the +z face of a box drawn by the scenes' own
    texturing (:func:`fallgen.world.dressing.dress_textured`), its local y up: the grey levels."""
    from fallgen.world.dressing import dress_textured

    spec = _flat_lit_spec()
    g = spec.worldbody.add_geom()
    g.type, g.size = mujoco.mjtGeom.mjGEOM_BOX, [half_x, half_y, 0.05]
    q = np.zeros(4)  # local z toward the camera (world -y), local y up
    mujoco.mju_mat2Quat(q, _FACING)
    g.quat = q
    dress_textured(spec, g, texture, [0.9, 0.9, 0.9, 1.0], repeat)
    return _orthographic_grey(spec, px, view_m)


def test_texture_repeats_at_its_size_in_metres():
    """Rendered, 25 cm tiles show a grout line every 25 cm of the face: 75 of the 300 pixels
    of a 1 m orthographic view (MuJoCo repeats a uniform texture every 2 / texrepeat
    metres)."""
    from fallgen.world.appearance import TextureSpec

    grey = _face_on(TextureSpec.make("tiles", 1.0, tile_m=0.25, grout_m=0.01, grout=0.3,
                                     variation=0.0), 1.0, 1.0)
    centres = _dark_line_centres(grey.mean(axis=0))
    spacing = np.diff(centres)
    assert len(spacing) >= 3, centres
    assert np.all(np.abs(spacing - 75.0) <= 1.5), centres


def test_fronts_fit_their_face_upright():
    """A counter's front: the drawer row's gap lies drawer_m below the face's top edge, and
    the doors' gaps part the face's width into equal doors."""
    from fallgen.world.appearance import TextureSpec

    # a 0.9 x 0.6 m face in a 1 m view: 300 px per metre, the face from row 60 to 240
    tex = TextureSpec.make("doors", door_m=0.3, drawer_m=0.15, gap_m=0.01, handle=0.0,
                           face_w_m=0.9, face_h_m=0.6)
    grey = _face_on(tex, 0.45, 0.3, repeat=(1 / 0.9, 1 / 0.6))
    rows = grey[60:240, 30:270].mean(axis=1)
    assert abs(int(np.argmin(rows[10:-10])) + 10 - 45) <= 2  # 0.15 m below the top: row 45
    cols = grey[150:230, 15:285].mean(axis=0)  # through the doors, below the drawers
    dark = np.flatnonzero(cols < cols.mean() - 2 * cols.std())
    runs = np.split(dark, np.flatnonzero(np.diff(dark) > 1) + 1)
    centres = sorted(r.mean() + 15 for r in runs if len(r))
    inner = [c for c in centres if 20 < c - 15 < 250]
    assert len(inner) == 2 and all(abs(c - e) <= 2 for c, e in zip(inner, (105, 195))), centres


def test_a_look_redraws_colours_and_textures_not_geometry(world):
    """``look_seed`` (appearance randomisation): another seed draws other colours, textures and
    light (RGB differs), the same seed the same pixels; segmentation and depth are the room's
    own."""
    import dataclasses

    def views(seed):
        settings = dataclasses.replace(LOOK, look_seed=seed)
        scene = build_scene(world.variant(VARIANT), world.materials, settings=settings)
        d = scene.data()
        mujoco.mj_forward(scene.model, d)
        cam = EgoCamera(scene)
        try:
            return [cam.render(d, p, "all") for p in POSES[:3]]
        finally:
            cam.close()

    a, b, a2 = views(1), views(2), views(1)
    for va, vb, va2 in zip(a, b, a2):
        assert np.array_equal(va.rgb, va2.rgb)
        assert np.abs(va.rgb.astype(int) - vb.rgb.astype(int)).mean() > 3.0
        assert np.array_equal(va.instance, vb.instance)
        np.testing.assert_allclose(va.depth, vb.depth, atol=1e-5)
    with pytest.raises(ValueError, match="look_seed"):
        PhysicsSettings(collision_meshes=False, look_seed=3)


def test_windows_are_bright_and_opaque_in_textured_views(world):
    """A glass wall is a transparent tint in the flat scene; drawn with textures it is an
    opaque window lit from outside (emission)."""
    v = world.variant("study_lounge-l1-m1")  # its south wall is glass
    flat = build_scene(v, world.materials, settings=FLAT)
    look = build_scene(v, world.materials, settings=LOOK)
    g_flat = flat.geom_owner.index("wall_south")
    g_look = look.geom_owner.index("wall_south")
    assert flat.model.geom_rgba[g_flat, 3] < 0.5
    mat = look.model.geom_matid[g_look]
    assert mat >= 0 and look.model.mat_rgba[mat, 3] == 1.0 and look.model.mat_emission[mat] > 0.5


def test_objects_look_like_their_material(world):
    """Drawn with textures, an object's visual mesh has its material's gloss (a glass shines,
    cloth does not) and, where the material has a texture, that texture (flat, on the mesh's
    box-projected texture coordinates); glass and clear plastic (a PET bottle) stay
    transparent, a coloured plastic does not; the geom's colour is its material's (MuJoCo lets
    a geom's colour override its material's)."""
    from fallgen.world.dressing import GLOSS
    from fallgen.world.scene import PlacedObject

    lib = world.categories
    placed = [PlacedObject("a", lib.instance("wineglass", "red_wine", "glass"),
                           (1.0, 1.0, 0.5), free=False),
              PlacedObject("b", lib.instance("spoon", "tablespoon", "metal"),
                           (1.5, 1.0, 0.5), free=False),
              PlacedObject("c", lib.instance("bottle", "pet", "plastic_hard/clear"),
                           (2.0, 1.0, 0.5), free=False),
              PlacedObject("d", lib.instance("spoon", "plastic", "plastic_hard"),
                           (2.5, 1.0, 0.5), free=False)]
    scene = build_scene(world.variant(VARIANT), world.materials, placed, settings=LOOK)
    m = scene.model
    for name, audio, textured in (("a", "glass", False), ("b", "metal", True),
                                  ("c", "plastic_hard", False), ("d", "plastic_hard", False)):
        g = next(k for k in range(m.ngeom) if scene.geom_owner[k] == f"obj:{name}"
                 and m.geom_matid[k] >= 0)
        mat = m.geom_matid[g]
        assert m.mat_specular[mat] == pytest.approx(GLOSS[audio][0])
        assert np.allclose(m.geom_rgba[g], m.mat_rgba[mat])
        has_tex = m.mat_texid[mat, mujoco.mjtTextureRole.mjTEXROLE_RGB] >= 0
        assert has_tex == textured
        if audio == "metal":
            assert m.tex_type[m.mat_texid[mat, mujoco.mjtTextureRole.mjTEXROLE_RGB]] \
                == mujoco.mjtTexture.mjTEXTURE_2D
        assert (m.geom_rgba[g, 3] < 0.5) == (name in "ac")


def test_a_plant_is_drawn_in_leaves_and_segmented_as_a_plant(world):
    """A plant's foliage (decor ellipsoids) is drawn, with its leaves' cube texture when the
    room is textured, and its pixels are the plant's in the segmentation, the same pixels
    flat and textured."""
    import math

    v = world.variant("study_lounge-l1-m1")
    plant = next(it for it in v.furniture if it.id == "plant1")
    x, y, _, yaw = plant.pose
    # 0.9 m in front of it, looking at it (the armchair beside it hides it from farther)
    fx, fy = math.sin(yaw), -math.cos(yaw)
    heading = int(round(math.atan2(-fy, -fx) / math.radians(30))) % 12
    pose = Pose(x + 0.9 * fx, y + 0.9 * fy, heading, -30)
    views = {}
    for name, settings in (("flat", FLAT), ("look", LOOK)):
        scene = build_scene(v, world.materials, settings=settings)
        d = scene.data()
        mujoco.mj_forward(scene.model, d)
        cam = EgoCamera(scene)
        try:
            views[name] = cam.render(d, pose)
            categories = cam.categories
        finally:
            cam.close()
        if name == "look":
            m = scene.model
            leaves = [g for g in range(m.ngeom) if scene.geom_owner[g] == "plant1"
                      and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_ELLIPSOID]
            tex = m.mat_texid[m.geom_matid[leaves[0]], mujoco.mjtTextureRole.mjTEXROLE_RGB]
            assert tex >= 0 and m.tex_type[tex] == mujoco.mjtTexture.mjTEXTURE_CUBE
    flat, look = views["flat"], views["look"]
    assert flat.pixels_of("plant1") > 2000
    assert np.array_equal(flat.instance, look.instance)
    mask = look.category == categories.index("plant")
    assert np.array_equal(mask, look.instance == look.instances.index("plant1"))
    # mostly green (its pot is terracotta), and textured: the leaves and the shade between
    g = look.rgb[mask].astype(float)
    assert (g[:, 1] > g[:, 0]).mean() > 0.75 and (g[:, 1] > g[:, 2]).mean() > 0.75
    assert g[:, 1].std() > 8.0


def test_a_cooker_shows_its_knobs_and_burners():
    """The cooker's front: ``knobs`` dark round knobs evenly across the control strip, an
    oven handle under it; its top: four burners, each a dark cap at a quarter point of the
    face inside a dark grate ring."""
    from fallgen.vision.textures import render_texture
    from fallgen.world.appearance import TextureSpec

    w, h, strip = 0.76, 0.87, 0.12
    front = render_texture(TextureSpec.make("doors", door_m=2.0, drawer_m=strip, knobs=4,
                                            face_w_m=w, face_h_m=h)).mean(axis=2)
    px = front.shape[0]
    band = front[:int(px * strip / h)]  # the control strip
    dark = (band < band.mean() - 40).sum(axis=0) >= 4  # columns through a knob
    runs = np.split(np.flatnonzero(dark), np.flatnonzero(np.diff(np.flatnonzero(dark)) > 1) + 1)
    centres = [r.mean() / px * w for r in runs if len(r) > 2]
    assert len(centres) == 4
    assert np.allclose(centres, [(k + 0.5) * w / 4 for k in range(4)], atol=0.01)
    below = front[int(px * (strip + 0.05) / h)]  # the oven's bar handle
    assert (below < below.mean() - 20).mean() > 0.5
    top = render_texture(TextureSpec.make("hob", burner_m=0.2, face_w_m=w,
                                          face_h_m=0.62)).mean(axis=2)
    mean = top.mean()
    for cx in (0.25, 0.75):
        for cy in (0.25, 0.75):
            assert top[int(cy * px), int(cx * px)] < mean - 60  # a cap
    assert top[px // 2, px // 2] > mean  # the top's own finish between them


def test_an_objects_texture_sits_at_its_size_in_metres():
    """An object's mesh gets texture coordinates by box projection (dressing.box_texcoords) and
    its material's texture at real size: 25 cm tiles on a mesh's side show a grout line every
    25 cm (75 of 300 pixels of a 1 m orthographic view), whatever the mesh's size; every
    triangle corner is mapped on the plane its triangle faces."""
    import types

    import trimesh

    from fallgen.world.appearance import TextureSpec
    from fallgen.world.dressing import box_texcoords, dress_object

    tiles = TextureSpec.make("tiles", 1.0, tile_m=0.25, grout_m=0.01, grout=0.3, variation=0.0)
    mesh = trimesh.creation.box((0.9, 0.3, 0.9))
    uv, corners = box_texcoords(mesh.vertices, mesh.faces, tiles.size_m)
    assert uv.shape == (3 * len(mesh.faces), 2) and corners.shape == mesh.faces.shape
    side = np.flatnonzero(mesh.face_normals[:, 1] < -0.9)  # the -y face: its x and z
    np.testing.assert_allclose(uv[corners[side]].reshape(-1, 2),
                               mesh.vertices[mesh.faces[side]].reshape(-1, 3)[:, [0, 2]])

    spec = _flat_lit_spec()
    m = spec.add_mesh()
    m.name = "thing"
    m.uservert = mesh.vertices.ravel().tolist()
    m.userface = mesh.faces.ravel().tolist()
    m.usertexcoord = uv.ravel().tolist()
    m.userfacetexcoord = corners.ravel().tolist()
    g = spec.worldbody.add_geom()
    g.type, g.meshname = mujoco.mjtGeom.mjGEOM_MESH, "thing"
    material = types.SimpleNamespace(name="tiled", audio="ceramic", texture=tiles)
    dress_object(spec, g, material, [0.9, 0.9, 0.9, 1.0], None, mapped=True)
    grey = _orthographic_grey(spec)
    centres = _dark_line_centres(grey[30:270, 30:270].mean(axis=0))
    spacing = np.diff(centres)
    assert len(spacing) >= 2, centres
    assert np.all(np.abs(spacing - 75.0) <= 1.5), centres
