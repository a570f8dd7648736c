"""Top-down pictures of room variants: furniture, numbered fall zones, free floor.

Drawn with OpenCV as a plan (not a render) so a person can check a layout at a glance: parts
coloured by their display colour and drawn lowest first, zones outlined in the colour of their
kind and numbered, the floor a robot can reach shaded, a 1 m scale bar and a legend.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from fallgen.world.furniture import ZONE_KINDS
from fallgen.world.rooms import RoomVariant
from fallgen.world.validate import ROBOT_RADIUS_M, occupancy

_KIND_COLORS = {  # BGR
    "floor": (60, 170, 60),
    "under_furniture": (160, 60, 160),
    "behind_furniture": (200, 120, 0),
    "table_top": (0, 140, 255),
    "counter_top": (0, 90, 220),
    "cabinet_top": (30, 30, 200),
    "shelf": (200, 40, 40),
    "seat": (140, 140, 0),
    "box": (0, 200, 200),
    "basket": (40, 160, 200),
    "pan": (90, 90, 90),
}
assert set(_KIND_COLORS) == set(ZONE_KINDS)


def draw_variant(v: RoomVariant, px_per_m: float = 110.0, overlay=None) -> np.ndarray:
    """An RGB image (H, W, 3) uint8 of the variant seen from above; ``overlay(img_bgr, px)``
    may draw on it before the title and legend (``px`` maps room (x, y) metres to pixels)."""
    lx, ly, _ = v.size_m
    margin, legend_w, title_h = 40, 230, 56
    W = int(lx * px_per_m) + 2 * margin + legend_w
    H = max(int(ly * px_per_m) + 2 * margin + title_h, 420)
    img = np.full((H, W, 3), 255, np.uint8)
    oy = title_h + margin

    def px(xy: np.ndarray) -> np.ndarray:
        xy = np.atleast_2d(xy)
        return np.stack([margin + xy[:, 0] * px_per_m, oy + (ly - xy[:, 1]) * px_per_m],
                        axis=1).round().astype(np.int32)

    floor_bgr = tuple(int(255 * c) for c in v.surfaces["floor"].rgba[2::-1])
    cv2.rectangle(img, tuple(px(np.array([0, ly]))[0]), tuple(px(np.array([lx, 0]))[0]),
                  floor_bgr, -1)
    # Floor a robot can reach (inflated occupancy): a light green wash.
    occ = occupancy(v, inflate_m=ROBOT_RADIUS_M)
    free = cv2.resize((~occ[::-1]).astype(np.uint8), (int(lx * px_per_m), int(ly * px_per_m)),
                      interpolation=cv2.INTER_NEAREST).astype(bool)
    region = img[oy:oy + free.shape[0], margin:margin + free.shape[1]]
    region[free] = (0.75 * region[free] + 0.25 * np.array([120, 230, 120])).astype(np.uint8)
    cv2.rectangle(img, tuple(px(np.array([0, ly]))[0]), tuple(px(np.array([lx, 0]))[0]),
                  (40, 40, 40), 3)

    for _, part in sorted(v.parts(), key=lambda ip: ip[1].box.zmax):
        color = tuple(int(255 * c) for c in (part.rgba or (0.6, 0.6, 0.6, 1))[2::-1])
        if part.shape == "cylinder":
            c = px(np.array(part.box.center[:2]))[0]
            r = int(round(part.box.half[0] * px_per_m))
            cv2.circle(img, tuple(c), r, color, -1, cv2.LINE_AA)
            cv2.circle(img, tuple(c), r, (50, 50, 50), 1, cv2.LINE_AA)
        elif part.shape == "ellipsoid":
            c = tuple(int(v) for v in px(np.array(part.box.center[:2]))[0])
            axes = tuple(int(round(part.box.half[k] * px_per_m)) for k in (0, 1))
            angle = -float(np.degrees(part.box.yaw))  # image rows run south
            cv2.ellipse(img, c, axes, angle, 0, 360, color, -1, cv2.LINE_AA)
            cv2.ellipse(img, c, axes, angle, 0, 360, (50, 50, 50), 1, cv2.LINE_AA)
        else:
            poly = px(part.box.corners2d())
            cv2.fillPoly(img, [poly], color, cv2.LINE_AA)
            cv2.polylines(img, [poly], True, (50, 50, 50), 1, cv2.LINE_AA)
    for item in v.furniture:
        c = px(np.array(item.pose[:2]))[0]
        cv2.putText(img, item.id, (int(c[0]) - 4 * len(item.id), int(c[1]) + 4),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.36, (20, 20, 20), 1, cv2.LINE_AA)

    # Zones stacked on one footprint (shelf boards, a table top and the floor under it) share
    # one label, e.g. "9/10/11".
    groups: list[tuple[np.ndarray, list]] = []
    for z in v.zones:
        poly = px(z.volume.corners2d())
        cv2.polylines(img, [poly], True, _KIND_COLORS[z.kind], 2, cv2.LINE_AA)
        c = poly.mean(axis=0)
        for gc, members in groups:
            if np.hypot(*(gc - c)) < 14:
                members.append(z)
                break
        else:
            groups.append((c, [z]))
    for c, members in groups:
        label = "/".join(str(z.index) for z in members)
        w = 7 * len(label) + 8
        x0, y0 = int(c[0] - w / 2), int(c[1] - 9)
        cv2.rectangle(img, (x0, y0), (x0 + w, y0 + 18), _KIND_COLORS[members[0].kind], -1)
        cv2.putText(img, label, (x0 + 4, y0 + 13), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    (255, 255, 255), 1, cv2.LINE_AA)

    if overlay is not None:
        overlay(img, px)
    title = f"{v.id}  ({v.kind}, {lx:g} x {ly:g} x {v.size_m[2]:g} m)"
    cv2.putText(img, title, (margin, 26), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 1, cv2.LINE_AA)
    sub = (f"floor {v.surfaces['floor'].name}, walls {v.surfaces['north'].name}, "
           f"ceiling {v.surfaces['ceiling'].name}; {len(v.zones)} zones")
    cv2.putText(img, sub, (margin, 46), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (60, 60, 60), 1,
                cv2.LINE_AA)
    # Scale bar (1 m) and north arrow.
    y0 = H - 14
    cv2.line(img, (margin, y0), (margin + int(px_per_m), y0), (0, 0, 0), 2)
    cv2.putText(img, "1 m", (margin + int(px_per_m) + 6, y0 + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                (0, 0, 0), 1, cv2.LINE_AA)
    # Legend.
    lx0 = W - legend_w + 10
    cv2.putText(img, "zone kinds", (lx0, oy), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1,
                cv2.LINE_AA)
    for i, kind in enumerate(ZONE_KINDS):
        y = oy + 20 + 19 * i
        cv2.rectangle(img, (lx0, y - 10), (lx0 + 14, y + 2), _KIND_COLORS[kind], -1)
        n = sum(z.kind == kind for z in v.zones)
        cv2.putText(img, f"{kind} ({n})", (lx0 + 22, y), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    (0, 0, 0), 1, cv2.LINE_AA)
    y = oy + 20 + 19 * len(ZONE_KINDS) + 10
    cv2.rectangle(img, (lx0, y - 10), (lx0 + 14, y + 2), (150, 220, 150), -1)
    cv2.putText(img, f"robot-reachable floor (r={ROBOT_RADIUS_M} m)", (lx0 + 22, y),
                cv2.FONT_HERSHEY_SIMPLEX, 0.33, (0, 0, 0), 1, cv2.LINE_AA)
    return img[:, :, ::-1].copy()


def write_png(img_rgb: np.ndarray, path: str | Path) -> Path:
    """Encode an RGB image as PNG and write it atomically."""
    from fallgen.atomic import write_bytes

    ok, buf = cv2.imencode(".png", np.ascontiguousarray(img_rgb[:, :, ::-1]))
    if not ok:
        raise OSError(f"could not encode {path}")
    return write_bytes(path, buf.tobytes())
