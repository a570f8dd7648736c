"""``fallgen show DATASET EPISODE``: one picture of an episode, for people to trust the data.

Top: the egocentric RGB, depth and category segmentation at step 0. Middle: the room from above
(furniture, fall zones, the episode's zone highlighted, the object's resting place, the spawn
with its heading and the expert's path to its final pose and view direction). Bottom: the
spectrograms of the left and right ear. Optionally the binaural audio as a stereo WAV.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import cv2
import numpy as np
import soundfile as sf

from fallgen.atomic import write_bytes
from fallgen.audio.mix import FULL_SCALE_PA
from fallgen.audio.preview import spectrogram_image
from fallgen.world.preview import draw_variant, write_png

PANEL = 360
_FONT = cv2.FONT_HERSHEY_SIMPLEX


def _label(img: np.ndarray, text: str, y: int = 18, x: int = 6, scale: float = 0.5,
           color=(0, 0, 0)) -> None:
    cv2.putText(img, text, (x, y), _FONT, scale, color, 1, cv2.LINE_AA)


def _palette(n: int) -> np.ndarray:
    """Distinct colours for segmentation labels (0 = nothing, black), golden-ratio hues."""
    hsv = np.zeros((n, 1, 3), np.uint8)
    hsv[:, 0, 0] = (np.arange(n) * 0.618034 * 180).astype(int) % 180
    hsv[:, 0, 1] = 170
    hsv[:, 0, 2] = 230
    rgb = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[:, 0]
    rgb[0] = 0
    return rgb


def depth_image(depth: np.ndarray, far_m: float | None = None) -> tuple[np.ndarray, float]:
    far = float(far_m or max(1.0, np.nanpercentile(depth, 99)))
    v = np.clip(depth / far, 0, 1)
    return cv2.applyColorMap((255 * (1 - v)).astype(np.uint8), cv2.COLORMAP_VIRIDIS)[:, :, ::-1], far


def segmentation_image(category: np.ndarray, labels: list[str], target: str
                       ) -> tuple[np.ndarray, list[tuple[str, np.ndarray, int]]]:
    """Coloured category segmentation and its legend (label, colour, pixels), largest first,
    the target's category always listed."""
    pal = _palette(max(len(labels), int(category.max()) + 1))
    img = pal[category]
    vals, counts = np.unique(category, return_counts=True)
    legend = [(labels[v] if v < len(labels) else str(v), pal[v], int(c))
              for v, c in zip(vals, counts) if v > 0]
    legend.sort(key=lambda t: (t[0] != target, -t[2]))
    return img, legend


def _tile(img: np.ndarray, title: str) -> np.ndarray:
    """The image at PANEL x PANEL with a caption strip above it."""
    t = np.full((PANEL + 26, PANEL + 4, 3), 255, np.uint8)
    t[26:, 2:-2] = cv2.resize(img, (PANEL, PANEL), interpolation=cv2.INTER_NEAREST)
    _label(t, title)
    return t


