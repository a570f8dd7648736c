"""Object categories: procedural or user meshes, materials, sizes, and the physical instance.

``objects/categories.toml`` lists the paper's 31 target categories and the occluders. Each
category has one or more *variants* (a procedural shape from :mod:`fallgen.world.shapes`, or a
user mesh file), the materials it is really made of (with sampling weights) and a scale range.
A user adds a category from a mesh file with no code change::

    [teapot]
    description = "Teapot"
    role = "target"
    materials = { ceramic = 1.0 }
    scale = [0.9, 1.1]
    [[teapot.variants]]
    name = "mesh"
    mesh = "meshes/teapot.obj"   # relative to this file; OBJ, STL, PLY, GLB
    size_m = 0.22                # longest bounding-box edge after loading
    collision = "hull"           # or "decompose" (V-HACD; pip install fallgen[decompose])

An :class:`ObjectInstance` is one drawn object: category, variant, material grade and scale,
with its mass and inertia computed from the watertight visual mesh.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fallgen.cache import CORRUPT_ENTRY, cache_root
from fallgen.errors import InputError
from fallgen.fields import Fields, load_toml
from fallgen.world.materials import MaterialLibrary, ObjectMaterial
from fallgen.world.shell import ThinShell

ROLES = ("target", "occluder")
MESH_SUFFIXES = (".obj", ".stl", ".ply", ".glb", ".gltf", ".off")
_CATEGORY_FIELDS = ("description", "role", "materials", "scale", "variants")
_VARIANT_FIELDS = ("name", "shape", "params", "mesh", "size_m", "collision", "materials")


@dataclass(frozen=True)
class Variant:
    name: str
    shape: str | None  # procedural generator name, or None for a mesh file
    params: Mapping[str, float | int | bool]
    mesh: Path | None
    size_m: float | None
    collision: str  # "procedural", "hull" or "decompose"
    materials: Mapping[str, float]  # material reference -> sampling weight


@dataclass(frozen=True)
class Category:
    id: str
    description: str
    role: str
    scale: tuple[float, float]
    variants: tuple[Variant, ...]
    file: Path

    def variant(self, name: str) -> Variant:
        for v in self.variants:
            if v.name == name:
                return v
        raise KeyError(f"category {self.id!r} has no variant {name!r}")


@dataclass(frozen=True)
class ObjectGeometry:
    """A variant's geometry at scale 1, in its own frame (metres)."""

    vertices: np.ndarray  # (n, 3) visual mesh
    faces: np.ndarray  # (m, 3) int
    collision: tuple[np.ndarray, ...]  # convex pieces, vertex arrays
    volume_m3: float
    com: np.ndarray  # (3,) centre of volume
    inertia_per_density: np.ndarray  # (3, 3) about com, for density 1 kg/m^3
    shell: ThinShell | None = None  # thin sheet walls (their modes come from shell theory)

    @functools.cached_property
    def extents(self) -> np.ndarray:
        e = self.vertices.max(axis=0) - self.vertices.min(axis=0)
        e.flags.writeable = False
        return e


@dataclass(frozen=True)
class ObjectInstance:
    """One concrete object: what a trial drops, a distractor, or an occluder."""

    category: str
    variant: str
    material: ObjectMaterial
    scale: float
    geometry: ObjectGeometry

    @property
    def mass_kg(self) -> float:
        return self.material.density_kg_m3 * self.geometry.volume_m3 * self.scale**3

    @property
    def com(self) -> np.ndarray:
        return self.geometry.com * self.scale

    @property
    def inertia(self) -> np.ndarray:
        """Inertia tensor about the centre of mass, kg m^2."""
        return self.material.density_kg_m3 * self.geometry.inertia_per_density * self.scale**5

    @property
    def extents_m(self) -> np.ndarray:
        return self.geometry.extents * self.scale


