"""Room specifications and the room variants built from them.

One TOML file per base room under ``rooms/``: its kind (kitchen or study), interior size, wall
/floor/ceiling material sets and furniture layouts, each layout with its fall zones. A *variant*
is one (layout, material set) pair: 8 base rooms x 4 layouts x 2 material sets = 64 variants,
with ids such as ``kitchen_galley-l2-m1``.

World frame: origin at the south-west floor corner of the room's interior, x east, y north,
z up; the interior spans [0, Lx] x [0, Ly] x [0, H]. Yaw is counter-clockwise from +x.
"""

from __future__ import annotations

import fnmatch
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fallgen.errors import InputError
from fallgen.fields import Fields, load_toml
from fallgen.world.furniture import (
    FURNITURE,
    TYPE_DEFAULT_PARAMS,
    ZONE_KINDS,
    Anchor,
    Part,
)
from fallgen.world.geometry import Box
from fallgen.world.materials import MaterialLibrary, SurfaceMaterial

ROOM_KINDS = ("kitchen", "study")
WALLS = ("south", "north", "west", "east")
#: Yaw that turns a wall-placed item's back (+y local) toward the wall.
WALL_YAW = {"north": 0.0, "south": math.pi, "east": -math.pi / 2, "west": math.pi / 2}
#: The six shoebox faces in a fixed order (used by the acoustics).
SHOEBOX_FACES = ("west", "east", "south", "north", "floor", "ceiling")

_ID = re.compile(r"^[a-z][a-z0-9_]*$")
_ROOM_FIELDS = ("id", "kind", "name", "description", "size_m", "materials", "layouts")
_FURN_FIELDS = ("id", "type", "size", "pos", "yaw_deg", "wall", "along", "gap", "z_m", "params",
                "materials", "rgba", "sets")
_ZONE_FIELDS = ("on", "rect", "distractors", "occluders", "drop_z")

#: Drop regions stop this far below the ceiling or an obstruction (m).
DROP_CLEARANCE_M = 0.02
#: Settle volume height of a floor zone (m).
FLOOR_ZONE_HEIGHT_M = 0.3


@dataclass(frozen=True)
class FurnitureItem:
    """A furniture item placed in a room variant; parts and anchors in world coordinates."""

    id: str
    type: str
    pose: tuple[float, float, float, float]  # x, y, z, yaw (rad) of the local frame
    size: tuple[float, float, float]
    parts: tuple[Part, ...]
    anchors: Mapping[str, Anchor]
    wall: str | None = None
    #: The material sets the item is in (a set's soft furnishings: rugs, curtains); None: all
    sets: tuple[str, ...] | None = None

    @property
    def floor_covering(self) -> bool:
        return FURNITURE[self.type].floor_covering


@dataclass(frozen=True)
class Zone:
    """A fall zone: where a dropped object must come to rest for the trial to be kept.

    ``volume`` is the settle volume (the object's centre of mass must end inside it); ``drop`` is
    the region starting poses are drawn from. ``open_above`` says the drop region reaches up to
    the ceiling (a rehearsal clamps its configured drop heights into it); otherwise it is a cavity
    (between shelf boards, under a table) and drops start inside it when it is tall enough for
    a real fall, beside it otherwise; under furniture they always start beside it, above the
    cover (:func:`fallgen.physics.drop.run_trial`).
    """

    id: str
    index: int
    kind: str
    anchor: str  # "floor" or "<furniture id>.<anchor name>"
    support: str  # "floor" or "<furniture id>/<part name>"
    volume: Box
    drop: Box
    open_above: bool
    distractors: int
    occluders: tuple[str, ...]


@dataclass(frozen=True)
class Shoebox:
    """The acoustic shoebox of a variant: interior size and the material of each face."""

    size_m: tuple[float, float, float]
    faces: Mapping[str, SurfaceMaterial]  # keys: SHOEBOX_FACES

    def absorption(self) -> list[tuple[float, ...]]:
        """Per face (SHOEBOX_FACES order), absorption coefficients per octave band."""
        return [self.faces[f].absorption for f in SHOEBOX_FACES]


