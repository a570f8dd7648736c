"""Modes of thin sheet walls by thin-shell theory (walls too thin for voxel finite elements).

Cylinder (a drink can, a tin, a PET bottle's body): a thin circular cylindrical shell of radius
R, length L and wall h whose ends are held round (simply supported: w = v = 0, free axially, the
classic closed-form case). Each mode (m axial half waves, n circumferential waves) is found by the
Rayleigh-Ritz method with the exact modal functions
u = A cos(a x) cos(n t), v = B sin(a x) sin(n t), w = C sin(a x) cos(n t), a = m pi / L:
membrane strains e_x = u_x, e_t = (v_t + w) / R, g = v_x + u_t / R and Love's changes of curvature
k_x = -w_xx, k_t = -(w_tt - v_t) / R^2, twist -(w_xt - v_x) / R, in the energy
C (e_x^2 + e_t^2 + 2 nu e_x e_t + (1 - nu) g^2 / 2) + D (k_x^2 + k_t^2 + 2 nu k_x k_t
+ 2 (1 - nu) twist^2), C = E h / (1 - nu^2), D = E h^3 / (12 (1 - nu^2)), give a 3 x 3 eigenproblem
per (m, n) whose lowest root is the bending (flexural) mode. Limits (tests): a long shell tends to
Rayleigh's inextensional ring frequencies, a very large radius to the simply supported plate.
Each n >= 1 mode comes as a pair (cos and sin orientation).

Box (a toaster's sheet body): six flat panels, each simply supported along its edges:
w = sin(m pi x / a) sin(n pi y / b), omega = sqrt(D / (rho h)) ((m pi / a)^2 + (n pi / b)^2).

Models are built at the reference material (E_REF, RHO_REF) and scale 1 like the voxel ones, as
a :class:`~fallgen.audio.modal_model.ModalModel` on a grid of surface nodes, mass-normalised, so they
rescale and synthesise the same way.
"""

from __future__ import annotations

import math

import numpy as np

from fallgen.audio.modal_model import E_REF, RHO_REF, ModalModel, round_nu
from fallgen.world.shell import ThinShell

#: Surface nodes of a shell model (about; at least 8 along any side).
TARGET_NODES = 4000


def _spacing(area_m2: float) -> float:
    return math.sqrt(area_m2 / TARGET_NODES)


def _flexural(R: float, L: float, h: float, nu: float, E: float, rho: float, m: int, n: int
              ) -> tuple[float, np.ndarray]:
    """Lowest omega (rad/s) of mode (m, n) of the simply supported cylinder and its (A, B, C),
    mass-normalised over the shell."""
    a = m * math.pi / L
    Cm = E * h / (1 - nu ** 2)
    D = E * h ** 3 / (12 * (1 - nu ** 2))
    ex = np.array([-a, 0.0, 0.0])
    et = np.array([0.0, n / R, 1 / R])
    g = np.array([-n / R, a, 0.0])
    kx = np.array([0.0, 0.0, a * a])
    kt = np.array([0.0, n / R ** 2, n * n / R ** 2])
    tw = np.array([0.0, a / R, a * n / R])

    def sym(p, q):
        return np.outer(p, q) + np.outer(q, p)

    K = Cm * (np.outer(ex, ex) + np.outer(et, et) + nu * sym(ex, et) + (1 - nu) / 2 * np.outer(g, g)) \
        + D * (np.outer(kx, kx) + np.outer(kt, kt) + nu * sym(kx, kt) + 2 * (1 - nu) * np.outer(tw, tw))
    dofs = [0, 2] if n == 0 else [0, 1, 2]  # n = 0 has no v in this family (torsion is separate)
    lam, vec = np.linalg.eigh(K[np.ix_(dofs, dofs)] / (rho * h))
    q = np.zeros(3)
    q[dofs] = vec[:, 0]
    # mass: rho h int(u^2 + v^2 + w^2) dA = rho h R (L / 2) (pi or 2 pi for n = 0) |q|^2
    mass = rho * h * R * L / 2 * (2 * math.pi if n == 0 else math.pi)
    return math.sqrt(max(lam[0], 0.0)), q / math.sqrt(mass)


