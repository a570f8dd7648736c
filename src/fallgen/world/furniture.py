"""Furniture built from primitives, and the fall-zone anchors each piece offers.

Every furniture type is a function from its outer size ``(w, d, h)`` (width along its local x,
depth along y, height) and a few parameters to a :class:`FurnitureGeometry`: boxes and vertical
cylinders (collision geometry at least :data:`MIN_THICKNESS_M` thick) in the item's local frame,
and named :class:`Anchor` volumes where a fallen object may come to rest (``top``, ``under``,
``board2``, ``pan1``, ``inside``, ...).

Local frame: origin at the centre of the footprint on the floor, x along the width, y along the
depth with the *front* facing -y (the back, +y, goes against a wall), z up.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from fallgen.fields import Fields
from fallgen.world.geometry import Box

#: Thinnest collision geometry allowed: thinner slabs let small fast objects tunnel.
MIN_THICKNESS_M = 0.02

#: Fall-zone kinds, as the paper names the places an object can end up.
ZONE_KINDS: tuple[str, ...] = (
    "floor",
    "under_furniture",
    "behind_furniture",
    "table_top",
    "counter_top",
    "cabinet_top",
    "shelf",
    "seat",
    "box",
    "basket",
    "pan",
)

#: Floor coverings (rugs) are at most this thick (m): the robot drives over them (its occupancy
#: band starts above, :func:`fallgen.nav.occupancy.occupancy`) and other furniture stands on them.
FLOOR_COVERING_MAX_M = 0.025

#: Height of the settle volume above an open surface (m).
SETTLE_HEIGHT_M = 0.25
#: Inset of settle volumes from supporting edges (m).
EDGE_MARGIN_M = 0.03

RGBA = tuple[float, float, float, float]


@dataclass(frozen=True)
class Part:
    """One rigid primitive of a furniture item.

    ``box`` is the part itself for ``shape == "box"``; for ``"cylinder"`` it is the bounding box
    of a vertical cylinder of radius ``box.half[0]``; for ``"ellipsoid"`` that of the ellipsoid
    with semi-axes ``box.half``.

    A ``decor`` part (a plant's foliage, a picture on a wall) is drawn and seen, and the robot
    cannot drive through it, but it is not simulated or heard: nothing collides with it and
    the room's acoustics leave it out (what it would change there is negligible, or not rigid:
    leaves give way).
    """

    name: str
    shape: str
    box: Box
    material: str  # object material reference: what a hit on this part sounds like
    rgba: RGBA | None = None
    role: str = ""  # the part's role in its furniture type ("top", "legs", "body", ...)
    decor: bool = False


@dataclass(frozen=True)
class Anchor:
    """A volume in which a fallen object may settle, and what supports it."""

    kind: str
    volume: Box
    support: str  # the supporting part's name, or "floor"


@dataclass(frozen=True)
class FurnitureGeometry:
    parts: tuple[Part, ...]
    anchors: Mapping[str, Anchor]


@dataclass(frozen=True)
class FurnitureType:
    name: str
    description: str
    materials: Mapping[str, str]  # role -> default object material
    colors: Mapping[str, RGBA]  # role -> default colour
    #: Builds the item in its local frame. Parts carry their *role* in ``material``; the room
    #: loader replaces it with the role's material and colour.
    build: Callable[[float, float, float, Fields], FurnitureGeometry]
    #: A floor covering (a rug): furniture may stand on it, zones may lie on it, the robot
    #: drives over it; it offers no ``behind`` zone.
    floor_covering: bool = False
    #: Offers the strip between its back and the wall as a ``behind`` zone when placed clear
    #: of the wall (curtains and rugs do not).
    has_behind: bool = True
    #: Hangs on a wall (a picture): placed by ``wall`` and ``along`` with no gap, ``z_m`` its
    #: bottom edge.
    wall_hung: bool = False
    #: Faces drawn with a texture fitted to them when the room is drawn with textures, by
    #: part name: the texture kind (``doors``: a counter's doors and drawers; ``cushions``: a
    #: sofa's), the face (``front``: the part's -y face; ``top``) and the kind's parameters
    #: (:mod:`fallgen.world.appearance`); the face's size is the part's.
    fronts: Mapping[str, tuple[str, str, Mapping[str, float]]] = field(default_factory=dict)


def _box(name: str, lo: tuple[float, float, float], hi: tuple[float, float, float], material: str,
         rgba: RGBA | None = None) -> Part:
    return Part(name, "box", Box.from_bounds(lo, hi), material, rgba)


def _cyl(name: str, x: float, y: float, r: float, z0: float, z1: float, material: str) -> Part:
    return Part(name, "cylinder", Box((x, y, (z0 + z1) / 2), (r, r, (z1 - z0) / 2)), material)


def _ellipsoid(name: str, center: tuple[float, float, float], half: tuple[float, float, float],
               material: str) -> Part:
    return Part(name, "ellipsoid", Box(center, half), material, decor=True)


def _volume(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> Box:
    return Box.from_bounds((x0, y0, z0), (x1, y1, z1))


def _top_anchor(kind: str, w: float, d: float, z: float, support: str,
                m: float = EDGE_MARGIN_M, y0: float | None = None) -> Anchor:
    y_lo = -d / 2 + m if y0 is None else y0 + m
    return Anchor(kind, _volume(-w / 2 + m, w / 2 - m, y_lo, d / 2 - m, z, z + SETTLE_HEIGHT_M),
                  support)


# --- counters, cabinets, appliances ------------------------------------------------------------

def _counter(w, d, h, p: Fields) -> FurnitureGeometry:
    top_t = p.float("top_thickness_m", 0.04, lo=MIN_THICKNESS_M, hi=0.1)
    overhang = p.float("overhang_m", 0.02, lo=0.0, hi=0.1)
    parts = (
        _box("body", (-w / 2, -d / 2 + overhang, 0.0), (w / 2, d / 2, h - top_t), "body"),
        _box("top", (-w / 2, -d / 2, h - top_t), (w / 2, d / 2, h), "top"),
    )
    return FurnitureGeometry(parts, {"top": _top_anchor("counter_top", w, d, h, "top")})


def _island(w, d, h, p: Fields) -> FurnitureGeometry:
    top_t = p.float("top_thickness_m", 0.04, lo=MIN_THICKNESS_M, hi=0.1)
    overhang = p.float("overhang_m", 0.25, lo=0.0, hi=0.4)  # seating overhang on the front
    parts = (
        _box("body", (-w / 2 + 0.02, -d / 2 + overhang, 0.0), (w / 2 - 0.02, d / 2 - 0.02,
             h - top_t), "body"),
        _box("top", (-w / 2, -d / 2, h - top_t), (w / 2, d / 2, h), "top"),
    )
    return FurnitureGeometry(parts, {"top": _top_anchor("counter_top", w, d, h, "top")})


def _cabinet(w, d, h, p: Fields) -> FurnitureGeometry:
    """A closed cabinet (sideboard, cupboard, fridge, wall cabinet): its top is a zone."""
    top_t = p.float("top_thickness_m", 0.025, lo=MIN_THICKNESS_M, hi=0.1)
    parts = (
        _box("body", (-w / 2, -d / 2, 0.0), (w / 2, d / 2, h - top_t), "body"),
        _box("top", (-w / 2, -d / 2, h - top_t), (w / 2, d / 2, h), "top"),
    )
    return FurnitureGeometry(parts, {"top": _top_anchor("cabinet_top", w, d, h, "top")})


def _pan_parts(tag: str, x: float, y: float, z: float, r: float, ph: float,
               material: str) -> tuple[list[Part], Anchor]:
    t = MIN_THICKNESS_M
    parts = [_cyl(f"{tag}_bottom", x, y, r, z, z + t, material)]
    n = 8
    chord = 2 * r * math.tan(math.pi / n)
    for k in range(n):
        a = 2 * math.pi * k / n
        c = Box((x + (r - t / 2) * math.cos(a), y + (r - t / 2) * math.sin(a), z + ph / 2),
                (t / 2, chord / 2, ph / 2), a)
        parts.append(Part(f"{tag}_wall{k}", "box", c, material))
    inner = (r - t) * 0.7
    anchor = Anchor("pan", _volume(x - inner, x + inner, y - inner, y + inner, z + t, z + ph + 0.02),
                    f"{tag}_bottom")
    return parts, anchor


def _stove(w, d, h, p: Fields) -> FurnitureGeometry:
    pans = p.int("pans", 2, lo=0, hi=4)
    r = p.float("pan_diameter_m", 0.26, lo=0.12, hi=0.34) / 2
    ph = p.float("pan_height_m", 0.07, lo=0.03, hi=0.2)
    top_t = 0.03
    parts = [
        _box("body", (-w / 2, -d / 2, 0.0), (w / 2, d / 2, h - top_t), "body"),
        _box("top", (-w / 2, -d / 2, h - top_t), (w / 2, d / 2, h), "top"),
    ]
    anchors: dict[str, Anchor] = {}
    burners = [(-w / 4, -d / 4), (w / 4, d / 4), (w / 4, -d / 4), (-w / 4, d / 4)]
    for i in range(pans):
        bx, by = burners[i]
        pp, a = _pan_parts(f"pan{i + 1}", bx, by, h, r, ph, "pans")
        parts += pp
        anchors[f"pan{i + 1}"] = a
    return FurnitureGeometry(tuple(parts), anchors)


# --- tables, desks, seats -----------------------------------------------------------------------

def _legs(w, d, z1, leg, inset, material) -> list[Part]:
    xs = (-w / 2 + inset, w / 2 - inset - leg)
    ys = (-d / 2 + inset, d / 2 - inset - leg)
    return [
        _box(f"leg{i}", (x, y, 0.0), (x + leg, y + leg, z1), material)
        for i, (x, y) in enumerate((x, y) for x in xs for y in ys)
    ]


def _table(w, d, h, p: Fields) -> FurnitureGeometry:
    top_t = p.float("top_thickness_m", 0.035, lo=MIN_THICKNESS_M, hi=0.1)
    leg = p.float("leg_m", 0.06, lo=MIN_THICKNESS_M, hi=0.2)
    inset = p.float("leg_inset_m", 0.04, lo=0.0, hi=0.5)
    parts = [_box("top", (-w / 2, -d / 2, h - top_t), (w / 2, d / 2, h), "top")]
    parts += _legs(w, d, h - top_t, leg, inset, "legs")
    m = inset + leg + 0.02
    under_h = min(0.35, h - top_t - 0.02)
    anchors = {
        "top": _top_anchor("table_top", w, d, h, "top"),
        "under": Anchor("under_furniture", _volume(-w / 2 + m, w / 2 - m, -d / 2 + m, d / 2 - m,
                                                   0.0, under_h), "floor"),
    }
    return FurnitureGeometry(tuple(parts), anchors)


def _desk(w, d, h, p: Fields) -> FurnitureGeometry:
    """A desk with a drawer pedestal on its right and legs on its left."""
    top_t = p.float("top_thickness_m", 0.03, lo=MIN_THICKNESS_M, hi=0.1)
    ped = p.float("pedestal_width_m", 0.42, lo=0.0, hi=w / 2)
    leg = 0.05
    parts = [_box("top", (-w / 2, -d / 2, h - top_t), (w / 2, d / 2, h), "top")]
    parts += [
        _box("leg0", (-w / 2 + 0.03, -d / 2 + 0.03, 0.0), (-w / 2 + 0.03 + leg, -d / 2 + 0.03 + leg,
             h - top_t), "legs"),
        _box("leg1", (-w / 2 + 0.03, d / 2 - 0.03 - leg, 0.0), (-w / 2 + 0.03 + leg, d / 2 - 0.03,
             h - top_t), "legs"),
    ]
    x_knee_hi = w / 2 - 0.02
    if ped > 0:
        parts.append(_box("pedestal", (w / 2 - ped, -d / 2 + 0.02, 0.0), (w / 2 - 0.01, d / 2 - 0.02,
                          h - top_t), "legs"))
        x_knee_hi = w / 2 - ped - 0.02
    anchors = {
        "top": _top_anchor("table_top", w, d, h, "top"),
        "under": Anchor("under_furniture", _volume(-w / 2 + 0.03 + leg + 0.02, x_knee_hi,
                                                   -d / 2 + 0.05, d / 2 - 0.05, 0.0,
                                                   min(0.35, h - top_t - 0.02)), "floor"),
    }
    return FurnitureGeometry(tuple(parts), anchors)


def _chair(w, d, h, p: Fields) -> FurnitureGeometry:
    seat_h = p.float("seat_height_m", 0.45, lo=0.2, hi=0.8)
    t = 0.03
    leg = 0.035
    parts = [_box("seat", (-w / 2, -d / 2, seat_h - t), (w / 2, d / 2, seat_h), "body")]
    parts += _legs(w, d, seat_h - t, leg, 0.01, "legs")
    parts.append(_box("back", (-w / 2, d / 2 - t, seat_h), (w / 2, d / 2, h), "body"))
    anchors = {
        "seat": Anchor("seat", _volume(-w / 2 + 0.03, w / 2 - 0.03, -d / 2 + 0.03, d / 2 - t - 0.02,
                                       seat_h, seat_h + SETTLE_HEIGHT_M), "seat"),
    }
    return FurnitureGeometry(tuple(parts), anchors)


def _sofa(w, d, h, p: Fields) -> FurnitureGeometry:
    """Sofa or armchair on short legs: seat, back, arms; gap under it; back against the wall."""
    leg_h = p.float("leg_height_m", 0.11, lo=0.0, hi=0.3)
    seat_h = p.float("seat_height_m", 0.43, lo=leg_h + 0.1, hi=0.7)
    arm = p.float("arm_width_m", 0.15, lo=MIN_THICKNESS_M, hi=0.4)
    back = p.float("back_depth_m", 0.2, lo=MIN_THICKNESS_M, hi=0.5)
    arm_h = p.float("arm_height_m", 0.62, lo=seat_h, hi=h)
    parts: list[Part] = []
    if leg_h > 0:
        parts += _legs(w, d, leg_h, 0.05, 0.03, "legs")
    parts += [
        _box("base", (-w / 2 + arm, -d / 2, leg_h), (w / 2 - arm, d / 2 - back, seat_h), "body"),
        _box("back", (-w / 2, d / 2 - back, leg_h), (w / 2, d / 2, h), "body"),
        _box("arm_l", (-w / 2, -d / 2, leg_h), (-w / 2 + arm, d / 2 - back, arm_h), "body"),
        _box("arm_r", (w / 2 - arm, -d / 2, leg_h), (w / 2, d / 2 - back, arm_h), "body"),
    ]
    anchors = {
        "seat": Anchor("seat", _volume(-w / 2 + arm + 0.02, w / 2 - arm - 0.02, -d / 2 + 0.03,
                                       d / 2 - back - 0.02, seat_h, seat_h + SETTLE_HEIGHT_M),
                       "base"),
    }
    if leg_h >= 0.06:
        anchors["under"] = Anchor("under_furniture", _volume(-w / 2 + 0.1, w / 2 - 0.1,
                                                             -d / 2 + 0.1, d / 2 - 0.1, 0.0,
                                                             leg_h - 0.005), "floor")
    return FurnitureGeometry(tuple(parts), anchors)


# --- shelves ------------------------------------------------------------------------------------

def _shelf(w, d, h, p: Fields) -> FurnitureGeometry:
    """Shelving unit: two sides, ``levels`` boards (the lowest raised on a plinth), optional back
    panel, optional rows of books filling part of each board but the top one."""
    levels = p.int("levels", 4, lo=2, hi=8)
    has_back = p.bool("back", True)
    books = p.float("books_fraction", 0.0, lo=0.0, hi=0.7)
    t = MIN_THICKNESS_M
    plinth = 0.08
    parts = [
        _box("side_l", (-w / 2, -d / 2, 0.0), (-w / 2 + t, d / 2, h), "body"),
        _box("side_r", (w / 2 - t, -d / 2, 0.0), (w / 2, d / 2, h), "body"),
    ]
    y_back = d / 2
    if has_back:
        parts.append(_box("back", (-w / 2 + t, d / 2 - t, 0.0), (w / 2 - t, d / 2, h), "body"))
        y_back = d / 2 - t
    x0, x1 = -w / 2 + t, w / 2 - t
    board_tops = [plinth + t + k * (h - plinth - t) / (levels - 1) for k in range(levels)]
    anchors: dict[str, Anchor] = {}
    for k, zt in enumerate(board_tops):
        parts.append(_box(f"board{k + 1}", (x0, -d / 2, zt - t), (x1, y_back, zt), "body"))
    for k, zt in enumerate(board_tops):
        top = k == levels - 1
        z_hi = zt + SETTLE_HEIGHT_M if top else min(board_tops[k + 1] - t - 0.01, zt + 0.3)
        xa = x0
        if books > 0 and not top:
            xb = x0 + books * (x1 - x0)
            book_h = min(0.24, board_tops[k + 1] - t - zt - 0.03)
            parts.append(_box(f"books{k + 1}", (x0 + 0.005, -d / 2 + 0.03, zt),
                              (xb, y_back - 0.005, zt + book_h), "books"))
            xa = xb
        anchors[f"board{k + 1}"] = Anchor(
            "shelf", _volume(xa + 0.02, x1 - 0.02, -d / 2 + 0.02, y_back - 0.02, zt, z_hi),
            f"board{k + 1}")
    return FurnitureGeometry(tuple(parts), anchors)


# --- soft furnishings ---------------------------------------------------------------------------

def _rug(w, d, h, p: Fields) -> FurnitureGeometry:
    """A loose rug: one slab of pile on the floor. Falls onto it land on it (a floor zone may
    lie on it); it absorbs sound on its top face and hides the floor under it."""
    if h > FLOOR_COVERING_MAX_M + 1e-9:
        raise ValueError(f"a rug is at most {FLOOR_COVERING_MAX_M} m thick (got {h:g})")
    return FurnitureGeometry((_box("pile", (-w / 2, -d / 2, 0.0), (w / 2, d / 2, h), "pile"),), {})


def _curtain(w, d, h, p: Fields) -> FurnitureGeometry:
    """Curtains drawn over a window, hung in folds: one slab from the wall to the front of the
    folds (``d``, ~0.1-0.15 m; the absorption of curtains is measured so, per m^2 of their
    front, the air behind them part of the absorber)."""
    if d > 0.3:
        raise ValueError(f"curtains hang within 0.3 m of the wall (depth {d:g})")
    return FurnitureGeometry((_box("drape", (-w / 2, -d / 2, 0.0), (w / 2, d / 2, h), "drape"),),
                             {})


def _picture(w, d, h, p: Fields) -> FurnitureGeometry:
    """A framed picture hung flat on a wall (``z_m``: its bottom edge): the canvas, recessed
    6 mm behind the front of a frame of ``frame_m`` wide bars, ``d`` (at most 6 cm) from the
    wall to the frame's front."""
    if d > 0.06:
        raise ValueError(f"a picture hangs within 0.06 m of the wall (depth {d:g})")
    b = p.float("frame_m", 0.04, lo=MIN_THICKNESS_M, hi=0.2)
    if 2 * b > min(w, h) - 0.1:
        raise ValueError(f"frame_m {b:g} leaves under 0.1 m of picture")
    recess = 0.006
    if d - recess < MIN_THICKNESS_M:
        raise ValueError(f"a picture is at least {MIN_THICKNESS_M + recess:g} m deep (got {d:g})")
    parts = (
        _box("canvas", (-w / 2 + b, -d / 2 + recess, b), (w / 2 - b, d / 2, h - b), "canvas"),
        _box("frame_b", (-w / 2, -d / 2, 0.0), (w / 2, d / 2, b), "frame"),
        _box("frame_t", (-w / 2, -d / 2, h - b), (w / 2, d / 2, h), "frame"),
        _box("frame_l", (-w / 2, -d / 2, b), (-w / 2 + b, d / 2, h - b), "frame"),
        _box("frame_r", (w / 2 - b, -d / 2, b), (w / 2, d / 2, h - b), "frame"),
    )
    # flat on the wall: it changes neither a fall nor the room's sound
    return FurnitureGeometry(tuple(dataclasses.replace(q, decor=True) for q in parts), {})


