"""Voxel FEM modes against beam theory, and the scaling laws a modal cache relies on."""

from __future__ import annotations

import math
import zipfile

import numpy as np
import pytest
import trimesh

from fallgen.audio.fem import brick_stiffness, solve_modes
from fallgen.audio.modes import ModalSettings, modal_model
from fallgen.audio.voxelize import voxelize

E, RHO, NU = 2.0e11, 7850.0, 0.29  # steel
BETA_L = (4.7300, 7.8532, 10.9956)  # free-free beam roots


def _beam_modes(L, b, t, h, E=E, rho=RHO, nu=NU, n=14):
    occ = np.ones((int(round(L / h)), int(round(b / h)), int(round(t / h))), bool)
    return solve_modes(occ, h, E=E, nu=nu, rho=rho, n_modes=n)


def _z_bending(m):
    """Indices of modes that bend the bar across its thickness (z motion dominates)."""
    s = m.shapes
    zfrac = (s[:, 2, :] ** 2).sum(0) / (s ** 2).sum((0, 1))
    return [i for i in range(len(m.omega)) if zfrac[i] > 0.9]


def _euler_bernoulli(L, b, t, n, timoshenko=False):
    I, A = b * t ** 3 / 12, b * t
    out = []
    for bl in BETA_L[:n]:
        f = bl ** 2 / (2 * math.pi * L ** 2) * math.sqrt(E * I / (RHO * A))
        if timoshenko:  # shear deformation and rotary inertia (Rayleigh-Timoshenko estimate)
            r2 = I / A
            f /= math.sqrt(1 + (bl / L) ** 2 * r2 * (1 + 2 * (1 + NU) / (5 / 6)))
        out.append(f)
    return np.array(out)


def test_brick_has_six_rigid_modes_and_scales_with_E_h():
    k = brick_stiffness(1.0, 1.0, 0.3)
    w = np.linalg.eigvalsh(k)
    assert np.sum(np.abs(w) < 1e-9) == 6 and w.min() > -1e-9
    assert np.allclose(brick_stiffness(0.5, 3.0, 0.3), 1.5 * k)


def test_steel_bar_bending_modes_match_beam_theory():
    # A steel bar 100 x 10 x 5 mm, 2 voxels through the thickness.
    L, b, t = 0.1, 0.01, 0.005
    m = _beam_modes(L, b, t, 0.0025)
    f = m.omega[_z_bending(m)][:3] / (2 * math.pi)
    eb = _euler_bernoulli(L, b, t, 3)
    tim = _euler_bernoulli(L, b, t, 3, timoshenko=True)
    assert np.all(np.abs(f[:2] / eb[:2] - 1) < 0.03), (f, eb)
    # The third: Euler-Bernoulli itself runs 5 % high on a bar this stubby (L / t = 20);
    # against the shear- and rotary-inertia-corrected beam it is within 3 %.
    assert np.all(np.abs(f / tim - 1) < 0.03), (f, tim)
    assert m.rigid_omega.max() < 1.0  # rad/s: the six dropped modes were the rigid ones


def test_slender_bar_matches_euler_bernoulli():
    L, b, t = 0.2, 0.01, 0.004
    m = _beam_modes(L, b, t, 0.002)
    f = m.omega[_z_bending(m)][:3] / (2 * math.pi)
    assert np.all(np.abs(f / _euler_bernoulli(L, b, t, 3) - 1) < 0.03)


def test_frequencies_scale_with_material_and_size():
    L, b, t = 0.06, 0.01, 0.005
    base = _beam_modes(L, b, t, 0.0025, n=8).omega
    # sqrt(E / rho): aluminium vs steel, solved from scratch
    alu = _beam_modes(L, b, t, 0.0025, E=6.9e10, rho=2700.0, n=8).omega
    assert np.allclose(alu / base, math.sqrt(6.9e10 / 2700 / (E / RHO)), rtol=1e-6)
    # 1 / L: the same bar twice as big
    big = _beam_modes(2 * L, 2 * b, 2 * t, 0.005, n=8).omega
    assert np.allclose(big / base, 0.5, rtol=1e-6)


