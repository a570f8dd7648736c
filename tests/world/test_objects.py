"""Object categories: the paper's list, materials that exist, user meshes with no code change."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from fallgen.errors import InputError
from fallgen.world.library import load_world
from fallgen.world.materials import AUDIO_MATERIALS
from fallgen.world.scene import PlacedObject, build_scene

PAPER_CATEGORIES = [
    "candle", "calculator", "flashlight_battery", "fork", "bookend", "spoon", "toothbrush",
    "kitchen_utensil", "cup", "coaster", "vase", "key", "bottle_cork", "toy", "bowl", "soda_can",
    "clothes_brush", "ipod", "box", "pepper_mill", "pepper_grinder", "bottle", "toaster",
    "wineglass", "jug", "watch", "knife", "pen", "headphone", "golf_ball", "shirt_button",
]


def test_paper_categories(world):
    assert sorted(world.categories.ids("target")) == sorted(PAPER_CATEGORIES)
    occluders = set(world.categories.ids("occluder"))
    assert {"book", "towel", "cardboard_box"} <= occluders


def test_every_material_exists_and_all_audio_materials_used(world):
    used = set()
    for cat in world.categories:
        for v in cat.variants:
            assert v.materials, (cat.id, v.name)
            for ref in v.materials:
                m = world.materials.object(ref)
                used.add(m.audio)
    # The dataset should exercise most of the paper's 14 audio materials.
    assert len(used) >= 12, sorted(set(AUDIO_MATERIALS) - used)


def tetrahedra_mass_properties(vertices, faces):
    """Volume, centre of mass and inertia tensor about it (density 1) of a closed, outward
    wound triangle mesh, summed over the tetrahedra each face makes with the origin
    (divergence theorem; a tetrahedron (0, a, b, c) of signed volume V = a . (b x c) / 6 has
    second moment V / 20 (s s^T + a a^T + b b^T + c c^T), s = a + b + c)."""
    v = np.asarray(vertices, float)[np.asarray(faces)]
    a, b, c = v[:, 0], v[:, 1], v[:, 2]
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6
    s = a + b + c
    com = (vol[:, None] * s / 4).sum(0) / vol.sum()
    cov = sum(np.einsum("i,ij,ik->jk", vol / 20, x, x) for x in (s, a, b, c))
    cov -= vol.sum() * np.outer(com, com)
    return float(vol.sum()), com, np.trace(cov) * np.eye(3) - cov


def test_geometry_watertight_and_its_mass_properties(world):
    """Every variant's mesh is closed and outward wound; its volume, centre of mass and
    inertia (what sets an object's mass and how it tumbles) are the mesh's own, integrated
    here tetrahedron by tetrahedron."""
    lib = world.categories
    for cat in lib:
        for v in cat.variants:
            g = lib.geometry(cat.id, v.name)
            mesh = trimesh.Trimesh(g.vertices, g.faces, process=False)
            assert mesh.is_watertight and mesh.is_winding_consistent, (cat.id, v.name)
            vol, com, inertia = tetrahedra_mass_properties(g.vertices, g.faces)
            assert vol > 0 and g.volume_m3 == pytest.approx(vol, rel=1e-9), (cat.id, v.name)
            assert np.allclose(g.com, com, rtol=0, atol=1e-9 * np.ptp(g.vertices)), \
                (cat.id, v.name)
            np.testing.assert_allclose(g.inertia_per_density, inertia, rtol=1e-7,
                                       atol=1e-9 * np.abs(inertia).max(),
                                       err_msg=f"{cat.id}/{v.name}")
            assert 1 <= len(g.collision) <= 32


def test_tetrahedra_reference_is_exact_for_a_box():
    """The reference itself: a 0.1 x 0.2 x 0.3 m box, I = V (b^2 + c^2) / 12 about x..."""
    box = trimesh.creation.box((0.1, 0.2, 0.3))
    box.apply_translation((1.0, -2.0, 0.5))
    vol, com, inertia = tetrahedra_mass_properties(box.vertices, box.faces)
    assert vol == pytest.approx(0.006) and np.allclose(com, (1.0, -2.0, 0.5))
    want = 0.006 / 12 * np.diag([0.2 ** 2 + 0.3 ** 2, 0.1 ** 2 + 0.3 ** 2, 0.1 ** 2 + 0.2 ** 2])
    np.testing.assert_allclose(inertia, want, atol=1e-15)


def test_sampling_is_seeded(world):
    lib = world.categories
    a = [lib.sample(np.random.default_rng(3), c) for c in lib.ids("target")]
    b = [lib.sample(np.random.default_rng(3), c) for c in lib.ids("target")]
    assert [(x.variant, x.material.name, x.scale) for x in a] == \
        [(x.variant, x.material.name, x.scale) for x in b]
    for cid, inst in zip(lib.ids("target"), a):
        lo, hi = lib[cid].scale
        assert lo <= inst.scale <= hi


def test_distractors_have_similar_size(world):
    lib = world.categories
    for cid in lib.ids("target"):
        size = lib.nominal_size_m(cid)
        cands = lib.distractors_for(cid)
        assert cid not in cands
        for c in cands:
            assert 0.5 <= lib.nominal_size_m(c) / size <= 2.0
    assert "toaster" not in lib.distractors_for("golf_ball")
    assert "bottle_cork" in lib.distractors_for("golf_ball")


# --- a user's own category from a mesh file, with no code change -------------------------------

USER_CATEGORY = """
[teapot_like]
description = "A user's object from an OBJ file"
role = "target"
materials = { ceramic = 1.0 }
scale = [0.9, 1.1]
[[teapot_like.variants]]
name = "mesh"
mesh = "meshes/{name}"
size_m = 0.2
collision = "hull"
"""


def _user_data(data_copy, mesh: trimesh.Trimesh, name: str = "thing.obj"):
    (data_copy / "objects" / "meshes").mkdir()
    mesh.export(data_copy / "objects" / "meshes" / name)
    (data_copy / "objects" / "user.toml").write_text(USER_CATEGORY.replace("{name}", name))
    return data_copy


@pytest.mark.parametrize("fmt", ["obj", "stl", "glb"])
def test_user_mesh_category(data_copy, fmt):
    torus = trimesh.creation.torus(major_radius=0.3, minor_radius=0.1)  # 0.8 m across
    world = load_world(_user_data(data_copy, torus, f"thing.{fmt}"))
    lib = world.categories
    assert "teapot_like" in lib.ids("target")
    inst = lib.instance("teapot_like", "mesh", "ceramic", 1.0)
    assert inst.extents_m.max() == pytest.approx(0.2, rel=1e-6)
    # Torus volume 2 pi^2 R r^2, scaled by (0.2 / 0.8)^3.
    vol = 2 * np.pi**2 * 0.3 * 0.1**2 * (0.2 / 0.8) ** 3
    assert inst.geometry.volume_m3 == pytest.approx(vol, rel=0.02)
    assert inst.mass_kg == pytest.approx(vol * world.materials.object("ceramic").density_kg_m3,
                                         rel=0.02)
    v = world.variant("kitchen_galley-l1-m1")
    scene = build_scene(v, world.materials, [PlacedObject("t", inst, (2.0, 1.8, 1.0))])
    assert scene.model.body_mass[scene.object_body["t"]] == pytest.approx(inst.mass_kg)


def test_user_mesh_not_watertight(data_copy):
    m = trimesh.creation.box()
    m = trimesh.Trimesh(m.vertices, m.faces[:-2])  # a hole
    root = _user_data(data_copy, m)
    with pytest.raises(InputError) as e:
        load_world(root)
    assert "thing.obj" in str(e.value) and "watertight" in str(e.value)
    assert "\n" not in str(e.value)


def test_user_mesh_missing_file(data_copy):
    (data_copy / "objects" / "user.toml").write_text(USER_CATEGORY.replace("{name}", "nope.obj"))
    with pytest.raises(InputError) as e:
        load_world(data_copy)
    assert "user.toml" in str(e.value) and "teapot_like.variants[0].mesh" in str(e.value)


def test_geometry_cache_gives_the_built_arrays(world, tmp_path, monkeypatch):
    """Procedural geometry comes back from the cache with the same values, dtypes and C
    layout as built (shells included); a corrupt entry is rebuilt; the key follows the
    generators' source."""
    from fallgen.world import objects

    monkeypatch.setenv("FALLGEN_CACHE", str(tmp_path))
    lib = world.categories
    for cid, vname in (("soda_can", None), ("cup", "mug"), ("fork", None)):
        cat = lib[cid]
        v = cat.variant(vname) if vname else cat.variants[0]
        built = objects.build_geometry(cat, v)
        first = objects.cached_geometry(cat, v)  # built and stored
        path = objects._geometry_cache_file(v)
        assert path.is_file()
        loaded = objects.cached_geometry(cat, v)
        for g in (first, loaded):
            for a, b in [(g.vertices, built.vertices), (g.faces, built.faces), (g.com, built.com),
                         (g.inertia_per_density, built.inertia_per_density),
                         *zip(g.collision, built.collision)]:
                assert a.dtype == b.dtype and a.flags.c_contiguous and np.array_equal(a, b)
            assert g.volume_m3 == built.volume_m3 and g.shell == built.shell
            assert len(g.collision) == len(built.collision)
        good = path.read_bytes()
        for bad in (b"not an npz", good[: len(good) // 2], good[:-30]):  # junk, truncated zips
            path.write_bytes(bad)
            again = objects.cached_geometry(cat, v)
            assert np.array_equal(again.vertices, built.vertices) and path.read_bytes() == good
    assert any(lib.geometry(c.id, c.variants[0].name).shell is not None for c in lib)
    key = objects._geometry_cache_file(lib["cup"].variant("mug"))
    objects._generator_source_digest.cache_clear()
    monkeypatch.setattr(objects, "_generator_source_digest", lambda: "edited")
    assert objects._geometry_cache_file(lib["cup"].variant("mug")) != key
