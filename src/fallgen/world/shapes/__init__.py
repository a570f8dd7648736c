"""Procedural object shapes: a registry of generators returning :class:`Shape` objects.

``make_shape("cup", {"height_m": 0.1})`` builds a shape; ``SHAPES`` maps generator names to
generators (keyword-only parameters in SI units, lengths end in ``_m``). Every shape comes
with a watertight visual mesh (mass = volume x density) and a few convex collision pieces.
The generators live in themed modules (:mod:`.basic`, :mod:`.vessels`, :mod:`.utensils`,
:mod:`.devices`, :mod:`.household`); the mesh tools in :mod:`fallgen.world.meshkit`.
"""

from fallgen.world.shapes._core import PARAMS, SHAPES, ParamSpec, Shape, make_shape, shape

# Importing the modules registers their generators.
from fallgen.world.shapes import basic, devices, household, utensils, vessels  # noqa: E402,F401

__all__ = ["PARAMS", "SHAPES", "ParamSpec", "Shape", "make_shape", "shape"]
