"""How a surface looks: the procedural texture a room surface or a material is drawn with.

A :class:`TextureSpec` names a texture kind, the square of surface one image spans
(``size_m``: the renderer repeats it every ``size_m`` metres, so boards and tiles keep their real
size), the kind's parameters and a seed; :func:`parse_texture` reads one from a data file's
``texture = { kind = "planks", board_width_m = 0.14, ... }`` table. The images themselves are
drawn by :mod:`fallgen.vision.textures`. Kinds and parameters (metres unless said; all optional):

- ``planks``: board_width_m, board_length_m, seam (0..1 darkening), grain (0..1)
- ``tiles``: tile_m, grout_m, grout (relative brightness of the grout, 0..2), variation
- ``plaster``: roughness (0..1)
- ``concrete``: roughness, pores (0..1)
- ``brick``: brick_length_m, brick_height_m, mortar_m, variation
- ``stone``: veins (0..1), scale_m (size of the veining)
- ``carpet``: pile (0..1), mottle (0..1)
- ``fabric``: weave_m (thread spacing), contrast (0..1), folds (0..2: shading of the folds
  curtains hang in), fold_m (their spacing)
- ``veneer``: grain (0..1), figure_m (width of the growth rings' figure)
- ``metal``: brushing (0..1)
- ``wallpaper``: repeat_m (the pattern's repeat), stripes (0..1: a band and a pinstripe per
  repeat, upright on a wall), motif (0..1: a sprig on a half-drop lattice), contrast (0..2)
- ``print``: contrast (0..2); a picture's image, in colour (the only kind not tinted by the
  surface's colour), different for every seed
- ``spines``: spine_m (a book's mean thickness), variation (0..0.5: the spines' tones)
- ``doors``: door_m (about how wide a door is), drawer_m (the drawer row's height, 0: none),
  gap_m, handle (0..1: how dark the handles are), knobs (0..8: a cooker's control knobs in
  the drawer row instead of drawers), face_w_m, face_h_m (the face it is fitted to: the fronts
  of a furniture type's parts, made per part by the scene)
- ``hob``: burner_m (a burner's grate across); a cooker's top with four burners at the
  quarter points of its face (face_w_m x face_h_m), fitted like ``doors``
- ``cushions``: cushion_m (about how wide a cushion is), seam (0..1), puff (0..2: the
  shading of their rounded edges), face_w_m, face_h_m (fitted like ``doors``: a sofa's seat and
  back)
- ``leaves``: leaf_m (a leaf's length), density (0.3..2: how many leaves overlap); a
  plant's foliage, leaves in every direction over the shade inside the crown
- ``window``: pane_m (a pane's side), frame_m (the bars' width); drawn opaque and lit from
  outside (daylight), where the flat view shows the glass as a transparent tint
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from fallgen.fields import Fields


@dataclass(frozen=True)
class TextureSpec:
    """What a texture is: its ``kind`` (a key of :data:`KINDS`), the square of surface it
    spans (``size_m``), its parameters (sorted (name, value) pairs; :meth:`make` fills the
    defaults and checks them) and a seed."""

    kind: str
    size_m: float
    params: tuple[tuple[str, float], ...] = ()
    seed: int = 0

    @staticmethod
    def make(kind: str, size_m: float | None = None, seed: int = 0,
             **params: float) -> TextureSpec:
        """A spec with the kind's defaults filled in; raises ``ValueError`` naming the bad
        field (unknown kind or parameter, a value out of its range)."""
        if kind not in KINDS:
            raise ValueError(f"kind: unknown texture kind {kind!r} ({', '.join(sorted(KINDS))})")
        k = KINDS[kind]
        full = dict(k.defaults)
        for name, value in params.items():
            if name not in k.defaults:
                raise ValueError(f"{name}: not a parameter of {kind} textures "
                                 f"({', '.join(sorted(k.defaults))})")
            lo, hi = k.ranges[name]
            if not isinstance(value, (int, float)) or isinstance(value, bool) \
                    or not (lo <= float(value) <= hi):
                raise ValueError(f"{name}: {value!r} outside {lo:g}..{hi:g}")
            full[name] = float(value)
        size = k.default_size_m(full) if size_m is None else float(size_m)
        if not (0.05 <= size <= 10.0):
            raise ValueError(f"size_m: {size_m!r} outside 0.05..10 m")
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
            raise ValueError(f"seed: {seed!r} is not a non-negative integer")
        return TextureSpec(kind, size, tuple(sorted(full.items())), seed)

    @property
    def param(self) -> Mapping[str, float]:
        return dict(self.params)

    def key(self) -> str:
        """A stable hash of the spec (the cache's file name)."""
        text = f"{self.kind}|{self.size_m!r}|{self.params!r}|{self.seed}"
        return hashlib.sha256(text.encode()).hexdigest()[:20]

    def rng(self) -> np.random.Generator:
        words = [int(self.key()[i:i + 8], 16) for i in range(0, 16, 8)]
        return np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=tuple(words)))


@dataclass(frozen=True)
class Params:
    """A texture kind's parameters: defaults, allowed ranges, and the square of surface a
    texture of given parameters spans by default (a whole number of its repeating units)."""

    defaults: Mapping[str, float]
    ranges: Mapping[str, tuple[float, float]]
    size: Callable[[Mapping[str, float]], float] = field(default=lambda p: 1.0)

    def default_size_m(self, params: Mapping[str, float]) -> float:
        return float(self.size(params))


