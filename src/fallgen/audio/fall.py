"""The dry sound of a fall event: every contact of the fall rings both bodies.

For each contact event of a :class:`~fallgen.physics.events.FallEvent`:

- an ``impact`` is a contact between the falling object (at its contact point) and the other
  body (floor, wall, furniture part, distractor; at the same world point): the effective mass
  that the recorded compression impulse implies, at the approach speed, meets both bodies'
  modes through a contact spring as stiff as that mass's Hertz contact with the other
  material (:mod:`fallgen.audio.coupling`), and the modes ring from the state it leaves them
  in: energy is conserved, and the modes never take more than the (1 - e^2) share of the
  impact's kinetic energy that the pair's restitution e says it loses (a prescribed rigid-body
  impulse gave a thin steel panel more energy than the whole fall had). The impulse times
  (1 + e), shared among the contact intervals (a body that chatters touches several times),
  one half-sine pulse each, makes the rigid-body noise and the struck surface's forced sound;
- a ``scrape`` or ``roll`` sample (10 ms of sustained contact) becomes a train of small random
  impulses, one per roughness wavelength travelled (``roughness_m``), each lasting the time to
  cross it, with an RMS of ``roughness_force_ratio`` (scrapes; a third of it for rolls) times
  the sample's normal force over the sample: the surface texture excites both bodies.

Bodies: the object's modal model (its mesh, material, scale); a furniture part's from its box or
cylinder; a floor, wall or ceiling as what rings behind its finish (the surface's
``structure_material`` and ``structure_thickness_m``: the concrete slab under a parquet or
tiles, 22 mm boards on joists, a gypsum board on studs): a ``PATCH_M`` square plate of it,
simply supported at its edges, takes the energy of the impact in the coupled contact, and the
surface radiates as an infinite plate of that mass per area, stiffness and loss factor
driven by the contact force, its coincidence included
(:func:`~fallgen.audio.impact.plate_pressure`); the finish (``impact_material``) sets the
contact's stiffness and restitution. A rug is a finish too: struck, the floor under it rings
through the rug's soft contact (the rug itself, a compliant fabric slab, has no audible modes).
Two earlier stand-ins were wrong both ways: a free 2 cm
panel of the finish radiating as a compact body radiated nothing (a free plate's modes have no
net volume displacement); the patch's modes radiating from its face (Rayleigh, baffled) put up
to 22 % of a heavy glass's fall into sound on a board floor (a bounded patch's fundamental
radiates like a piston; a continuous floor's bays cancel). Objects also radiate their rigid-body
acceleration noise (a hit jerks them as a whole); furniture parts are held by the rest of
their structure and only ring (a light basket bottom jerked as a free body made 137 dB at
1 m). Output: float64 pressure at 1 m in pascals, no normalisation.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import trimesh

from fallgen.audio.coupling import coupled_impact
from fallgen.audio.floors import MOUNTED_LOSS_FACTOR, surface_plate
from fallgen.audio.hertz import hertz_impact, plate_contact
from fallgen.audio.hits import Hit, HitTrain, ModalHit
from fallgen.audio.impact import SoundingBody, plate_pressure, render
from fallgen.audio.mix import DrySource
from fallgen.audio.modal_model import ModalModel, round_nu
from fallgen.audio.modes import ModalSettings, StoredArray, modal_model
from fallgen.audio.shells import plate_model
from fallgen.physics.contacts import ContactEvent
from fallgen.physics.events import GRAVITY, FallEvent
from fallgen.world.library import World
from fallgen.world.materials import ObjectMaterial, SurfaceMaterial
from fallgen.world.objects import ObjectInstance
from fallgen.world.scene import WALL_OWNERS, Scene, build_scene
from fallgen.world.shell import ThinShell

PATCH_M = 0.6
#: Where a floor or wall patch is struck, as a fraction of its side from the centre (an
#: off-centre point excites odd and even modes alike).
PATCH_HIT = (0.21, 0.13)


@dataclass(frozen=True)
class AudioSettings:
    sample_rate: int = 44100
    length_s: float = 2.0
    modal: ModalSettings = ModalSettings()
    roughness_m: float = 0.002
    roughness_force_ratio: float = 0.2
    cache_dir: Path | None = None


@dataclass
class _Body:
    sounding: SoundingBody
    volume_m3: float
    frame_pos: np.ndarray  # world position of the body frame the modes live in
    frame_mat: np.ndarray  # (3, 3) world rotation of that frame
    material: ObjectMaterial
    patch: bool = False  # a floor/wall/ceiling plate standing in for a large surface
    mass_per_area: float = 0.0  # a patch's structure, kg/m^2
    coincidence_hz: float | None = None  # ... its coincidence frequency (stiff direction)
    stiffness_ratio: float = 1.0  # ... and its orthotropy, D_across / D_along
    #: ... and its point impedance as the large plate it is, 8 sqrt(B m'') (N s/m)
    point_impedance_n_s_m: float = math.inf
    #: a free body (an object): a hit jerks it as a whole, which radiates (acceleration
    #: noise); a furniture part or a room surface is held by the rest and only rings
    free: bool = True
    hits: list[Hit] = field(default_factory=list)
    group: list[int] = field(default_factory=list)  # source group of each hit

    def render(self, s: AudioSettings, group: int | None = None) -> np.ndarray:
        """This body's pressure at 1 m from its hits (those of one source ``group``)."""
        hits = self.hits if group is None else \
            [h for h, g in zip(self.hits, self.group) if g == group]
        if self.patch:  # a room surface: the plate's forced sound where it is hit
            return plate_pressure(self.mass_per_area, hits,
                                  int(round(s.length_s * s.sample_rate)), s.sample_rate,
                                  coincidence_hz=self.coincidence_hz,
                                  loss_factor=self.sounding.loss_factor,
                                  stiffness_ratio=self.stiffness_ratio)
        return render(self.sounding, hits, s.length_s, s.sample_rate,
                      volume_m3=self.volume_m3 if self.free else None)

    def local(self, p_world) -> np.ndarray:
        return self.frame_mat.T @ (np.asarray(p_world, float) - self.frame_pos)


