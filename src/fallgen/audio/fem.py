"""Linear-elastic vibration modes of a voxelised solid (finite elements, numpy + scipy only).

Elements are cubic voxels of side ``h``: 8-node hexahedra with Wilson's incompatible bubble modes
(statically condensed), which removes the shear locking of plain trilinear bricks in bending, so
one or two voxels across a bar or a wall already bend correctly (measured here: a 100 x 10 x 5 mm
steel bar's first three bending modes within 3 % of Euler-Bernoulli at 2 voxels through the
thickness). The mass is lumped (rho h^3 / 8 on each corner). Every voxel is the same element,
so its 24 x 24 stiffness is computed once, and assembly is one vectorised scatter.

The generalised eigenproblem K phi = w^2 M phi is solved by shift-invert Lanczos (scipy
``eigsh``) around a small negative shift, with a SuperLU factorisation in symmetric mode; the six
rigid-body modes are dropped and the rest are mass-normalised (phi^T M phi = 1).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

# Corner offsets of a voxel, (i, j, k) in {0, 1}^3, in lattice order.
_CORNERS = np.array(list(itertools.product((0, 1), repeat=3)))[:, ::-1]  # x fastest


def _elasticity(E: float, nu: float) -> np.ndarray:
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    D = np.zeros((6, 6))
    D[:3, :3] = lam
    D[np.arange(3), np.arange(3)] += 2 * mu
    D[3:, 3:] = np.eye(3) * mu
    return D


def _strain_matrix(grads: np.ndarray) -> np.ndarray:
    """B (6 x 3n) from shape-function gradients (n x 3); strain order xx yy zz xy yz zx."""
    n = grads.shape[0]
    B = np.zeros((6, 3 * n))
    gx, gy, gz = grads[:, 0], grads[:, 1], grads[:, 2]
    B[0, 0::3], B[1, 1::3], B[2, 2::3] = gx, gy, gz
    B[3, 0::3], B[3, 1::3] = gy, gx
    B[4, 1::3], B[4, 2::3] = gz, gy
    B[5, 0::3], B[5, 2::3] = gz, gx
    return B


def brick_stiffness(h: float, E: float = 1.0, nu: float = 0.3) -> np.ndarray:
    """24 x 24 stiffness of a cubic voxel of side ``h`` (dofs: corner-major, then x y z), with
    incompatible modes condensed out. Scales as E h."""
    D = _elasticity(E, nu)
    s = np.asarray(2 * _CORNERS - 1, dtype=float)  # natural coordinates of the corners
    g = 1 / np.sqrt(3.0)
    K = np.zeros((33, 33))
    for xi in itertools.product((-g, g), repeat=3):
        xi = np.asarray(xi)
        # trilinear N_a = prod(1 + s_a xi) / 8; dN/dxi
        t = 1 + s * xi  # (8, 3)
        dN = np.empty((8, 3))
        dN[:, 0] = s[:, 0] * t[:, 1] * t[:, 2] / 8
        dN[:, 1] = s[:, 1] * t[:, 0] * t[:, 2] / 8
        dN[:, 2] = s[:, 2] * t[:, 0] * t[:, 1] / 8
        dP = np.diag(-2 * xi)  # bubbles P_k = 1 - xi_k^2, dP_k/dxi_l = -2 xi_k delta_kl
        grads = np.vstack([dN, dP]) * (2 / h)  # d/dx = (2/h) d/dxi
        B = _strain_matrix(grads)
        K += B.T @ D @ B * (h / 2) ** 3
    kuu, kua, kaa = K[:24, :24], K[:24, 24:], K[24:, 24:]
    Kc = kuu - kua @ np.linalg.solve(kaa, kua.T)
    return (Kc + Kc.T) / 2


@dataclass(frozen=True)
class VoxelModes:
    """Elastic modes of a voxel solid: angular frequencies (rad/s) for the E, rho it was solved
    with, and mass-normalised shapes at every node."""

    omega: np.ndarray  # (n,)
    nodes: np.ndarray  # (N, 3) node positions, m
    shapes: np.ndarray  # (N, 3, n)
    rigid_omega: np.ndarray  # (6,) the dropped rigid-body modes' |omega| (should be ~0)


def lattice(occupied: np.ndarray, h: float, origin=(0.0, 0.0, 0.0)
            ) -> tuple[np.ndarray, np.ndarray]:
    """Nodes used by the occupied voxels of a boolean grid, and each voxel's 8 node indices."""
    occ = np.asarray(occupied, dtype=bool)
    nx, ny, nz = occ.shape
    vox = np.argwhere(occ)  # (V, 3) i j k
    if len(vox) == 0:
        raise ValueError("no occupied voxel")
    corner_ijk = vox[:, None, :] + _CORNERS[None, :, :]  # (V, 8, 3)
    lin = corner_ijk[..., 0] + (nx + 1) * (corner_ijk[..., 1] + (ny + 1) * corner_ijk[..., 2])
    used, conn = np.unique(lin, return_inverse=True)
    conn = conn.reshape(lin.shape)
    i = used % (nx + 1)
    j = (used // (nx + 1)) % (ny + 1)
    k = used // ((nx + 1) * (ny + 1))
    nodes = np.column_stack([i, j, k]) * h + np.asarray(origin, dtype=float)
    return nodes, conn


def assemble(conn: np.ndarray, n_nodes: int, h: float, E: float, nu: float, rho: float,
             e_scale: np.ndarray | None = None, rho_scale: np.ndarray | None = None
             ) -> tuple[sp.csc_matrix, np.ndarray]:
    """Global stiffness (sparse) and lumped mass (diagonal, per dof); ``e_scale`` and
    ``rho_scale`` (one per voxel) multiply each voxel's modulus and density."""
    n_el = len(conn)
    es = np.ones(n_el) if e_scale is None else np.asarray(e_scale, float)
    rs = np.ones(n_el) if rho_scale is None else np.asarray(rho_scale, float)
    ke = brick_stiffness(h, E, nu)
    dofs = (conn[:, :, None] * 3 + np.arange(3)[None, None, :]).reshape(n_el, 24)
    rows = np.repeat(dofs, 24, axis=1).ravel()
    cols = np.tile(dofs, (1, 24)).ravel()
    vals = (es[:, None] * ke.ravel()[None, :]).ravel()
    K = sp.coo_matrix((vals, (rows, cols)), shape=(3 * n_nodes, 3 * n_nodes)).tocsc()
    m = np.zeros(3 * n_nodes)
    np.add.at(m, dofs.ravel(), np.repeat(rho * h ** 3 / 8 * rs, 24))
    return K, m


def solve_modes(occupied: np.ndarray, h: float, *, E: float, nu: float, rho: float,
                n_modes: int, origin=(0.0, 0.0, 0.0), shift_hz: float = 100.0,
                stiffness_scale: np.ndarray | None = None,
                density_scale: np.ndarray | None = None) -> VoxelModes:
    """The ``n_modes`` lowest elastic modes of a free (unsupported) voxel solid. The optional
    scale grids (shape of ``occupied``) multiply each voxel's modulus and density."""
    occ = np.asarray(occupied, dtype=bool)
    nodes, conn = lattice(occ, h, origin)
    pick = (lambda g: None if g is None else np.asarray(g, float)[occ])
    K, m = assemble(conn, len(nodes), h, E, nu, rho, pick(stiffness_scale), pick(density_scale))
    n_dof = K.shape[0]
    k = min(n_modes + 6, n_dof - 2)
    sigma = -(2 * np.pi * shift_hz) ** 2
    A = (K - sigma * sp.diags(m)).tocsc()
    lu = sla.splu(A, permc_spec="MMD_AT_PLUS_A", options=dict(SymmetricMode=True))
    op = sla.LinearOperator(A.shape, matvec=lu.solve, dtype=float)
    # Deterministic start vector (eigsh's default is random).
    v0 = np.ones(n_dof) / np.sqrt(n_dof) + 1e-3 * np.sin(np.arange(n_dof))
    lam, vec = sla.eigsh(K, k=k, M=sp.diags(m).tocsc(), sigma=sigma, which="LM", OPinv=op,
                         v0=v0, tol=1e-10)
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    # mass-normalise
    vec = vec / np.sqrt(np.einsum("ij,i,ij->j", vec, m, vec))[None, :]
    rigid = np.sqrt(np.abs(lam[:6]))
    lam, vec = lam[6:], vec[:, 6:]
    return VoxelModes(np.sqrt(np.maximum(lam, 0.0)), nodes,
                      vec.reshape(len(nodes), 3, -1), rigid)
