"""Modal models of object shapes: solve once per shape, rescale for material and size, cache.

A shape's modes are solved by voxel FEM (:mod:`fallgen.audio.fem`) at a reference material
(E_REF, RHO_REF and the material's Poisson ratio, rounded to 0.05) and scale 1. For the same
shape scaled by ``s`` in a material (E, rho): omega = omega_ref sqrt(E rho_ref / (E_ref rho)) / s,
and mass-normalised shapes phi = phi_ref sqrt(rho_ref / rho) s^(-3/2). Only what synthesis needs
is kept: the frequencies, and at the surface nodes their position, outward area vector and mode
shapes. Models are cached as ``.npz`` files keyed by a hash of the mesh and the solver settings,
so a full build solves each (shape, Poisson ratio) once.
"""

from __future__ import annotations

import hashlib
import io
import os
import struct
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from fallgen.atomic import write_bytes
from fallgen.audio.fem import lattice, solve_modes
from fallgen.audio.modal_model import E_REF, RHO_REF, ModalModel, round_nu
from fallgen.audio.shells import shell_modes
from fallgen.audio.voxelize import VoxelSolid, voxel_size, voxelize
from fallgen.cache import CORRUPT_ENTRY, cache_root
from fallgen.world.shell import ThinShell

SOLVER_VERSION = 3  # bump when the solver changes what it produces


@dataclass(frozen=True)
class ModalSettings:
    target_voxels: int = 3000
    n_modes: int = 40
    sub_samples: int = 3


