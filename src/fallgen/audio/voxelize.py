"""Watertight mesh -> voxel solid for the modal FEM, with each voxel's fill fraction.

A voxel is occupied when any of its ``sub``^3 sample points lies inside the mesh, so walls
thinner than a voxel survive as a one-voxel layer; its fill fraction (the share of samples
inside) then scales its density (so the mass is right) and its Young's modulus: by the fill for
voxels inside thick parts, by the fill cubed for a one-voxel-thick layer (a plate's bending
stiffness goes as E t^3: a 1 mm wall in a 2 mm voxel bends like that 1 mm wall). Only the
largest face-connected piece is kept (a handle hanging on a single edge would add fake
low-frequency modes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.ndimage as ndi
import trimesh


@dataclass(frozen=True)
class VoxelSolid:
    occupied: np.ndarray  # (nx, ny, nz) bool
    fill: np.ndarray  # (nx, ny, nz) float in [0, 1], 0 where not occupied
    stiffness_scale: np.ndarray  # (nx, ny, nz) E multiplier per voxel
    origin: np.ndarray  # (3,) position of the grid's corner, m
    h: float  # voxel side, m
    volume_error: float  # |voxel volume x fill - mesh volume| / mesh volume

    @property
    def n_voxels(self) -> int:
        return int(self.occupied.sum())


def voxel_size(volume_m3: float, extents: np.ndarray, target_voxels: int) -> float:
    """Voxel side giving about ``target_voxels`` of solid, and at least one across the smallest
    extent (incompatible-mode bricks bend well even one layer thick: a steel bar's first three
    bending modes move by < 2 % from one to three layers)."""
    h = (volume_m3 / target_voxels) ** (1 / 3)
    return float(min(h, float(np.min(extents))))


def inside_on_lines(vertices: np.ndarray, faces: np.ndarray, ys: np.ndarray, zs: np.ndarray,
                    xs: np.ndarray) -> np.ndarray:
    """Inside test of a watertight mesh on the grid xs x ys x zs by ray parity along x: every
    (y, z) line is intersected with every triangle whose y-z shadow holds it. Returns a bool
    array (len(xs), len(ys), len(zs))."""
    tri = np.asarray(vertices, float)[np.asarray(faces)]  # (F, 3, 3)
    out = np.zeros((len(xs), len(ys), len(zs)), dtype=bool)
    # Nudge the lines off the vertices' exact coordinates (a line through an edge or a vertex
    # would count a crossing twice or not at all).
    ys = np.asarray(ys, float) + 1.234567e-9
    zs = np.asarray(zs, float) + 2.345678e-9
    ymin, ymax = tri[:, :, 1].min(1), tri[:, :, 1].max(1)
    zmin, zmax = tri[:, :, 2].min(1), tri[:, :, 2].max(1)
    j0 = np.searchsorted(ys, ymin)
    j1 = np.searchsorted(ys, ymax, side="right")
    k0 = np.searchsorted(zs, zmin)
    k1 = np.searchsorted(zs, zmax, side="right")
    cnt = np.maximum(j1 - j0, 0) * np.maximum(k1 - k0, 0)
    keep = np.nonzero(cnt)[0]
    if len(keep) == 0:
        return out
    # expand (triangle, line) pairs
    t_idx = np.repeat(keep, cnt[keep])
    local = np.arange(len(t_idx)) - np.repeat(np.cumsum(cnt[keep]) - cnt[keep], cnt[keep])
    nj = (j1 - j0)[t_idx]
    jj = j0[t_idx] + local % nj
    kk = k0[t_idx] + local // nj
    p0, p1, p2 = tri[t_idx, 0], tri[t_idx, 1], tri[t_idx, 2]
    y, z = ys[jj], zs[kk]
    # barycentric coordinates of (y, z) in the triangle's y-z projection
    d = (p1[:, 1] - p0[:, 1]) * (p2[:, 2] - p0[:, 2]) - (p2[:, 1] - p0[:, 1]) * (p1[:, 2] - p0[:, 2])
    ok = np.abs(d) > 1e-30
    with np.errstate(divide="ignore", invalid="ignore"):
        u = ((y - p0[:, 1]) * (p2[:, 2] - p0[:, 2]) - (p2[:, 1] - p0[:, 1]) * (z - p0[:, 2])) / d
        v = ((p1[:, 1] - p0[:, 1]) * (z - p0[:, 2]) - (y - p0[:, 1]) * (p1[:, 2] - p0[:, 2])) / d
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1)
    x = p0[hit, 0] + u[hit] * (p1[hit, 0] - p0[hit, 0]) + v[hit] * (p2[hit, 0] - p0[hit, 0])
    line = jj[hit] * len(zs) + kk[hit]
    order = np.lexsort((x, line))
    line, x = line[order], x[order]
    # parity: count crossings at x below each grid x, per line
    starts = np.searchsorted(line, np.arange(len(ys) * len(zs)))
    ends = np.searchsorted(line, np.arange(len(ys) * len(zs)), side="right")
    for L in np.nonzero(ends > starts)[0]:
        xc = x[starts[L]:ends[L]]
        n_below = np.searchsorted(xc, xs)
        out[:, L // len(zs), L % len(zs)] = (n_below % 2) == 1
    return out


def voxelize(vertices: np.ndarray, faces: np.ndarray, h: float, sub: int = 3) -> VoxelSolid:
    v = np.asarray(vertices, float)
    lo, hi = v.min(axis=0), v.max(axis=0)
    n = np.maximum(np.ceil((hi - lo) / h).astype(int), 1)
    origin = lo - (n * h - (hi - lo)) / 2  # centre the grid on the mesh
    # sample points: sub^3 per voxel, at the centres of a sub-grid
    offs = (np.arange(sub) + 0.5) / sub * h
    axes = [origin[a] + np.repeat(np.arange(n[a]) * h, sub) + np.tile(offs, n[a])
            for a in range(3)]
    inside = inside_on_lines(v, faces, axes[1], axes[2], axes[0])
    fill = inside.reshape(n[0], sub, n[1], sub, n[2], sub).mean(axis=(1, 3, 5))
    occ = fill > 0
    lab, nlab = ndi.label(occ)
    if nlab > 1:
        sizes = ndi.sum(occ, lab, index=np.arange(1, nlab + 1))
        occ = lab == (1 + int(np.argmax(sizes)))
    fill = np.where(occ, fill, 0.0)
    # one-voxel-thick along some axis: both neighbours along it empty
    pad = np.pad(occ, 1)
    thin = np.zeros_like(occ)
    for a in range(3):
        lo_n = np.take(pad, range(0, pad.shape[a] - 2), axis=a)
        hi_n = np.take(pad, range(2, pad.shape[a]), axis=a)
        core = tuple(slice(1, -1) if b != a else slice(None) for b in range(3))
        thin |= ~lo_n[core] & ~hi_n[core]
    stiff = np.where(thin, fill ** 3, fill)
    vol = float(fill.sum()) * h ** 3
    mvol = abs(float(trimesh.Trimesh(v, np.asarray(faces), process=False).volume))
    err = abs(vol - mvol) / mvol if mvol else np.inf
    return VoxelSolid(occ, fill, np.where(occ, stiff, 0.0), origin, float(h), float(err))
