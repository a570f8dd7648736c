"""A small toolkit for building the procedural object meshes.

Units are metres; z is up. Every builder returns a closed, watertight
:class:`trimesh.Trimesh` with outward winding (counter-clockwise seen from outside, so that the
signed volume is positive). The pieces that make up a MuJoCo collision model are plain
``(n, 3)`` float64 vertex arrays: MuJoCo takes the convex hull of each one.

Building blocks
---------------
Lathe (surfaces of revolution about +z)
    A *profile* is a polyline of ``(r, z)`` points that starts and ends on the axis (``r == 0``)
    with ``r > 0`` in between. :func:`revolve` turns it into a closed mesh. Hollow vessels are
    one closed profile (outer bottom centre, outer wall, rim, inner wall, inner bottom centre);
    :func:`hollow_section` derives it from the outer curve alone by offsetting it in 2-D with
    shapely, and :class:`Lathe` bundles the 2-D section with its mesh and collision pieces.
Flat parts
    :func:`extrude` (a shapely polygon, optionally with holes, extruded along z) and
    :func:`warp` (bend or taper a mesh by moving its vertices).
Tubes
    :func:`sweep` moves a (super-)elliptic cross-section along a planar path: handles, bands,
    straps, pen bodies. :func:`torus_arc` is the circular special case.
Primitives
    :func:`box`, :func:`rounded_box`, :func:`rounded_slab`, :func:`cylinder`,
    :func:`rounded_cylinder`, :func:`ellipsoid`, :func:`sphere`, :func:`capsule`.
Booleans
    :func:`union`, :func:`difference`, :func:`intersection` run manifold3d (trimesh's boolean
    engine) directly in float64, then remove the slivers the cut lines leave
    (:func:`collapse_short_edges`, :func:`flip_flat_caps`); results are checked to be closed.
Collision pieces
    :func:`convex_parts_2d` (approximate convex decomposition of a polygon),
    :meth:`Lathe.pieces` / :func:`convex_pieces_of_revolution` (angular sectors of a revolved
    wall plus full-turn axial pieces), :meth:`Sweep.pieces`, :func:`clip_piece` (the part of a
    mesh inside a box) and :func:`hull_points`.
Checks
    :func:`validate_shape` lists what is wrong with a shape; :func:`collision_stats` gives the
    numbers behind it.

Modules
-------
:mod:`.profiles` (polylines, profiles, 2-D sections), :mod:`.convex2d` (2-D convex parts),
:mod:`.lathe` (revolve, Lathe), :mod:`.flat` (extrude, warp), :mod:`.tubes` (sweep),
:mod:`.primitives`, :mod:`.booleans`, :mod:`.checks` (collision pieces, validation);
shared constants in :mod:`._common`. Everything public is re-exported here.
"""

from __future__ import annotations

from ._common import AXIS_EPS, COVER_TOL, MIN_PIECE_VOLUME
from .booleans import (
    BOOLEAN_TOLERANCE,
    collapse_short_edges,
    difference,
    flip_flat_caps,
    from_manifold,
    intersection,
    to_manifold,
    union,
)
from .checks import (
    clip_piece,
    collision_stats,
    default_max_excursion,
    hull_points,
    mesh_quality,
    validate_shape,
    winding_number,
)
from .convex2d import concavity_2d, convex_parts_2d
from .flat import bend_z, clean_polygon, extrude, smoothstep, triangulate, warp
from .lathe import Lathe, convex_pieces_of_revolution, revolve
from .primitives import (
    box,
    capsule,
    cylinder,
    ellipsoid,
    hull_mesh,
    rounded_box,
    rounded_cylinder,
    rounded_cylinder_profile,
    rounded_rect,
    rounded_slab,
    sphere,
)
from .profiles import (
    _single_polygon,  # noqa: F401  (used by fallgen.world.shapes)
    arc_points,
    clean_polyline,
    fillet_polyline,
    half_section,
    hollow_section,
    open_section,
    pchip_curve,
    resample_polyline,
    round_section,
    section_profile,
    solid_section,
)
from .tubes import Sweep, arc_path, sweep, torus_arc

__all__ = [
    # constants
    "AXIS_EPS", "MIN_PIECE_VOLUME", "COVER_TOL", "BOOLEAN_TOLERANCE",
    # polylines and profiles, 2-D sections
    "resample_polyline", "clean_polyline", "arc_points", "fillet_polyline", "pchip_curve",
    "solid_section", "open_section", "hollow_section", "round_section", "half_section",
    "section_profile",
    # 2-D convex parts
    "concavity_2d", "convex_parts_2d",
    # revolve, Lathe
    "revolve", "Lathe", "convex_pieces_of_revolution",
    # flat parts
    "clean_polygon", "triangulate", "extrude", "warp", "bend_z", "smoothstep",
    # tubes
    "Sweep", "sweep", "arc_path", "torus_arc",
    # primitives
    "box", "rounded_box", "rounded_slab", "rounded_rect", "hull_mesh", "rounded_cylinder",
    "rounded_cylinder_profile", "cylinder", "ellipsoid", "sphere", "capsule",
    # booleans
    "to_manifold", "from_manifold", "flip_flat_caps", "collapse_short_edges", "union",
    "difference", "intersection",
    # collision pieces and checks
    "hull_points", "clip_piece", "collision_stats", "winding_number", "default_max_excursion",
    "validate_shape", "mesh_quality",
]
