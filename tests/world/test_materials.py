"""The shipped material files load, hold physically sane numbers, and malformed copies fail with a
one-line InputError naming the file and the field."""

from __future__ import annotations

import math
import re
import shutil
from pathlib import Path

import pytest

from fallgen.errors import InputError
from fallgen.world.materials import (
    AUDIO_MATERIALS,
    OCTAVE_BANDS_HZ,
    SURFACE_USES,
    MaterialLibrary,
    load_materials,
)

MATERIALS_DIR = Path(__file__).resolve().parents[2] / "materials"
NOT_RESONANT = {"plastic_soft_foam", "fabric", "leather", "paper", "rubber"}
TIMESTEP_S = 0.002  # the physics timestep fallgen uses; solref[0] must be >= 2 x timestep

REQUIRED_GRADES = {
    "metal/aluminium": 2700.0,
    "metal/brass": 8500.0,
    "metal/battery_cell": 2800.0,
    "plastic_hard/wax": 900.0,
    "wood_soft/cork": 200.0,
    "cardboard/corrugated": 150.0,
}
BASE_DENSITIES = {
    "plastic_hard": 1050.0,
    "plastic_soft_foam": 60.0,
    "glass": 2500.0,
    "metal": 7850.0,
    "ceramic": 2400.0,
    "stone": 2700.0,
    "cardboard": 600.0,
    "wood_soft": 450.0,
    "wood_medium": 680.0,
    "wood_hard": 750.0,
    "fabric": 300.0,
    "leather": 900.0,
    "paper": 800.0,
    "rubber": 1100.0,
}


@pytest.fixture(scope="module")
def lib() -> MaterialLibrary:
    return load_materials(MATERIALS_DIR)


# -- object materials ---------------------------------------------------------------------------
def test_all_14_audio_materials_present(lib):
    assert len(AUDIO_MATERIALS) == 14
    bases = {ref for ref in lib.objects if "/" not in ref}
    assert bases == set(AUDIO_MATERIALS)
    for name in AUDIO_MATERIALS:
        m = lib.object(name)
        assert m.name == name and m.audio == name
        assert m.description and m.sources


def test_base_densities_are_the_agreed_ones(lib):
    # other code sizes object masses with these: they must not drift
    for name, rho in BASE_DENSITIES.items():
        assert lib.object(name).density_kg_m3 == rho, name


def test_required_grades_resolve_and_keep_audio_label(lib):
    for ref, rho in REQUIRED_GRADES.items():
        g = lib.object(ref)
        base = ref.split("/")[0]
        assert g.name == ref
        assert g.audio == base
        assert g.density_kg_m3 == rho, ref


def test_every_grade_keeps_base_label_contact_and_flag(lib):
    grades = [ref for ref in lib.objects if "/" in ref]
    assert len(grades) >= len(REQUIRED_GRADES)
    for ref in grades:
        base_name, grade = ref.split("/")
        g, base = lib.object(ref), lib.object(base_name)
        assert grade.isidentifier()
        assert g.audio == base_name
        assert g.resonant == base.resonant
        assert g.friction == base.friction
        if g.restitution == base.restitution:  # contact parameters go with the restitution
            assert g.solref == base.solref
        assert g.sources and g.description
        # a grade exists to change something: its mechanics, how it absorbs sound as a
        # furnishing (a rug, curtains: the fabric's mechanics, their own absorption), or how it
        # looks (books on shelves, a picture: the paper's physics)
        assert (g.density_kg_m3, g.youngs_modulus_pa, g.poisson_ratio, g.loss_factor,
                g.absorption, g.absorption_per, g.texture) != (
            base.density_kg_m3,
            base.youngs_modulus_pa,
            base.poisson_ratio,
            base.loss_factor,
            base.absorption,
            base.absorption_per,
            base.texture,
        ), ref


def test_unknown_object_reference_is_a_key_error(lib):
    with pytest.raises(KeyError):
        lib.object("metal/unobtainium")
    with pytest.raises(KeyError):
        lib.surface("lava")


def test_resonant_flag_false_exactly_for_soft_materials(lib):
    not_resonant = {name for name in AUDIO_MATERIALS if not lib.object(name).resonant}
    assert not_resonant == NOT_RESONANT


