"""A modal model: the modes of one shape, as synthesis needs them, and how it rescales.

Models are made at a reference material (:data:`E_REF`, :data:`RHO_REF`, the material's Poisson
ratio rounded by :func:`round_nu`) and scale 1, by voxel finite elements
(:mod:`fallgen.audio.modes`) or in closed form for thin walls (:mod:`fallgen.audio.shells`). For
the same shape scaled by ``s`` in a material (E, rho): omega = omega_ref sqrt(E rho_ref / (E_ref
rho)) / s, and mass-normalised shapes phi = phi_ref sqrt(rho_ref / rho) s^(-3/2)
(:meth:`ModalModel.scaled`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

E_REF = 1.0e10  # Pa
RHO_REF = 1000.0  # kg/m^3


@dataclass(frozen=True)
class ModalModel:
    """Modes of one shape at E_REF, RHO_REF, scale 1 (or, after :meth:`scaled`, of an object)."""

    omega: np.ndarray  # (n,) rad/s, ascending
    points: np.ndarray  # (S, 3) surface nodes, object frame, m
    area: np.ndarray  # (S, 3) outward area vector of each surface node, m^2
    #: (S, 3, n) mass-normalised mode shapes at the surface nodes of the reference model; this
    #: model's shapes are ``shapes * shape_factor`` (see :meth:`phi`), so that rescaling copies
    #: no per-node array. A model loaded again from the cache leaves them in its file
    #: (:class:`fallgen.audio.modes.StoredArray`: the rows indexed are read).
    shapes: np.ndarray
    nu: float
    h: float  # voxel side, m
    n_voxels: int
    volume_error: float
    #: Surface moments of each mode, for radiation (computed once, carried through scaling):
    #: Q (n,) net volume displacement sum(a . phi), D (n, 3) its first moment about the area
    #: centroid, A (n,) sum(|a| (n . phi)^2).
    moments: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    shape_factor: float = 1.0

    def phi(self, node: int) -> np.ndarray:
        """(3, n) mass-normalised mode shapes at one surface node, 1/sqrt(kg)."""
        return self.shapes[node].astype(float) * self.shape_factor

    def surface_moments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self.moments is not None:
            return self.moments
        a = self.area.astype(float)
        an = np.einsum("sc,scn->sn", a, self.shapes.astype(float)) * self.shape_factor
        area = np.linalg.norm(a, axis=1)
        centre = (area[:, None] * self.points).sum(0) / area.sum()
        Q = an.sum(axis=0)
        D = np.einsum("sn,sc->nc", an, self.points - centre)
        with np.errstate(invalid="ignore", divide="ignore"):
            A = np.where(area[:, None] > 0, an ** 2 / np.maximum(area, 1e-30)[:, None], 0.0).sum(0)
        object.__setattr__(self, "moments", (Q, D, A))
        return Q, D, A

    def scaled(self, youngs_modulus_pa: float, density_kg_m3: float, scale: float) -> ModalModel:
        """The same shape in a material, ``scale`` times the size."""
        k = np.sqrt(youngs_modulus_pa * RHO_REF / (E_REF * density_kg_m3)) / scale
        a = np.sqrt(RHO_REF / density_kg_m3) * scale ** -1.5
        Q, D, A = self.surface_moments()
        return ModalModel(self.omega * k, self.points * scale, self.area * scale ** 2,
                          self.shapes, self.nu, self.h * scale, self.n_voxels, self.volume_error,
                          (Q * a * scale ** 2, D * a * scale ** 3, A * a * a * scale ** 2),
                          self.shape_factor * a)

    def nearest(self, points: np.ndarray) -> np.ndarray:
        """Indices of the surface nodes nearest to each of ``points`` (K, 3)."""
        p = np.asarray(points, float).reshape(-1, 3)
        d2 = (p ** 2).sum(1)[:, None] - 2 * p @ self.points.T + self._node_norms[None, :]
        return np.argmin(d2, axis=1)

    @cached_property
    def _node_norms(self) -> np.ndarray:
        """|x|^2 of every surface node (once per model: a fall asks for nodes many times)."""
        return (self.points ** 2).sum(1)

    def normal(self, node: int) -> np.ndarray:
        """Outward unit normal at a surface node."""
        a = self.area[node]
        n = float(np.linalg.norm(a))
        return a / n if n > 0 else a


def round_nu(nu: float) -> float:
    """Poisson ratio to the 0.05 grid models are solved on, at most 0.45 (nearly incompressible
    rubber, nu 0.49, would lock the bricks: its modes are heavily damped anyway)."""
    return min(round(round(nu / 0.05) * 0.05, 2), 0.45)
