"""Swept tubes: :class:`Sweep`, :func:`sweep` along a planar path, :func:`arc_path` and
:func:`torus_arc`."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

from ._common import capped_ring_faces

# =============================================================================================
# Tubes
# =============================================================================================
@dataclass(frozen=True)
class Sweep:
    """A swept tube: ``rings`` (N, M, 3) cross-sections along the path, plus end points.

    ``start``/``end`` are the apexes closing the two ends (the centre of a flat cap or the tip
    of a rounded one).
    """

    rings: np.ndarray
    start: np.ndarray
    end: np.ndarray

    @property
    def mesh(self) -> trimesh.Trimesh:
        n, m, _ = self.rings.shape
        verts = np.vstack([self.start[None], self.rings.reshape(-1, 3), self.end[None]])
        mesh = trimesh.Trimesh(verts, capped_ring_faces(n, m), process=False)
        if mesh.volume < 0:
            mesh.invert()
        return mesh

    def pieces(self, n: int) -> list[np.ndarray]:
        """Split the tube into ``n`` consecutive convex pieces (ring vertices, overlapping by one
        ring; the first and last include the end apexes)."""
        count = len(self.rings)
        n = max(1, min(n, count - 1))
        cuts = np.linspace(0, count - 1, n + 1).round().astype(int)
        out = []
        for j in range(n):
            pts = self.rings[cuts[j]:cuts[j + 1] + 1].reshape(-1, 3)
            if j == 0:
                pts = np.vstack([pts, self.start])
            if j == n - 1:
                pts = np.vstack([pts, self.end])
            out.append(pts)
        return out


def _path_frames(path: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.gradient(path, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    u = np.broadcast_to(normal, path.shape).copy()
    u -= (u * t).sum(1, keepdims=True) * t
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(t, u)
    return t, u, v


def sweep(path: Any, half_width: Any, half_height: Any, *, normal: Sequence[float] = (0, 1, 0),
          exponent: float = 2.0, ring: int = 24, caps: str = "round",
          cap_segments: int = 4, cap_length: float | None = None) -> Sweep:
    """Sweep a super-elliptic cross-section along a planar path.

    ``path`` (N, 3) lies in a plane with unit normal ``normal``; the cross-section has
    half-extent ``half_width`` along ``normal`` and ``half_height`` in the plane (scalars or
    per-station arrays). ``exponent`` 2 gives ellipses, larger values rounded rectangles.
    ``caps``: ``"flat"`` (a fan to the end centre) or ``"round"`` (half-ellipsoidal ends of
    length ``cap_length``, default the smaller half-extent). Keep the path's radius of
    curvature larger than ``half_height`` or the tube folds over itself.
    """
    P = np.asarray(path, dtype=float)
    N = len(P)
    a = np.broadcast_to(np.asarray(half_width, float), (N,)).copy()
    b = np.broadcast_to(np.asarray(half_height, float), (N,)).copy()
    nrm = np.asarray(normal, dtype=float)
    nrm = nrm / np.linalg.norm(nrm)
    t, u, v = _path_frames(P, nrm)
    phi = 2 * np.pi * (np.arange(ring) + 0.5) / ring
    c, s = np.cos(phi), np.sin(phi)
    e = 2.0 / exponent
    cx = np.sign(c) * np.abs(c) ** e
    cy = np.sign(s) * np.abs(s) ** e

    def rings_at(Pi: np.ndarray, ui: np.ndarray, vi: np.ndarray, ai: Any, bi: Any) -> np.ndarray:
        ai = np.asarray(ai, float)[..., None, None]
        bi = np.asarray(bi, float)[..., None, None]
        return (Pi[..., None, :] + ui[..., None, :] * (ai * cx[:, None])
                + vi[..., None, :] * (bi * cy[:, None]))

    rings = rings_at(P, u, v, a, b)
    if caps == "flat":
        return Sweep(rings, P[0].copy(), P[-1].copy())
    if caps != "round":
        raise ValueError("caps must be 'flat' or 'round'")
    ang = np.linspace(0, np.pi / 2, cap_segments + 1)[1:-1]
    L0 = cap_length if cap_length is not None else min(a[0], b[0])
    L1 = cap_length if cap_length is not None else min(a[-1], b[-1])
    pre = [rings_at(P[0] - t[0] * L0 * np.sin(g), u[0], v[0], a[0] * np.cos(g), b[0] * np.cos(g))
           for g in ang[::-1]]
    post = [rings_at(P[-1] + t[-1] * L1 * np.sin(g), u[-1], v[-1], a[-1] * np.cos(g),
                     b[-1] * np.cos(g)) for g in ang]
    allr = np.concatenate([np.array(pre).reshape(-1, ring, 3), rings,
                           np.array(post).reshape(-1, ring, 3)], axis=0)
    return Sweep(allr, P[0] - t[0] * L0, P[-1] + t[-1] * L1)


def arc_path(center: Sequence[float], radius: float, start: float, stop: float, n: int,
             plane: str = "xz") -> np.ndarray:
    """``n + 1`` points on a circular arc in the ``xz`` (angle from +x towards +z), ``xy`` or
    ``yz`` plane."""
    t = np.linspace(start, stop, n + 1)
    p = np.zeros((n + 1, 3))
    i, j = {"xz": (0, 2), "xy": (0, 1), "yz": (1, 2)}[plane]
    p[:, i] = radius * np.cos(t)
    p[:, j] = radius * np.sin(t)
    return p + np.asarray(center, float)


def torus_arc(major_radius: float, minor_radius: float, start: float, stop: float, *,
              center: Sequence[float] = (0, 0, 0), segments: int = 24, ring: int = 16,
              caps: str = "round") -> Sweep:
    """A tube of circular section along an arc in the xz plane (angles from +x towards +z)."""
    path = arc_path(center, major_radius, start, stop, segments, "xz")
    return sweep(path, minor_radius, minor_radius, normal=(0, 1, 0), ring=ring, caps=caps)
