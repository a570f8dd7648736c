"""The built-in rooms: 64 variants, 20 valid zones each, sound geometry, navigable floors."""

from __future__ import annotations

import dataclasses
import math
from collections import Counter

import numpy as np
import pytest

from fallgen.world.furniture import MIN_THICKNESS_M, ZONE_KINDS
from fallgen.world.geometry import Box
from fallgen.world.materials import OCTAVE_BANDS_HZ
from fallgen.world.rooms import SHOEBOX_FACES, FurnitureItem, Zone
from fallgen.world.validate import check_variant, navigability


def _all(world):
    return [v for r in world.rooms.values() for v in r.variants]


def test_sixty_four_variants(world):
    vs = _all(world)
    assert len(world.rooms) == 8
    assert Counter(r.kind for r in world.rooms.values()) == {"kitchen": 4, "study": 4}
    assert len(vs) == 64
    assert Counter(v.kind for v in vs) == {"kitchen": 32, "study": 32}
    assert len({v.id for v in vs}) == 64
    for r in world.rooms.values():
        assert r.layouts == ("l1", "l2", "l3", "l4"), r.id
        assert r.material_sets == ("m1", "m2"), r.id
        assert [v.id for v in r.variants] == [f"{r.id}-l{i}-m{j}" for i in range(1, 5)
                                              for j in (1, 2)]


def test_realistic_sizes(world):
    for r in world.rooms.values():
        lx, ly, h = r.size_m
        assert 3.5 <= lx <= 8.0 and 3.5 <= ly <= 8.0, r.id
        assert 2.5 <= h <= 3.2, r.id


def test_layouts_differ(world):
    """The four layouts of a room are different arrangements, not copies."""
    for r in world.rooms.values():
        for m in r.material_sets:  # (a set may add its soft furnishings: rugs, curtains)
            sigs = {tuple(sorted((it.type, round(it.pose[0], 1), round(it.pose[1], 1))
                                 for it in v.furniture))
                    for v in r.variants if v.material_set == m}
            assert len(sigs) == 4, (r.id, m)


def test_material_sets_differ(world):
    for r in world.rooms.values():
        m1, m2 = r.variants[0], r.variants[1]
        assert m1.surfaces != m2.surfaces, r.id


@pytest.mark.parametrize("i", range(64))
def test_variant_is_valid(world, i):
    """Zones inside the room, supported, free, with a drop region; no intersections;
    navigable floor. The validator itself is tested below against planted faults."""
    v = _all(world)[i]
    assert len(v.zones) == 20
    assert check_variant(v) == [], v.id


def test_zone_kinds_cover_the_paper(world):
    """Every variant has floor, under/behind furniture, raised surfaces and containers."""
    for v in _all(world):
        kinds = Counter(z.kind for z in v.zones)
        assert kinds["floor"] >= 2, v.id
        assert kinds["under_furniture"] + kinds["behind_furniture"] >= 2, v.id
        assert kinds["table_top"] + kinds["counter_top"] >= 1, v.id
        assert kinds["shelf"] >= 1 and kinds["cabinet_top"] >= 1, v.id
        assert kinds["box"] + kinds["basket"] + kinds["pan"] >= 1, v.id
        if v.kind == "kitchen":
            assert kinds["pan"] >= 1 and kinds["counter_top"] >= 1, v.id
    every = Counter(z.kind for v in _all(world) for z in v.zones)
    assert set(every) == set(ZONE_KINDS)


def test_collision_geometry_is_thick_enough(world):
    for v in _all(world):
        for item, p in v.parts():
            assert min(p.box.size) >= MIN_THICKNESS_M - 1e-9, (v.id, item.id, p.name)


