"""Object (audio) materials and room surface materials.

Two TOML files under ``materials/``:

``objects.toml``
    The paper's 14 audio materials. Each gives what MuJoCo needs (density, friction, contact
    softness) and what modal synthesis needs (Young's modulus, Poisson ratio, density, loss
    factor). A material may have *grades* (``metal/aluminium``) that override physical constants
    but keep the audio label, so a soda can and a fork are both "metal" with the right mass.

``surfaces.toml``
    Wall, floor and ceiling finishes with octave-band absorption coefficients (125 Hz to 8 kHz)
    and the object material a surface sounds like when something hits it.

Units are SI throughout and spelled in the field names (``density_kg_m3``, ``youngs_modulus_pa``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from fallgen.errors import InputError
from fallgen.fields import Fields, load_toml
from fallgen.world.appearance import TextureSpec, parse_texture

#: The paper's 14 audio materials, in the paper's order.
AUDIO_MATERIALS: tuple[str, ...] = (
    "plastic_hard",
    "plastic_soft_foam",
    "glass",
    "metal",
    "ceramic",
    "stone",
    "cardboard",
    "wood_soft",
    "wood_hard",
    "wood_medium",
    "fabric",
    "leather",
    "paper",
    "rubber",
)

#: Octave-band centre frequencies of the absorption coefficients, Hz.
OCTAVE_BANDS_HZ: tuple[float, ...] = (125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0, 8000.0)

SURFACE_USES = ("wall", "floor", "ceiling")

_OBJECT_FIELDS = (
    "description",
    "density_kg_m3",
    "youngs_modulus_pa",
    "poisson_ratio",
    "loss_factor",
    "resonant",
    "friction_sliding",
    "friction_torsional_m",
    "friction_rolling_m",
    "restitution",
    "contact_timeconst_s",
    "contact_dampratio",
    "contact_modulus_ratio",
    "absorption",
    "scattering",
    "absorption_per",
    "rgba",
    "texture",
    "sources",
    "grades",
)
_GRADE_FIELDS = (
    "description",
    "density_kg_m3",
    "youngs_modulus_pa",
    "poisson_ratio",
    "loss_factor",
    "restitution",
    "contact_timeconst_s",
    "contact_dampratio",
    "contact_modulus_ratio",
    "absorption",
    "scattering",
    "absorption_per",
    "rgba",
    "texture",
    "sources",
)
_SURFACE_FIELDS = (
    "description",
    "absorption",
    "scattering",
    "impact_material",
    "structure_material",
    "structure_thickness_m",
    "structure_stiffness_ratio",
    "impact_improvement_db",
    "friction_sliding",
    "uses",
    "rgba",
    "texture",
    "sources",
)


@dataclass(frozen=True)
class ObjectMaterial:
    """Physical and modal constants of one object material (or one grade of it).

    ``name`` is the full reference (``metal`` or ``metal/aluminium``); ``audio`` is the paper's
    audio-material label, which is what the dataset reports.
    """

    name: str
    audio: str
    description: str
    density_kg_m3: float
    youngs_modulus_pa: float
    poisson_ratio: float
    loss_factor: float
    resonant: bool
    friction_sliding: float
    friction_torsional_m: float
    friction_rolling_m: float
    restitution: float  # coefficient of restitution against a rigid surface, 1-5 m/s
    contact_timeconst_s: float
    contact_dampratio: float
    rgba: tuple[float, float, float, float]
    sources: tuple[str, ...]
    #: the modulus a contact on the surface meets over ``youngs_modulus_pa`` (1: isotropic;
    #: wood is hit across the grain, E_R / E_L ~ 0.1)
    contact_modulus_ratio: float = 1.0
    #: a furniture part of the material as a room surface: random-incidence absorption per
    #: OCTAVE_BANDS_HZ band and scattering coefficient (the furnished room's acoustics)
    absorption: tuple[float, ...] = ()
    scattering: float = 0.1
    #: what ``absorption`` is per: "surface" (each m^2 of a part's exposed faces) or
    #: "seating_area" (each m^2 of an upholstered item's acoustical area: its footprint plus
    #: a 0.5 m strip along its free edges, as seating absorption is measured and tabled)
    absorption_per: str = "surface"
    #: how a furniture part of the material looks (its colour tints it); None: flat colour
    texture: TextureSpec | None = None

    @property
    def contact_modulus_pa(self) -> float:
        """Young's modulus an impact on the surface meets (the Hertz contact's)."""
        return self.youngs_modulus_pa * self.contact_modulus_ratio

    @property
    def friction(self) -> tuple[float, float, float]:
        """MuJoCo ``geom.friction``: sliding, torsional (m), rolling (m)."""
        return (self.friction_sliding, self.friction_torsional_m, self.friction_rolling_m)

    @property
    def solref(self) -> tuple[float, float]:
        """MuJoCo ``geom.solref``: contact time constant (s) and damping ratio."""
        return (self.contact_timeconst_s, self.contact_dampratio)

    @property
    def solmix(self) -> float:
        """MuJoCo ``geom.solmix``: the material's compliance in 1/GPa, so that in a contact the
        softer body's ``solref`` dominates (it stores most of the impact energy)."""
        return 1e9 / self.youngs_modulus_pa