def test_modal_model_scaling_and_cache(tmp_path):
    box = trimesh.creation.box((0.08, 0.012, 0.006))
    s = ModalSettings(target_voxels=600, n_modes=10)
    ref = modal_model(box.vertices, box.faces, NU, s, tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 1
    again = modal_model(box.vertices, box.faces, NU, s, tmp_path)
    assert np.array_equal(ref.omega, again.omega) and np.array_equal(ref.shapes, again.shapes)
    # a fresh solve and a cached one sound the same to the last bit (same memory layout too)
    from fallgen.audio.impact import radiation_factors

    assert np.array_equal(radiation_factors(ref.scaled(E, RHO, 1.0)),
                          radiation_factors(again.scaled(E, RHO, 1.0)))
    # the cached reference, rescaled, equals a direct solve of the scaled object
    steel = ref.scaled(E, RHO, 1.5)
    big = trimesh.creation.box((0.12, 0.018, 0.009))
    vs = voxelize(big.vertices, big.faces, ref.h * 1.5)
    direct = solve_modes(vs.occupied, vs.h, E=E, nu=0.3, rho=RHO, n_modes=10,
                         stiffness_scale=vs.stiffness_scale, density_scale=vs.fill)
    assert np.allclose(steel.omega, direct.omega, rtol=1e-5)
    # a corrupt cache entry is recomputed, not trusted
    f = next(tmp_path.glob("*.npz"))
    f.write_bytes(b"not a cache entry")
    fixed = modal_model(box.vertices, box.faces, NU, s, tmp_path)
    assert np.array_equal(fixed.omega, ref.omega)


def test_voxelizer_keeps_volume():
    """The voxels' filled volume (fill fraction times h^3, summed here) is the mesh's own
    (trimesh's divergence-theorem volume, and the closed forms of a sphere-like icosphere, a
    cylinder and an annulus) within 3 %, and the voxelizer reports that error."""
    cases = [(trimesh.creation.icosphere(3, 0.03), None),
             (trimesh.creation.cylinder(0.02, 0.1, sections=64), math.pi * 0.02 ** 2 * 0.1),
             (trimesh.creation.annulus(0.02, 0.03, 0.05, sections=64),
              math.pi * (0.03 ** 2 - 0.02 ** 2) * 0.05)]
    for mesh, closed in cases:
        vs = voxelize(mesh.vertices, mesh.faces, 0.004)
        filled = float(vs.fill.sum()) * vs.h ** 3
        assert filled == pytest.approx(mesh.volume, rel=0.03), (filled, mesh.volume)
        if closed is not None:  # the mesh itself is the closed form, to its facets
            assert mesh.volume == pytest.approx(closed, rel=0.01)
        assert vs.volume_error == pytest.approx(abs(filled - mesh.volume) / mesh.volume,
                                                abs=1e-9)
        assert vs.n_voxels == int(np.count_nonzero(vs.occupied)) > 0


def test_a_model_loaded_again_reads_its_shapes_from_the_cache_file(tmp_path):
    """A model loaded again with its mode shapes left in the cache file holds the same arrays
    as a full load and reads the rows indexed (an integer, an array, negative rows) as the
    full load's; a truncated entry is recomputed, not read."""
    from fallgen.audio.modes import StoredArray

    box = trimesh.creation.box((0.08, 0.012, 0.006))
    s = ModalSettings(target_voxels=600, n_modes=10)
    ref = modal_model(box.vertices, box.faces, NU, s, tmp_path)
    stored = modal_model(box.vertices, box.faces, NU, s, tmp_path, stored=True)
    for name in ("omega", "points", "area"):
        assert np.array_equal(getattr(stored, name), getattr(ref, name)), name
    assert isinstance(stored.shapes, StoredArray) and stored.shapes.shape == ref.shapes.shape
    assert np.array_equal(np.asarray(stored.shapes), ref.shapes)
    rows = np.array([[0, 7], [len(ref.shapes) - 1, -2]])
    assert np.array_equal(stored.shapes[rows], ref.shapes[rows])
    assert np.array_equal(stored.shapes[3], ref.shapes[3]) and stored.shapes[3].shape == (3, 10)
    assert np.array_equal(stored.phi(5), ref.phi(5))
    with pytest.raises(IndexError):
        stored.shapes[len(ref.shapes)]
    # an entry whose shapes lack their last 400 bytes (the zip itself sound)
    f = next(tmp_path.glob("*.npz"))
    with zipfile.ZipFile(f) as z:
        members = {n: z.read(n) for n in z.namelist()}
    members["shapes.npy"] = members["shapes.npy"][:-400]
    with zipfile.ZipFile(f, "w") as z:
        for name, data in members.items():
            z.writestr(name, data)
    again = modal_model(box.vertices, box.faces, NU, s, tmp_path, stored=True)
    assert np.array_equal(again.shapes, ref.shapes)
    with zipfile.ZipFile(f) as z:  # recomputed and cached whole again
        assert len(z.read("shapes.npy")) == len(members["shapes.npy"]) + 400