def test_shoebox(world):
    for v in _all(world):
        sb = v.shoebox()
        assert sb.size_m == v.size_m
        a = np.array(sb.absorption())
        assert sorted(SHOEBOX_FACES) == sorted(("west", "east", "south", "north", "floor",
                                               "ceiling"))
        assert a.shape == (len(SHOEBOX_FACES), len(OCTAVE_BANDS_HZ))
        for face, row in zip(SHOEBOX_FACES, a):  # each face absorbs as its surface's table
            assert np.array_equal(row, v.surfaces[face].absorption), (v.id, face)
        assert sb.faces["floor"] is v.surfaces["floor"]


# --- the validator catches planted faults ------------------------------------------------------

def _variant(world):
    return world.variant("kitchen_galley-l1-m1")


def test_validator_catches_intersection(world):
    v = _variant(world)
    a = v.furniture[0]
    clone = dataclasses.replace(a, id="clone", parts=tuple(
        dataclasses.replace(p, box=Box((p.box.center[0] + 0.1, *p.box.center[1:]), p.box.half,
                                       p.box.yaw)) for p in a.parts))
    bad = dataclasses.replace(v, furniture=v.furniture + (clone,))
    assert any("intersects" in p for p in check_variant(bad))


def test_validator_catches_floating_and_outside_zones(world):
    v = _variant(world)
    z = next(z for z in v.zones if z.kind == "table_top")
    lifted = dataclasses.replace(z, volume=z.volume.with_z(z.volume.zmin + 0.2, z.volume.zmax))
    outside = dataclasses.replace(v.zones[0], volume=Box((-1.0, 1.0, 0.15), (0.3, 0.3, 0.15)))
    bad = dataclasses.replace(v, zones=(lifted, outside) + v.zones[2:])
    problems = check_variant(bad)
    assert any("does not rest on" in p for p in problems)
    assert any("outside the room" in p for p in problems)


def test_validator_catches_blocked_floor(world):
    v = _variant(world)
    lx, ly, h = v.size_m
    wall = FurnitureItem("divider", "cabinet", (lx / 2, ly / 2, 0.0, 0.0), (0.1, ly, 1.0), parts=(
        dataclasses.replace(v.furniture[0].parts[0], name="body",
                            box=Box((lx / 2, ly / 2, 0.5), (0.05, ly / 2, 0.5))),), anchors={})
    bad = dataclasses.replace(v, furniture=v.furniture + (wall,))
    assert navigability(bad).largest_component_fraction < 0.9
    assert any("split" in p or "intersects" in p for p in check_variant(bad))


def test_drop_regions(world):
    for v in _all(world):
        for z in v.zones:
            assert z.drop.zmin >= z.volume.zmin - 1e-9
            assert z.drop.zmax <= v.size_m[2]
            if z.open_above:
                assert z.drop.zmax > 2.3, (v.id, z.id)
            assert isinstance(z, Zone)
            assert math.isclose(z.drop.center[0], z.volume.center[0])


# --- soft furnishings: rugs, curtains, and items of one material set ----------------------------

def test_rugs_lie_under_things_and_the_robot_drives_over_them(world):
    """Rugs are thin fabric slabs on the floor that tables and chairs stand on, zones lie on
    and the robot crosses: a variant's free floor is the same without its rugs."""
    from fallgen.world.furniture import FLOOR_COVERING_MAX_M

    rugs = 0
    for v in _all(world):
        mine = [it for it in v.furniture if it.type == "rug"]
        for it in mine:
            (pile,) = it.parts
            assert pile.material == "fabric/rug" and pile.box.zmin == 0.0
            assert pile.box.zmax <= FLOOR_COVERING_MAX_M + 1e-9
            assert "behind" not in it.anchors
        if mine:
            rugs += len(mine)
            bare = dataclasses.replace(v, furniture=tuple(it for it in v.furniture
                                                          if it.type != "rug"))
            assert navigability(v) == navigability(bare), v.id
    assert rugs >= 20
    # the dining table and its chairs stand on the rug, and the variant is valid
    v = world.variant("kitchen_dining-l1-m1")
    rug = next(it for it in v.furniture if it.id == "rug").parts[0].box
    legs = [p for it in v.furniture if it.id == "table" for p in it.parts if p.role == "legs"]
    assert legs and all(rug.contains(np.array([p.box.center[:2] + (0.01,)])).all()
                        for p in legs)
    assert check_variant(v) == []