@dataclass(frozen=True)
class SurfaceMaterial:
    """A room surface finish: absorption per octave band and how it sounds when hit."""

    name: str
    description: str
    absorption: tuple[float, ...]  # one per OCTAVE_BANDS_HZ
    scattering: float
    impact_material: str  # an ObjectMaterial reference: the finish a falling object meets
    #: what vibrates when the surface is hit (an ObjectMaterial reference) and how thick it is:
    #: the concrete slab under parquet or tiles, the boards on joists, a gypsum board on studs
    structure_material: str
    structure_thickness_m: float
    friction_sliding: float
    uses: tuple[str, ...]
    rgba: tuple[float, float, float, float]
    sources: tuple[str, ...]
    #: the structure's bending stiffness across its stiffer direction over along it (1: an
    #: isotropic slab, board or pane; ~0.06: solid timber boards, E_T / E_L)
    structure_stiffness_ratio: float = 1.0
    #: how the surface looks (its colour tints it); None: flat colour
    texture: TextureSpec | None = None
    #: a floor covering's measured weighted impact sound improvement Delta L_w (dB, ISO
    #: 10140-3 rated per ISO 717-2), low and high, that the rendered hits on it must reproduce
    #: (:func:`fallgen.audio.floors.covering_improvement`); None: not a covering, or no data
    impact_improvement_db: tuple[float, float] | None = None


@dataclass(frozen=True)
class MaterialLibrary:
    objects: Mapping[str, ObjectMaterial]  # keyed by full reference, grades included
    surfaces: Mapping[str, SurfaceMaterial]
    files: tuple[Path, ...] = field(default=())

    def object(self, ref: str) -> ObjectMaterial:
        try:
            return self.objects[ref]
        except KeyError:
            raise KeyError(f"unknown object material {ref!r}") from None

    def surface(self, ref: str) -> SurfaceMaterial:
        try:
            return self.surfaces[ref]
        except KeyError:
            raise KeyError(f"unknown surface material {ref!r}") from None

    def check_object_ref(self, f: Fields, key: str, ref: str) -> ObjectMaterial:
        """Resolve ``ref`` or raise an InputError naming ``f``'s file and ``key``."""
        if ref not in self.objects:
            raise f.error(key, f"unknown object material {ref!r} (known: {_short(self.objects)})")
        return self.objects[ref]

    def check_surface_ref(self, f: Fields, key: str, ref: str, use: str) -> SurfaceMaterial:
        if ref not in self.surfaces:
            raise f.error(
                key, f"unknown surface material {ref!r} (known: {_short(self.surfaces)})"
            )
        s = self.surfaces[ref]
        if use not in s.uses:
            raise f.error(key, f"surface material {ref!r} is not usable as a {use}")
        return s


def _short(names: Mapping[str, object]) -> str:
    keys = sorted(names)
    return ", ".join(keys[:12]) + (", ..." if len(keys) > 12 else "")


def _rgba(f: Fields, default: tuple[float, ...] | None = None) -> tuple[float, float, float, float]:
    if default is not None and "rgba" not in f:
        return default  # type: ignore[return-value]
    v = f.floats("rgba", lo=0.0, hi=1.0)
    if len(v) not in (3, 4):
        raise f.error("rgba", f"expected 3 or 4 numbers, got {len(v)}")
    return (v[0], v[1], v[2], v[3] if len(v) == 4 else 1.0)


def _sources(f: Fields) -> tuple[str, ...]:
    s = f.strs("sources")
    if not s:
        raise f.error("sources", "cite at least one source for the constants")
    return s


def _own_or_base(f: Fields, base: ObjectMaterial | None, key: str, read: Callable[[], Any]):
    """A grade's own ``key`` where it sets one, else its base material's (``read`` parses
    it; a base material always reads its own)."""
    return getattr(base, key) if base is not None and key not in f else read()


def _elastic(f: Fields, base: ObjectMaterial | None) -> dict:
    """Elastic and contact constants; a grade inherits what it does not override from its base."""

    def num(key: str, *default, **kw) -> float:
        return _own_or_base(f, base, key, lambda: f.float(key, *default, **kw))

    return dict(
        density_kg_m3=num("density_kg_m3", lo=1.0, hi=25000.0),
        youngs_modulus_pa=num("youngs_modulus_pa", lo=1e4, hi=1e12),
        poisson_ratio=num("poisson_ratio", lo=0.0, hi=0.4999),
        loss_factor=num("loss_factor", positive=True, hi=2.0),
        restitution=num("restitution", lo=0.0, hi=0.95),
        contact_timeconst_s=num("contact_timeconst_s", lo=0.004, hi=0.1),
        contact_dampratio=num("contact_dampratio", positive=True, hi=10.0),
        contact_modulus_ratio=num("contact_modulus_ratio", 1.0, lo=0.001, hi=1.0),
    )