#: Measured speeds of longitudinal waves in thin bars, sqrt(E / rho) (m/s): Kinsler, Frey,
#: Coppens & Sanders, Fundamentals of Acoustics (4th ed., 2000), appendix A10 (aluminium
#: 5150, brass 3480, steel 5050, Pyrex glass 5170); what a material's E and rho give is held
#: within 10 % of them (alloys and glasses vary by about that)
BAR_SPEED_MPS = {"metal": 5050.0, "metal/aluminium": 5150.0, "metal/brass": 3480.0,
                 "glass": 5170.0}


def test_bar_wave_speed_plausible_for_resonant_materials(lib):
    for ref, want in BAR_SPEED_MPS.items():
        m = lib.object(ref)
        c = math.sqrt(m.youngs_modulus_pa / m.density_kg_m3)
        assert c == pytest.approx(want, rel=0.10), (ref, c, want)
    for ref, m in lib.objects.items():
        if not m.resonant:
            continue
        c = math.sqrt(m.youngs_modulus_pa / m.density_kg_m3)
        assert 300.0 <= c <= 7000.0, (ref, c)  # no resonant solid is slower or faster


def test_known_stiffness_ordering(lib):
    E = {name: lib.object(name).youngs_modulus_pa for name in AUDIO_MATERIALS}
    assert E["metal"] > E["glass"] > E["wood_hard"] > E["plastic_hard"] > E["rubber"]
    assert E["wood_soft"] <= E["wood_medium"] <= E["wood_hard"]
    assert E["plastic_soft_foam"] < 1e8 and E["rubber"] < 1e8 and E["fabric"] < 1e8


def test_loss_factors_ordered(lib):
    eta = {name: lib.object(name).loss_factor for name in AUDIO_MATERIALS}
    for ringing in ("metal", "glass", "ceramic"):
        for dull in ("wood_soft", "rubber", "plastic_soft_foam", "fabric", "leather"):
            assert eta[ringing] < eta[dull], (ringing, dull)
    for soft in NOT_RESONANT:
        assert eta[soft] > eta["metal"] * 5, soft
    assert lib.object("metal/battery_cell").loss_factor > eta["metal"]
    assert lib.object("wood_soft/cork").loss_factor > eta["wood_soft"]


def test_physical_ranges(lib):
    for ref, m in lib.objects.items():
        assert 0.0 <= m.poisson_ratio < 0.5, ref
        assert 0.0 < m.loss_factor <= 1.0, ref
        assert 0.1 <= m.friction_sliding <= 1.5, ref
        assert 1e-4 <= m.friction_torsional_m <= 0.02, ref
        assert 1e-6 <= m.friction_rolling_m <= 5e-3, ref
        assert len(m.rgba) == 4 and all(0.0 <= x <= 1.0 for x in m.rgba), ref
    assert lib.object("rubber").friction_sliding > lib.object("metal").friction_sliding


def test_contact_parameters(lib):
    """solref is fitted to restitution (tests/physics/test_calibrate.py checks the fit); here:
    the time constants respect the timestep, bouncy things are bouncy, soft things are not,
    and solmix is the compliance."""
    for ref, m in lib.objects.items():
        assert m.contact_timeconst_s >= 2 * TIMESTEP_S - 1e-12, ref
        assert 0 < m.contact_dampratio <= 2.0, ref
        assert m.solmix == pytest.approx(1e9 / m.youngs_modulus_pa), ref
    e = {ref: m.restitution for ref, m in lib.objects.items()}
    assert e["plastic_hard/golf_ball"] >= 0.75 and e["rubber"] >= 0.7
    for name in ("plastic_soft_foam", "fabric"):
        assert e[name] <= 0.1, name
    for name in ("metal", "glass", "ceramic", "stone", "wood_hard", "plastic_hard"):
        assert 0.4 <= e[name] <= 0.8, name
    assert min(AUDIO_MATERIALS, key=lambda n: e[n]) == "fabric"
    # a softer material sets the bounce of a pair
    assert lib.object("fabric").solmix > lib.object("wood_hard").solmix > lib.object("metal").solmix


# -- surfaces -----------------------------------------------------------------------------------
def test_surfaces_well_formed(lib):
    assert len(OCTAVE_BANDS_HZ) == 7
    for name, s in lib.surfaces.items():
        assert len(s.absorption) == 7, name
        assert all(0.0 <= a <= 1.0 for a in s.absorption), name
        assert 0.0 <= s.scattering <= 1.0, name
        assert s.uses and set(s.uses) <= set(SURFACE_USES), name
        assert s.sources, name
        lib.object(s.impact_material)  # resolves (grades allowed)