class CategoryLibrary:
    """The categories of one or more category files, with a per-library geometry cache."""

    def __init__(self, categories: Mapping[str, Category], materials: MaterialLibrary) -> None:
        self.categories = dict(categories)
        self.materials = materials
        self._geometry: dict[tuple[str, str], ObjectGeometry] = {}
        self._nominal: dict[str, float] = {}

    def __getitem__(self, cid: str) -> Category:
        return self.categories[cid]

    def __contains__(self, cid: str) -> bool:
        return cid in self.categories

    def __iter__(self):
        return iter(self.categories.values())

    def __len__(self) -> int:
        return len(self.categories)

    def ids(self, role: str | None = None) -> list[str]:
        return [c.id for c in self.categories.values() if role is None or c.role == role]

    def geometry(self, cid: str, variant: str) -> ObjectGeometry:
        key = (cid, variant)
        if key not in self._geometry:
            cat = self.categories[cid]
            self._geometry[key] = cached_geometry(cat, cat.variant(variant))
        return self._geometry[key]

    def instance(self, cid: str, variant: str, material: str, scale: float = 1.0) -> ObjectInstance:
        cat = self.categories[cid]
        v = cat.variant(variant)
        if material not in v.materials:
            raise KeyError(f"{cid}/{variant} is not made of {material!r}")
        return ObjectInstance(cid, variant, self.materials.object(material), float(scale),
                              self.geometry(cid, variant))

    def nominal_size_m(self, cid: str) -> float:
        """Longest bounding-box edge of a category, averaged over its variants, at scale 1."""
        if cid not in self._nominal:
            cat = self.categories[cid]
            self._nominal[cid] = float(np.mean([self.geometry(cid, v.name).extents.max()
                                                for v in cat.variants]))
        return self._nominal[cid]

    def distractors_for(self, cid: str, ratio: float = 2.0) -> list[str]:
        """Target categories of similar size to ``cid`` (longest edges within ``ratio``), which
        make plausible distractors: a golf ball among corks and batteries, not toasters."""
        size = self.nominal_size_m(cid)
        return [c for c in self.ids("target") if c != cid
                and 1 / ratio <= self.nominal_size_m(c) / size <= ratio]

    def sample(self, rng: np.random.Generator, cid: str) -> ObjectInstance:
        """Draw a variant, a material (by weight) and a scale for category ``cid``."""
        cat = self.categories[cid]
        v = cat.variants[int(rng.integers(len(cat.variants)))]
        names = sorted(v.materials)
        w = np.array([v.materials[n] for n in names])
        material = names[int(rng.choice(len(names), p=w / w.sum()))]
        scale = float(rng.uniform(*cat.scale))
        return self.instance(cid, v.name, material, scale)


# --- parsing ------------------------------------------------------------------------------------

def _materials(f: Fields, key: str, mats: MaterialLibrary) -> dict[str, float]:
    t = f.table(key)
    out = {}
    for ref in t.keys():
        mats.check_object_ref(t, ref, ref)
        out[ref] = t.float(ref, positive=True)
    if not out:
        raise f.error(key, "at least one material is required")
    return out


def _variant(f: Fields, default_materials: dict[str, float] | None,
             mats: MaterialLibrary) -> Variant:
    from fallgen.world.shapes import SHAPES

    name = f.str("name")
    materials = _materials(f, "materials", mats) if "materials" in f else default_materials
    if materials is None:
        raise f.error("materials", "missing (give it on the category or the variant)")
    if ("shape" in f) == ("mesh" in f):
        raise f.error("shape", "give exactly one of shape (procedural) or mesh (a file)")
    if "shape" in f:
        shape = f.str("shape")
        if shape not in SHAPES:
            raise f.error("shape", f"unknown procedural shape {shape!r}")
        params = dict(f.table("params").data) if "params" in f else {}
        f.reject_unknown(("name", "shape", "params", "materials"))
        return Variant(name, shape, params, None, None, "procedural", materials)
    mesh = (f.file.parent / f.str("mesh")).resolve()
    if mesh.suffix.lower() not in MESH_SUFFIXES:
        raise f.error("mesh", f"unsupported mesh format {mesh.suffix!r} ({', '.join(MESH_SUFFIXES)})")
    if not mesh.is_file():
        raise f.error("mesh", f"file not found: {mesh}")
    size = f.float("size_m", positive=True, hi=2.0)
    collision = f.str("collision", "hull", choices=("hull", "decompose"))
    f.reject_unknown(("name", "mesh", "size_m", "collision", "materials"))
    return Variant(name, None, {}, mesh, size, collision, materials)


