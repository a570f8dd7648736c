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
        sigs = {tuple(sorted((it.type, round(it.pose[0], 1), round(it.pose[1], 1))
                             for it in v.furniture)) for v in r.variants}
        assert len(sigs) == 4, r.id


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
        assert a.shape == (len(SHOEBOX_FACES), len(OCTAVE_BANDS_HZ))
        assert ((a >= 0) & (a <= 1)).all()
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