def test_every_use_has_surfaces(lib):
    for use in SURFACE_USES:
        usable = [n for n, s in lib.surfaces.items() if use in s.uses]
        assert len(usable) >= 3, use


def test_required_surfaces_present(lib):
    required = {
        "plaster_painted": {"wall", "ceiling"},
        "plaster_rough": {"wall"},
        "gypsum_board": {"wall"},
        "brick_bare": {"wall"},
        "brick_painted": {"wall"},
        "concrete_bare": {"wall", "floor"},
        "concrete_painted": {"wall"},
        "wood_parquet": {"floor"},
        "wood_planks": {"floor"},
        "wood_panel": {"wall"},
        "ceramic_tile": {"wall", "floor"},
        "marble": {"floor", "wall"},
        "linoleum": {"floor"},
        "carpet_thin": {"floor"},
        "carpet_thick": {"floor"},
        "acoustic_ceiling_tile": {"ceiling"},
        "glass_window": {"wall"},
    }
    for name, uses in required.items():
        assert uses <= set(lib.surface(name).uses), name
    assert any(
        lib.object(s.impact_material).audio == "fabric" and "wall" in s.uses
        for s in lib.surfaces.values()
    )


def test_absorption_relations(lib):
    band = {f: i for i, f in enumerate(OCTAVE_BANDS_HZ)}
    a = {name: s.absorption for name, s in lib.surfaces.items()}
    k2 = band[2000.0]
    k125 = band[125.0]
    assert a["carpet_thin"][k2] > a["ceramic_tile"][k2]
    assert a["carpet_thick"][k2] > a["carpet_thin"][k2]
    assert a["carpet_thick"][k2] > a["wood_parquet"][k2]
    assert sum(a["acoustic_ceiling_tile"]) / 7 > 0.5
    # light panels over an air space absorb low frequencies more than massive finishes
    assert a["gypsum_board"][k125] > a["plaster_painted"][k125]
    assert a["wood_planks"][k125] > a["wood_parquet"][k125]
    for hard in ("ceramic_tile", "marble", "concrete_painted", "brick_painted", "plaster_painted"):
        assert max(a[hard]) < 0.1, hard


def test_impact_materials_sound_like_the_finish(lib):
    audio = {name: lib.object(s.impact_material).audio for name, s in lib.surfaces.items()}
    assert audio["ceramic_tile"] == "ceramic"
    assert audio["glass_window"] == "glass"
    assert audio["carpet_thin"] == audio["carpet_thick"] == "fabric"
    assert audio["concrete_bare"] == "stone"
    assert audio["wood_parquet"].startswith("wood_")
    assert audio["linoleum"] == "plastic_hard"


def test_wood_is_hit_across_the_grain(lib):
    """An impact on a board's face meets the modulus across the grain (Wood Handbook: E_R / E_L
    ~0.07-0.16); isotropic materials (and cork) meet their Young's modulus."""
    for w in ("wood_soft", "wood_medium", "wood_hard"):
        m = lib.object(w)
        assert 0.07 <= m.contact_modulus_ratio <= 0.16
        assert m.contact_modulus_pa == pytest.approx(m.contact_modulus_ratio * m.youngs_modulus_pa)
    assert lib.object("wood_soft/cork").contact_modulus_ratio == 1.0
    assert lib.object("metal").contact_modulus_pa == lib.object("metal").youngs_modulus_pa


def test_what_rings_behind_a_finish(lib):
    """A finish bonded to a slab rings as the slab; boards and boards on studs as themselves."""
    s = lib.surfaces
    for bonded in ("wood_parquet", "ceramic_tile", "linoleum", "carpet_thin", "cork_floor"):
        assert s[bonded].structure_material == "stone", bonded
        assert s[bonded].structure_thickness_m >= 0.1, bonded
    assert s["wood_planks"].structure_material.startswith("wood_")
    assert s["wood_planks"].structure_thickness_m < 0.05
    # solid timber boards are orthotropic (E_T / E_L); slabs, panes and gypsum are not
    assert 0.03 < s["wood_planks"].structure_stiffness_ratio < 0.1
    assert s["glass_window"].structure_stiffness_ratio == 1.0
    assert s["gypsum_board"].structure_material == "stone/gypsum"
    assert s["glass_window"].structure_thickness_m < 0.01