def test_curtains_hang_at_the_walls(world):
    for v in _all(world):
        for it in v.furniture:
            if it.type == "curtain":
                assert it.wall is not None and it.size[1] <= 0.3, (v.id, it.id)
                assert it.parts[0].material == "fabric/drape"


def test_pictures_hang_on_walls_clear_of_zones_and_the_robot(world):
    """Every layout hangs pictures; each is flat on a wall above the robot's height band, and
    no zone's settle volume or drop region reaches it (it changes no fall)."""
    for v in _all(world):
        pictures = [it for it in v.furniture if it.type == "picture"]
        assert pictures, v.id
        for it in pictures:
            assert it.wall is not None and it.size[1] <= 0.06 and it.pose[2] >= 1.25, it.id
            assert {p.material for p in it.parts} == {"paper/print", "wood_hard"}
            for p in it.parts:
                lo, hi = p.box.aabb()
                for z in v.zones:
                    for box in (z.volume, z.drop):
                        a, b = box.aabb()
                        assert not all(a[k] < hi[k] and b[k] > lo[k] for k in range(3)), \
                            (v.id, it.id, z.anchor)


def test_plants_stand_clear_of_zones_and_are_decor(world):
    """Most layouts have potted plants; a plant's pot is solid, its foliage decor (drawn, not
    simulated or heard), all of it inside its footprint and height, on the floor, and no
    zone's settle volume or drop region comes within 10 cm of it (it changes no fall)."""
    layouts = set()
    for v in _all(world):
        for it in (it for it in v.furniture if it.type == "plant"):
            layouts.add((v.room, v.layout))
            pot = [p for p in it.parts if p.name == "pot"]
            leaves = [p for p in it.parts if p.name.startswith("leaves")]
            assert len(pot) == 1 and not pot[0].decor and pot[0].shape == "cylinder"
            assert leaves and all(p.decor and p.shape == "ellipsoid" for p in leaves)
            assert {p.material for p in it.parts} == {"ceramic", "wood_soft/foliage"}
            w, d, h = it.size
            for p in it.parts:
                lo, hi = p.box.aabb()
                assert lo[2] >= -1e-9 and hi[2] <= h + 1e-9, (v.id, it.id, p.name)
                assert np.all(np.abs(np.array(p.box.center[:2]) - it.pose[:2])
                              + np.array(p.box.half[:2]) <= max(w, d) / 2 + 1e-9), (v.id, it.id)
                for z in v.zones:
                    for box in (z.volume, z.drop):
                        a, b = box.aabb()
                        gap = np.maximum(0.0, np.maximum(a[:2] - hi[:2], lo[:2] - b[:2]))
                        assert np.hypot(*gap) >= 0.1 - 1e-9, (v.id, it.id, z.anchor)
    assert len(layouts) >= 24, sorted(layouts)


def test_items_of_one_material_set(world):
    """``sets`` puts an item in some material sets only: study_lounge's m2 (wall-to-wall
    carpet) has no rug and no curtains, its m1 has both; the zones are the same."""
    m1, m2 = world.variant("study_lounge-l1-m1"), world.variant("study_lounge-l1-m2")
    types1, types2 = {it.type for it in m1.furniture}, {it.type for it in m2.furniture}
    assert {"rug", "curtain"} <= types1 and not {"rug", "curtain"} & types2
    assert [z.anchor for z in m1.zones] == [z.anchor for z in m2.zones]


def _room_file(tmp_path, world, edit):
    from fallgen.fields import load_toml
    from fallgen.world.rooms import parse_room

    src = world.rooms["kitchen_galley"].file.read_text()
    p = tmp_path / "kitchen_galley.toml"
    p.write_text(edit(src))
    return lambda: parse_room(load_toml(p), world.materials)


