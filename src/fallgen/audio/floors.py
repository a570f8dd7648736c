"""Room surfaces as the plates an impact strikes, checked against building acoustics.

A floor, wall or ceiling is hit through its finish (``impact_material``: the contact's stiffness
and restitution) and rings as what lies behind it (``structure_material``,
``structure_thickness_m``: the slab under the tiles, 22 mm boards on joists): a large plate of
mass per area m'', bending stiffness B, coincidence frequency f_c and point impedance
Z = 8 sqrt(B m'') (:class:`SurfacePlate`; :mod:`fallgen.audio.fall` renders a fall's hits on
it with :func:`~fallgen.audio.impact.plate_pressure`).

The same model is measured here as building acousticians measure floors, so that it can be
checked against their data: the ISO 10140-5 tapping machine (five 0.5 kg steel hammers with a
500 mm spherical face, dropped 40 mm, 10 hits a second) on the floor, the normalised impact
sound pressure level L_n in the room below in third-octave bands 100-3150 Hz (the slab's lower
face radiates as its upper one: the sound power into one half space, L_n = L_W - 10 lg(A0 / 4),
A0 = 10 m^2), rated per ISO 717-2 (:func:`impact_rating`). References:

- a bare homogeneous floor: EN ISO 12354-2:2017's empirical L_n,w,eq = 164 - 35 lg(m'')
  (m'' in kg/m^2, 100-600 kg/m^2; a regression on laboratory measurements,
  :func:`bare_floor_reference`);
- a covering: its weighted improvement Delta L_w (ISO 717-2: Delta L = the bare floor's
  L_n minus the covered one's, applied to the standard's reference floor, 78 dB minus its
  rating; :func:`covering_improvement`), against measured ranges of its kind (cited in
  the material's sources).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from fallgen.audio.hertz import hertz_impact, plate_contact
from fallgen.audio.impact import C_AIR, RHO_AIR, ModalHit, plate_pressure
from fallgen.world.materials import MaterialLibrary, ObjectMaterial, SurfaceMaterial

#: A furniture part's or room surface's loss factor at least (held by the rest of its
#: structure: joints, supports, edges).
MOUNTED_LOSS_FACTOR = 0.05

#: ISO 10140-5's tapping machine: hammer mass, face radius, drop height, hits per second.
HAMMER_KG = 0.5
HAMMER_FACE_RADIUS_M = 0.5
HAMMER_DROP_M = 0.04
HAMMER_RATE_HZ = 10.0
#: ISO 717-2: third-octave centre frequencies 100-3150 Hz and the reference curve for impact
#: sound (its value at 500 Hz is the rating when shifted).
BANDS_HZ = tuple(float(f) for f in
                 (100, 125, 160, 200, 250, 315, 400, 500, 630, 800, 1000, 1250, 1600, 2000,
                  2500, 3150))
REFERENCE_CURVE_DB = (62, 62, 62, 62, 62, 62, 61, 60, 59, 58, 57, 54, 51, 48, 45, 42)
#: ISO 717-2's heavy reference floor L_n,r,0 (for a covering's Delta L_w).
REFERENCE_FLOOR_DB = (67, 67.5, 68, 68.5, 69, 69.5, 70, 70.5, 71, 71.5, 72, 72, 72, 72, 72, 72)
#: the normalising absorption area, m^2
A0_M2 = 10.0


@dataclass(frozen=True)
class SurfacePlate:
    """A room surface's structure as an infinite plate: mass per area (kg/m^2), bending
    stiffness along its stiff direction (N m), coincidence frequency there (Hz), orthotropy
    D_across / D_along, loss factor, and point impedance (N s/m: 8 sqrt(m'') (D_x D_y)^(1/4),
    the isotropic plate's in coordinates scaled by (D_y / D_x)^(1/4)); and the finish struck."""

    mass_per_area: float
    bending_n_m: float
    coincidence_hz: float
    stiffness_ratio: float
    loss_factor: float
    point_impedance_n_s_m: float
    structure: ObjectMaterial
    finish: ObjectMaterial


def surface_plate(surface: SurfaceMaterial, materials: MaterialLibrary) -> SurfacePlate:
    struct = materials.object(surface.structure_material)
    t = surface.structure_thickness_m
    r = surface.structure_stiffness_ratio
    m2 = struct.density_kg_m3 * t
    bending = struct.youngs_modulus_pa * t ** 3 / (12 * (1 - struct.poisson_ratio ** 2))
    fc = C_AIR ** 2 / (2 * math.pi) * math.sqrt(m2 / bending)
    return SurfacePlate(m2, bending, fc, r, max(struct.loss_factor, MOUNTED_LOSS_FACTOR),
                        8.0 * math.sqrt(bending * m2) * r ** 0.25, struct,
                        materials.object(surface.impact_material))


def floor_hit(plate: SurfacePlate, impactor: ObjectMaterial, mass_kg: float,
              radius_m: float, speed_mps: float) -> tuple[float, float, float]:
    """A rigid impactor's hit on the surface, as :mod:`fallgen.audio.fall` makes it: the Hertz
    contact with the finish in series with the plate's impedance (Zener). Returns the impulse
    (N s), the force's duration (s) and the restitution."""
    fin = plate.finish
    h = hertz_impact(impactor.contact_modulus_pa, impactor.poisson_ratio,
                     fin.contact_modulus_pa, fin.poisson_ratio, radius_m, math.inf, mass_kg,
                     math.inf, speed_mps)
    pc = plate_contact(mass_kg, h.duration_s, plate.point_impedance_n_s_m)
    e = min(impactor.restitution, fin.restitution) * pc.restitution
    return mass_kg * speed_mps * (1.0 + e), max(pc.duration_s, h.duration_s), e


def band_energies(p: np.ndarray, sample_rate: int, bands_hz=BANDS_HZ) -> np.ndarray:
    """The integral of p^2 dt (Pa^2 s) in each third-octave band (edges f 2^(+-1/6)), from
    the signal's spectrum (Parseval: the bands' sum over all frequencies is the whole)."""
    n = len(p)
    X = np.fft.rfft(np.asarray(p, float))
    e = np.abs(X) ** 2 / (n * sample_rate)
    e[1:(n + 1) // 2] *= 2.0  # the negative frequencies' share (not DC, not Nyquist)
    f = np.fft.rfftfreq(n, 1.0 / sample_rate)
    return np.array([e[(f >= fc * 2 ** (-1 / 6)) & (f < fc * 2 ** (1 / 6))].sum()
                     for fc in bands_hz])


@dataclass(frozen=True)
class ImpactLevels:
    """A floor's normalised impact sound pressure level under the tapping machine."""

    bands_hz: tuple[float, ...]
    ln_db: np.ndarray  # (16,) L_n per third-octave band
    rating_db: int  # L_n,w (ISO 717-2)
    hammer_impulse_ns: float
    hammer_contact_s: float


def hit_pressure(plate: SurfacePlate, impactor: ObjectMaterial, mass_kg: float,
                 radius_m: float, speed_mps: float, sample_rate: int = 44100
                 ) -> tuple[np.ndarray, float, float, float]:
    """One rigid impactor's hit on the surface (:func:`floor_hit`): the surface's dry pressure
    at 1 m (one second, :func:`~fallgen.audio.impact.plate_pressure`), the kinetic energy the
    hit loses, m v^2 (1 - e^2) / 2 (J), and the hit's impulse (N s) and duration (s)."""
    j, t, e = floor_hit(plate, impactor, mass_kg, radius_m, speed_mps)
    p = plate_pressure(plate.mass_per_area, [ModalHit(0.01, np.zeros(3), j, t)], sample_rate,
                       sample_rate, coincidence_hz=plate.coincidence_hz,
                       loss_factor=plate.loss_factor, stiffness_ratio=plate.stiffness_ratio)
    return p, 0.5 * mass_kg * speed_mps ** 2 * (1.0 - e * e), j, t


#: J per (Pa^2 s) of a surface's dry signal at 1 m, into the room's half space
_HALF_SPACE = 8 * math.pi / (RHO_AIR * C_AIR)


def half_space_energy_j(p: np.ndarray, sample_rate: int) -> np.ndarray:
    """The energy per third-octave band a surface's dry signal radiates into the room: the dry
    signal is the free-field monopole whose image makes the plate's pressure, so into the half
    space it is twice the monopole's, 2 * 4 pi r^2 / (rho c) * int p^2 dt (r = 1 m)."""
    return _HALF_SPACE * band_energies(p, sample_rate)


def radiated_share(plate: SurfacePlate, impactor: ObjectMaterial, mass_kg: float,
                   radius_m: float, speed_mps: float, sample_rate: int = 44100) -> float:
    """The share of a rigid impactor's lost energy that the struck surface radiates into the
    room (the impactor's own sound not included)."""
    p, lost, _, _ = hit_pressure(plate, impactor, mass_kg, radius_m, speed_mps, sample_rate)
    return float(_HALF_SPACE * np.dot(p, p) / sample_rate / lost)


def tapping_machine(surface: SurfaceMaterial, materials: MaterialLibrary,
                    sample_rate: int = 44100) -> ImpactLevels:
    """The tapping machine on ``surface`` as fallgen renders a hit on it: one hammer blow's
    plate pressure (:func:`hit_pressure`), its energy into a half space per band, 10 blows a
    second."""
    plate = surface_plate(surface, materials)
    steel = materials.object("metal")
    v = math.sqrt(2 * 9.81 * HAMMER_DROP_M)
    p, _, j, t = hit_pressure(plate, steel, HAMMER_KG, HAMMER_FACE_RADIUS_M, v, sample_rate)
    power = HAMMER_RATE_HZ * half_space_energy_j(p, sample_rate)
    ln = 10 * np.log10(np.maximum(power, 1e-30) / 1e-12) + 10 * math.log10(4 / A0_M2)
    return ImpactLevels(BANDS_HZ, ln, impact_rating(ln), j, t)


def impact_rating(ln_db) -> int:
    """ISO 717-2's single number: the reference curve shifted in 1 dB steps until the sum of
    the bands' excess over it is as large as possible but at most 32 dB; its value at 500 Hz."""
    ln = np.asarray(ln_db, float)
    ref = np.asarray(REFERENCE_CURVE_DB, float)
    shift = math.floor(float(np.max(ln - ref))) + 1  # nothing above the curve yet
    while np.maximum(ln - (ref + shift - 1), 0.0).sum() <= 32.0:
        shift -= 1
    return int(60 + shift)


def bare_floor_reference(mass_per_area: float) -> float:
    """EN ISO 12354-2's L_n,w,eq of a bare homogeneous floor, dB (m'' 100-600 kg/m^2)."""
    return 164.0 - 35.0 * math.log10(mass_per_area)


def covering_improvement(surface: SurfaceMaterial, materials: MaterialLibrary,
                         bare_finish: str = "stone") -> float:
    """A covering's weighted impact sound improvement Delta L_w (ISO 717-2): its Delta L per
    band on its own structure (struck bare through ``bare_finish`` against struck through the
    covering), applied to the reference floor, 78 dB minus that floor's rating."""
    return check_floor(surface, materials, bare_finish, always=True).improvement_db


#: EN ISO 12354-2's bare-floor law holds for homogeneous floors of this mass per area.
HOMOGENEOUS_KG_M2 = (100.0, 600.0)
#: How far a bare homogeneous floor's rating may lie from EN ISO 12354-2's (dB): the law's
#: scatter about the measurements it was fitted to is of this order.
BARE_FLOOR_TOLERANCE_DB = 3.0


@dataclass(frozen=True)
class FloorCheck:
    """One floor surface under the tapping machine: its rating, its bare structure's against
    EN ISO 12354-2 (homogeneous structures only), its covering's improvement against the
    measured range (where the material gives one)."""

    surface: str
    mass_per_area: float
    rating_db: int
    bare_rating_db: int | None = None
    bare_reference_db: float | None = None
    improvement_db: float | None = None
    improvement_range_db: tuple[float, float] | None = None

    @property
    def bare_ok(self) -> bool | None:
        """The bare structure within :data:`BARE_FLOOR_TOLERANCE_DB` of EN ISO 12354-2 (None:
        not a homogeneous floor)."""
        if self.bare_reference_db is None:
            return None
        return abs(self.bare_rating_db - self.bare_reference_db) <= BARE_FLOOR_TOLERANCE_DB

    @property
    def improvement_ok(self) -> bool | None:
        """The covering's Delta L_w inside its measured range (None: no range on file)."""
        if self.improvement_range_db is None:
            return None
        lo, hi = self.improvement_range_db
        return lo <= self.improvement_db <= hi

    @property
    def ok(self) -> bool | None:
        """Both checks that apply (None: nothing to check it against)."""
        checks = [c for c in (self.bare_ok, self.improvement_ok) if c is not None]
        return all(checks) if checks else None


def check_floor(surface: SurfaceMaterial, materials: MaterialLibrary,
                bare_finish: str = "stone", always: bool = False) -> FloorCheck:
    """:class:`FloorCheck` of one floor surface (its bare structure struck through
    ``bare_finish``, a hard one); a structure outside EN ISO 12354-2's homogeneous range gets
    no bare reference nor improvement (``always``: the improvement all the same)."""
    plate = surface_plate(surface, materials)
    levels = tapping_machine(surface, materials)
    lo, hi = HOMOGENEOUS_KG_M2
    homogeneous = lo <= plate.mass_per_area <= hi
    if not (homogeneous or always):
        return FloorCheck(surface.name, plate.mass_per_area, levels.rating_db)
    bare = tapping_machine(replace(surface, impact_material=bare_finish), materials)
    dl = bare.ln_db - levels.ln_db
    return FloorCheck(surface.name, plate.mass_per_area, levels.rating_db, bare.rating_db,
                      bare_floor_reference(plate.mass_per_area) if homogeneous else None,
                      78.0 - impact_rating(np.asarray(REFERENCE_FLOOR_DB) - dl),
                      surface.impact_improvement_db)