def _plant(w, d, h, p: Fields) -> FurnitureGeometry:
    """A potted house plant: a pot (``pot_diameter_m`` across, ``pot_height_m`` high) under
    a crown of foliage filling the rest of the ``w`` x ``d`` x ``h`` size: a central tuft and
    ``lobes`` lower tufts around it (ellipsoids). The pot is solid; the foliage is decor."""
    pot_h = p.float("pot_height_m", 0.3, lo=0.1, hi=1.0)
    pot_d = p.float("pot_diameter_m", 0.3, lo=0.1, hi=0.8)
    lobes = p.int("lobes", 5, lo=0, hi=8)
    if pot_d > min(w, d) + 1e-9:
        raise p.error("pot_diameter_m", f"{pot_d:g} m is wider than the plant ({min(w, d):g} m)")
    if pot_h > h - 0.15:
        raise p.error("pot_height_m", f"{pot_h:g} m leaves under 0.15 m of foliage (the plant "
                      f"is {h:g} m high)")
    z0 = pot_h - 0.03  # the foliage springs from inside the pot's rim
    crown = h - z0
    parts = [_cyl("pot", 0.0, 0.0, pot_d / 2, 0.0, pot_h, "pot"),
             _ellipsoid("leaves0", (0.0, 0.0, z0 + 0.55 * crown),
                        (0.32 * w, 0.32 * d, 0.45 * crown), "leaves")]
    for k in range(lobes):
        a = 2 * math.pi * k / lobes + 0.4
        parts.append(_ellipsoid(f"leaves{k + 1}",
                                (0.25 * w * math.cos(a), 0.25 * d * math.sin(a),
                                 z0 + (0.3 + 0.1 * (k % 3)) * crown),
                                (0.22 * w, 0.22 * d, 0.28 * crown), "leaves"))
    return FurnitureGeometry(tuple(parts), {})