#: The geom owners of a room's surfaces (a furniture id may start with "wall" too: a wall
#: cabinet, "wall_cab_n")
PANELS = frozenset(("floor", "ceiling", *WALL_OWNERS))


def is_panel(owner: str) -> bool:
    """Whether a geom owner is a room surface (rendered as a plate patch, not as its own
    solid)."""
    return owner in PANELS


def part_mesh(gtype: int, size: np.ndarray) -> trimesh.Trimesh:
    """A furniture part's solid from its MuJoCo geom: a cylinder (radius, half height) or a
    box (half sizes)."""
    if gtype == int(mujoco.mjtGeom.mjGEOM_CYLINDER):
        return trimesh.creation.cylinder(float(size[0]), 2 * float(size[1]), sections=32)
    return trimesh.creation.box(tuple(2 * np.asarray(size[:3], float)))


def _nbytes(m: ModalModel) -> int:
    """The bytes a model holds in memory (its shapes none when left in the cache file)."""
    shapes = 0 if isinstance(m.shapes, StoredArray) else m.shapes.nbytes
    return shapes + m.points.nbytes + m.area.nbytes + m.omega.nbytes


def _quat_mat(quat) -> np.ndarray:
    """The rotation matrix of a placed body's quaternion (w, x, y, z), as MuJoCo's kinematics
    make it for a body of the world (normalised, then converted)."""
    q = np.asarray(quat, float).copy()
    mujoco.mju_normalize4(q)
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, q)
    return mat.reshape(3, 3)