def _cylinder(s: ThinShell, nu: float, E: float, rho: float, n_modes: int
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    R, L, h = s.size[0], s.size[2], s.thickness
    cands = []
    for m in range(1, 13):
        for n in range(0, 25):
            w, q = _flexural(R, L, h, nu, E, rho, m, n)
            for turn in ((0.0,) if n == 0 else (0.0, math.pi / (2 * n))):
                cands.append((w, m, n, turn, q))
    cands.sort(key=lambda c: c[0])
    cands = cands[:n_modes]
    dl = _spacing(2 * math.pi * R * L)
    nt = max(32, int(math.ceil(2 * math.pi * R / dl)))
    nx = max(8, int(math.ceil(L / dl)))
    th = (np.arange(nt) + 0.5) * 2 * math.pi / nt
    x = (np.arange(nx) + 0.5) * L / nx
    T, X = np.meshgrid(th, x, indexing="ij")
    T, X = T.ravel(), X.ravel()
    er = np.column_stack([np.cos(T), np.sin(T), np.zeros_like(T)])
    et = np.column_stack([-np.sin(T), np.cos(T), np.zeros_like(T)])
    ez = np.array([0.0, 0.0, 1.0])
    points = R * er + np.outer(X - L / 2, ez) + np.asarray(s.center)
    area = er * (R * 2 * math.pi / nt * L / nx)
    shapes = np.empty((len(T), 3, len(cands)))
    omega = np.empty(len(cands))
    for i, (w, m, n, turn, (A, B, C)) in enumerate(cands):
        a = m * math.pi / L
        ct, st = np.cos(n * (T - turn)), np.sin(n * (T - turn))
        u = A * np.cos(a * X) * ct
        v = B * np.sin(a * X) * st
        wr = C * np.sin(a * X) * ct
        shapes[:, :, i] = wr[:, None] * er + v[:, None] * et + u[:, None] * ez
        omega[i] = w
    return omega, points, area, shapes, min(2 * math.pi * R / nt, L / nx)


def _box(s: ThinShell, nu: float, E: float, rho: float, n_modes: int
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    size, h = np.asarray(s.size, float), s.thickness
    D = E * h ** 3 / (12 * (1 - nu ** 2))
    c = math.sqrt(D / (rho * h))
    dl = _spacing(2 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2]))
    points, area, panel_of, frames = [], [], [], []
    for axis in range(3):
        u_ax, v_ax = [k for k in range(3) if k != axis]
        a, b = size[u_ax], size[v_ax]
        nu_, nv_ = max(8, int(math.ceil(a / dl))), max(8, int(math.ceil(b / dl)))
        uu, vv = np.meshgrid((np.arange(nu_) + 0.5) * a / nu_, (np.arange(nv_) + 0.5) * b / nv_,
                             indexing="ij")
        for side in (-1.0, 1.0):
            p = np.zeros((uu.size, 3))
            p[:, axis] = side * size[axis] / 2
            p[:, u_ax] = uu.ravel() - a / 2
            p[:, v_ax] = vv.ravel() - b / 2
            nrm = np.zeros(3)
            nrm[axis] = side
            points.append(p)
            area.append(np.tile(nrm * (a / nu_) * (b / nv_), (uu.size, 1)))
            panel_of.append(np.full(uu.size, len(frames)))
            frames.append((a, b, uu.ravel(), vv.ravel(), nrm))
    cands = []
    for k, (a, b, _, _, _) in enumerate(frames):
        for m in range(1, 13):
            for n in range(1, 13):
                cands.append((c * ((m * math.pi / a) ** 2 + (n * math.pi / b) ** 2), k, m, n))
    cands.sort(key=lambda t: (t[0], t[1]))
    cands = cands[:n_modes]
    points_a, area_a, panel_a = np.vstack(points), np.vstack(area), np.concatenate(panel_of)
    shapes = np.zeros((len(points_a), 3, len(cands)))
    for i, (_, k, m, n) in enumerate(cands):
        a, b, uu, vv, nrm = frames[k]
        amp = 2.0 / math.sqrt(rho * h * a * b)  # mass-normalised: rho h a b / 4 |amp|^2 = 1
        w = amp * np.sin(m * math.pi * uu / a) * np.sin(n * math.pi * vv / b)
        shapes[panel_a == k, :, i] = w[:, None] * nrm
    omega = np.array([t[0] for t in cands])
    return omega, points_a + np.asarray(s.center), area_a, shapes, dl


def shell_modes(shell: ThinShell, nu: float, E: float, rho: float, n_modes: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """(omega, surface points, area vectors, mode shapes (S, 3, n), node spacing) of a thin
    shell, lowest ``n_modes`` modes, ascending."""
    fn = _cylinder if shell.kind == "cylinder" else _box
    return fn(shell, nu, E, rho, n_modes)


def plate_model(a: float, b: float, thickness: float, nu: float, n_modes: int,
                nodes: int = 48, stiffness_ratio: float = 1.0) -> ModalModel:
    """Reference modal model (E_REF, RHO_REF) of an ``a`` x ``b`` plate simply supported
    along its edges (a patch of floor between joists, of a wall between studs, of a slab),
    ``thickness`` thick, centred at the origin: the lowest ``n_modes`` of
    w = sin(m pi x / a) sin(n pi y / b), omega = sqrt(D / (rho h)) ((m pi / a)^2 + (n pi / b)^2),
    mass-normalised, on a ``nodes`` x ``nodes`` grid of its +z face (the face into the
    room). ``stiffness_ratio`` r = D_y / D_x < 1: an orthotropic plate (timber boards along
    x) in Huffington's form, H = sqrt(D_x D_y), whose simply supported modes are the same
    shapes at omega = sqrt(D_x / (rho h)) ((m pi / a)^2 + sqrt(r) (n pi / b)^2) (Leissa,
    Vibration of Plates, NASA SP-160, 1969, ch. 11)."""
    nu = round_nu(nu)
    h = thickness
    c = math.sqrt(E_REF * h ** 3 / (12 * (1 - nu ** 2)) / (RHO_REF * h))
    sr = math.sqrt(stiffness_ratio)
    cands = sorted((c * ((m * math.pi / a) ** 2 + sr * (n * math.pi / b) ** 2), m, n)
                   for m in range(1, n_modes + 1) for n in range(1, n_modes + 1))[:n_modes]
    du, dv = a / nodes, b / nodes
    uu, vv = np.meshgrid((np.arange(nodes) + 0.5) * du, (np.arange(nodes) + 0.5) * dv,
                         indexing="ij")
    points = np.stack([uu.ravel() - a / 2, vv.ravel() - b / 2,
                       np.full(uu.size, h / 2)], 1)
    area = np.zeros_like(points)
    area[:, 2] = du * dv
    amp = 2.0 / math.sqrt(RHO_REF * h * a * b)
    shapes = np.zeros((len(points), 3, len(cands)), np.float32)
    for i, (_, m, n) in enumerate(cands):
        shapes[:, 2, i] = (amp * np.sin(m * math.pi * uu / a)
                           * np.sin(n * math.pi * vv / b)).ravel()
    return ModalModel(np.array([t[0] for t in cands]), points, area, shapes, nu,
                      min(du, dv), 0, 0.0)