KINDS: dict[str, Params] = {
    "planks": Params({"board_width_m": 0.14, "board_length_m": 1.2, "seam": 0.6, "grain": 1.0},
                     {"board_width_m": (0.04, 0.4), "board_length_m": (0.2, 5.0),
                      "seam": (0.0, 1.0), "grain": (0.0, 2.0)},
                     lambda p: p["board_width_m"] * max(8, round(p["board_length_m"]
                                                                 / p["board_width_m"]))),
    "tiles": Params({"tile_m": 0.3, "grout_m": 0.004, "grout": 0.75, "variation": 0.02},
                    {"tile_m": (0.02, 1.5), "grout_m": (0.0, 0.02), "grout": (0.0, 2.0),
                     "variation": (0.0, 0.2)},
                    lambda p: 4 * p["tile_m"]),
    "plaster": Params({"roughness": 1.0}, {"roughness": (0.0, 3.0)}, lambda p: 1.0),
    "concrete": Params({"roughness": 1.0, "pores": 0.3},
                       {"roughness": (0.0, 3.0), "pores": (0.0, 1.0)}, lambda p: 1.0),
    "brick": Params({"brick_length_m": 0.215, "brick_height_m": 0.065, "mortar_m": 0.01,
                     "variation": 0.06},
                    {"brick_length_m": (0.1, 0.5), "brick_height_m": (0.03, 0.3),
                     "mortar_m": (0.0, 0.03), "variation": (0.0, 0.3)},
                    lambda p: 4 * (p["brick_length_m"] + p["mortar_m"])),
    "stone": Params({"veins": 1.0, "scale_m": 0.4},
                    {"veins": (0.0, 2.0), "scale_m": (0.05, 2.0)}, lambda p: 2 * p["scale_m"]),
    "carpet": Params({"pile": 1.0, "mottle": 1.0},
                     {"pile": (0.0, 2.0), "mottle": (0.0, 2.0)}, lambda p: 0.5),
    "fabric": Params({"weave_m": 0.004, "contrast": 1.0, "folds": 0.0, "fold_m": 0.12},
                     {"weave_m": (0.001, 0.05), "contrast": (0.0, 2.0), "folds": (0.0, 2.0),
                      "fold_m": (0.03, 0.5)}, lambda p: 0.25 if p["folds"] == 0 else 0.6),
    "veneer": Params({"grain": 1.0, "figure_m": 0.12},
                     {"grain": (0.0, 2.0), "figure_m": (0.01, 1.0)}, lambda p: 0.6),
    "metal": Params({"brushing": 1.0}, {"brushing": (0.0, 2.0)}, lambda p: 0.5),
    "wallpaper": Params({"repeat_m": 0.16, "stripes": 0.0, "motif": 1.0, "contrast": 1.0},
                        {"repeat_m": (0.02, 1.0), "stripes": (0.0, 1.0), "motif": (0.0, 1.0),
                         "contrast": (0.0, 2.0)}, lambda p: 4 * p["repeat_m"]),
    "print": Params({"contrast": 1.0}, {"contrast": (0.0, 2.0)}, lambda p: 0.5),
    "spines": Params({"spine_m": 0.03, "variation": 0.15},
                     {"spine_m": (0.005, 0.2), "variation": (0.0, 0.5)}, lambda p: 0.6),
    "doors": Params({"door_m": 0.5, "drawer_m": 0.15, "gap_m": 0.004, "handle": 1.0,
                     "knobs": 0.0, "face_w_m": 1.0, "face_h_m": 0.8},
                    {"door_m": (0.1, 5.0), "drawer_m": (0.0, 2.0), "gap_m": (0.0, 0.02),
                     "handle": (0.0, 1.0), "knobs": (0.0, 8.0), "face_w_m": (0.05, 10.0),
                     "face_h_m": (0.05, 10.0)},
                    lambda p: p["face_h_m"]),
    "hob": Params({"burner_m": 0.17, "face_w_m": 0.6, "face_h_m": 0.6},
                  {"burner_m": (0.05, 0.4), "face_w_m": (0.1, 3.0), "face_h_m": (0.1, 3.0)},
                  lambda p: p["face_h_m"]),
    "cushions": Params({"cushion_m": 0.6, "seam": 1.0, "puff": 1.0, "face_w_m": 1.8,
                        "face_h_m": 0.6},
                       {"cushion_m": (0.1, 3.0), "seam": (0.0, 1.0), "puff": (0.0, 2.0),
                        "face_w_m": (0.05, 10.0), "face_h_m": (0.05, 10.0)},
                       lambda p: p["face_h_m"]),
    "leaves": Params({"leaf_m": 0.07, "density": 1.0},
                     {"leaf_m": (0.01, 0.5), "density": (0.3, 2.0)}, lambda p: 6 * p["leaf_m"]),
    "window": Params({"pane_m": 0.6, "frame_m": 0.06},
                     {"pane_m": (0.2, 2.0), "frame_m": (0.02, 0.2)}, lambda p: 2 * p["pane_m"]),
}


def parse_texture(f: Fields, key: str = "texture") -> TextureSpec:
    """The texture of a data file's ``key`` table (``kind`` required, ``size_m``, ``seed`` and
    the kind's parameters optional); a bad field is an error naming it."""
    t = f.table(key)
    kind = t.str("kind", choices=sorted(KINDS))
    params = {k: t.float(k) for k in t.keys() if k not in ("kind", "size_m", "seed")}
    size = t.float("size_m") if "size_m" in t else None
    seed = t.int("seed", 0, lo=0)
    try:
        return TextureSpec.make(kind, size, seed, **params)
    except ValueError as e:
        name, _, msg = str(e).partition(": ")
        raise t.error(name, msg) from None