def episode_figure(ep: dict, variant, labels: list[str]) -> np.ndarray:
    """The picture (RGB uint8) of one episode (a dict from :mod:`fallgen.dataset.reader`)."""
    rgb = _tile(ep["rgb"], "RGB, step 0")
    dimg, far = depth_image(ep["depth"])
    depth = _tile(dimg, f"depth, 0-{far:.1f} m (bright = near)")
    seg_raw, legend = segmentation_image(ep["category_seg"], labels, ep["category"])
    seg = _tile(seg_raw, "category segmentation")
    key = np.full((PANEL + 26, 220, 3), 255, np.uint8)
    _label(key, "segments (pixels)", 18)
    for k, (name, col, n) in enumerate(legend[:16]):
        y = 40 + 19 * k
        cv2.rectangle(key, (6, y - 11), (20, y + 2), tuple(int(c) for c in col), -1)
        mark = " <- target" if name == ep["category"] else ""
        cv2.putText(key, f"{name} ({n}){mark}"[:32], (26, y), _FONT, 0.38, (0, 0, 0), 1,
                    cv2.LINE_AA)
    top = np.hstack([rgb, depth, seg, key])

    plan = draw_variant(variant, 90.0, overlay=lambda img, px: _overlay(img, px, ep, variant))
    spectra = []
    audio = np.asarray(ep["audio"], float) * FULL_SCALE_PA / ep["audio_gain"]
    top_db = 10 * math.ceil(ep["audio_peak_db_spl"] / 10)  # the colour range follows the clip
    for e, name in enumerate(("left ear", "right ear")):
        spectra.append(spectrogram_image(audio[e], ep["sample_rate"], name, top_db - 90,
                                         top_db, size=(top.shape[1] // 2, 220)))
    bottom = np.hstack(spectra)

    w = top.shape[1]
    if plan.shape[1] > w:
        plan = cv2.resize(plan, (w, int(plan.shape[0] * w / plan.shape[1])),
                          interpolation=cv2.INTER_AREA)
    middle = np.full((plan.shape[0], w, 3), 255, np.uint8)
    middle[:, :plan.shape[1]] = plan
    head = np.full((76, w, 3), 255, np.uint8)
    _label(head, (f"episode {ep['episode_id']} ({ep['split']}): {ep['category']} "
                  f"({ep['audio_material']}, {ep['mass_kg'] * 1e3:.0f} g) fell onto "
                  f"{ep['zone']} ({ep['zone_kind']}) of {ep['room_variant']}"), 22, scale=0.6)
    _label(head, (f"expert {len(ep['expert_actions'])} actions, {ep['expert_path_m']:.2f} m; "
                  f"audio peak {ep['audio_peak_db_spl']:.0f} dB SPL, Leq(125 ms) "
                  f"{ep['audio_leq_db_spl']:.0f} dB SPL; event {ep['event_id']}"), 46, scale=0.5,
           color=(60, 60, 60))
    x = 6
    for text, col in (("map: spawn and heading", (0, 140, 0)), ("expert path, final heading",
                                                                (0, 60, 255)),
                      ("object (star) and its fall zone", (255, 0, 0))):
        _label(head, text, 68, x, 0.45, col)
        x += 8 * len(text) + 24
    return np.vstack([head, top, middle, bottom])


def _arrow(img, px, x, y, yaw, color, length_m=0.45, thickness=2) -> None:
    a = px(np.array([x, y]))[0]
    b = px(np.array([x + length_m * math.cos(yaw), y + length_m * math.sin(yaw)]))[0]
    cv2.arrowedLine(img, tuple(int(v) for v in a), tuple(int(v) for v in b), color, thickness,
                    cv2.LINE_AA, tipLength=0.35)


def _overlay(img: np.ndarray, px, ep: dict, variant) -> None:
    """Draw (BGR) the zone, the object, the spawn and the expert's path onto the plan."""
    for z in variant.zones:
        if z.id == ep["zone"]:
            cv2.polylines(img, [px(z.volume.corners2d())], True, (0, 0, 255), 4, cv2.LINE_AA)
    poses = np.asarray(ep["expert_poses"], float)
    if len(poses):
        pts = px(poses[:, :2])
        cv2.polylines(img, [pts.reshape(-1, 1, 2)], False, (255, 60, 0), 3, cv2.LINE_AA)
        for p in pts:
            cv2.circle(img, tuple(int(v) for v in p), 3, (255, 60, 0), -1, cv2.LINE_AA)
        g = poses[-1]
        _arrow(img, px, g[0], g[1], math.radians(30 * g[2]), (255, 60, 0), 0.6, 2)
    _arrow(img, px, ep["spawn_x"], ep["spawn_y"], ep["spawn_yaw_rad"], (0, 140, 0), 0.5, 3)
    s = px(np.array([ep["spawn_x"], ep["spawn_y"]]))[0]
    cv2.circle(img, tuple(int(v) for v in s), 9, (0, 140, 0), 2, cv2.LINE_AA)
    o = px(np.asarray(ep["settle_pos"][:2]))[0]
    cv2.drawMarker(img, tuple(int(v) for v in o), (0, 0, 255), cv2.MARKER_STAR, 22, 3,
                   cv2.LINE_AA)


def show(ds, episode_id: int, world, out: str | Path, wav: str | Path | None = None) -> Path:
    """Write the picture of episode ``episode_id`` of dataset ``ds`` (and its audio as a
    stereo float WAV: ear pressure / 20 Pa, times the row's audio_gain)."""
    ep = ds.get(episode_id)
    img = episode_figure(ep, world.variant(ep["room_variant"]), ds.category_labels)
    path = write_png(img, out)
    if wav is not None:
        buf = io.BytesIO()
        sf.write(buf, np.asarray(ep["audio"], np.float32).T, int(ep["sample_rate"]),
                 format="WAV", subtype="FLOAT")
        write_bytes(wav, buf.getvalue())
    return path


__all__ = ["show", "episode_figure", "depth_image", "segmentation_image"]