def _sounding(ref: ModalModel, mat: ObjectMaterial, scale: float, mass: float, radius: float,
              loss_floor: float = 0.0) -> SoundingBody:
    return SoundingBody(ref.scaled(mat.youngs_modulus_pa, mat.density_kg_m3, scale),
                        max(mat.loss_factor, loss_floor), mat.contact_modulus_pa,
                        mat.poisson_ratio, mass, radius)


def _contact_modes(body: SoundingBody, point: np.ndarray, direction: np.ndarray | None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(omega, b) of a body's modes at the surface node nearest ``point``: b the
    mass-normalised shapes along ``direction`` (None: the outward normal there), as
    :func:`fallgen.audio.impact.render` excites them."""
    m = body.modes
    node = int(m.nearest(point)[0])
    d = m.normal(node) if direction is None else np.asarray(direction, float)
    return m.omega, d @ m.phi(node)


def contact_pulses(contacts, impulse_ns: float, plate_duration_s: float
                   ) -> tuple[tuple[float, float, float], ...]:
    """The force of an impact as half-sine pulses, one per contact interval of
    :func:`~fallgen.audio.coupling.coupled_impact` (``contacts``: start, length, impulse):
    (start s, impulse N s, duration s) each, the impulses shared out of ``impulse_ns`` (the
    impact's, (1 + e) m* v) as the contacts deliver theirs. A wall that yields as a large plate
    (Zener's pulse of ``plate_duration_s`` for the whole impulse:
    :func:`~fallgen.audio.hertz.plate_contact`) holds every pulse to that pulse's peak force,
    pi J / (2 T): a pulse lasts at least its share of the plate's time, and a single contact
    the longer of its own and the plate's."""
    total = float(sum(max(jk, 0.0) for _, _, jk in contacts))
    if not contacts or total <= 0.0:
        return ((0.0, impulse_ns, plate_duration_s),)
    out = []
    for start, length, jk in contacts:
        share = max(jk, 0.0) / total
        if share > 0.0:
            out.append((float(start), impulse_ns * share,
                        max(float(length), plate_duration_s * share)))
    return tuple(out)


class FallRenderer:
    """Renders fall events of one world; keeps the modal models it has used most recently,
    up to ``model_budget_bytes`` (a worker of a full build meets ~300 models, ~500 MB; one
    dropped is loaded again from the modal cache, the same model, its surface moments kept and
    its mode shapes, nine tenths of it, left in the file and read by the rows a render needs:
    such a model counts ~160 kB instead of ~1.7 MB). Kept models stay resident: on 300
    episodes of two paper-size shards, 32 MB loaded 575 models against 128 MB's 341 (each
    load then read the whole model) and left 96 MB less in the process."""

    def __init__(self, world: World, settings: AudioSettings = AudioSettings(),
                 model_budget_bytes: int = 32 * 2 ** 20) -> None:
        self.world = world
        self.s = settings
        self.budget = model_budget_bytes
        self._models: OrderedDict[tuple, ModalModel] = OrderedDict()
        self._model_bytes = 0
        self._moments: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._rooms: dict[str, tuple[mujoco.MjModel, mujoco.MjData]] = {}
        self._plates: dict[tuple, ModalModel] = {}

    def _room(self, variant_id: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
        """The room alone, compiled once per variant: the static geoms every scene of the
        variant starts with (same ids, same poses)."""
        if variant_id not in self._rooms:
            from fallgen.physics.drop import PHYSICS

            room = build_scene(self.world.variant(variant_id), self.world.materials,
                               settings=PHYSICS)
            d = room.data()
            mujoco.mj_forward(room.model, d)
            self._rooms[variant_id] = (room.model, d)
        return self._rooms[variant_id]

    @property
    def rooms_kept(self) -> frozenset[str]:
        """The variants whose compiled rooms are kept."""
        return frozenset(self._rooms)

    def retain_rooms(self, variant_ids: Collection[str]) -> None:
        """Forget the compiled rooms of every variant not in ``variant_ids``."""
        for v in [v for v in self._rooms if v not in variant_ids]:
            del self._rooms[v]

    def _floor_coverings(self, variant_id: str) -> frozenset[str]:
        """The ids of a variant's floor coverings (rugs): struck, the floor under them rings."""
        return frozenset(it.id for it in self.world.variant(variant_id).furniture
                         if it.floor_covering)

    # -- bodies ---------------------------------------------------------------------------
    def _ref(self, key: tuple, mesh, shell: ThinShell | None = None) -> ModalModel:
        """The reference modal model of a mesh (``mesh()`` builds it when not yet loaded), or
        of its thin ``shell``."""
        model = self._models.get(key)
        if model is not None:
            self._models.move_to_end(key)
            return model
        v, f, nu = mesh()
        # loaded again: the moments its first load computed from all of it (the same arrays),
        # its shapes left in the cache file (a render reads the rows of a few nodes)
        again = key in self._moments
        model = self._models[key] = modal_model(v, f, nu, self.s.modal, self.s.cache_dir, shell,
                                                stored=again)
        if again:
            object.__setattr__(model, "moments", self._moments[key])
        else:
            self._moments[key] = model.surface_moments()
        self._model_bytes += _nbytes(model)
        while self._model_bytes > self.budget and len(self._models) > 1:
            _, old = self._models.popitem(last=False)
            self._model_bytes -= _nbytes(old)
        return model

    def _object_body(self, inst: ObjectInstance, pos, mat33) -> _Body:
        nu = inst.material.poisson_ratio
        ref = self._ref(("obj", inst.category, inst.variant, nu),
                        lambda: (inst.geometry.vertices, inst.geometry.faces, nu),
                        inst.geometry.shell)
        ext = inst.extents_m
        radius = float(np.clip(0.25 * np.min(ext), 0.001, 0.05))
        vol = inst.geometry.volume_m3 * inst.scale ** 3
        body = _sounding(ref, inst.material, inst.scale, inst.mass_kg, radius)
        return _Body(body, vol, np.asarray(pos, float), np.asarray(mat33, float), inst.material)

    def _static_body(self, m: mujoco.MjModel, d: mujoco.MjData, gid: int, material: str,
                     owner: str, surface: SurfaceMaterial | None = None) -> _Body:
        """A furniture part (its geom's solid in its ``material``), or for a room surface
        (``surface``) a ``PATCH_M`` square patch of what rings behind its finish: the finish
        (``material``) gives the contact its stiffness and restitution."""
        mat = self.world.materials.object(material)
        pos, rot = d.geom_xpos[gid].copy(), d.geom_xmat[gid].reshape(3, 3).copy()
        if surface is not None:
            return self._surface_body(mat, surface, pos, rot)
        nu = mat.poisson_ratio
        gtype, size = int(m.geom_type[gid]), m.geom_size[gid].copy()
        vol = math.pi * size[0] ** 2 * 2 * size[1] \
            if gtype == int(mujoco.mjtGeom.mjGEOM_CYLINDER) else float(np.prod(2 * size[:3]))

        def mesh() -> tuple[np.ndarray, np.ndarray, float]:
            solid = part_mesh(gtype, size)
            return solid.vertices, solid.faces, nu

        ref = self._ref(("part", gtype, *map(float, size), nu), mesh)
        body = _sounding(ref, mat, 1.0, mat.density_kg_m3 * vol, math.inf, MOUNTED_LOSS_FACTOR)
        return _Body(body, vol, pos, rot, mat, free=False)

    def _surface_body(self, finish: ObjectMaterial, surface: SurfaceMaterial, pos, rot
                      ) -> _Body:
        """The patch of a floor, wall or ceiling where it is hit: a simply supported plate of
        the surface's structure (the slab under a parquet, boards on joists) takes the energy
        an impact gives the surface (its modes in the coupled contact), hit through the
        finish; what the surface radiates is the infinite plate's forced sound
        (:func:`~fallgen.audio.impact.plate_pressure`)."""
        plate = surface_plate(surface, self.world.materials)
        struct, t = plate.structure, surface.structure_thickness_m
        key = ("plate", PATCH_M, t, round_nu(struct.poisson_ratio), plate.stiffness_ratio)
        ref = self._plates.get(key)
        if ref is None:  # closed form, ~1 MB, a handful per build: kept
            ref = self._plates[key] = plate_model(PATCH_M, PATCH_M, t, struct.poisson_ratio,
                                                  self.s.modal.n_modes,
                                                  stiffness_ratio=plate.stiffness_ratio)
        vol = PATCH_M * PATCH_M * t
        body = SoundingBody(ref.scaled(struct.youngs_modulus_pa, struct.density_kg_m3, 1.0),
                            plate.loss_factor, finish.contact_modulus_pa, finish.poisson_ratio,
                            struct.density_kg_m3 * vol, math.inf)
        return _Body(body, vol, np.asarray(pos, float), np.asarray(rot, float), finish,
                     patch=True, free=False, mass_per_area=plate.mass_per_area,
                     coincidence_hz=plate.coincidence_hz, stiffness_ratio=plate.stiffness_ratio,
                     point_impedance_n_s_m=plate.point_impedance_n_s_m)

    def energy_lost_j(self, event: FallEvent) -> float:
        """The mechanical energy the fall loses, all of it in its contacts: the drop of the
        target's centre of mass times m g, plus its kinetic energy at the start (translation
        and rotation; it comes to rest)."""
        from fallgen.physics.drop import instance_of

        inst = instance_of(self.world, event.target)
        com0 = np.asarray(event.start_pos, float) + _quat_mat(event.start_quat) @ inst.com
        v, w = np.asarray(event.start_linvel, float), np.asarray(event.start_angvel, float)
        return float(inst.mass_kg * GRAVITY * (com0[2] - event.settle_com[2])
                     + 0.5 * inst.mass_kg * v @ v + 0.5 * w @ inst.inertia @ w)

    # -- the fall ---------------------------------------------------------------------------
    def render(self, event: FallEvent, rng: np.random.Generator,
               scene: Scene | None = None) -> np.ndarray:
        """Dry pressure at 1 m (Pa) of the fall, ``settings.length_s`` long from the drop."""
        parts = self.render_bodies(event, rng, scene)
        return np.sum(list(parts.values()), axis=0)

    def render_bodies(self, event: FallEvent, rng: np.random.Generator,
                      scene: Scene | None = None) -> dict[str, np.ndarray]:
        """Each sounding body's share of the fall: ``"target"`` and one entry per other body
        hit (``"floor"``, ``"<furniture id>#<geom>"``, ``"obj:d0"``...).

        ``scene``: the compiled scene whose geom ids the event's contacts name (a replay's,
        where the agent stands in the room); by default the rehearsal's (the room's geoms, of
        a model compiled once per variant, and the objects' placed poses)."""
        target, others, _ = self._bodies(event, rng, scene)
        out = {"target": target.render(self.s)}
        for name, b in others:
            p = b.render(self.s)
            out[name] = out[name] + p if name in out else p
        return out

    def render_sources(self, event: FallEvent, rng: np.random.Generator,
                       scene: Scene | None = None, cluster_m: float = 0.25
                       ) -> list[DrySource]:
        """The fall as sound sources in the room: contacts within ``cluster_m`` of a group's
        first contact point form one source there (both bodies' sound of those contacts, their
        ringing included). Their signals sum to :meth:`render` (up to the inaudible pruning of
        decayed modes). Same generator use as :meth:`render`."""
        target, others, centres = self._bodies(event, rng, scene, cluster_m)
        bodies = [target] + [b for _, b in others]
        return [DrySource(np.asarray(c), np.sum([b.render(self.s, g) for b in bodies
                                                  if g in b.group], axis=0))
                for g, c in enumerate(centres)]

    def _bodies(self, event: FallEvent, rng: np.random.Generator, scene: Scene | None,
                cluster_m: float = 0.0) -> tuple[_Body, list[tuple[str, _Body]], list]:
        """The target and every other body hit, with their hits (and each hit's source group:
        contacts within ``cluster_m`` of a group's first point)."""
        from fallgen.physics.drop import instance_of, scene_objects

        world = self.world
        objs = scene_objects(world, instance_of(world, event.target), event.start_pos,
                              event.start_quat, event.distractors, event.occluders)
        placed = {o.name: o for o in objs}  # "target", "d0".., "o0"..
        if scene is None:
            # the rehearsal's scene: the room's geoms come first, so their ids are the room
            # model's; the other objects stand where they were placed
            m, d = self._room(event.room_variant)
        else:
            m, d = scene.model, scene.data()
            mujoco.mj_forward(m, d)
        target = self._object_body(placed["target"].instance, (0, 0, 0), np.eye(3))
        others: dict[int, _Body] = {}
        names: dict[int, str] = {}
        centres: list[np.ndarray] = []
        coverings = self._floor_coverings(event.room_variant)
        for c in event.contacts:
            other = others.get(c.geom_other)
            if other is None:
                if c.other.startswith("obj:"):
                    o = placed[c.other[4:]]
                    if scene is None:
                        pos, rot = np.asarray(o.pos, float), _quat_mat(o.quat)
                    else:
                        b = scene.object_body[o.name]
                        pos, rot = d.xpos[b], d.xmat[b].reshape(3, 3)
                    other = self._object_body(o.instance, pos, rot)
                else:
                    if c.geom_other >= m.ngeom:
                        raise ValueError(f"event {event.event_id}: contact with geom "
                                         f"{c.geom_other} ({c.other}) outside the room's "
                                         f"{m.ngeom} geoms: pass the scene that recorded it")
                    surface = None
                    if is_panel(c.other):
                        face = c.other if c.other in ("floor", "ceiling") else \
                            c.other.split("_", 1)[1]
                        surface = world.variant(event.room_variant).surfaces[face]
                    elif c.other in coverings:
                        # a rug: the floor under it rings, struck through the rug (its
                        # finish: a soft contact, a long and gentle force)
                        surface = world.variant(event.room_variant).surfaces["floor"]
                    other = self._static_body(m, d, c.geom_other, c.material_other, c.other,
                                              surface)
                others[c.geom_other] = other
                names[c.geom_other] = c.other if is_panel(c.other) or \
                    c.other.startswith("obj:") else f"{c.other}#{c.geom_other}"
            p = np.asarray(c.point_world, float)
            dist = [float(np.linalg.norm(p - q)) for q in centres]
            if dist and min(dist) <= cluster_m:
                g = int(np.argmin(dist))
            else:
                g = len(centres)
                centres.append(p)
            n0, n1 = len(target.hits), len(other.hits)
            self._add_hits(c, target, other, rng)
            target.group += [g] * (len(target.hits) - n0)
            other.group += [g] * (len(other.hits) - n1)
        return target, [(names[g], b) for g, b in others.items()], centres

    def _add_hits(self, c: ContactEvent, target: _Body, other: _Body,
                  rng: np.random.Generator) -> None:
        a, b = target.sounding, other.sounding
        p_other = other.local(c.point_world)
        if other.patch:
            p_other = np.array([PATCH_HIT[0] * PATCH_M, PATCH_HIT[1] * PATCH_M,
                                float(other.sounding.modes.points[0, 2])])  # its face
        n_other = other.frame_mat.T @ np.asarray(c.normal, float)  # force on the other: -n
        if c.kind == "impact":
            e = min(target.material.restitution, other.material.restitution)
            v = max(c.normal_speed_mps, 1e-3)
            # the mass the contact meets is the effective mass the recorded impulse implies
            # (a body struck off its centre of mass, a lever, pushes back with less than its
            # whole mass): the contact spring is its Hertz contact with the other surface
            # (Johnson 11.4: t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5)); the whole mass's Hertz
            # time, longer, made a spring softer by (m* / m)^(4/5)
            m_eff = float(np.clip(c.impulse_ns / v, 1e-6, a.mass_kg))
            h = hertz_impact(a.contact_modulus_pa, a.poisson_ratio, b.contact_modulus_pa,
                             b.poisson_ratio, a.contact_radius_m, b.contact_radius_m,
                             m_eff, math.inf, v)
            # a room surface is a large plate: where it is struck it yields as a dashpot, its
            # point impedance Z = 8 sqrt(B m'') (Cremer, Heckl & Petersson ch. 5), in series
            # with the contact (hertz.plate_contact, Zener's model): a light pane or board
            # takes much of the impact, the force lasts longer and never exceeds Z v (the
            # patch's few modes alone leave it rigid far above its highest: a jug thrown
            # against a 4 mm pane pushed it with 11 kN, Z v ~1.1 kN); a slab is rigid
            plate = plate_contact(m_eff, h.duration_s, other.point_impedance_n_s_m)
            e *= plate.restitution
            # A free body hitting a surface at v takes at most (1 + e) m v; a wedged or
            # pinched contact's recorded impulse can be many times that (resting forces
            # squeezing it), which is no impact: no sound is made of the excess.
            j = min(c.impulse_ns, a.mass_kg * v) * (1.0 + e)
            p_target = np.asarray(c.point_object, float)
            # the modes take what the contact gives them (coupling.py), at most what the
            # impact loses: (1 - e^2) of the effective mass's kinetic energy
            bt, bo = _contact_modes(a, p_target, None), _contact_modes(b, p_other, -n_other)
            imp = coupled_impact(m_eff, v, h.duration_s, [bt, bo])
            cap = (1.0 - e * e) * imp.incoming_j
            if imp.vibration_j > cap:
                imp = imp.scaled(math.sqrt(cap / imp.vibration_j))
            # the force is what the contacts are: one half-sine pulse per contact interval
            # (a body that chatters touches for short intervals between flights: one pulse
            # over the time to the last parting spread a slender body's click and the floor's
            # sound over milliseconds), each interval's share of the impulse
            pulses = contact_pulses(imp.contacts, j, plate.duration_s)
            touch = float(sum(d for _, _, d in pulses))
            state = imp.parting_s  # the modes ring from the last parting
            target.hits.append(ModalHit(c.time_s, p_target, j, touch, None,
                                        (imp.displacement[0], imp.velocity[0], state),
                                        pulses))
            other.hits.append(ModalHit(c.time_s, p_other, j, touch, -n_other,
                                       (imp.displacement[1], imp.velocity[1], state), pulses))
            return
        # scrape / roll: texture bumps along the sample
        # a scrape's texture passes at the slip speed, a roll's at the contact point's travel
        speed = c.tangential_speed_mps if c.kind == "scrape" else c.travel_speed_mps
        ratio = self.s.roughness_force_ratio * (1.0 if c.kind == "scrape" else 1 / 3)
        k = max(1, int(round(speed * c.duration_s / self.s.roughness_m)))
        tb = self.s.roughness_m / max(speed, 1e-3)
        amp = ratio * c.mean_force_n * c.duration_s / math.sqrt(k)
        times = c.time_s + np.sort(rng.uniform(0, c.duration_s, k))
        mags = np.abs(rng.normal(0.0, amp, k))
        target.hits.append(HitTrain(times, np.asarray(c.point_object, float), mags, tb))
        other.hits.append(HitTrain(times, p_other, mags, tb, -n_other))