def parse_categories(f: Fields, mats: MaterialLibrary) -> dict[str, Category]:
    out = {}
    for cid, c in f.items():
        if not cid.replace("_", "").isalnum() or not cid.islower():
            raise f.error(cid, "category ids are lower-case snake_case")
        role = c.str("role", "target", choices=ROLES)
        materials = _materials(c, "materials", mats) if "materials" in c else None
        lo, hi = c.floats("scale", [1.0, 1.0], n=2, positive=True, increasing=True)
        if hi > 3 or lo < 0.2:
            raise c.error("scale", f"scale range [{lo}, {hi}] is implausible (0.2 .. 3)")
        variants = tuple(_variant(v, materials, mats) for v in c.tables("variants"))
        if not variants:
            raise c.error("variants", "at least one variant is required")
        names = [v.name for v in variants]
        if len(set(names)) != len(names):
            raise c.error("variants", "variant names must be unique")
        description = c.str("description")
        c.reject_unknown(_CATEGORY_FIELDS)
        out[cid] = Category(cid, description, role, (lo, hi), variants, f.file)
    return out


def load_categories(directory: str | Path, mats: MaterialLibrary) -> CategoryLibrary:
    """All ``*.toml`` category files in ``directory`` (later files may add categories)."""
    directory = Path(directory)
    files = sorted(directory.glob("*.toml"))
    if not files:
        raise InputError(directory, "<dir>", "no category files (*.toml) found")
    cats: dict[str, Category] = {}
    for p in files:
        f = load_toml(p)
        for cid, cat in parse_categories(f, mats).items():
            if cid in cats:
                raise f.error(cid, f"category already defined in {cats[cid].file.name}")
            cats[cid] = cat
    lib = CategoryLibrary(cats, mats)
    for cat in cats.values():  # user meshes are checked now, not when a trial first draws them
        for v in cat.variants:
            if v.mesh is not None:
                lib.geometry(cat.id, v.name)
    return lib


# --- geometry -----------------------------------------------------------------------------------

def _mass_properties(vertices: np.ndarray, faces: np.ndarray) -> tuple[float, np.ndarray,
                                                                      np.ndarray]:
    import trimesh

    m = trimesh.Trimesh(vertices, faces, process=False)
    mp = m.mass_properties  # density 1
    return float(mp["volume"]), np.asarray(mp["center_mass"]), np.asarray(mp["inertia"])


def build_geometry(cat: Category, v: Variant) -> ObjectGeometry:
    """Build a variant's geometry at scale 1. Raises InputError for a bad mesh or shape params."""
    import trimesh

    where = f"{cat.id}.variants[{cat.variants.index(v)}]"
    if v.shape is not None:
        from fallgen.world.shapes import make_shape

        try:
            shape = make_shape(v.shape, v.params)
        except (TypeError, ValueError, KeyError) as e:
            raise InputError(cat.file, f"{where}.params", str(e).strip("'\"")) from None
        mesh, collision = shape.visual, tuple(np.asarray(c, float) for c in shape.collision)
        shell = shape.shell
    else:
        shell = None
        assert v.mesh is not None and v.size_m is not None
        try:
            mesh = trimesh.load(v.mesh, force="mesh", process=True)
        except Exception as e:  # trimesh raises many types for broken files
            raise InputError(v.mesh, "<mesh>", f"cannot read mesh: {e}") from None
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise InputError(v.mesh, "<mesh>", "no triangles found")
        trimesh.repair.fix_normals(mesh)
        if not mesh.is_watertight:
            raise InputError(v.mesh, "<mesh>", "mesh is not watertight (mass and modes need a "
                             "closed surface)")
        lo, hi = mesh.bounds
        mesh.apply_translation(-(lo + hi) / 2)
        mesh.apply_scale(v.size_m / float((hi - lo).max()))
        if v.collision == "hull":
            collision = (np.asarray(mesh.convex_hull.vertices, float),)
        else:
            try:
                parts = mesh.convex_decomposition()
            except Exception as e:
                raise InputError(cat.file, f"{where}.collision",
                                 f"convex decomposition failed ({e}); install fallgen[decompose] "
                                 "or use collision = \"hull\"") from None
            parts = parts if isinstance(parts, list) else [parts]
            collision = tuple(np.asarray(p.vertices, float) for p in parts)
    # C order throughout, as arrays loaded from the geometry cache are
    vertices = np.ascontiguousarray(mesh.vertices, float)
    faces = np.ascontiguousarray(mesh.faces, np.int64)
    collision = tuple(np.ascontiguousarray(c, float) for c in collision)
    volume, com, inertia = _mass_properties(vertices, faces)
    if not volume > 0:
        raise InputError(v.mesh or cat.file, where, f"mesh volume is {volume:g} m^3 (inside out?)")
    return ObjectGeometry(vertices, faces, collision, volume, np.ascontiguousarray(com, float),
                          np.ascontiguousarray(inertia, float), shell)