#: What an object material's ``absorption`` is per (see :class:`ObjectMaterial`).
ABSORPTION_PER = ("surface", "seating_area")


def _acoustic(f: Fields, base: ObjectMaterial | None) -> dict:
    """A furniture part's absorption, scattering and what the absorption is per; a grade
    inherits them unless it sets them."""
    return dict(
        absorption=_own_or_base(f, base, "absorption", lambda: f.floats(
            "absorption", n=len(OCTAVE_BANDS_HZ), lo=0.0, hi=1.0)),
        scattering=_own_or_base(f, base, "scattering",
                                lambda: f.float("scattering", lo=0.0, hi=1.0)),
        absorption_per=_own_or_base(f, base, "absorption_per", lambda: f.str(
            "absorption_per", "surface", choices=ABSORPTION_PER)),
    )


def parse_object_materials(f: Fields) -> dict[str, ObjectMaterial]:
    out: dict[str, ObjectMaterial] = {}
    for name, m in f.items():
        if name not in AUDIO_MATERIALS:
            raise f.error(name, f"not one of the 14 audio materials ({', '.join(AUDIO_MATERIALS)})")
        base = ObjectMaterial(
            name=name,
            audio=name,
            description=m.str("description"),
            **_elastic(m, None),
            **_acoustic(m, None),
            resonant=m.bool("resonant"),
            friction_sliding=m.float("friction_sliding", lo=0.0, hi=3.0),
            friction_torsional_m=m.float("friction_torsional_m", lo=0.0, hi=0.1),
            friction_rolling_m=m.float("friction_rolling_m", lo=0.0, hi=0.1),
            rgba=_rgba(m),
            texture=parse_texture(m) if "texture" in m else None,
            sources=_sources(m),
        )
        out[name] = base
        if "grades" in m:
            for gname, g in m.table("grades").items():
                if not gname.isidentifier():
                    raise m.error(f"grades.{gname}", "grade names are identifiers")
                ref = f"{name}/{gname}"
                out[ref] = replace(
                    base,
                    name=ref,
                    description=g.str("description"),
                    rgba=_rgba(g, base.rgba),
                    texture=_own_or_base(g, base, "texture", lambda: parse_texture(g)),
                    sources=_sources(g),
                    **_elastic(g, base),
                    **_acoustic(g, base),
                )
                g.reject_unknown(_GRADE_FIELDS)
        m.reject_unknown(_OBJECT_FIELDS)
    missing = [a for a in AUDIO_MATERIALS if a not in out]
    if missing:
        raise InputError(f.file, missing[0], "missing audio material (all 14 are required)")
    return out


def parse_surface_materials(f: Fields, objects: Mapping[str, ObjectMaterial]) -> dict:
    out: dict[str, SurfaceMaterial] = {}
    for name, s in f.items():
        absorption = s.floats("absorption", n=len(OCTAVE_BANDS_HZ), lo=0.0, hi=1.0)
        impact = s.str("impact_material")
        if impact not in objects:
            raise s.error("impact_material", f"unknown object material {impact!r}")
        structure = s.str("structure_material")
        if structure not in objects:
            raise s.error("structure_material", f"unknown object material {structure!r}")
        uses = s.strs("uses")
        for u in uses:
            if u not in SURFACE_USES:
                raise s.error("uses", f"{u!r} is not one of {', '.join(SURFACE_USES)}")
        out[name] = SurfaceMaterial(
            name=name,
            description=s.str("description"),
            absorption=absorption,
            scattering=s.float("scattering", 0.1, lo=0.0, hi=1.0),
            impact_material=impact,
            structure_material=structure,
            structure_thickness_m=s.float("structure_thickness_m", lo=0.002, hi=0.5),
            structure_stiffness_ratio=s.float("structure_stiffness_ratio", 1.0, lo=0.01,
                                              hi=1.0),
            friction_sliding=s.float("friction_sliding", lo=0.0, hi=3.0),
            uses=uses,
            rgba=_rgba(s),
            texture=parse_texture(s) if "texture" in s else None,
            sources=_sources(s),
            impact_improvement_db=s.floats("impact_improvement_db", n=2, lo=0.0, hi=60.0,
                                           increasing=True)
            if "impact_improvement_db" in s else None,
        )
        s.reject_unknown(_SURFACE_FIELDS)
    return out


def load_materials(directory: str | Path) -> MaterialLibrary:
    """Load and validate ``objects.toml`` and ``surfaces.toml`` from ``directory``."""
    directory = Path(directory)
    obj_file, surf_file = directory / "objects.toml", directory / "surfaces.toml"
    objects = parse_object_materials(load_toml(obj_file))
    surfaces = parse_surface_materials(load_toml(surf_file), objects)
    return MaterialLibrary(objects=objects, surfaces=surfaces, files=(obj_file, surf_file))