@dataclass(frozen=True)
class RoomVariant:
    id: str
    room: str
    kind: str
    name: str
    layout: str
    material_set: str
    size_m: tuple[float, float, float]
    surfaces: Mapping[str, SurfaceMaterial]  # SHOEBOX_FACES -> material
    furniture: tuple[FurnitureItem, ...]
    zones: tuple[Zone, ...]
    file: Path

    def shoebox(self) -> Shoebox:
        return Shoebox(self.size_m, dict(self.surfaces))

    def parts(self) -> Iterable[tuple[FurnitureItem, Part]]:
        for item in self.furniture:
            for part in item.parts:
                yield item, part

    def zone(self, zone_id: str) -> Zone:
        for z in self.zones:
            if z.id == zone_id:
                return z
        raise KeyError(f"{self.id} has no zone {zone_id!r}")


@dataclass(frozen=True)
class RoomSpec:
    """One base room file: its layouts and material sets, parsed and validated."""

    id: str
    kind: str
    name: str
    size_m: tuple[float, float, float]
    variants: tuple[RoomVariant, ...]
    file: Path
    layouts: tuple[str, ...] = field(default=())
    material_sets: tuple[str, ...] = field(default=())


# --- parsing ------------------------------------------------------------------------------------

def _check_id(f: Fields, key: str, value: str) -> str:
    if not _ID.match(value):
        raise f.error(key, f"{value!r} must be lower-case letters, digits and underscores")
    return value


def _material_set(f: Fields, mats: MaterialLibrary) -> dict[str, SurfaceMaterial]:
    faces = {
        "floor": mats.check_surface_ref(f, "floor", f.str("floor"), "floor"),
        "ceiling": mats.check_surface_ref(f, "ceiling", f.str("ceiling"), "ceiling"),
    }
    walls = f.raw("walls")
    if isinstance(walls, str):
        w = mats.check_surface_ref(f, "walls", walls, "wall")
        faces.update({side: w for side in WALLS})
    else:
        wf = f.table("walls")
        for side in WALLS:
            faces[side] = mats.check_surface_ref(wf, side, wf.str(side), "wall")
        wf.reject_unknown(WALLS)
    f.reject_unknown(("floor", "ceiling", "walls"))
    return faces


def _place(f: Fields, size_room: tuple[float, float, float],
           size: tuple[float, float, float]) -> tuple[tuple[float, float, float, float], str | None,
                                                      float]:
    """Pose (x, y, z, yaw) of a furniture item's local frame, its wall, and its gap to the wall."""
    lx, ly, _ = size_room
    w, d, _ = size
    z = f.float("z_m", 0.0, lo=0.0)
    if "wall" in f:
        if "pos" in f or "yaw_deg" in f:
            raise f.error("wall", "give either wall/along/gap or pos/yaw_deg, not both")
        wall = f.str("wall", choices=WALLS)
        along = f.float("along")
        gap = f.float("gap", 0.0, lo=0.0, hi=2.0)
        off = gap + d / 2
        x, y = {
            "north": (along, ly - off),
            "south": (along, off),
            "east": (lx - off, along),
            "west": (off, along),
        }[wall]
        return (x, y, z, WALL_YAW[wall]), wall, gap
    pos = f.floats("pos", n=2)
    yaw = math.radians(f.float("yaw_deg", 0.0, lo=-360.0, hi=360.0))
    return (pos[0], pos[1], z, yaw), None, 0.0


