"""Thin-shell modal models (fallgen.audio.shells) against shell and plate theory."""

import math

import numpy as np
import pytest

from fallgen.audio.modes import E_REF, RHO_REF, shell_model
from fallgen.audio.shells import _flexural
from fallgen.world.shell import THIN_WALL_M, ThinShell

E, RHO, NU = 2.0e11, 7850.0, 0.3


def _D(h):
    return E * h ** 3 / (12 * (1 - NU ** 2))


@pytest.mark.parametrize("n", [2, 3, 4, 6])
def test_long_cylinder_tends_to_rayleigh_ring(n):
    """Rayleigh's inextensional ring: omega^2 = D / (rho h R^4) n^2 (n^2 - 1)^2 / (n^2 + 1)."""
    R, h = 0.05, 0.0005
    w, _ = _flexural(R, 100 * R, h, NU, E, RHO, 1, n)
    ring = math.sqrt(_D(h) / (RHO * h * R ** 4) * n ** 2 * (n ** 2 - 1) ** 2 / (n ** 2 + 1))
    assert w == pytest.approx(ring, rel=0.01)


@pytest.mark.parametrize("m,n", [(1, 1000), (2, 1500), (3, 3000)])
def test_flat_limit_is_the_simply_supported_plate(m, n):
    """R -> infinity: a strip of plate, omega = sqrt(D / rho h) (k_x^2 + k_y^2)."""
    R, L, h = 1e3, 0.3, 0.002
    w, _ = _flexural(R, L, h, NU, E, RHO, m, n)
    plate = math.sqrt(_D(h) / (RHO * h)) * ((m * math.pi / L) ** 2 + (n / R) ** 2)
    assert w == pytest.approx(plate, rel=0.01)


@pytest.mark.parametrize("shell", [ThinShell.cylinder(0.033, 0.1, 0.00012, (0, 0, 0.01)),
                                   ThinShell("box", (0.28, 0.17, 0.19), 0.0008)])
def test_modes_mass_normalised_and_orthogonal(shell):
    """sum over nodes of rho h |a| phi_i . phi_j ~ delta_ij (the node grid integrates the
    shell's kinetic energy)."""
    m = shell_model(shell, NU)
    w = RHO_REF * shell.thickness * np.linalg.norm(m.area, axis=1)
    phi = m.shapes.astype(float)
    G = np.einsum("s,sci,scj->ij", w, phi, phi)
    assert np.allclose(np.diag(G), 1.0, atol=0.03)
    assert np.abs(G - np.diag(np.diag(G))).max() < 0.03
    assert np.all(np.diff(m.omega) >= 0) and m.omega[0] > 0


def test_box_panel_frequency_and_rescaling():
    """A toaster's lowest mode is its largest panel's (1, 1) mode; material and size rescale it
    like any modal model."""
    box = ThinShell("box", (0.28, 0.17, 0.19), 0.0008)
    ref = shell_model(box, NU)
    s = ref.scaled(E, RHO, 1.0)
    a, b, h = 0.28, 0.19, 0.0008
    want = math.sqrt(_D(h) / (RHO * h)) * ((math.pi / a) ** 2 + (math.pi / b) ** 2)
    assert s.omega[0] == pytest.approx(want, rel=1e-9)
    assert ref.scaled(E, RHO, 2.0).omega[0] == pytest.approx(want / 2, rel=1e-9)
    assert ref.omega[0] == pytest.approx(want * math.sqrt(E_REF * RHO / (E * RHO_REF)), rel=1e-9)


def test_thin_walled_library_objects_carry_their_shell(world):
    """Cans, tins, a PET bottle and the toaster get a shell that fits inside their mesh; thick
    walls (a glass bottle) stay with voxel FEM."""
    lib = world.categories
    for cid, var in [("soda_can", "355ml"), ("soda_can", "500ml"), ("box", "tea_tin"),
                     ("bottle", "pet"), ("toaster", "steel")]:
        g = lib.geometry(cid, var)
        assert g.shell is not None and g.shell.thickness <= THIN_WALL_M, (cid, var)
        lo, hi = g.vertices.min(0), g.vertices.max(0)
        c, half = np.asarray(g.shell.center), np.asarray(g.shell.size) / 2
        if g.shell.kind == "cylinder":
            half = np.array([g.shell.size[0], g.shell.size[0], g.shell.size[2] / 2])
        assert np.all(c - half >= lo - 1e-6) and np.all(c + half <= hi + 1e-6), (cid, var)
    assert lib.geometry("bottle", "wine").shell is None


