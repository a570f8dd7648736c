"""Procedural shapes (fallgen.world.shapes, fallgen.world.meshkit) and objects/categories.toml.

The density table and the expected mass ranges are kept here on purpose (not read from the
materials file), so that a change of a density, a wall thickness or a size that makes an
object's mass unrealistic fails here.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
import trimesh

from fallgen.world import meshkit as mk
from fallgen.world.shapes import PARAMS, SHAPES, Shape, make_shape

ROOT = Path(__file__).resolve().parents[2]
CATEGORIES_FILE = ROOT / "objects" / "categories.toml"

#: Densities (kg/m^3) of the material references, as in materials/objects.toml.
DENSITY = {
    "plastic_hard": 1050.0,
    "plastic_hard/wax": 900.0,
    "plastic_hard/golf_ball": 1130.0,
    "plastic_hard/clear": 1380.0,
    "plastic_soft_foam": 60.0,
    "glass": 2500.0,
    "metal": 7850.0,  # steel
    "metal/aluminium": 2700.0,
    "metal/brass": 8500.0,
    "metal/appliance": 7850.0,
    "metal/battery_cell": 2800.0,
    "ceramic": 2400.0,
    "stone": 2700.0,
    "cardboard": 600.0,
    "cardboard/corrugated": 150.0,
    "wood_soft": 450.0,
    "wood_soft/cork": 200.0,
    "wood_medium": 680.0,
    "wood_hard": 750.0,
    "fabric": 300.0,
    "leather": 900.0,
    "paper": 800.0,
    "rubber": 1100.0,
}

#: The 31 categories of the paper's supplement.
PAPER_CATEGORIES = {
    "candle", "calculator", "flashlight_battery", "fork", "bookend", "spoon", "toothbrush",
    "kitchen_utensil", "cup", "coaster", "vase", "key", "bottle_cork", "toy", "bowl",
    "soda_can", "clothes_brush", "ipod", "box", "pepper_mill", "pepper_grinder", "bottle",
    "toaster", "wineglass", "jug", "watch", "knife", "pen", "headphone", "golf_ball",
    "shirt_button",
}
OCCLUDERS = {"book", "towel", "cardboard_box"}

# Expected mass (grams) at scale 1, keyed (category, variant, material); "*" matches any. The
# most specific key wins. Sources are retail/spec figures for typical products.
MASS_G: dict[tuple[str, str, str], tuple[float, float]] = {
    # dinner taper 25 cm: 60-90 g; pillar 7 x 10 cm: ~300-380 g; tealight 12-17 g (wax + cup)
    ("candle", "taper", "*"): (40, 120),
    ("candle", "pillar", "*"): (200, 450),
    ("candle", "tealight", "*"): (8, 20),
    # Casio fx-82MS 100 g, TI-30XS 112 g, TI-84 ~200 g; basic pocket calculators 50-100 g
    ("calculator", "*", "*"): (45, 220),
    # alkaline cells: AA 23-24 g (Energizer E91, Duracell MN1500), AAA 11-12 g,
    # D 135-150 g (NiMH D up to 170 g)
    ("flashlight_battery", "AA", "*"): (20, 26),
    ("flashlight_battery", "AAA", "*"): (9, 13),
    ("flashlight_battery", "D", "*"): (120, 170),
    # stainless dinner fork 40-60 g, dessert fork 30-45 g; disposable fork 2-5 g, picnic 6-10 g
    ("fork", "*", "metal"): (20, 80),
    ("fork", "*", "plastic_hard"): (2, 10),
    # sheet-steel bookends 200-450 g each; wooden 250-500 g; marble 0.8-2 kg
    ("bookend", "*", "metal"): (150, 600),
    ("bookend", "*", "wood_medium"): (150, 700),
    ("bookend", "*", "wood_hard"): (150, 700),
    ("bookend", "*", "stone"): (600, 2500),
    # teaspoon 15-25 g, tablespoon 40-70 g; disposable spoon 2-5 g
    ("spoon", "*", "metal"): (12, 80),
    ("spoon", "*", "plastic_hard"): (1.5, 10),
    # manual toothbrush 15-20 g (child 10-15 g)
    ("toothbrush", "*", "*"): (8, 30),
    # nylon turner 40-80 g; stainless ladle 150-250 g; 30 cm beech spoon 30-60 g
    ("kitchen_utensil", "turner", "*"): (25, 110),
    ("kitchen_utensil", "ladle", "*"): (90, 300),
    ("kitchen_utensil", "wooden_spoon", "*"): (20, 80),
    # ceramic mug 300-400 g, tea cup 120-200 g; glass tumbler 200-300 g;
    # melamine mug 100-150 g, plastic tumbler 40-100 g
    ("cup", "*", "ceramic"): (100, 450),
    ("cup", "*", "glass"): (120, 400),
    ("cup", "*", "plastic_hard"): (40, 200),
    ("cup", "*", "plastic_hard/clear"): (40, 200),
    # paper coffee cups (8-12 oz): single wall 9-12 g, double-walled 15-30 g
    ("cup", "paper", "*"): (9, 35),
    # cork coaster 4-10 g; stone/ceramic absorbent coaster 150-200 g; wooden 30-60 g
    ("coaster", "*", "wood_soft/cork"): (3, 15),
    # pulpboard beer mats (107 mm, 1.5-2 mm): 6-12 g
    ("coaster", "pulpboard", "cardboard"): (5, 14),
    ("coaster", "*", "ceramic"): (100, 300),
    ("coaster", "*", "stone"): (100, 300),
    ("coaster", "*", "wood_medium"): (20, 80),
    ("coaster", "*", "wood_hard"): (20, 80),
    # round leather coasters (10 cm, 3-4 mm): 15-30 g
    ("coaster", "leather", "*"): (10, 40),
    # bud vase 150-400 g; 20-25 cm glass or stoneware vase 0.7-1.5 kg
    ("vase", "bud", "*"): (120, 450),
    ("vase", "*", "*"): (500, 1800),
    # house keys 5-10 g, small mailbox/padlock keys 3-6 g
    ("key", "*", "*"): (3, 15),
    # natural wine cork 24 x 44 mm 3.5-6 g; small tapered stoppers 1-3 g
    ("bottle_cork", "*", "*"): (1, 8),
    # tapered rubber bottle stoppers (22 mm top, 25 mm tall): 8-15 g
    ("bottle_cork", "rubber_stopper", "*"): (5, 20),
    # plastic toy car 50-250 g, wooden 40-200 g; vinyl bath duck 30-60 g; foam ball 5-30 g
    ("toy", "car", "plastic_hard"): (50, 250),
    ("toy", "car", "wood_medium"): (40, 200),
    ("toy", "duck", "*"): (20, 80),
    ("toy", "foam_ball", "*"): (5, 30),
    # stuffed fabric balls 8-10 cm: 40-120 g
    ("toy", "plush_ball", "*"): (40, 120),
    # ceramic cereal bowl 300-450 g, rice bowl 150-250 g; glass bowls 300-1500 g;
    # wooden salad bowl 300-600 g; plastic bowls 100-600 g
    ("bowl", "*", "ceramic"): (150, 550),
    ("bowl", "*", "glass"): (250, 1500),
    ("bowl", "*", "wood_hard"): (200, 700),
    ("bowl", "*", "plastic_hard"): (100, 600),
    # empty 355 ml aluminium can 12.75-15 g (Ball, Crown specs), 500 ml 16-18 g
    ("soda_can", "355ml", "*"): (11, 17),
    ("soda_can", "500ml", "*"): (13, 21),
    # wooden clothes brushes 80-150 g
    ("clothes_brush", "*", "*"): (50, 200),
    # iPod classic 140 g (6th gen 80 GB) to 162 g; iPod nano (5th gen) 36 g
    ("ipod", "classic", "*"): (120, 170),
    ("ipod", "nano", "*"): (25, 50),
    # wooden jewellery box 15 x 10 x 7 cm 250-500 g; empty tea tin 50-100 g
    ("box", "jewellery", "*"): (150, 700),
    ("box", "tea_tin", "*"): (40, 150),
    # small rigid cardboard gift boxes (12 x 9 x 6 cm, 1.5 mm board): 30-70 g
    ("box", "gift", "*"): (25, 80),
    # small leather jewellery / watch cases: 50-120 g
    ("box", "leather_case", "*"): (40, 150),
    # Peugeot-style wooden mills: 12 cm ~100-150 g, 22 cm ~300 g, 30 cm ~400-500 g
    ("pepper_mill", "*", "*"): (80, 600),
    # glass jar grinders 200-350 g; acrylic grinders 100-200 g
    ("pepper_grinder", "*", "glass"): (150, 400),
    ("pepper_grinder", "*", "plastic_hard"): (60, 250),
    # 750 ml wine bottle 400-600 g (heavy premium up to 900 g); 330 ml beer bottle 180-250 g;
    # 500 ml PET water bottle 10-25 g
    ("bottle", "wine", "*"): (350, 900),
    ("bottle", "beer", "*"): (150, 350),
    ("bottle", "pet", "*"): (8, 40),
    # 2-slice toasters: stainless 1.5-2.5 kg, plastic housing 0.8-1.3 kg
    ("toaster", "*", "metal/appliance"): (1000, 2600),
    ("toaster", "*", "plastic_hard"): (600, 1500),
    # red wine glass 150-250 g, champagne flute 100-180 g
    ("wineglass", "*", "*"): (80, 300),
    # 1 l pitchers: stoneware 0.6-1.2 kg, glass 0.5-1.0 kg, plastic 150-350 g
    ("jug", "*", "ceramic"): (500, 1300),
    ("jug", "*", "glass"): (450, 1300),
    ("jug", "*", "plastic_hard/clear"): (120, 400),
    # steel bracelet watches 120-180 g (Seiko SKX ~150 g); Casio F-91W 21 g, G-Shock ~50-70 g
    ("watch", "*", "metal"): (90, 220),
    ("watch", "*", "plastic_hard"): (12, 80),
    # table knife 60-110 g; paring knife with plastic handle 20-40 g
    ("knife", "*", "metal"): (50, 130),
    ("knife", "*", "plastic_hard"): (12, 60),
    # plastic ballpoint 5-12 g (BIC Cristal 5.9 g); aluminium pens 10-30 g
    ("pen", "*", "plastic_hard"): (3, 15),
    ("pen", "*", "metal/aluminium"): (7, 35),
    # over-ear headphones 200-300 g, on-ear 120-180 g
    ("headphone", "*", "*"): (90, 350),
    # rules: at most 45.93 g; real balls 45-46 g (grade plastic_hard/golf_ball, 1130 kg/m^3)
    ("golf_ball", "*", "*"): (44.5, 46.0),
    # 11.5 mm (18 L) polyester shirt buttons ~0.2-0.3 g, 15 mm 0.4-0.8 g
    ("shirt_button", "*", "*"): (0.12, 1.5),
    # paperback 250-350 g, hardcover novel 500-900 g, coffee-table book 1-2 kg
    ("book", "*", "*"): (200, 2000),
    # hand towel 150-300 g, bath towel 400-800 g
    ("towel", "*", "*"): (150, 900),
    # single-wall cartons: 30 x 20 x 15 cm ~150 g, 35 x 25 x 20 cm ~250 g
    ("cardboard_box", "*", "*"): (80, 500),
}


def _categories() -> dict:
    with CATEGORIES_FILE.open("rb") as f:
        return tomllib.load(f)


def _variants() -> list[tuple[str, str, str, dict]]:
    return [(cid, v["name"], v["shape"], v.get("params", {}))
            for cid, c in _categories().items() for v in c["variants"]]


def _combos() -> list[tuple[str, str, str]]:
    out = []
    for cid, c in _categories().items():
        for v in c["variants"]:
            for mat in v.get("materials", c["materials"]):
                out.append((cid, v["name"], mat))
    return out


def _expected(cid: str, variant: str, material: str) -> tuple[float, float] | None:
    for key in ((cid, variant, material), (cid, variant, "*"), (cid, "*", material), (cid, "*", "*")):
        if key in MASS_G:
            return MASS_G[key]
    return None


def _variant_shape(cid: str, name: str) -> Shape:
    for c, n, shp, params in _variants():
        if (c, n) == (cid, name):
            return make_shape(shp, params)
    raise KeyError((cid, name))


# ---------------------------------------------------------------------------------------------
# generators
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(SHAPES))
def test_generator_defaults_pass_validation(name: str) -> None:
    s = make_shape(name, {})
    assert isinstance(s, Shape)
    assert mk.validate_shape(s) == []
    assert 100 <= len(s.visual.faces) <= 12000
    assert s.visual.volume > 0


def test_every_generator_has_documented_si_parameters() -> None:
    for name, gen in SHAPES.items():
        assert gen.__doc__, name
        for p, spec in PARAMS[name].items():
            if spec.kind is float and p.endswith("_m"):
                assert 0 <= spec.default < 1.0, (name, p)


def test_generators_are_deterministic() -> None:
    for name in ("cup", "key"):
        a, b = SHAPES[name](), SHAPES[name]()
        assert np.array_equal(a.visual.vertices, b.visual.vertices)
        assert np.array_equal(a.visual.faces, b.visual.faces)
        assert all(np.array_equal(p, q) for p, q in zip(a.collision, b.collision, strict=True))


def test_make_shape_returns_independent_copies() -> None:
    a = make_shape("sphere", {"diameter_m": 0.05})
    a.visual.vertices = a.visual.vertices * 2
    a.collision[0][:] = 0
    b = make_shape("sphere", {"diameter_m": 0.05})
    assert b.visual.extents.max() == pytest.approx(0.05, rel=1e-3)
    assert np.ptp(b.collision[0], axis=0).max() == pytest.approx(0.05, rel=1e-3)


@pytest.mark.parametrize(
    ("name", "params", "error", "word"),
    [
        ("no_such_shape", {}, KeyError, "no_such_shape"),
        ("cup", {"heigth_m": 0.1}, TypeError, "heigth_m"),
        ("cup", {"height_m": "tall"}, TypeError, "height_m"),
        ("cup", {"handle": 1}, TypeError, "handle"),
        ("fork", {"tines": 4.0}, TypeError, "tines"),
        ("fork", {"tines": 9}, ValueError, "tines"),
        ("cup", {"height_m": -0.1}, ValueError, "height_m"),
        ("cup", {"height_m": math.nan}, ValueError, "height_m"),
        ("cup", {"wall_m": 0.03}, ValueError, "wall_m"),
    ],
)
def test_make_shape_rejects_bad_input(name: str, params: dict, error: type, word: str) -> None:
    with pytest.raises(error) as info:
        make_shape(name, params)
    msg = str(info.value)
    assert word in msg
    assert "\n" not in msg


def test_shape_frame_is_bbox_centred_and_collision_matches_scale() -> None:
    s = make_shape("cup", {})
    assert np.allclose(s.visual.bounds.mean(axis=0), 0.0, atol=1e-9)
    allpts = np.vstack(s.collision)
    assert np.all(allpts.min(axis=0) >= s.visual.bounds[0] - 1e-3)
    assert np.all(allpts.max(axis=0) <= s.visual.bounds[1] + 1e-3)


def test_open_vessels_are_decomposed_and_hull_fits_are_single() -> None:
    for name in ("cup", "bowl", "vase", "jug", "wineglass", "fork", "headphones", "bookend", "key"):
        assert len(make_shape(name, {}).collision) >= 2, name
    for name in ("sphere", "soda_can", "bottle", "toaster", "battery"):
        assert len(make_shape(name, {}).collision) == 1, name


# ---------------------------------------------------------------------------------------------
# meshkit
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("reverse", [False, True])
def test_revolve_cylinder(reverse: bool) -> None:
    prof = [(0.0, 0.0), (0.04, 0.0), (0.04, 0.1), (0.0, 0.1)]
    m = mk.revolve(prof[::-1] if reverse else prof, 64)
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(math.pi * 0.04**2 * 0.1, rel=0.01)
    assert m.area_faces.min() > 1e-9


def test_revolve_rejects_bad_profiles() -> None:
    with pytest.raises(ValueError):
        mk.revolve([(0.01, 0.0), (0.04, 0.0), (0.0, 0.1)])
    with pytest.raises(ValueError):
        mk.revolve([(0.0, 0.0), (0.04, 0.0), (0.0, 0.05), (0.04, 0.1), (0.0, 0.1)])


def test_hollow_lathe_wall_thickness_and_pieces() -> None:
    outer = [(0.0, 0.0), (0.04, 0.0), (0.04, 0.1)]
    lathe = mk.Lathe.hollow(outer, 0.003, bottom=0.005, segments=48)
    m = lathe.mesh()
    assert m.is_watertight and m.volume > 0
    shell = math.pi * (0.04**2 - 0.037**2) * 0.095 + math.pi * 0.04**2 * 0.005
    assert m.volume == pytest.approx(shell, rel=0.02)
    pieces = lathe.pieces(0.002)
    assert 6 < len(pieces) <= 24
    s = Shape(m, tuple(pieces))
    assert mk.collision_stats(s)["cover_max"] < 1e-6


def test_extrude_with_hole() -> None:
    sq = [(0, 0), (0.02, 0), (0.02, 0.02), (0, 0.02)]
    hole = [(0.005, 0.005), (0.015, 0.005), (0.015, 0.015), (0.005, 0.015)]
    m = mk.extrude(sq, 0.002, holes=[hole])
    assert m.is_watertight and m.volume == pytest.approx((4e-4 - 1e-4) * 0.002, rel=1e-6)


def test_union_and_difference_are_closed() -> None:
    a = mk.box((0.02, 0.02, 0.02))
    b = mk.sphere(0.012)
    u = mk.union([a, b])
    d = mk.difference(a, b)
    assert u.is_watertight and d.is_watertight
    assert u.volume > a.volume and 0 < d.volume < a.volume


def test_validate_shape_reports_problems() -> None:
    good = make_shape("block", {})
    assert mk.validate_shape(good) == []
    flipped = good.visual.copy()
    flipped.invert()
    assert any("volume" in p for p in mk.validate_shape(Shape(flipped, good.collision)))
    half = good.collision[0][good.collision[0][:, 0] < 0]
    assert any("uncovered" in p for p in mk.validate_shape(Shape(good.visual, (half,))))
    flat = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0.01, 0.01, 0]], float)
    assert any("degenerate" in p for p in mk.validate_shape(Shape(good.visual, (*good.collision, flat))))
    big = np.vstack([good.collision[0], [[0.2, 0.0, 0.0]]])
    assert any("beyond" in p for p in mk.validate_shape(Shape(good.visual, (big,))))
    open_mesh = trimesh.Trimesh(good.visual.vertices, good.visual.faces[1:], process=False)
    assert any("watertight" in p for p in mk.validate_shape(Shape(open_mesh, good.collision)))


# ---------------------------------------------------------------------------------------------
# categories file
# ---------------------------------------------------------------------------------------------
def test_category_ids_and_roles() -> None:
    cats = _categories()
    assert set(cats) == PAPER_CATEGORIES | OCCLUDERS
    for cid, c in cats.items():
        assert c["role"] == ("occluder" if cid in OCCLUDERS else "target"), cid


def test_category_fields_and_material_references() -> None:
    for cid, c in _categories().items():
        assert set(c) <= {"description", "role", "materials", "scale", "variants"}, cid
        assert isinstance(c["description"], str) and c["description"], cid
        lo, hi = c["scale"]
        assert 0 < lo <= hi < 2, cid
        assert 1 <= len(c["variants"]) <= 5, cid
        names = [v["name"] for v in c["variants"]]
        assert len(set(names)) == len(names), cid
        for mats in [c["materials"]] + [v["materials"] for v in c["variants"] if "materials" in v]:
            assert mats, cid
            for ref, w in mats.items():
                assert ref in DENSITY, (cid, ref)
                assert w > 0, (cid, ref)
        for v in c["variants"]:
            assert set(v) <= {"name", "shape", "params", "materials"}, (cid, v["name"])
            assert v["shape"] in SHAPES, (cid, v["name"])


@pytest.mark.parametrize(("cid", "name", "shape_name", "params"), _variants(),
                         ids=[f"{c}-{n}" for c, n, _, _ in _variants()])
def test_every_variant_builds(cid: str, name: str, shape_name: str, params: dict) -> None:
    s = make_shape(shape_name, params)
    m = s.visual
    assert m.is_watertight and m.is_winding_consistent and m.volume > 0
    assert 1 <= len(s.collision) <= 24
    for p in s.collision:
        assert p.dtype == np.float64 and p.ndim == 2 and p.shape[1] == 3
        assert mk.hull_mesh(p).volume > mk.MIN_PIECE_VOLUME
    assert np.allclose(m.bounds.mean(axis=0), 0.0, atol=1e-9)


def test_real_world_dimensions() -> None:
    ext = np.sort(_variant_shape("golf_ball", "standard").visual.extents) * 1e3
    assert np.allclose(ext, 42.7, atol=0.5)
    can = _variant_shape("soda_can", "355ml").visual.extents * 1e3
    assert can[0] == pytest.approx(66, abs=2) and can[1] == pytest.approx(66, abs=2)
    assert can[2] == pytest.approx(122, abs=2)
    aa = _variant_shape("flashlight_battery", "AA").visual.extents * 1e3
    assert aa[0] == pytest.approx(14.5, abs=1) and aa[2] == pytest.approx(50.5, abs=1)
    d = _variant_shape("flashlight_battery", "D").visual.extents * 1e3
    assert d[0] == pytest.approx(34.2, abs=1) and d[2] == pytest.approx(61.5, abs=1)
    for name in ("house", "small"):
        assert 40 <= _variant_shape("key", name).visual.extents.max() * 1e3 <= 70
    toaster = np.sort(_variant_shape("toaster", "steel").visual.extents) * 1e3
    assert np.allclose(toaster, [170, 190, 280], atol=20)
    glass = _variant_shape("wineglass", "red_wine")
    assert glass.visual.body_count == 1  # foot, stem and bowl are one shell


def test_mass_table_covers_every_combination() -> None:
    missing = [c for c in _combos() if _expected(*c) is None]
    assert missing == []


@pytest.mark.parametrize(("cid", "name", "material"), _combos(),
                         ids=[f"{c}-{n}-{m}" for c, n, m in _combos()])
def test_mass_is_realistic(cid: str, name: str, material: str) -> None:
    lo, hi = _expected(cid, name, material)
    grams = _variant_shape(cid, name).visual.volume * DENSITY[material] * 1e3
    assert lo <= grams <= hi, f"{cid}/{name} in {material}: {grams:.1f} g not in [{lo}, {hi}] g"