@pytest.mark.parametrize("edit,field", [
    (lambda s: s.replace('type = "rug", pos = [5.3, 1.8], size = [2.1, 2.5, 0.02]',
                         'type = "rug", pos = [5.3, 1.8], size = [2.1, 2.5, 0.05]'), "].size"),
    (lambda s: s.replace('along = 1.8, size = [3, 0.13, 2.3]',
                         'along = 1.8, size = [3, 0.4, 2.3]'), "].size"),
    (lambda s: s.replace('along = 1.8, size = [3, 0.13, 2.3]',
                         'along = 1.8, size = [3, 0.13, 2.3], sets = ["m3"]'), "].sets"),
    (lambda s: s.replace('along = 1.8, size = [3, 0.13, 2.3]',
                         'along = 1.8, size = [3, 0.13, 2.3], sets = []'), "].sets"),
    (lambda s: s.replace('along = 1.55, z_m = 1.35, size = [1.0, 0.04, 0.7]',
                         'along = 1.55, z_m = 1.35, size = [1.0, 0.1, 0.7]'), "].size"),
    (lambda s: s.replace('along = 1.55, z_m = 1.35, size = [1.0, 0.04, 0.7]',
                         'along = 1.55, size = [1.0, 0.04, 0.7]'), "].z_m"),
    (lambda s: s.replace('along = 1.55, z_m = 1.35, size = [1.0, 0.04, 0.7]',
                         'along = 1.55, z_m = 1.35, gap = 0.1, size = [1.0, 0.04, 0.7]'),
     "].gap"),
    (lambda s: s.replace('along = 1.55, z_m = 1.35, size = [1.0, 0.04, 0.7]',
                         'along = 1.55, z_m = 1.35, size = [1.0, 0.04, 0.7], '
                         'params = { frame_m = 0.5 }'), "].params.frame_m"),
    (lambda s: s.replace('along = 1.55, z_m = 1.35, size = [1.0, 0.04, 0.7]',
                         'along = 1.55, z_m = 1.35, size = [1.0, 0.04, 0.3], '
                         'params = { frame_m = 0.15 }'), "].size"),
    (lambda s: s.replace('pot_diameter_m = 0.26, pot_height_m = 0.26, lobes = 6',
                         'pot_diameter_m = 0.5, pot_height_m = 0.26, lobes = 6'),
     "].params.pot_diameter_m"),
    (lambda s: s.replace('pot_diameter_m = 0.26, pot_height_m = 0.26, lobes = 6',
                         'pot_diameter_m = 0.26, pot_height_m = 0.7, lobes = 6'),
     "].params.pot_height_m"),
    (lambda s: s.replace('pot_diameter_m = 0.26, pot_height_m = 0.26, lobes = 6',
                         'pot_diameter_m = 0.26, pot_height_m = 0.26, lobes = 12'),
     "].params.lobes"),
])
def test_bad_soft_furnishing_is_one_error(tmp_path, world, edit, field):
    from fallgen.errors import InputError

    parse = _room_file(tmp_path, world, edit)
    with pytest.raises(InputError) as e:
        parse()
    assert "kitchen_galley.toml" in str(e.value) and field in str(e.value), str(e.value)


def test_a_zone_on_an_item_a_set_lacks_is_an_error(tmp_path, world):
    from fallgen.errors import InputError

    parse = _room_file(tmp_path, world, lambda s: s.replace(
        '{ id = "table", type = "dining_table", pos = [5.3, 1.8], yaw_deg = 90, '
        'size = [1.2, 0.8, 0.75] }',
        '{ id = "table", type = "dining_table", pos = [5.3, 1.8], yaw_deg = 90, '
        'size = [1.2, 0.8, 0.75], sets = ["m2"] }', 1))
    with pytest.raises(InputError) as e:
        parse()
    assert "kitchen_galley.toml" in str(e.value) and "table" in str(e.value)
    assert "m1" in str(e.value), str(e.value)