# --- containers ---------------------------------------------------------------------------------

def _open_box(kind: str) -> Callable[..., FurnitureGeometry]:
    def build(w, d, h, p: Fields) -> FurnitureGeometry:
        t = MIN_THICKNESS_M
        m = "body"
        parts = (
            _box("bottom", (-w / 2, -d / 2, 0.0), (w / 2, d / 2, t), m),
            _box("wall_s", (-w / 2, -d / 2, t), (w / 2, -d / 2 + t, h), m),
            _box("wall_n", (-w / 2, d / 2 - t, t), (w / 2, d / 2, h), m),
            _box("wall_w", (-w / 2, -d / 2 + t, t), (-w / 2 + t, d / 2 - t, h), m),
            _box("wall_e", (w / 2 - t, -d / 2 + t, t), (w / 2, d / 2 - t, h), m),
        )
        inner = _volume(-w / 2 + t + 0.01, w / 2 - t - 0.01, -d / 2 + t + 0.01, d / 2 - t - 0.01,
                        t, h + 0.02)
        return FurnitureGeometry(parts, {"inside": Anchor(kind, inner, "bottom")})

    return build


_WOOD = (0.55, 0.38, 0.24, 1.0)
_LIGHT_WOOD = (0.72, 0.58, 0.40, 1.0)
_WHITE = (0.9, 0.9, 0.88, 1.0)
_STEEL = (0.62, 0.63, 0.65, 1.0)
_DARK = (0.18, 0.18, 0.2, 1.0)