# -- malformed files ----------------------------------------------------------------------------
def _copy(tmp_path: Path) -> Path:
    for fname in ("objects.toml", "surfaces.toml"):
        shutil.copy(MATERIALS_DIR / fname, tmp_path / fname)
    return tmp_path


def _edit(path: Path, table: str, key: str, line: str | None) -> None:
    """Replace (or with None delete) the ``key = ...`` line of ``[table]``; add it if missing."""
    lines = path.read_text(encoding="utf-8").splitlines()
    header = f"[{table}]"
    start = lines.index(header)
    end = next(
        (i for i in range(start + 1, len(lines)) if lines[i].startswith("[")), len(lines)
    )
    pattern = re.compile(rf"^{re.escape(key)}\s*=")
    hits = [i for i in range(start + 1, end) if pattern.match(lines[i])]
    if hits:
        first = last = hits[0]
        if lines[first].rstrip().endswith("["):  # a multi-line array: up to its closing "]"
            last = next(i for i in range(first + 1, end) if lines[i].strip() == "]")
        lines[first : last + 1] = [] if line is None else [line]
    else:
        assert line is not None, f"{key} not in [{table}]"
        lines.insert(start + 1, line)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _drop_table(path: Path, table: str) -> None:
    lines = path.read_text(encoding="utf-8").splitlines()
    out, skipping = [], False
    for ln in lines:
        if ln.startswith("["):
            name = ln.strip("[] ")
            skipping = name == table or name.startswith(table + ".")
        if not skipping:
            out.append(ln)
    path.write_text("\n".join(out) + "\n", encoding="utf-8")


def _expect_error(directory: Path, fname: str, field: str) -> InputError:
    with pytest.raises(InputError) as info:
        load_materials(directory)
    err = info.value
    text = str(err)
    assert "\n" not in text
    assert fname in text, text
    assert field in text, text
    assert Path(err.file).name == fname
    assert err.field == field
    return err


def test_copy_of_shipped_files_loads(tmp_path):
    lib = load_materials(_copy(tmp_path))
    assert lib.files == (tmp_path / "objects.toml", tmp_path / "surfaces.toml")


@pytest.mark.parametrize(
    "table, key, line, field",
    [
        ("metal", "density_kg_m3", None, "metal.density_kg_m3"),  # required field removed
        ("glass", "density_kg_m3", "density_kg_m3 = -2500", "glass.density_kg_m3"),
        ("rubber", "resonant", None, "rubber.resonant"),
        ("rubber", "resonant", 'resonant = "no"', "rubber.resonant"),
        ("ceramic", "poisson_ratio", "poisson_ratio = 0.5", "ceramic.poisson_ratio"),
        ("wood_soft", "loss_factor", "loss_factor = 0", "wood_soft.loss_factor"),
        ("paper", "youngs_modulus_pa", 'youngs_modulus_pa = "4 GPa"', "paper.youngs_modulus_pa"),
        ("metal", "densty", "densty = 7850", "metal.densty"),  # unknown extra field
        ("stone", "rgba", "rgba = [0.5, 0.5]", "stone.rgba"),
        ("leather", "sources", "sources = []", "leather.sources"),
        ("metal.grades.brass", "density_kg_m3", "density_kg_m3 = -1",
         "metal.grades.brass.density_kg_m3"),
        ("metal.grades.aluminium", "colour", 'colour = "grey"', "metal.grades.aluminium.colour"),
        ("metal.grades.aluminium", "resonant", "resonant = false",
         "metal.grades.aluminium.resonant"),
        ("metal.grades.brass", "description", None, "metal.grades.brass.description"),
        ("wood_hard", "contact_modulus_ratio", "contact_modulus_ratio = 2.0",
         "wood_hard.contact_modulus_ratio"),
        # a furniture part's acoustics: 7 octave bands in 0..1, a scattering coefficient
        ("fabric", "absorption", None, "fabric.absorption"),
        ("fabric", "absorption", "absorption = [0.4, 0.6, 0.8]", "fabric.absorption"),
        ("paper", "absorption", "absorption = [0.1, 0.1, 1.3, 0.1, 0.1, 0.1, 0.1]",
         "paper.absorption[2]"),
        ("wood_medium", "scattering", "scattering = 2", "wood_medium.scattering"),
        ("fabric", "absorption_per", 'absorption_per = "seat"', "fabric.absorption_per"),
        ("metal.grades.brass", "absorption", "absorption = [0.1]",
         "metal.grades.brass.absorption"),
    ],
)
def test_malformed_objects(tmp_path, table, key, line, field):
    d = _copy(tmp_path)
    _edit(d / "objects.toml", table, key, line)
    _expect_error(d, "objects.toml", field)