def _surface(solid: VoxelSolid, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Surface node indices and their outward area vectors (each exposed voxel face gives a
    quarter of its area to each of its 4 corners)."""
    occ = solid.occupied
    h = solid.h
    pad = np.pad(occ, 1)
    nx, ny, nz = occ.shape
    # node lattice index -> row in `nodes` (fem.lattice lists nodes by ascending lattice index)
    ijk = np.rint((nodes - solid.origin) / h).astype(int)
    lin = ijk[:, 0] + (nx + 1) * (ijk[:, 1] + (ny + 1) * ijk[:, 2])
    acc = np.zeros((len(nodes), 3))
    vox = np.argwhere(occ)
    for axis in range(3):
        for side in (-1, 1):
            nb = vox.copy()
            nb[:, axis] += side
            exposed = ~pad[nb[:, 0] + 1, nb[:, 1] + 1, nb[:, 2] + 1]
            faces = vox[exposed]
            if len(faces) == 0:
                continue
            # the 4 corners of that face
            base = faces.copy()
            if side == 1:
                base[:, axis] += 1
            o1, o2 = [a for a in range(3) if a != axis]
            for d1 in (0, 1):
                for d2 in (0, 1):
                    c = base.copy()
                    c[:, o1] += d1
                    c[:, o2] += d2
                    li = c[:, 0] + (nx + 1) * (c[:, 1] + (ny + 1) * c[:, 2])
                    rows = np.searchsorted(lin, li)
                    np.add.at(acc[:, axis], rows, side * h * h / 4)
    surf = np.nonzero(np.abs(acc).sum(axis=1) > 0)[0]
    return surf, acc[surf]


def solve_shape(vertices: np.ndarray, faces: np.ndarray, nu: float,
                settings: ModalSettings = ModalSettings()) -> ModalModel:
    """Voxelise a watertight mesh and solve its modes at the reference material."""
    v = np.asarray(vertices, float)
    mesh = trimesh.Trimesh(v, np.asarray(faces), process=False)
    ext = v.max(axis=0) - v.min(axis=0)
    h = voxel_size(abs(float(mesh.volume)), ext, settings.target_voxels)
    solid = voxelize(v, faces, h, settings.sub_samples)
    # Thin shells (a can, a toaster) fill few voxels of their volume-based size: coarsen until
    # the count is near the target (a shell's count goes as 1 / h^2).
    for _ in range(4):
        if solid.n_voxels <= 1.5 * settings.target_voxels:
            break
        h *= (solid.n_voxels / settings.target_voxels) ** 0.5
        solid = voxelize(v, faces, h, settings.sub_samples)
    vm = solve_modes(solid.occupied, h, E=E_REF, nu=nu, rho=RHO_REF,
                     n_modes=settings.n_modes, origin=solid.origin,
                     stiffness_scale=solid.stiffness_scale, density_scale=solid.fill)
    nodes, _ = lattice(solid.occupied, h, solid.origin)
    surf, area = _surface(solid, nodes)
    # C order, as a model loaded from the cache has (the memory layout decides the summation
    # order of later reductions, so a fresh model and a cached one give identical sounds)
    return ModalModel(vm.omega, nodes[surf], area,
                      np.ascontiguousarray(vm.shapes[surf], dtype=np.float32), nu, h,
                      solid.n_voxels, solid.volume_error)


def cache_key(vertices: np.ndarray, faces: np.ndarray, nu: float,
              settings: ModalSettings) -> str:
    hsh = hashlib.sha256()
    hsh.update(np.ascontiguousarray(vertices, dtype=np.float64).tobytes())
    hsh.update(np.ascontiguousarray(faces, dtype=np.int64).tobytes())
    hsh.update(repr((round_nu(nu), settings, SOLVER_VERSION, E_REF, RHO_REF)).encode())
    return hsh.hexdigest()[:24]


def default_cache_dir() -> Path:
    return cache_root() / "modes"


def cache_path(vertices: np.ndarray, faces: np.ndarray, nu: float,
               settings: ModalSettings = ModalSettings(), cache_dir: Path | None = None) -> Path:
    """Where the shape's reference modal model is (or will be) cached."""
    return (cache_dir or default_cache_dir()) / f"{cache_key(vertices, faces, nu, settings)}.npz"


def _save(path: Path, m: ModalModel) -> None:
    buf = io.BytesIO()
    if m.shape_factor != 1.0:
        raise ValueError("only reference (unscaled) modal models are cached")
    np.savez(buf, omega=m.omega, points=m.points, area=m.area, shapes=m.shapes,
             meta=np.array([m.nu, m.h, m.n_voxels, m.volume_error]))
    write_bytes(path, buf.getvalue())


def _load(path: Path, stored: bool = False) -> ModalModel:
    """A cached model; ``stored``: its mode shapes (nine tenths of it) left in the file as a
    :class:`StoredArray`, read where they are indexed (a render reads a few surface nodes'
    rows), not held in memory, and not checked against the file's CRC (a full load checks
    every array)."""
    with np.load(path) as z:
        nu, h, nvox, err = z["meta"]
        shapes = _stored(path, z.zip, "shapes.npy") if stored else z["shapes"]
        return ModalModel(z["omega"], z["points"], z["area"], shapes, float(nu), float(h),
                          int(nvox), float(err))


class StoredArray:
    """A read-only C-ordered array of ``shape`` and ``dtype`` at ``offset`` in the file at
    ``path``: indexing its first axis (an integer or an integer array) reads those rows alone
    (``os.pread``); ``np.asarray`` reads it whole. A file read this way keeps no page of it in
    the process (a memory map faults in ~64 kB around every row read: 120 models with 6 rows
    read each held 64 MB)."""

    def __init__(self, path: Path, offset: int, shape: tuple[int, ...], dtype) -> None:
        self.path, self.offset = str(path), int(offset)
        self.shape, self.dtype = tuple(int(n) for n in shape), np.dtype(dtype)
        self.row_bytes = int(np.prod(self.shape[1:], dtype=np.int64)) * self.dtype.itemsize

    @property
    def ndim(self) -> int:
        return len(self.shape)

    @property
    def nbytes(self) -> int:
        return self.shape[0] * self.row_bytes

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, index) -> np.ndarray:
        rows = np.asarray(index)
        if not np.issubdtype(rows.dtype, np.integer):
            raise TypeError(f"a stored array is indexed by rows, not {rows.dtype}")
        flat = rows.ravel()
        if len(flat) and (flat.min() < -self.shape[0] or flat.max() >= self.shape[0]):
            raise IndexError(f"rows {flat.min()}..{flat.max()} of {self.shape[0]}")
        out = np.empty((len(flat), *self.shape[1:]), self.dtype)
        fd = os.open(self.path, os.O_RDONLY)
        try:
            for k, r in enumerate(flat.tolist()):
                start = self.offset + (r % self.shape[0]) * self.row_bytes
                data = os.pread(fd, self.row_bytes, start)
                if len(data) != self.row_bytes:
                    raise ValueError(f"{self.path}: row {r} lies past the end of the file")
                out[k] = np.frombuffer(data, self.dtype).reshape(self.shape[1:])
        finally:
            os.close(fd)
        return out.reshape(rows.shape + self.shape[1:])

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        whole = np.fromfile(self.path, self.dtype, int(np.prod(self.shape, dtype=np.int64)),
                            offset=self.offset).reshape(self.shape)
        return whole if dtype is None else whole.astype(dtype)

    def astype(self, dtype) -> np.ndarray:
        return np.asarray(self).astype(dtype)