def test_plate_patch_is_the_simply_supported_plate():
    """A room surface's patch (:func:`fallgen.audio.shells.plate_model`): Kirchhoff's
    frequencies of a simply supported plate, ascending, mass-normalised shapes on its +z face,
    frequencies scaling with the thickness; a 150 mm concrete slab patch starts in the kHz,
    22 mm floorboards in the low hundreds of Hz."""
    from fallgen.audio.shells import plate_model

    a, t, nu = 0.6, 0.022, 0.3
    m = plate_model(a, a, t, nu, 12)
    D = E_REF * t ** 3 / (12 * (1 - nu ** 2))
    w11 = math.sqrt(D / (RHO_REF * t)) * 2 * (math.pi / a) ** 2
    assert m.omega[0] == pytest.approx(w11, rel=1e-9)
    assert m.omega[1] == pytest.approx(m.omega[2]) == pytest.approx(2.5 * w11)  # (1,2), (2,1)
    assert np.all(np.diff(m.omega) >= 0)
    assert np.all(m.area[:, 2] > 0) and np.allclose(m.points[:, 2], t / 2)
    shapes = m.shapes[:, 2, :].astype(float)
    mass = RHO_REF * t * m.area[:, 2]  # the plate's mass per node
    np.testing.assert_allclose((mass[:, None] * shapes ** 2).sum(0), 1.0, rtol=0.01)
    assert plate_model(a, a, 2 * t, nu, 12).omega[0] == pytest.approx(2 * w11)
    # in materials: concrete (stone) 150 mm vs pine-like boards 22 mm: Kirchhoff's (1, 1)
    # frequency of each, 1.57 kHz and 237 Hz
    for t_m, nu_m, e_m, rho_m, hz in ((0.15, 0.2, 4e10, 2400.0, 1574.5),
                                      (0.022, 0.3, 1e10, 600.0, 237.2)):
        d_m = e_m * t_m ** 3 / (12 * (1 - nu_m ** 2))
        f11 = math.sqrt(d_m / (rho_m * t_m)) * 2 * (math.pi / a) ** 2 / (2 * math.pi)
        got = plate_model(a, a, t_m, nu_m, 4).scaled(e_m, rho_m, 1.0).omega[0] / (2 * math.pi)
        assert got == pytest.approx(f11, rel=1e-9) == pytest.approx(hz, rel=0.002)


def test_orthotropic_plate_patch_has_the_modal_density_of_its_impedance():
    """Timber boards are orthotropic (``structure_stiffness_ratio`` r = D_y / D_x): the patch's
    simply supported modes are at sqrt(D_x / m'') ((m pi / a)^2 + sqrt(r) (n pi / b)^2)
    (Huffington's plate), and their count per band is the modal density
    n(f) = A / 2 sqrt(m'' / sqrt(D_x D_y)) that makes the plate's mean point conductance
    1 / (8 sqrt(m'') (D_x D_y)^(1/4)): the point impedance the renderer gives the surface."""
    from fallgen.audio.shells import plate_model

    a, t, nu, r = 0.6, 0.022, 0.35, 0.06
    m = plate_model(a, a, t, nu, 400, stiffness_ratio=r)
    D = E_REF * t ** 3 / (12 * (1 - nu ** 2))
    c = math.sqrt(D / (RHO_REF * t))
    assert m.omega[0] == pytest.approx(c * (1 + math.sqrt(r)) * (math.pi / a) ** 2, rel=1e-9)
    iso = plate_model(a, a, t, nu, 400)
    assert m.omega[0] < iso.omega[0]
    f = m.omega / (2 * math.pi)
    lo, hi = f[50], f[300]  # away from the lowest modes' and the truncation's edges
    count = np.sum((f >= lo) & (f < hi))
    density = a * a / 2 * math.sqrt(RHO_REF * t / (D * math.sqrt(r)))
    assert count == pytest.approx(density * (hi - lo), rel=0.08)
    # the same count, as an isotropic plate's, would be sqrt(1 / sqrt(r)) = 2x fewer
    f_iso = iso.omega / (2 * math.pi)
    assert np.sum((f_iso >= lo) & (f_iso < hi)) < 0.6 * count
