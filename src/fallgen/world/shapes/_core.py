"""The shape contract, the generator registry and parameter checking."""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

from fallgen.world import meshkit as mk
from fallgen.world.shell import ThinShell

#: Default range of a length parameter (name ending in ``_m``), metres.
LENGTH_RANGE = (1e-5, 3.0)


@dataclass(frozen=True)
class Shape:
    """A procedural object: what is rendered and what collides.

    ``visual`` is watertight with outward normals and positive volume (metres), so that
    ``visual.volume * density`` is the mass. ``collision`` holds convex pieces, each an
    ``(n_i, 3)`` float64 vertex array whose convex hull MuJoCo uses. Frame: z up in the
    object's natural upright pose, origin at the centre of the visual bounding box.
    """

    visual: trimesh.Trimesh
    collision: tuple[np.ndarray, ...]
    #: The sheet walls of a thin-walled shape, for its vibration model (None: solid enough
    #: for voxel finite elements).
    shell: ThinShell | None = None


@dataclass(frozen=True)
class ParamSpec:
    """One keyword parameter of a generator: its default, type and inclusive range."""

    name: str
    default: float | int | bool
    kind: type
    low: float | None
    high: float | None


#: Registry: generator name -> generator (keyword-only parameters, returns a Shape).
SHAPES: dict[str, Callable[..., Shape]] = {}
#: Parameter specs of each registered generator.
PARAMS: dict[str, dict[str, ParamSpec]] = {}


def shape(name: str, **ranges: tuple[float | None, float | None]) -> Callable[[Callable[..., Shape]], Callable[..., Shape]]:
    """Register a generator under ``name``.

    The generator takes keyword-only parameters with defaults; their types come from the
    defaults (bool, int or float). ``ranges`` gives inclusive ``(low, high)`` limits; a float
    whose name ends in ``_m`` defaults to :data:`LENGTH_RANGE`. The registered callable checks
    its arguments (``TypeError`` for unknown names or wrong types, ``ValueError`` for values out
    of range) before building.
    """

    def deco(fn: Callable[..., Shape]) -> Callable[..., Shape]:
        specs: dict[str, ParamSpec] = {}
        for p in inspect.signature(fn).parameters.values():
            if p.kind is not inspect.Parameter.KEYWORD_ONLY or p.default is inspect.Parameter.empty:
                raise TypeError(f"shape {name!r}: parameter {p.name!r} must be keyword-only with a default")
            d = p.default
            kind = bool if isinstance(d, bool) else int if isinstance(d, int) else float
            lo, hi = ranges.get(p.name, (None, None))
            if kind is float and p.name.endswith("_m") and p.name not in ranges:
                lo, hi = LENGTH_RANGE
            specs[p.name] = ParamSpec(p.name, d, kind, lo, hi)
        unknown = set(ranges) - set(specs)
        if unknown:
            raise TypeError(f"shape {name!r}: ranges for unknown parameters {sorted(unknown)}")
        if name in SHAPES:
            raise ValueError(f"shape {name!r} registered twice")

        @functools.wraps(fn)
        def generator(**params: Any) -> Shape:
            checked = check_params(name, specs, params)
            try:
                return fn(**checked)
            except ValueError as e:
                if str(e).startswith(f"shape {name!r}"):
                    raise
                msg = " ".join(str(e).split())
                raise ValueError(f"shape {name!r}: cannot build with these parameters ({msg})") from e
            except TypeError:
                raise
            except Exception as e:  # geometry that cannot be built from these parameters
                msg = " ".join(str(e).split()) or type(e).__name__
                raise ValueError(f"shape {name!r}: cannot build with these parameters ({msg})") from e

        SHAPES[name] = generator
        PARAMS[name] = specs
        return generator

    return deco


def check_params(name: str, specs: Mapping[str, ParamSpec], params: Mapping[str, Any]) -> dict[str, Any]:
    """Type- and range-check ``params`` against ``specs``; returns them with defaults filled."""
    out = {k: s.default for k, s in specs.items()}
    for key, value in params.items():
        if key not in specs:
            allowed = ", ".join(sorted(specs)) or "none"
            raise TypeError(f"shape {name!r}: unknown parameter {key!r} (allowed: {allowed})")
        s = specs[key]
        if s.kind is bool:
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"shape {name!r}: parameter {key!r} must be true or false, got {value!r}")
            value = bool(value)
        elif s.kind is int:
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
                raise TypeError(f"shape {name!r}: parameter {key!r} must be an integer, got {value!r}")
            value = int(value)
        else:
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise TypeError(f"shape {name!r}: parameter {key!r} must be a number, got {value!r}")
            value = float(value)
            if not math.isfinite(value):
                raise ValueError(f"shape {name!r}: parameter {key!r} must be finite, got {value!r}")
        if s.kind is not bool:
            if (s.low is not None and value < s.low) or (s.high is not None and value > s.high):
                lo = "-inf" if s.low is None else f"{s.low:g}"
                hi = "inf" if s.high is None else f"{s.high:g}"
                raise ValueError(f"shape {name!r}: parameter {key!r} = {value:g} is out of range [{lo}, {hi}]")
        out[key] = value
    return out


def need(cond: bool, name: str, param: str, message: str) -> None:
    """Raise a one-line ``ValueError`` naming the parameter unless ``cond`` holds."""
    if not cond:
        raise ValueError(f"shape {name!r}: parameter {param!r}: {message}")


def finish(visual: trimesh.Trimesh, pieces: Iterable[np.ndarray] | None = None,
           shell: ThinShell | None = None) -> Shape:
    """Centre a visual mesh, its collision pieces (and its thin shell) on the visual bounding
    box.

    ``pieces`` default to the visual mesh's convex hull (one piece). Each piece is reduced to
    its hull vertices.
    """
    if pieces is None:
        pieces = [np.asarray(visual.vertices)]
    c = visual.bounds.mean(axis=0)
    v = trimesh.Trimesh(np.asarray(visual.vertices, float) - c, np.asarray(visual.faces),
                        process=False)
    col = tuple(mk.hull_points(np.asarray(p, float) - c) for p in pieces)
    return Shape(v, col, None if shell is None else shell.shifted(-c))


@functools.lru_cache(maxsize=160)
def _build(name: str, key: tuple[tuple[str, Any], ...]) -> Shape:
    return SHAPES[name](**dict(key))


def make_shape(name: str, params: Mapping[str, float | int | bool] | None = None) -> Shape:
    """Build the shape ``name`` with ``params`` (others take their defaults).

    Raises ``KeyError`` for an unknown generator, ``TypeError``/``ValueError`` (one line naming
    the parameter) for unknown, mistyped or out-of-range parameters. Results are cached; each
    call returns its own copy.
    """
    if name not in SHAPES:
        raise KeyError(f"unknown shape generator {name!r} (known: {', '.join(sorted(SHAPES))})")
    checked = check_params(name, PARAMS[name], dict(params or {}))
    s = _build(name, tuple(sorted(checked.items())))
    return Shape(s.visual.copy(), tuple(p.copy() for p in s.collision), s.shell)