def _furniture(f: Fields, size_room, mats: MaterialLibrary) -> FurnitureItem:
    fid = _check_id(f, "id", f.str("id"))
    ftype = f.str("type", choices=sorted(FURNITURE))
    spec = FURNITURE[ftype]
    size = f.floats("size", n=3, positive=True)
    if min(size) < 0.02:
        raise f.error("size", "every dimension must be at least 0.02 m (collision thickness)")
    pose, wall, gap = _place(f, size_room, size)
    if spec.wall_hung and (wall is None or gap > 0 or pose[2] <= 0):
        raise f.error("wall" if wall is None else "gap" if gap > 0 else "z_m",
                      f"a {ftype} hangs on a wall: give wall, along and z_m (its bottom edge), "
                      "no gap")
    roles = dict(spec.materials)
    if "materials" in f:
        mf = f.table("materials")
        for role in mf.keys():
            if role not in roles:
                raise mf.error(role, f"{ftype} has no part role {role!r} ({', '.join(roles)})")
            roles[role] = mats.check_object_ref(mf, role, mf.str(role)).name
    params_raw = dict(TYPE_DEFAULT_PARAMS.get(ftype, {}))
    if "params" in f:
        params_raw.update(f.table("params").data)
    params = Fields(params_raw, f.file, f.path("params"))
    try:
        geom = spec.build(size[0], size[1], size[2], params)
    except ValueError as e:
        raise f.error("size", str(e)) from None
    params.reject_unknown()
    rgba = None
    if "rgba" in f:
        v = f.floats("rgba", lo=0.0, hi=1.0)
        if len(v) not in (3, 4):
            raise f.error("rgba", "expected 3 or 4 numbers")
        rgba = (v[0], v[1], v[2], v[3] if len(v) == 4 else 1.0)
    x, y, z, yaw = pose
    parts = tuple(
        Part(p.name, p.shape, p.box.placed((x, y), yaw, z), roles[p.material],
             rgba if rgba is not None else spec.colors[p.material], role=p.material,
             decor=p.decor)
        for p in geom.parts
    )
    anchors = {k: Anchor(a.kind, a.volume.placed((x, y), yaw, z), a.support)
               for k, a in geom.anchors.items()}
    # The strip between the item's back and the wall (or behind a free-standing item).
    behind_depth = gap if wall is not None else 0.3
    if behind_depth >= 0.12 and z == 0.0 and spec.has_behind:
        w, d, h = size
        vol = Box.from_bounds((-w / 2 + 0.03, d / 2 + 0.02, 0.0),
                              (w / 2 - 0.03, d / 2 + behind_depth - 0.02, min(h, 0.4)))
        anchors["behind"] = Anchor("behind_furniture", vol.placed((x, y), yaw, z), "floor")
    sets = tuple(_check_id(f, "sets", k) for k in f.strs("sets")) if "sets" in f else None
    if sets is not None and not sets:
        raise f.error("sets", "an item in no material set: list at least one, or leave it out")
    f.reject_unknown(_FURN_FIELDS)
    return FurnitureItem(fid, ftype, pose, size, parts, anchors, wall, sets)


def _drop_region(volume: Box, size_room, parts: _Footprints) -> tuple[Box, bool, str]:
    """The column above a zone's settle volume, up to the ceiling or the lowest obstruction
    (a furniture part above the volume whose footprint overlaps it by more than 5 mm).

    Returns the region, whether it is open up to the ceiling, and what bounds it from above.
    """
    above = (parts.zmin >= volume.zmin + 0.01) & (parts.zmin < size_room[2])
    hit = np.nonzero(above)[0]
    hit = hit[parts.overlap(hit, volume) > 0.005]
    if len(hit) == 0:
        lowest, by = size_room[2], "ceiling"
    else:
        k = hit[int(np.argmin(parts.zmin[hit]))]  # the first of the lowest
        lowest, by = float(parts.zmin[k]), parts.names[k]
    return volume.with_z(volume.zmin + 0.005, lowest - DROP_CLEARANCE_M), by == "ceiling", by


class _Footprints:
    """The footprints of every furniture part of a layout, for many overlap tests at once
    (:func:`fallgen.world.geometry.overlap2d`, vectorised: the zones of the 64 variants made
    ~21000 calls, 2 s of every process's start)."""

    def __init__(self, furniture: Iterable[FurnitureItem]) -> None:
        boxes = [(f"{item.id}/{p.name}", p.box) for item in furniture for p in item.parts]
        self.names = [n for n, _ in boxes]
        self.zmin = np.array([b.zmin for _, b in boxes], float)
        self.corners = np.array([b.corners2d() for _, b in boxes], float).reshape(-1, 4, 2)
        self.axes = np.array([b.axes2d() for _, b in boxes], float).reshape(-1, 2, 2)

    def overlap(self, idx: np.ndarray, box: Box) -> np.ndarray:
        """overlap2d(part, box) of the parts ``idx``: the separating-axis depth over both
        boxes' axes."""
        cb, ab = box.corners2d(), box.axes2d()
        axes = np.concatenate([self.axes[idx], np.broadcast_to(ab, (len(idx), 2, 2))], axis=1)
        ca = self.corners[idx]
        # projections (parts, axes, corners): x * ax + y * ay, as ``corners @ axis``
        pa = ca[:, None, :, 0] * axes[:, :, None, 0] + ca[:, None, :, 1] * axes[:, :, None, 1]
        pb = cb[None, None, :, 0] * axes[:, :, None, 0] + cb[None, None, :, 1] * axes[:, :, None, 1]
        depth = np.minimum(pa.max(2), pb.max(2)) - np.maximum(pa.min(2), pb.min(2))
        return depth.min(1)