def _doors(door_m: float, drawer_m: float) -> dict[str, tuple[str, str, dict[str, float]]]:
    """The body's front: doors about ``door_m`` wide under drawers ``drawer_m`` high."""
    return {"body": ("doors", "front", {"door_m": door_m, "drawer_m": drawer_m})}


#: A cooker's front (an oven door under a strip of four control knobs) and its top (four
#: burners in their grates, where the pans stand).
_COOKER = {"body": ("doors", "front", {"door_m": 2.0, "drawer_m": 0.12, "knobs": 4.0}),
           "top": ("hob", "top", {"burner_m": 0.2})}

#: A sofa's or armchair's seat and back cushions, about 0.6 m wide each.
_CUSHIONS = {"base": ("cushions", "top", {"cushion_m": 0.6}),
             "back": ("cushions", "front", {"cushion_m": 0.6})}

FURNITURE: dict[str, FurnitureType] = {
    t.name: t
    for t in (
        FurnitureType("counter", "base cabinets with a worktop (kitchen counter)",
                      {"body": "wood_medium", "top": "stone"},
                      {"body": _WHITE, "top": (0.35, 0.33, 0.32, 1.0)}, _counter,
                      fronts=_doors(0.5, 0.15)),
        FurnitureType("island", "free-standing kitchen island with a seating overhang",
                      {"body": "wood_medium", "top": "stone"},
                      {"body": (0.3, 0.42, 0.5, 1.0), "top": (0.85, 0.84, 0.8, 1.0)}, _island,
                      fronts=_doors(0.5, 0.15)),
        FurnitureType("cabinet", "closed cabinet: sideboard, cupboard, chest of drawers",
                      {"body": "wood_medium", "top": "wood_medium"},
                      {"body": _LIGHT_WOOD, "top": _LIGHT_WOOD}, _cabinet,
                      fronts=_doors(0.45, 0.16)),
        FurnitureType("wall_cabinet", "wall-mounted cabinet (set z_m to its bottom height)",
                      {"body": "wood_medium", "top": "wood_medium"},
                      {"body": _WHITE, "top": _WHITE}, _cabinet, fronts=_doors(0.4, 0.0)),
        FurnitureType("fridge", "refrigerator", {"body": "metal", "top": "metal"},
                      {"body": (0.85, 0.86, 0.88, 1.0), "top": (0.85, 0.86, 0.88, 1.0)}, _cabinet,
                      fronts=_doors(2.0, 0.5)),
        FurnitureType("stove", "cooker with pans on its burners (params: pans, pan_diameter_m)",
                      {"body": "metal", "top": "metal", "pans": "metal"},
                      {"body": _STEEL, "top": _STEEL, "pans": (0.25, 0.25, 0.27, 1.0)}, _stove,
                      fronts=_COOKER),
        FurnitureType("dining_table", "table on four legs", {"top": "wood_hard", "legs": "wood_hard"},
                      {"top": _WOOD, "legs": _WOOD}, _table),
        FurnitureType("coffee_table", "low table on four legs",
                      {"top": "wood_medium", "legs": "wood_medium"},
                      {"top": _LIGHT_WOOD, "legs": _LIGHT_WOOD}, _table),
        FurnitureType("side_table", "small table on four legs",
                      {"top": "wood_medium", "legs": "wood_medium"},
                      {"top": _WOOD, "legs": _WOOD}, _table),
        FurnitureType("desk", "desk with a drawer pedestal", {"top": "wood_medium", "legs": "metal"},
                      {"top": _LIGHT_WOOD, "legs": _DARK}, _desk),
        FurnitureType("chair", "chair with a back", {"body": "wood_medium", "legs": "wood_medium"},
                      {"body": _WOOD, "legs": _WOOD}, _chair),
        FurnitureType("sofa", "sofa on short legs", {"body": "fabric", "legs": "wood_hard"},
                      {"body": (0.35, 0.42, 0.52, 1.0), "legs": _DARK}, _sofa,
                      fronts=_CUSHIONS),
        FurnitureType("armchair", "armchair on short legs", {"body": "fabric", "legs": "wood_hard"},
                      {"body": (0.55, 0.35, 0.3, 1.0), "legs": _DARK}, _sofa,
                      fronts=_CUSHIONS),
        FurnitureType("shelf", "open shelving unit (params: levels, back, books_fraction)",
                      {"body": "wood_medium", "books": "paper/books"},
                      {"body": _LIGHT_WOOD, "books": (0.5, 0.2, 0.2, 1.0)}, _shelf),
        FurnitureType("bookshelf", "bookcase with books on each shelf",
                      {"body": "wood_hard", "books": "paper/books"},
                      {"body": _WOOD, "books": (0.45, 0.25, 0.2, 1.0)}, _shelf),
        FurnitureType("box", "open cardboard box on the floor",
                      {"body": "cardboard/corrugated"}, {"body": (0.7, 0.55, 0.36, 1.0)},
                      _open_box("box")),
        FurnitureType("basket", "open wicker basket", {"body": "wood_soft"},
                      {"body": (0.76, 0.62, 0.38, 1.0)}, _open_box("basket")),
        FurnitureType("rug", "loose rug on the floor (at most 2.5 cm thick; furniture may stand "
                      "on it)", {"pile": "fabric/rug"}, {"pile": (0.55, 0.3, 0.25, 1.0)}, _rug,
                      floor_covering=True, has_behind=False),
        FurnitureType("curtain", "curtains drawn over a window, hung in folds against a wall "
                      "(depth: wall to the folds' front)", {"drape": "fabric/drape"},
                      {"drape": (0.75, 0.7, 0.6, 1.0)}, _curtain, has_behind=False),
        FurnitureType("picture", "framed picture hung on a wall (set z_m to its bottom edge; "
                      "params: frame_m)", {"canvas": "paper/print", "frame": "wood_hard"},
                      {"canvas": (0.9, 0.9, 0.9, 1.0), "frame": (0.22, 0.16, 0.12, 1.0)},
                      _picture, has_behind=False, wall_hung=True),
        FurnitureType("plant", "potted house plant, foliage over a pot (params: pot_height_m, "
                      "pot_diameter_m, lobes)", {"pot": "ceramic", "leaves": "wood_soft/foliage"},
                      {"pot": (0.62, 0.34, 0.24, 1.0), "leaves": (0.28, 0.48, 0.2, 1.0)},
                      _plant, has_behind=False),
    )
}

#: Default parameters some types need that differ from their builder's defaults.
TYPE_DEFAULT_PARAMS: dict[str, dict[str, object]] = {
    "bookshelf": {"books_fraction": 0.45},
    "shelf": {"back": False},
    "armchair": {"arm_width_m": 0.18},
}
