"""Procedural textures for the rooms' surfaces and furniture: wood floors, tiles, plaster,
stone, carpet, fabric, veneer, brushed metal, wallpaper, pictures, books' spines and windows.

A texture is a pure function of its :class:`TextureSpec` (kind, physical size, parameters,
seed): a square, seamlessly tileable image of ``size_m`` x ``size_m`` of surface, so that a
renderer repeating it every ``size_m`` metres shows boards, tiles and grain at their real
size. Randomness comes from ``numpy.random.SeedSequence`` over the spec's seed and a hash of
its fields, never from a global generator; noise is made periodic by filtering white noise in
the Fourier domain, so the image wraps without a seam.

Images are *luminance patterns* around a mean of :data:`MEAN_LEVEL` (a slight warm or cool
cast where the material has one): the renderer multiplies them by the surface's own colour
(the room file's or material's ``rgba``), so one texture serves every colour of its kind. A
picture (``print``) is in colour and is not tinted.
:func:`texture_file` writes a texture once as a PNG under a cache directory, keyed by the
spec's hash.

Kinds, parameters and their ranges: :mod:`fallgen.world.appearance`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from fallgen.atomic import write_bytes
from fallgen.world.appearance import TextureSpec

#: Mean level of every texture (0..1): surface colour x texture ~ the colour itself.
MEAN_LEVEL = 0.9
#: Pixels per side of a texture image.
DEFAULT_PX = 256
#: Pixels per side of the textures a scene carries to the renderer: a 300 px view of a room
#: resolves ~1 cm at 1 m, and every episode's scene uploads its textures.
SCENE_PX = 128


# --- building blocks -----------------------------------------------------------------------------

def periodic_noise(rng: np.random.Generator, px: int, sigma_px: float | tuple[float, float]
                   ) -> np.ndarray:
    """(px, px) float32 noise of zero mean and unit standard deviation, smooth over
    ``sigma_px`` pixels (a Gaussian kernel; a pair: (along y, along x)), periodic in both
    axes (filtered in the Fourier domain)."""
    sy, sx = (sigma_px, sigma_px) if np.isscalar(sigma_px) else sigma_px
    white = rng.standard_normal((px, px))
    fy = np.fft.fftfreq(px)[:, None]
    fx = np.fft.fftfreq(px)[None, :]
    kernel = np.exp(-2 * math.pi ** 2 * ((fy * sy) ** 2 + (fx * sx) ** 2))
    n = np.fft.ifft2(np.fft.fft2(white) * kernel).real
    s = n.std()
    return ((n - n.mean()) / (s if s > 0 else 1.0)).astype(np.float32)


def _to_image(level: np.ndarray, tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
              ) -> np.ndarray:
    """A luminance field (mean ~0) around :data:`MEAN_LEVEL`, tinted, as (px, px, 3) uint8."""
    rgb = (MEAN_LEVEL * (1.0 + level))[..., None] * np.asarray(tint, np.float32)
    return np.clip(np.rint(rgb * 255.0), 0, 255).astype(np.uint8)


def _units(size_m: float, unit_m: float) -> int:
    """How many whole units of about ``unit_m`` fit in ``size_m`` (at least 1)."""
    return max(1, int(round(size_m / unit_m)))


# --- kinds ---------------------------------------------------------------------------------------

def _planks(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    p = spec.param
    n_boards = _units(spec.size_m, p["board_width_m"])
    n_len = _units(spec.size_m, p["board_length_m"])
    x = np.arange(px)
    board = x * n_boards // px  # column -> board index
    level = np.zeros((px, px), np.float32)
    grain = periodic_noise(rng, px, (px / 16, 0.6))  # long streaks along y
    fine = periodic_noise(rng, px, 0.7)
    tone = rng.normal(0.0, 0.07, n_boards)
    offset = rng.integers(0, px, n_boards)
    level += tone[board][None, :]
    level += p["grain"] * (0.09 * grain + 0.02 * fine)
    seam_w = max(1, px // 256)
    dark = p["seam"] * 0.35  # a joint is darker than both boards it parts
    starts = (np.arange(n_boards) * px) // n_boards
    for b in range(n_boards):
        c0 = starts[b]
        c1 = starts[b + 1] if b + 1 < n_boards else px
        level[:, c0:c0 + seam_w] = min(tone[b], tone[b - 1]) - dark
        for k in range(n_len):  # staggered end joints
            r = (offset[b] + k * px // n_len) % px
            level[r:r + seam_w, c0 + seam_w:c1] = tone[b] - dark
    return _to_image(level, (1.0, 0.97, 0.93))


def _tiles(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    p = spec.param
    n = _units(spec.size_m, p["tile_m"])
    idx = np.arange(px) * n // px
    pos = (np.arange(px) * n / px) % 1.0  # position within a tile, 0..1
    g = p["grout_m"] / (spec.size_m / n)  # grout as a share of a tile
    tone = rng.normal(0.0, p["variation"], (n, n))
    level = tone[idx[:, None], idx[None, :]] + 0.015 * periodic_noise(rng, px, 1.0)
    in_grout = (pos[:, None] < g / 2) | (pos[:, None] > 1 - g / 2) | \
        (pos[None, :] < g / 2) | (pos[None, :] > 1 - g / 2)
    level = np.where(in_grout, p["grout"] - 1.0 + 0.03 * periodic_noise(rng, px, 0.8), level)
    return _to_image(level.astype(np.float32))


def _plaster(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    r = spec.param["roughness"]
    # a trowelled, painted finish: grain at ~1 cm (what a view 2-4 m away still resolves)
    # over broad, faint clouding
    level = r * (0.02 * periodic_noise(rng, px, 0.8) + 0.045 * periodic_noise(rng, px, px / 96)
                 + 0.03 * periodic_noise(rng, px, px / 24))
    return _to_image(level)


def _concrete(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    p = spec.param
    level = p["roughness"] * (0.05 * periodic_noise(rng, px, 1.0)
                              + 0.06 * periodic_noise(rng, px, px / 20))
    pores = periodic_noise(rng, px, 1.2) > 3.0 - p["pores"]
    level = np.where(pores, level - 0.25, level)
    return _to_image(level.astype(np.float32), (1.0, 1.0, 0.98))


def _brick(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    p = spec.param
    rows = _units(spec.size_m, p["brick_height_m"] + p["mortar_m"])
    cols = _units(spec.size_m, p["brick_length_m"] + p["mortar_m"])
    y = np.arange(px) * rows / px
    x = np.arange(px) * cols / px
    row = y.astype(int)
    xs = (x[None, :] + 0.5 * (row[:, None] % 2)) % cols  # running bond
    col = xs.astype(int)
    tone = rng.normal(0.0, p["variation"], (rows, cols))
    level = tone[row[:, None], col] + 0.05 * periodic_noise(rng, px, 1.0)
    my = p["mortar_m"] / (spec.size_m / rows)
    mx = p["mortar_m"] / (spec.size_m / cols)
    mortar = ((y % 1.0)[:, None] < my) | ((xs % 1.0) < mx)
    level = np.where(mortar, 0.15 + 0.03 * periodic_noise(rng, px, 0.8), level)
    return _to_image(level.astype(np.float32), (1.0, 0.9, 0.85))


def _stone(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    p = spec.param
    k = max(1, int(round(spec.size_m / p["scale_m"])))
    u = np.arange(px) / px
    turb = periodic_noise(rng, px, px / (6 * k)) * 1.6 + periodic_noise(rng, px, px / (20 * k))
    phase = 2 * math.pi * k * (u[None, :] + 0.5 * u[:, None]) + 2.5 * turb
    veins = np.abs(np.sin(phase)) ** 0.25  # 0 at a vein, 1 between
    level = p["veins"] * 0.22 * (veins - 1.0) + 0.04 * periodic_noise(rng, px, px / 32) \
        + 0.015 * periodic_noise(rng, px, 0.8)
    return _to_image(level.astype(np.float32))


def _carpet(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    p = spec.param
    # tufts at ~1 cm (what a view still resolves) over fine pile and broad mottling
    level = p["pile"] * (0.06 * periodic_noise(rng, px, 0.5)
                         + 0.06 * periodic_noise(rng, px, px / 128)) \
        + p["mottle"] * 0.06 * periodic_noise(rng, px, px / 16)
    return _to_image(level)


def _fabric(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    p = spec.param
    threads = max(2, int(round(spec.size_m / p["weave_m"])))
    threads = min(threads, px // 3)  # at least 3 pixels a thread
    u = np.arange(px) * threads / px
    warp = np.sin(2 * math.pi * u)[None, :]
    weft = np.sin(2 * math.pi * u)[:, None]
    checker = np.where((u.astype(int)[:, None] + u.astype(int)[None, :]) % 2 == 0, warp, weft)
    level = p["contrast"] * 0.08 * checker + 0.03 * periodic_noise(rng, px, px / 24)
    if p["folds"] > 0:  # hung in folds: light and shade across them, along the image's x
        n_folds = max(1, int(round(spec.size_m / p["fold_m"])))
        u = np.arange(px) / px
        wobble = 0.15 * periodic_noise(rng, px, (px / 4, px / 16))
        level = level + p["folds"] * 0.18 * np.sin(2 * math.pi * (n_folds * u[None, :] + wobble))
    return _to_image(level.astype(np.float32))


def _veneer(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    p = spec.param
    k = max(1, int(round(spec.size_m / p["figure_m"])))
    u = np.arange(px) / px
    warp = periodic_noise(rng, px, (px / 8, px / 40))
    rings = np.sin(2 * math.pi * k * (u[None, :] + 0.04 * warp)) * np.ones((px, 1))
    streaks = periodic_noise(rng, px, (px / 10, 0.7))
    level = p["grain"] * (0.05 * rings + 0.05 * streaks)
    return _to_image(level.astype(np.float32), (1.0, 0.97, 0.93))


def _metal(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    b = spec.param["brushing"]
    level = b * 0.06 * periodic_noise(rng, px, (0.5, px / 6)) \
        + 0.01 * periodic_noise(rng, px, px / 16)
    return _to_image(level, (0.98, 0.99, 1.0))


def _smooth_step(x: np.ndarray, width: float) -> np.ndarray:
    """0 below -width / 2, 1 above +width / 2, linear between (an edge anti-aliased over
    ``width``)."""
    return np.clip(x / width + 0.5, 0.0, 1.0)


def _wallpaper(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    p = spec.param
    n = _units(spec.size_m, p["repeat_m"])  # pattern repeats across the image, both ways
    u = (np.arange(px) + 0.5) * n / px
    x, y = u[None, :] % 1.0, u[:, None] % 1.0  # position within a repeat (x: along the wall)
    pix = n / px  # one pixel, in repeats
    level = np.zeros((px, px), np.float32)
    if p["stripes"] > 0:  # a broad band and a pinstripe per repeat, upright on a wall
        band = 2.0 * _smooth_step(0.25 - np.abs(x - 0.25), pix) - 1.0
        pin = _smooth_step(0.012 - np.abs(x - 0.75), pix)
        level = level + p["stripes"] * (0.05 * band + 0.08 * pin)
    if p["motif"] > 0:  # a four-petalled sprig on a half-drop (diamond) lattice
        best = np.full((px, px), np.inf, np.float32)
        for cx, cy in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)):
            dx, dy = x - cx, y - cy
            r = np.hypot(dx, dy)
            th = np.arctan2(dy, dx)
            edge = r - 0.2 * (0.7 + 0.3 * np.cos(4 * th))  # < 0 inside the petals
            best = np.minimum(best, edge)
        level = level - p["motif"] * 0.11 * _smooth_step(-best, pix)
    level = p["contrast"] * level + 0.012 * periodic_noise(rng, px, 0.8)  # the paper's grain
    return _to_image((level - level.mean()).astype(np.float32))


def _print(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    """A framed picture's image: broad fields of colour from a small palette, broken by
    brush-like streaks (in colour: the picture's frame and canvas colours do not tint it)."""
    c = spec.param["contrast"]
    k = 4
    # muted colours: a grey of random lightness, each channel off it by ~25 %
    palette = np.clip(rng.uniform(0.2, 0.9, (k, 1)) * (1.0 + 0.25 * rng.standard_normal((k, 3))),
                      0.03, 1.0)
    fields = np.stack([periodic_noise(rng, px, px / 12) for _ in range(k)])
    fields = fields + 0.4 * np.stack([periodic_noise(rng, px, px / 48) for _ in range(k)])
    soft = np.exp(2.5 * fields)  # soft assignment of each pixel to one palette colour
    weights = soft / soft.sum(0, keepdims=True)
    rgb = np.einsum("kyx,kc->yxc", weights, palette)
    streaks = 0.07 * periodic_noise(rng, px, (0.8, px / 24))
    rgb = rgb.mean() + c * (rgb - rgb.mean()) + c * streaks[..., None]
    return np.clip(np.rint(rgb * 255.0), 0, 255).astype(np.uint8)


def _spines(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    """Books on a shelf seen from the front: upright spines of random widths and tones, each
    with a lighter label band, parted by dark gaps."""
    p = spec.param
    edges = [0]
    w = spec.size_m / px  # metres per pixel
    while edges[-1] < px:
        edges.append(edges[-1] + max(2, int(round(rng.uniform(0.5, 1.5) * p["spine_m"] / w))))
    edges[-1] = px  # the last spine ends at the image's edge (it wraps onto the first)
    level = np.zeros((px, px), np.float32)
    rows = np.arange(px)
    for a, b in zip(edges[:-1], edges[1:]):
        tone = rng.normal(0.0, p["variation"])
        col = np.full(px, tone, np.float32)
        y0 = int(rng.integers(0, px))
        band = (rows - y0) % px < max(2, px // 10)  # a title label across the spine
        col[band] += 0.12
        level[:, a:b] = col[:, None]
        level[:, a] = tone - 0.3  # the gap between two books
    level = level + 0.02 * periodic_noise(rng, px, 0.8)
    return _to_image(level.astype(np.float32))


def _window(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    """A glazed wall from inside: bright panes of daylit sky with soft cloud, between the
    frame's bars (``frame_m`` wide, a pane every ``pane_m``), their edges in shade."""
    p = spec.param
    n = _units(spec.size_m, p["pane_m"])
    u = (np.arange(px) + 0.5) * n / px % 1.0  # position within a pane, 0..1
    half = 0.5 * p["frame_m"] / (spec.size_m / n)  # half a bar, as a share of a pane
    dist = np.minimum(np.minimum(u, 1.0 - u)[:, None], np.minimum(u, 1.0 - u)[None, :])
    sky = 0.1 + 0.05 * periodic_noise(rng, px, px / 10)
    bar = -0.12 + 0.01 * periodic_noise(rng, px, 0.8)
    edge = dist < half + 1.5 * n / px  # the bar's rebate, in shade
    level = np.where(dist < half, bar, np.where(edge, -0.3, sky))
    return _to_image(level.astype(np.float32))


def _cover(lo: float, hi: float, size: float, px: int) -> np.ndarray:
    """(px,) share of each of ``px`` pixels spanning ``size`` that [lo, hi] covers: a line
    thinner than a pixel drawn as the part of it it darkens (anti-aliased)."""
    edges = np.arange(px + 1) * size / px
    return np.clip(np.minimum(hi, edges[1:]) - np.maximum(lo, edges[:-1]), 0.0, None) \
        * px / size


def _doors(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    """The front of a cabinet, counter or appliance, fitted to one face (``face_w_m`` x
    ``face_h_m``: the image spans the face once, stretched): doors about ``door_m`` wide under
    a row of drawers ``drawer_m`` high (0: none), parted by ``gap_m`` shadow gaps, each with a
    bar handle (``handle``: how dark), lines thinner than a pixel anti-aliased. The image's
    first row is the face's top edge."""
    p = spec.param
    w, h, g = p["face_w_m"], p["face_h_m"], p["gap_m"]
    n = max(1, int(round(w / p["door_m"])))
    # gaps between the doors (and the drawers above them), half gaps at the face's edges
    gx = np.maximum.reduce([_cover(k * w / n - g / 2, k * w / n + g / 2, w, px)
                            for k in range(n + 1)])
    drawer = p["drawer_m"] if 0.0 < p["drawer_m"] < 0.7 * h else 0.0
    rows = [0.0, h] + ([drawer] if drawer else [])
    gy = np.maximum.reduce([_cover(r - g / 2, r + g / 2, h, px) for r in rows])
    gap = np.minimum(1.0, np.maximum(gx[None, :], gy[:, None]))
    handle = np.zeros((px, px))
    hw, hl = 0.012, min(0.14, 0.5 * h)  # a bar handle's width and length
    knobs = int(round(p["knobs"])) if drawer else 0
    for k in range(n):
        x0, x1 = k * w / n, (k + 1) * w / n
        if knobs:  # an oven: one bar across the top of its door, knobs above (no drawers)
            handle = np.maximum(handle, _cover(drawer + 0.04, drawer + 0.04 + 1.5 * hw, h,
                                               px)[:, None]
                                * _cover(x0 + 0.15 * (x1 - x0), x1 - 0.15 * (x1 - x0), w,
                                         px)[None, :])
            continue
        # a door's handle by the edge it opens from (pairs meet in the middle), near its top
        hx = x1 - 0.05 if (k % 2 == 0 and k + 1 < n) or n == 1 else x0 + 0.05
        handle = np.maximum(handle, _cover(drawer + 0.05, drawer + 0.05 + hl, h, px)[:, None]
                            * _cover(hx - hw / 2, hx + hw / 2, w, px)[None, :])
        if drawer:  # the drawer's handle, across its middle
            xm = (x0 + x1) / 2
            handle = np.maximum(handle,
                                _cover(drawer / 2 - hw / 2, drawer / 2 + hw / 2, h, px)[:, None]
                                * _cover(xm - hl / 2, xm + hl / 2, w, px)[None, :])
    handle = np.minimum(handle, 1.0)
    level = 0.012 * periodic_noise(rng, px, 1.0) - 0.45 * gap \
        - 0.5 * p["handle"] * handle * (1.0 - gap)
    if knobs:
        level = level + _knobs(knobs, w, h, drawer, px, rng)
    return _to_image(level.astype(np.float32))


def _face_metres(w: float, h: float, px: int) -> tuple[np.ndarray, np.ndarray, float]:
    """(x, y) of the pixel centres of an image stretched over a ``w`` x ``h`` m face, in
    metres from its top left corner (x across, y down), and the larger pixel side."""
    x = (np.arange(px) + 0.5) * w / px
    y = (np.arange(px) + 0.5) * h / px
    return x[None, :], y[:, None], max(w, h) / px


def _disc(d: np.ndarray, r: float, pixel: float) -> np.ndarray:
    """Coverage of a disc of radius ``r`` at distance ``d`` (m) from its centre, its edge
    anti-aliased over a pixel."""
    return np.clip((r - d) / pixel + 0.5, 0.0, 1.0)


def _knobs(n: int, w: float, h: float, strip: float, px: int, rng: np.random.Generator
           ) -> np.ndarray:
    """A cooker's control strip (the top ``strip`` m of a ``w`` x ``h`` m front): ``n`` round
    knobs in a row across it, dark, lit from above (a bright upper rim, a shadow under), each
    with its pointer turned to its own setting."""
    x, y, pixel = _face_metres(w, h, px)
    r = min(0.022, 0.35 * strip, 0.4 * w / n)
    out = np.zeros((px, px))
    for k in range(n):
        cx, cy = (k + 0.5) * w / n, strip / 2
        dx, dy = x - cx, y - cy
        d = np.hypot(dx, dy)
        shadow = _disc(np.hypot(dx, dy - 0.3 * r), 1.1 * r, pixel)
        body = _disc(d, r, pixel)
        rim = body * (1.0 - _disc(d, 0.75 * r, pixel)) * np.clip(-dy / r, 0.0, 1.0)
        turn = float(rng.uniform(-0.75, 0.75)) * math.pi  # from pointing straight up
        along = dx * math.sin(turn) - dy * math.cos(turn)  # along the pointer
        across = np.abs(dx * math.cos(turn) + dy * math.sin(turn))
        pointer = _disc(d, 0.8 * r, pixel) * (along > 0.15 * r) \
            * np.clip((0.12 * r - across) / pixel + 0.5, 0.0, 1.0)
        out += -0.25 * shadow * (1.0 - body) - 0.55 * body + 0.35 * rim + 0.6 * pointer
    return out


def _hob(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    """A gas cooker's top, fitted to its face (``face_w_m`` x ``face_h_m``): four burners at
    the face's quarter points, each a dark cap in a lighter crown inside a black cast-iron
    grate of ``burner_m`` across (an outer ring and four bars), on the top's own finish."""
    p = spec.param
    w, h = p["face_w_m"], p["face_h_m"]
    x, y, pixel = _face_metres(w, h, px)
    big = 0.5 * min(p["burner_m"], 0.45 * min(w, h))  # a grate's radius
    bar = max(0.01, pixel)
    level = 0.01 * periodic_noise(rng, px, 1.0)
    for cx in (w / 4, 3 * w / 4):
        for cy in (h / 4, 3 * h / 4):
            dx, dy = x - cx, y - cy
            d = np.hypot(dx, dy)
            crown = _disc(d, 0.42 * big, pixel) - _disc(d, 0.3 * big, pixel)
            cap = _disc(d, 0.3 * big, pixel)
            ring = _disc(d, big, pixel) - _disc(d, big - bar, pixel)
            arms = np.maximum(np.clip((bar / 2 - np.abs(dx)) / pixel + 0.5, 0, 1),
                              np.clip((bar / 2 - np.abs(dy)) / pixel + 0.5, 0, 1)) \
                * (d > 0.45 * big) * _disc(d, big, pixel)
            # the grate's shadow on the top, then the grate over everything
            shade = _disc(d, big, pixel) * 0.12
            grate = np.maximum(ring, arms)
            level = level - shade - 0.3 * crown - 0.7 * cap
            level = level * (1.0 - grate) - 0.75 * grate
    return _to_image((level - level.mean()).astype(np.float32))


def _cushions(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    """Upholstered cushions side by side, fitted to one face (``face_w_m`` x ``face_h_m``):
    about ``cushion_m`` wide each, parted by seams (``seam``: how dark), each shaded toward its
    rounded edges (``puff``), in a woven fabric."""
    p = spec.param
    w = p["face_w_m"]
    n = max(1, int(round(w / p["cushion_m"])))
    x = (np.arange(px) + 0.5) / px  # across the face, 0..1
    y = (np.arange(px) + 0.5) / px
    within = (x * n) % 1.0  # across one cushion
    # the cushion's surface falls away toward its edges: darker there
    shade_x = 1.0 - np.sin(np.pi * within) ** 0.5
    shade_y = 1.0 - np.sin(np.pi * y) ** 0.5
    level = -p["puff"] * 0.12 * np.maximum(shade_x[None, :], shade_y[:, None])
    seam = np.minimum(within, 1.0 - within) * w / n < max(0.006, 0.75 * w / px)
    level = np.where(seam[None, :], level - 0.25 * p["seam"], level)
    level = level + 0.03 * periodic_noise(rng, px, 0.7) + 0.02 * periodic_noise(rng, px, px / 32)
    return _to_image((level - level.mean()).astype(np.float32))


def _leaves(spec: TextureSpec, px: int, rng: np.random.Generator) -> np.ndarray:
    """Foliage: pointed leaves about ``leaf_m`` long (the image spans 6 of them) lying in
    every direction, later ones over earlier ones, each in its own tone and lit on one side
    of its midrib, over the deep shade between them; ``density`` sets how many overlap (at 1
    the shade shows through about a tenth of the crown)."""
    p = spec.param
    n = int(round(350 * p["density"]))
    scale = px / 6.0  # pixels per leaf length
    level = np.full((px, px), -0.5, np.float32)  # the shade inside the crown
    for _ in range(n):
        cx, cy = rng.uniform(0, px, 2)
        a = float(rng.uniform(0, math.pi))
        half_l = 0.5 * scale * float(rng.uniform(0.7, 1.3))
        half_w = half_l * float(rng.uniform(0.3, 0.5))
        tone = float(rng.uniform(-0.1, 0.06))
        side = float(rng.choice((-1.0, 1.0)))
        # the pixels of the leaf's bounding square, wrapped (the image tiles)
        r = int(math.ceil(half_l)) + 1
        cols = np.arange(int(cx) - r, int(cx) + r + 1)
        rows = np.arange(int(cy) - r, int(cy) + r + 1)
        dx = (cols + 0.5 - cx)[None, :]
        dy = (rows + 0.5 - cy)[:, None]
        u = dx * math.cos(a) + dy * math.sin(a)  # along the leaf
        v = -dx * math.sin(a) + dy * math.cos(a)
        t = np.clip(u / half_l, -1.0, 1.0)
        inside = (np.abs(u) < half_l) & (np.abs(v) < half_w * (1.0 - t * t))  # a lens
        rib = np.clip(1.0 - np.abs(v) / 0.8, 0.0, 1.0) * (np.abs(t) < 0.9)
        leaf = tone + 0.05 * side * np.sign(v) - 0.12 * rib
        ix = np.ix_(rows % px, cols % px)
        level[ix] = np.where(inside, leaf, level[ix])
    level = level + 0.02 * periodic_noise(rng, px, 1.0)
    # the leaves at the mean level, the shade below it (a brighter pattern would clip)
    return _to_image(level.astype(np.float32))


#: How each kind is drawn (its parameters: :data:`fallgen.world.appearance.KINDS`).
DRAW: dict[str, Callable[[TextureSpec, int, np.random.Generator], np.ndarray]] = {
    "planks": _planks, "tiles": _tiles, "plaster": _plaster, "concrete": _concrete,
    "brick": _brick, "stone": _stone, "carpet": _carpet, "fabric": _fabric, "veneer": _veneer,
    "metal": _metal, "wallpaper": _wallpaper, "print": _print, "spines": _spines,
    "window": _window, "doors": _doors, "hob": _hob, "leaves": _leaves,
    "cushions": _cushions,
}


def render_texture(spec: TextureSpec, px: int = DEFAULT_PX) -> np.ndarray:
    """The texture's image, (px, px, 3) uint8, RGB, tileable; the same bytes for the same
    spec and size."""
    if px < 16 or px & (px - 1):
        raise ValueError(f"px: {px} is not a power of two >= 16")
    return DRAW[spec.kind](spec, px, spec.rng())


@functools.lru_cache(maxsize=512)
def texture_bytes(spec: TextureSpec, px: int = SCENE_PX) -> tuple[int, int, int, bytes]:
    """(width, height, channels, RGB bytes) of the texture, as a MuJoCo texture takes them;
    drawn once per process (the 64 variants use ~120 textures, fronts fitted to their parts
    and pictures included: 49 kB each at 128 px)."""
    img = render_texture(spec, px)
    return img.shape[1], img.shape[0], 3, img.tobytes()


def texture_file(spec: TextureSpec, cache_dir: str | Path, px: int = DEFAULT_PX) -> Path:
    """The texture as a PNG under ``cache_dir`` (made once; its name is the spec's hash and
    the size)."""
    d = Path(cache_dir)
    path = d / f"{spec.kind}-{spec.key()}-{px}.png"
    if not path.exists():
        d.mkdir(parents=True, exist_ok=True)
        ok, png = cv2.imencode(".png", cv2.cvtColor(render_texture(spec, px), cv2.COLOR_RGB2BGR))
        if not ok:
            raise OSError(f"{path}: could not encode the texture as PNG")
        write_bytes(path, png.tobytes())  # atomic: a reader never sees half a file
    return path


def detail_share(rgb: np.ndarray, threshold: float = 3.0, window: int = 5) -> float:
    """The share of pixels with local detail: grey-level standard deviation above
    ``threshold`` (0-255 scale) in a ``window`` x ``window`` neighbourhood (how much of a
    view shows texture rather than flat colour)."""
    g = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY).astype(np.float32)
    mu = cv2.blur(g, (window, window))
    sd = np.sqrt(np.maximum(cv2.blur(g * g, (window, window)) - mu * mu, 0.0))
    return float((sd > threshold).mean())