def _zones(fs: list[Fields], furniture: tuple[FurnitureItem, ...], size_room,
           occluder_names: frozenset[str] | None, material_set: str = "",
           elsewhere: frozenset[str] = frozenset()) -> tuple[Zone, ...]:
    """The zones of a layout over ``furniture``, its items in ``material_set``; ``elsewhere``:
    the layout's items that set does not have (a zone on one is an error)."""
    by_id = {item.id: item for item in furniture}
    parts = _Footprints(furniture)
    lx, ly, _ = size_room
    zones = []
    seen: set[str] = set()
    for i, f in enumerate(fs):
        on = f.str("on")
        if on == "floor":
            x0, y0, x1, y1 = f.floats("rect", n=4)
            if not (x1 > x0 and y1 > y0):
                raise f.error("rect", "expected [x0, y0, x1, y1] with x1 > x0 and y1 > y0")
            if x0 < 0 or y0 < 0 or x1 > lx or y1 > ly:
                raise f.error("rect", f"outside the room (0..{lx:g} x 0..{ly:g} m)")
            volume = Box.from_bounds((x0, y0, 0.0), (x1, y1, FLOOR_ZONE_HEIGHT_M))
            kind, support = "floor", "floor"
        else:
            if "rect" in f:
                raise f.error("rect", "only floor zones take a rect")
            fid, _, aname = on.partition(".")
            if fid in elsewhere:
                raise f.error("on", f"furniture {fid!r} is not in material set {material_set} "
                              "(its sets): a zone's furniture is in every set")
            if fid not in by_id:
                raise f.error("on", f"no furniture {fid!r} in this layout")
            item = by_id[fid]
            if aname not in item.anchors:
                raise f.error("on", f"{item.type} {fid!r} has no zone anchor {aname!r} "
                              f"(has: {', '.join(item.anchors) or 'none'})")
            a = item.anchors[aname]
            volume, kind = a.volume, a.kind
            support = "floor" if a.support == "floor" else f"{fid}/{a.support}"
        if on != "floor" and on in seen:
            raise f.error("on", f"zone {on!r} appears twice")
        seen.add(on)
        drop, open_above, bound = _drop_region(volume, size_room, parts)
        if "drop_z" in f:
            z0, z1 = f.floats("drop_z", n=2, lo=0.0, increasing=True)
            drop, open_above = drop.with_z(z0, z1), False
        if drop.half[2] <= 0.01:
            raise f.error("on", f"no room to drop an object into zone {on!r}: {bound} lies "
                          f"just above it (drop region {drop.zmin:.2f}..{drop.zmax:.2f} m)")
        occluders = f.strs("occluders", ())
        for o in occluders:
            if occluder_names is not None and o not in occluder_names:
                raise f.error("occluders", f"unknown object category {o!r}")
        zones.append(Zone(
            id=f"z{i:02d}", index=i, kind=kind, anchor=on, support=support, volume=volume,
            drop=drop, open_above=open_above, distractors=f.int("distractors", 0, lo=0, hi=8),
            occluders=occluders,
        ))
        f.reject_unknown(_ZONE_FIELDS)
    assert all(z.kind in ZONE_KINDS for z in zones)
    return tuple(zones)