def _stored(path: Path, zf: zipfile.ZipFile, member: str) -> StoredArray:
    """The array stored (uncompressed, C-ordered) as ``member`` of the ``.npz`` at ``path``,
    left in the file (``np.savez`` stores its members uncompressed); raises
    ``zipfile.BadZipFile`` or ``ValueError`` where the entry is not what it says (truncated)."""
    info = zf.getinfo(member)
    if info.compress_type != zipfile.ZIP_STORED:
        raise zipfile.BadZipFile(f"{path}: {member} is compressed")
    with open(path, "rb") as f:
        f.seek(info.header_offset)
        head = f.read(30)  # the local file header; its name and extra field follow
        if len(head) < 30 or head[:4] != b"PK\x03\x04":
            raise zipfile.BadZipFile(f"{path}: no local header for {member}")
        n_name, n_extra = struct.unpack("<HH", head[26:30])
        start = info.header_offset + 30 + n_name + n_extra
        f.seek(start)
        version = np.lib.format.read_magic(f)
        read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) \
            else np.lib.format.read_array_header_2_0
        shape, fortran, dtype = read_header(f)
        offset = f.tell()
    if fortran and len(shape) > 1:
        raise ValueError(f"{path}: {member} is stored in Fortran order")
    size = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if offset + size != start + info.file_size:
        raise ValueError(f"{path}: {member} holds {info.file_size} bytes, not its array's")
    return StoredArray(path, offset, shape, dtype)


def shell_model(shell: ThinShell, nu: float, settings: ModalSettings = ModalSettings()
                ) -> ModalModel:
    """Reference modal model of a thin-walled shape from its shell (closed-form modes,
    milliseconds: not cached)."""
    nu = round_nu(nu)
    omega, points, area, shapes, h = shell_modes(shell, nu, E_REF, RHO_REF, settings.n_modes)
    return ModalModel(omega, points, area, np.ascontiguousarray(shapes, dtype=np.float32), nu,
                      h, 0, 0.0)


def modal_model(vertices: np.ndarray, faces: np.ndarray, nu: float,
                settings: ModalSettings = ModalSettings(),
                cache_dir: Path | None = None, shell: ThinShell | None = None,
                stored: bool = False) -> ModalModel:
    """The shape's reference modal model: from its thin ``shell`` when it has one, else from
    the cache (``stored``: its mode shapes left in the file, see :func:`_load`) or solved
    by voxel FEM (and cached)."""
    if shell is not None:
        return shell_model(shell, nu, settings)
    path = cache_path(vertices, faces, nu, settings, cache_dir)
    if path.exists():
        try:
            return _load(path, stored)
        except CORRUPT_ENTRY:
            path.unlink(missing_ok=True)  # a corrupt cache entry is recomputed
    m = solve_shape(vertices, faces, round_nu(nu), settings)
    _save(path, m)
    return m
