"""Fall-event records (what the rehearsal keeps) and their one conversion to and from Arrow."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import pyarrow as pa

from fallgen.physics.contacts import ContactEvent

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


@dataclass(frozen=True)
class ObjectSpec:
    """Which object: enough to rebuild it exactly from the category library."""

    category: str
    variant: str
    material: str  # full reference, e.g. "metal/aluminium"
    scale: float


@dataclass(frozen=True)
class Placement:
    """A static object (settled distractor, placed occluder) in a fall event's scene."""

    object: ObjectSpec
    pos: Vec3
    quat: Quat


@dataclass(frozen=True)
class FallEvent:
    event_id: str  # "<variant>/<zone>/t<trial>"
    room_variant: str
    room_kind: str
    zone: str
    zone_kind: str
    trial: int
    root_seed: int
    target: ObjectSpec
    audio_material: str
    mass_kg: float
    start_pos: Vec3
    start_quat: Quat
    start_linvel: Vec3  # world frame, m/s
    start_angvel: Vec3  # body frame, rad/s (MuJoCo free-joint convention)
    settle_pos: Vec3  # body origin
    settle_quat: Quat
    settle_com: Vec3  # centre of mass, world
    settle_time_s: float
    steps: int  # simulated steps (replays run exactly these)
    distractors: tuple[Placement, ...]
    occluders: tuple[Placement, ...]
    contacts: tuple[ContactEvent, ...]
    # the target's body origin's (min x, min y, max x, max y) over every step of the fall
    # (None in rehearsals made before it was recorded): where an agent cannot touch the fall
    sweep_xy: tuple[float, float, float, float] | None = None


GRAVITY = 9.81  # m/s^2, MuJoCo's default (the scenes keep it)


def event_variant(event_id: str) -> str:
    """The room variant a rehearsed event's id names (ids are ``variant/zone/tNNNN``)."""
    return event_id.split("/", 1)[0]


def fall_height_m(contacts, vz0: float = 0.0) -> float:
    """How far the centre of mass falls before the first contact: v0z t + g t^2 / 2 down
    (free fall from the start; inf without any contact)."""
    if not contacts:
        return math.inf
    t = min(c.time_s for c in contacts)
    return -vz0 * t + 0.5 * GRAVITY * t * t


def first_impact_surface(contacts) -> str:
    """The material the fall's first impact struck (the contact's ``material_other``:
    ``stone``, ``wood_medium``, ``fabric/rug``...; "" when it made no impact)."""
    impacts = [c for c in contacts if c.kind == "impact"]
    return min(impacts, key=lambda c: c.time_s).material_other if impacts else ""


_V3 = pa.list_(pa.float64(), 3)
_V4 = pa.list_(pa.float64(), 4)
_OBJ = pa.struct([("category", pa.string()), ("variant", pa.string()),
                  ("material", pa.string()), ("scale", pa.float64())])
_PLACEMENT = pa.struct([("object", _OBJ), ("pos", _V3), ("quat", _V4)])


def _contact_type(name: str) -> pa.DataType:
    return {"time_s": pa.float64(), "kind": pa.string(), "other": pa.string(),
            "geom_object": pa.int32(), "geom_other": pa.int32(),
            "material_object": pa.string(), "material_other": pa.string(),
            "point_world": _V3, "point_object": _V3, "normal": _V3}.get(name, pa.float64())


_CONTACT = pa.struct([(f.name, _contact_type(f.name)) for f in fields(ContactEvent)])

SCHEMA = pa.schema([
    ("event_id", pa.string()), ("room_variant", pa.string()), ("room_kind", pa.string()),
    ("zone", pa.string()), ("zone_kind", pa.string()), ("trial", pa.int32()),
    ("root_seed", pa.int64()), ("target", _OBJ), ("audio_material", pa.string()),
    ("mass_kg", pa.float64()), ("start_pos", _V3), ("start_quat", _V4), ("start_linvel", _V3),
    ("start_angvel", _V3), ("settle_pos", _V3), ("settle_quat", _V4), ("settle_com", _V3),
    ("settle_time_s", pa.float64()), ("steps", pa.int32()),
    ("distractors", pa.list_(_PLACEMENT)), ("occluders", pa.list_(_PLACEMENT)),
    ("contacts", pa.list_(_CONTACT)),
    ("sweep_xy", pa.list_(pa.float64(), 4)),
])


def to_table(events: list[FallEvent]) -> pa.Table:
    rows = [asdict(e) for e in events]
    return pa.Table.from_pylist(rows, schema=SCHEMA)


def _obj(d: dict) -> ObjectSpec:
    return ObjectSpec(d["category"], d["variant"], d["material"], d["scale"])


def _placements(items: list[dict]) -> tuple[Placement, ...]:
    return tuple(Placement(_obj(p["object"]), tuple(p["pos"]), tuple(p["quat"])) for p in items)


def from_table(table: pa.Table) -> list[FallEvent]:
    out = []
    for r in table.to_pylist():
        contacts = tuple(ContactEvent(**{**c, "point_world": tuple(c["point_world"]),
                                         "point_object": tuple(c["point_object"]),
                                         "normal": tuple(c["normal"])})
                         for c in r["contacts"])
        vec = {k: tuple(r[k]) for k in ("start_pos", "start_quat", "start_linvel",
                                        "start_angvel", "settle_pos", "settle_quat",
                                        "settle_com")}
        if r.get("sweep_xy") is not None:
            vec["sweep_xy"] = tuple(r["sweep_xy"])
        out.append(FallEvent(**{**r, **vec, "target": _obj(r["target"]),
                                "distractors": _placements(r["distractors"]),
                                "occluders": _placements(r["occluders"]),
                                "contacts": contacts}))
    return out