def parse_room(f: Fields, mats: MaterialLibrary,
               object_names: frozenset[str] | None = None) -> RoomSpec:
    """Parse and validate one room file (syntax, references, sizes, zone anchors)."""
    rid = _check_id(f, "id", f.str("id"))
    if rid != f.file.stem:
        raise f.error("id", f"room id {rid!r} must match the file name {f.file.stem!r}")
    kind = f.str("kind", choices=ROOM_KINDS)
    name = f.str("name", rid)
    f.str("description", "")
    size = f.floats("size_m", n=3, positive=True)
    if not (2.0 <= size[0] <= 20 and 2.0 <= size[1] <= 20 and 2.0 <= size[2] <= 6):
        raise f.error("size_m", f"implausible interior size {list(size)} (m)")
    msets = {
        _check_id(f, f"materials.{k}", k): _material_set(m, mats)
        for k, m in f.table("materials").items()
    }
    if not msets:
        raise f.error("materials", "at least one material set is required")
    variants = []
    layouts = f.table("layouts")
    layout_ids = []
    for lid, lf in layouts.items():
        _check_id(layouts, lid, lid)
        layout_ids.append(lid)
        lf.str("description", "")
        items = tuple(_furniture(ff, size, mats) for ff in lf.tables("furniture"))
        ids = [it.id for it in items]
        dup = next((x for x in ids if ids.count(x) > 1), None)
        if dup:
            raise lf.error("furniture", f"furniture id {dup!r} appears twice")
        for k, it in enumerate(items):
            for p in it.parts:
                lo, hi = p.box.aabb()
                if (lo[:2] < -0.01).any() or hi[0] > size[0] + 0.01 or hi[1] > size[1] + 0.01 \
                        or hi[2] > size[2] + 0.01:
                    raise InputError(f.file, f"{lf.path('furniture')}[{k}]",
                                     f"{it.id!r} part {p.name!r} sticks out of the room")
        for k, it in enumerate(items):
            unknown = [m for m in it.sets or () if m not in msets]
            if unknown:
                raise InputError(f.file, f"{lf.path('furniture')}[{k}].sets",
                                 f"no material set {unknown[0]!r} ({', '.join(msets)})")
        if not lf.tables("zones"):
            raise lf.error("zones", "a layout needs at least one fall zone")
        by_sets: dict[tuple[str, ...], tuple[tuple[FurnitureItem, ...], tuple[Zone, ...]]] = {}
        for mid, faces in msets.items():
            mine = tuple(it for it in items if it.sets is None or mid in it.sets)
            key = tuple(it.id for it in mine)
            if key not in by_sets:  # the layout's zones over the furniture this set has
                others = frozenset(it.id for it in items) - frozenset(key)
                by_sets[key] = (mine, _zones(lf.tables("zones"), mine, size, object_names,
                                             mid, others))
            mine, zones = by_sets[key]
            variants.append(RoomVariant(
                id=f"{rid}-{lid}-{mid}", room=rid, kind=kind, name=name, layout=lid,
                material_set=mid, size_m=size, surfaces=faces, furniture=mine, zones=zones,
                file=f.file,
            ))
        lf.reject_unknown(("description", "furniture", "zones"))
    if not variants:
        raise f.error("layouts", "at least one layout is required")
    f.reject_unknown(_ROOM_FIELDS)
    return RoomSpec(rid, kind, name, size, tuple(variants), f.file, tuple(layout_ids),
                    tuple(msets))


def load_rooms(directory: str | Path, mats: MaterialLibrary,
               object_names: frozenset[str] | None = None) -> dict[str, RoomSpec]:
    """Every ``*.toml`` room file in ``directory``, keyed by room id, in sorted order."""
    directory = Path(directory)
    files = sorted(directory.glob("*.toml"))
    if not files:
        raise InputError(directory, "<dir>", "no room files (*.toml) found")
    return {(spec := parse_room(load_toml(p), mats, object_names)).id: spec for p in files}


def select_variants(rooms: Mapping[str, RoomSpec], pattern: str = "*") -> list[RoomVariant]:
    """Variants whose id matches a glob ``pattern`` (comma-separated patterns allowed)."""
    pats = [p.strip() for p in pattern.split(",") if p.strip()]
    out = [v for r in rooms.values() for v in r.variants
           if any(fnmatch.fnmatchcase(v.id, p) or fnmatch.fnmatchcase(v.room, p) for p in pats)]
    return out