# --- the geometry cache -------------------------------------------------------------------------

#: Bump when the stored layout changes.
GEOMETRY_CACHE_VERSION = 1


@functools.cache
def _generator_source_digest() -> str:
    """A hash of the code that builds procedural geometry (the shape generators, the mesh kit,
    this module and the shell description)."""
    here = Path(__file__).parent
    files = sorted([*here.glob("shapes/*.py"), *here.glob("meshkit/*.py"), here / "objects.py",
                    here / "shell.py"])
    h = hashlib.sha256()
    for f in files:
        h.update(f.name.encode() + f.read_bytes())
    return h.hexdigest()


def _geometry_cache_file(v: Variant) -> Path:

    spec = json.dumps([GEOMETRY_CACHE_VERSION, v.shape, sorted(v.params.items())])
    key = hashlib.sha256((_generator_source_digest() + spec).encode()).hexdigest()[:24]
    return cache_root() / "geometry" / f"{v.shape}-{key}.npz"


def _save_geometry(path: Path, g: ObjectGeometry) -> None:
    import io

    from fallgen.atomic import write_bytes

    shell = None if g.shell is None else [g.shell.kind, list(g.shell.size), g.shell.thickness,
                                          list(g.shell.center)]
    arrays = {"vertices": g.vertices, "faces": g.faces, "com": g.com,
              "inertia": g.inertia_per_density, "volume": np.array([g.volume_m3]),
              "shell": np.array(json.dumps(shell))}
    arrays.update({f"collision{i}": c for i, c in enumerate(g.collision)})
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    write_bytes(path, buf.getvalue())


def _load_geometry(path: Path) -> ObjectGeometry:
    with np.load(path) as z:
        n = sum(1 for k in z.files if k.startswith("collision"))
        shell = json.loads(str(z["shell"]))
        return ObjectGeometry(
            z["vertices"], z["faces"], tuple(z[f"collision{i}"] for i in range(n)),
            float(z["volume"][0]), z["com"], z["inertia"],
            None if shell is None else ThinShell(shell[0], tuple(shell[1]), shell[2],
                                                 tuple(shell[3])))


def cached_geometry(cat: Category, v: Variant) -> ObjectGeometry:
    """:func:`build_geometry`, through the geometry cache for procedural shapes (user meshes
    are loaded from their files). Loaded arrays are identical to freshly built ones."""
    if v.shape is None:
        return build_geometry(cat, v)
    path = _geometry_cache_file(v)
    if path.exists():
        try:
            return _load_geometry(path)
        except CORRUPT_ENTRY:
            path.unlink(missing_ok=True)  # a corrupt entry is rebuilt
    g = build_geometry(cat, v)
    try:
        _save_geometry(path, g)
    except OSError:
        pass  # a read-only cache: just build every time
    return g