def test_missing_audio_material(tmp_path):
    d = _copy(tmp_path)
    _drop_table(d / "objects.toml", "paper")
    _expect_error(d, "objects.toml", "paper")


def test_unknown_audio_material(tmp_path):
    d = _copy(tmp_path)
    with (d / "objects.toml").open("a", encoding="utf-8") as f:
        f.write('\n[unobtainium]\ndescription = "x"\n')
    _expect_error(d, "objects.toml", "unobtainium")


@pytest.mark.parametrize("fname", ["objects.toml", "surfaces.toml"])
def test_toml_syntax_error(tmp_path, fname):
    d = _copy(tmp_path)
    with (d / fname).open("a", encoding="utf-8") as f:
        f.write("\n[broken\nthis is = = not toml\n")
    _expect_error(d, fname, "<syntax>")


@pytest.mark.parametrize("fname", ["objects.toml", "surfaces.toml"])
def test_missing_file(tmp_path, fname):
    d = _copy(tmp_path)
    (d / fname).unlink()
    _expect_error(d, fname, "<file>")


@pytest.mark.parametrize(
    "table, key, line, field",
    [
        ("ceramic_tile", "impact_material", 'impact_material = "unobtainium"',
         "ceramic_tile.impact_material"),
        ("ceramic_tile", "impact_material", 'impact_material = "metal/unobtainium"',
         "ceramic_tile.impact_material"),
        ("carpet_thick", "absorption", "absorption = [0.08, 0.24, 0.57, 0.69, 0.71, 0.73]",
         "carpet_thick.absorption"),
        ("marble", "absorption", "absorption = [0.01, 0.01, 1.2, 0.02, 0.02, 0.02, 0.02]",
         "marble.absorption[2]"),
        ("marble", "absorption", None, "marble.absorption"),
        ("linoleum", "uses", 'uses = ["roof"]', "linoleum.uses"),
        ("linoleum", "scattering", "scattering = -0.1", "linoleum.scattering"),
        ("glass_window", "absorbtion", "absorbtion = [0, 0, 0, 0, 0, 0, 0]",
         "glass_window.absorbtion"),
        ("brick_bare", "friction_sliding", None, "brick_bare.friction_sliding"),
        ("wood_parquet", "structure_material", 'structure_material = "adamantium"',
         "wood_parquet.structure_material"),
        ("wood_parquet", "structure_material", None, "wood_parquet.structure_material"),
        ("carpet_thin", "impact_improvement_db", "impact_improvement_db = [26, 18]",
         "carpet_thin.impact_improvement_db"),
        ("linoleum", "impact_improvement_db", "impact_improvement_db = [5]",
         "linoleum.impact_improvement_db"),
        ("wood_planks", "structure_thickness_m", "structure_thickness_m = 2.0",
         "wood_planks.structure_thickness_m"),
        ("wood_planks", "structure_stiffness_ratio", "structure_stiffness_ratio = 1.5",
         "wood_planks.structure_stiffness_ratio"),
        ("wood_planks", "structure_stiffness_ratio", 'structure_stiffness_ratio = "low"',
         "wood_planks.structure_stiffness_ratio"),
    ],
)
def test_malformed_surfaces(tmp_path, table, key, line, field):
    d = _copy(tmp_path)
    _edit(d / "surfaces.toml", table, key, line)
    _expect_error(d, "surfaces.toml", field)


def test_scattering_defaults_when_omitted(tmp_path):
    d = _copy(tmp_path)
    _edit(d / "surfaces.toml", "linoleum", "scattering", None)
    assert load_materials(d).surface("linoleum").scattering == pytest.approx(0.1)


def test_grade_inherits_missing_constants(tmp_path):
    d = _copy(tmp_path)
    _edit(d / "objects.toml", "metal.grades.brass", "poisson_ratio", None)
    _edit(d / "objects.toml", "metal.grades.brass", "rgba", None)
    lib = load_materials(d)
    assert lib.object("metal/brass").poisson_ratio == lib.object("metal").poisson_ratio
    assert lib.object("metal/brass").rgba == lib.object("metal").rgba
