"""One rehearsal trial: drop an object into a fall zone and keep it if it settles inside.

A trial depends only on its seed, ``SeedSequence(root_seed, spawn_key=(room_key, zone, trial))``
with ``room_key`` a stable hash of the variant id, so results do not depend on which rooms run,
in which order, or on how many workers. Distractors are dropped first (all together) and frozen
where they settle; occluders are placed at rest on the zone's support; then the target falls
with the others static, which keeps :func:`replay` bit-identical (a moving body elsewhere would
perturb the target's trajectory at the 1e-9 level).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import mujoco
import numpy as np

from fallgen.config import RehearseConfig
from fallgen.physics.contacts import ContactEvent, ContactRecorder
from fallgen.physics.events import GRAVITY, FallEvent, ObjectSpec, Placement, fall_height_m
from fallgen.physics.mjraw import timers_off
from fallgen.physics.settle import (EnergyFloor, SettleCriteria, SettleResult,
                                   mujoco_warnings, simulate_until_settled)
from fallgen.world.geometry import BoxSet
from fallgen.world.library import World
from fallgen.world.objects import ObjectInstance
from fallgen.world.rooms import RoomVariant, Zone
from fallgen.world.scene import AgentBody, PhysicsSettings, PlacedObject, Scene, build_scene

#: Physics-only scenes: no render meshes (they do not collide; compiling them is wasted time).
PHYSICS = PhysicsSettings(visual_meshes=False)

#: Why a trial was not kept; every trial ends with exactly one of these (or "kept").
REASONS = ("kept", "does_not_fit", "start_overlap", "unstable", "not_settled", "left_room",
           "tunnelled", "outside_zone", "short_fall")


def room_key(variant_id: str) -> int:
    """A stable integer for a room variant's id (CRC-32), used in seed spawn keys."""
    return zlib.crc32(variant_id.encode("utf-8"))


def trial_rng(root_seed: int, variant_id: str, zone_index: int, trial: int) -> np.random.Generator:
    ss = np.random.SeedSequence(root_seed, spawn_key=(room_key(variant_id), zone_index, trial))
    return np.random.default_rng(ss)


@dataclass(frozen=True)
class TrialOutcome:
    reason: str  # one of REASONS
    event: FallEvent | None
    category: str


def _radius(inst: ObjectInstance) -> float:
    """Radius of a sphere around the body origin that holds the object."""
    v = inst.geometry.vertices * inst.scale
    return float(np.linalg.norm(v, axis=1).max())


def _uniform_quat(rng: np.random.Generator) -> tuple[float, float, float, float]:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return tuple(float(x) for x in q)


def _spec(inst: ObjectInstance) -> ObjectSpec:
    return ObjectSpec(inst.category, inst.variant, inst.material.name, inst.scale)


def instance_of(world: World, s: ObjectSpec) -> ObjectInstance:
    """The object instance an event's :class:`ObjectSpec` names."""
    return world.categories.instance(s.category, s.variant, s.material, s.scale)



def _fits(world: World, zone: Zone, cid: str) -> bool:
    lib = world.categories
    cat = lib[cid]
    size = lib.nominal_size_m(cid) * cat.scale[1]
    foot = 2 * min(zone.volume.half[0], zone.volume.half[1])
    if size > 1.5 * foot:
        return False
    if not zone.open_above:
        thick = min(float(np.sort(lib.geometry(cid, v.name).extents)[0]) for v in cat.variants)
        return thick * cat.scale[1] < (zone.drop.zmax - zone.drop.zmin) * 0.8
    return True


@dataclass(frozen=True)
class ZoneFits:
    """The categories that fit a zone (:func:`_fits`): the targets, in the library's order,
    and each target's distractors (the similar-sized targets that fit, or the target itself).
    The same for every trial of the zone: :func:`zone_fits` once, then :func:`run_trial`."""

    targets: tuple[str, ...]
    distractors: dict[str, tuple[str, ...]]


def zone_fits(world: World, zone: Zone) -> ZoneFits:
    lib = world.categories
    targets = tuple(c for c in lib.ids("target") if _fits(world, zone, c))
    return ZoneFits(targets, {c: tuple(d for d in lib.distractors_for(c)
                                       if _fits(world, zone, d)) or (c,) for c in targets})


def _xy(rng: np.random.Generator, zone: Zone, margin: float) -> tuple[float, float]:
    hx, hy = (max(zone.drop.half[i] - margin, 0.0) for i in (0, 1))
    lx, ly = rng.uniform(-hx, hx), rng.uniform(-hy, hy)
    c, s = math.cos(zone.drop.yaw), math.sin(zone.drop.yaw)
    return zone.drop.center[0] + c * lx - s * ly, zone.drop.center[1] + s * lx + c * ly


def _occluders(world: World, zone: Zone, rng: np.random.Generator) -> list[Placement]:
    out = []
    for name in zone.occluders:
        inst = world.categories.sample(rng, name)
        lo = (inst.geometry.vertices * inst.scale).min(axis=0)
        ext = inst.extents_m
        x, y = _xy(rng, zone, 0.5 * float(max(ext[0], ext[1])))
        yaw = rng.uniform(-math.pi, math.pi)
        out.append(Placement(_spec(inst), (x, y, zone.volume.zmin - float(lo[2]) + 1e-4),
                             (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))))
    return out


def _draw_distractors(world: World, zone: Zone, cands: tuple[str, ...],
                      rng: np.random.Generator) -> list[PlacedObject]:
    """The zone's distractors, drawn from ``cands`` (objects and start poses above the zone,
    stacked)."""
    if zone.distractors == 0:
        return []
    lib = world.categories
    objs = []
    for k in range(zone.distractors):
        inst = lib.sample(rng, cands[int(rng.integers(len(cands)))])
        r = _radius(inst)
        x, y = _xy(rng, zone, r)
        z = zone.drop.zmin + r + 0.02 + 0.12 * k
        if z + r > zone.drop.zmax:
            break
        objs.append(PlacedObject(f"d{k}", inst, (x, y, z), _uniform_quat(rng)))
    return objs


def _settle_distractors(world: World, variant: RoomVariant, objs: list[PlacedObject],
                        occluders: list[Placement]) -> list[Placement]:
    """Where the drawn distractors ``objs`` come to rest among the occluders (they are
    dropped together and frozen when calm); none if the simulation fails. Draws nothing: a
    trial settles them only once it has drawn all it draws and knows it will fall."""
    if not objs:
        return []
    statics = [PlacedObject(f"o{k}", instance_of(world, p.object), p.pos, p.quat, free=False)
               for k, p in enumerate(occluders)]
    scene = build_scene(variant, world.materials, objs + statics, settings=PHYSICS)
    data = scene.data()
    mujoco.mj_forward(scene.model, data)
    _settle_all(scene.model, data, DISTRACTOR_SETTLE_S)
    if mujoco_warnings(data) or not np.isfinite(data.qpos).all():
        return []
    lx, ly, h = variant.size_m
    out = []
    for o in objs:
        b = scene.object_body[o.name]
        adr = scene.model.jnt_qposadr[scene.model.body_jntadr[b]]
        pos, quat = data.qpos[adr:adr + 3], data.qpos[adr + 3:adr + 7]
        if 0 <= pos[0] <= lx and 0 <= pos[1] <= ly and -0.01 <= pos[2] <= h:
            out.append(Placement(_spec(o.instance), tuple(map(float, pos)),
                                 tuple(map(float, quat / np.linalg.norm(quat)))))
    return out


#: Longest time given to distractors to come to rest (they are frozen where they are then).
DISTRACTOR_SETTLE_S = 2.0


def _settle_all(m: mujoco.MjModel, d: mujoco.MjData, max_s: float) -> None:
    """Step in C chunks until every free body is calm (1 cm/s, 0.1 rad/s) or ``max_s``."""
    timers_off()
    steps = int(round(max_s / m.opt.timestep))
    done = 0
    while done < steps:
        n = min(CHECK_EVERY_STEPS, steps - done)
        mujoco.mj_step(m, d, nstep=n)
        done += n
        v = d.qvel.reshape(-1, 6) if m.nv % 6 == 0 else None
        if v is not None and done >= 100 and np.all(np.abs(v[:, :3]) < 0.01) and \
                np.all(np.abs(v[:, 3:]) < 0.1):
            return


def scene_objects(world: World, target: ObjectInstance, start_pos, start_quat,
                  distractors, occluders) -> list[PlacedObject]:
    """The objects of a trial's scene: the target at its start pose (free), the distractors
    and occluders where they were placed (fixed)."""
    objs = [PlacedObject("target", target, tuple(start_pos), tuple(start_quat))]
    objs += [PlacedObject(f"d{k}", instance_of(world, p.object), p.pos, p.quat, free=False)
             for k, p in enumerate(distractors)]
    objs += [PlacedObject(f"o{k}", instance_of(world, p.object), p.pos, p.quat, free=False)
             for k, p in enumerate(occluders)]
    return objs


#: Steps run in C between settle checks (and between the distractors' calm checks).
CHECK_EVERY_STEPS = 10


def _simulate(world: World, variant: RoomVariant, objs: list[PlacedObject], linvel, angvel,
              criteria: SettleCriteria, max_steps: int | None = None,
              agent: AgentBody | None = None, floor_z: float | None = None
              ) -> tuple[SettleResult, list[ContactEvent], np.ndarray, float, bool, Scene]:
    """Simulate the target's fall, recording its contacts at every step (the recorder makes
    the steps, ``CHECK_EVERY_STEPS`` between settle checks), until it settles, times out or
    (``floor_z``) its centre of mass can no longer climb back to that height
    (:func:`_below_for_good`). ``max_steps`` (a replay): exactly that many steps. A start that
    overlaps another body is not simulated."""
    scene = build_scene(variant, world.materials, objs, agent=agent, settings=PHYSICS)
    m = scene.model
    b = scene.object_body["target"]
    vadr = m.jnt_dofadr[m.body_jntadr[b]]
    d = mujoco.MjData(m)
    d.qvel[vadr:vadr + 3] = linvel
    d.qvel[vadr + 3:vadr + 6] = angvel
    mujoco.mj_forward(m, d)
    overlap = any(
        (m.geom_bodyid[d.contact[i].geom1] == b) != (m.geom_bodyid[d.contact[i].geom2] == b)
        and d.contact[i].dist < -1e-3 for i in range(d.ncon))
    if max_steps is None and overlap:  # rejected whatever it does: not simulated
        res = simulate_until_settled(m, d, b, criteria, max_steps=0)
        return res, [], d.xipos[b].copy(), float(m.body_mass[b]), overlap, scene
    rec = ContactRecorder(m, b, scene.geom_owner, scene.geom_material)
    res = simulate_until_settled(
        m, d, b, criteria, recorder=rec, max_steps=max_steps, chunk=CHECK_EVERY_STEPS,
        give_up=None if floor_z is None else _below_for_good(m, b, floor_z))
    return res, rec.finish(), d.xipos[b].copy(), float(m.body_mass[b]), overlap, scene


def _below_for_good(m: mujoco.MjModel, body: int, floor_z: float) -> EnergyFloor:
    """``give_up(data)``: whether body ``body`` (the only moving one) can no longer bring its
    centre of mass up to ``floor_z`` (:class:`~fallgen.physics.settle.EnergyFloor`)."""
    return EnergyFloor(body, int(m.jnt_dofadr[m.body_jntadr[body]]), float(m.body_mass[body]),
                       tuple(map(float, m.body_inertia[body])),
                       float(np.linalg.norm(m.opt.gravity)), float(floor_z))


def run_trial(world: World, variant: RoomVariant, zone: Zone, trial: int,
              cfg: RehearseConfig, root_seed: int, fits: ZoneFits | None = None
              ) -> TrialOutcome:
    """Run one seeded trial; the outcome says whether it was kept, and why not. ``fits``:
    :func:`zone_fits` of ``zone``, made once for many trials (else made here)."""
    rng = trial_rng(root_seed, variant.id, zone.index, trial)
    lib = world.categories
    if fits is None:
        fits = zone_fits(world, zone)
    cands = fits.targets
    if not cands:
        return TrialOutcome("does_not_fit", None, "")
    cid = cands[int(rng.integers(len(cands)))]
    target = lib.sample(rng, cid)
    occluders = _occluders(world, zone, rng)
    drawn = _draw_distractors(world, zone, fits.distractors[cid], rng)
    r = _radius(target)
    x, y = _xy(rng, zone, r)
    # high enough to fall min_fall_m onto the zone's support
    lowest = zone.volume.zmin + cfg.min_fall_m + r
    if zone.open_above:
        lo = max(cfg.drop_height_m[0], zone.drop.zmin + r, lowest)
        hi = min(cfg.drop_height_m[1], zone.drop.zmax - r)
    else:
        lo, hi = max(zone.drop.zmin + r, lowest), zone.drop.zmax - r
    quat = _uniform_quat(rng)
    throw = (0.0, 0.0)
    under = zone.kind == "under_furniture" and not zone.open_above
    if hi < lo or under:
        # No room above the zone for such a fall (under a sofa, between shelf boards, a
        # cabinet top under the ceiling): it falls beside the zone, thrown toward it, as an
        # object knocked off something nearby, and is kept if it ends inside. Under a table
        # or a desk too, though there is room below its top: nothing falls from there; an
        # object gets under a table by falling off it (or off the counter beside it) onto the
        # floor by its edge and sliding or rolling in.
        top = variant.size_m[2] - r
        if under:
            z0 = max(lowest, zone.drop.zmax + COVER_CLEARANCE_M + r)
            start = _landing(rng, variant, zone, r, z0, min(z0 + LANDING_SPAN_M, top)) \
                if z0 <= top else None
        else:
            start = _beside(rng, variant, zone, r, lowest, min(lowest + BESIDE_SPAN_M, top)) \
                if lowest <= top else None
        if start is None:
            return TrialOutcome("does_not_fit", None, cid)
        x, y, z, throw = start
    else:
        z = float(rng.uniform(lo, hi))
    linvel = (float(rng.normal(0, cfg.push_speed_mps)) + throw[0],
              float(rng.normal(0, cfg.push_speed_mps)) + throw[1], 0.0)
    angvel = tuple(float(a) for a in rng.normal(0, cfg.spin_radps, 3))
    start = (float(x), float(y), z)
    # settled only now: a trial given up above (no start beside the zone) needs no distractors
    distractors = _settle_distractors(world, variant, drawn, occluders)
    objs = scene_objects(world, target, start, quat, distractors, occluders)
    res, contacts, com, mass, overlap, _ = _simulate(
        world, variant, objs, linvel, angvel, cfg.settle, floor_z=zone.volume.zmin)
    if overlap:
        return TrialOutcome("start_overlap", None, cid)
    reason = _judge(variant, zone, res, com)
    if reason == "kept" and fall_height_m(contacts, linvel[2]) < cfg.min_fall_m - 1e-9:
        reason = "short_fall"  # hit something (a board above, an edge) too soon
    if reason != "kept":
        return TrialOutcome(reason, None, cid)
    event = FallEvent(
        event_id=f"{variant.id}/{zone.id}/t{trial:04d}", room_variant=variant.id,
        room_kind=variant.kind, zone=zone.id, zone_kind=zone.kind, trial=trial,
        root_seed=root_seed, target=_spec(target), audio_material=target.material.audio,
        mass_kg=mass, start_pos=start, start_quat=quat, start_linvel=linvel,
        start_angvel=angvel, settle_pos=tuple(map(float, res.pos)),
        settle_quat=tuple(map(float, res.quat)), settle_com=tuple(map(float, com)),
        settle_time_s=float(res.time_s), steps=res.steps, distractors=tuple(distractors),
        occluders=tuple(occluders), contacts=tuple(contacts),
        sweep_xy=(*map(float, res.xy_min), *map(float, res.xy_max)))
    return TrialOutcome("kept", event, cid)


#: A start beside a zone is drawn this far (m) above the lowest height of a long enough fall.
BESIDE_SPAN_M = 0.5
#: Sides tried for a start beside a zone before giving up.
BESIDE_TRIES = 12
#: A fall into a zone under furniture starts at least this far (m) above the underside of
#: its cover (the top's thickness and a margin): off the table, not from beneath it.
COVER_CLEARANCE_M = 0.1


def _low_cover(zone: Zone, r: float) -> bool:
    """Whether ``zone``'s cover is lower than an object of bounding radius ``r`` (under a
    sofa): it is entered sliding, not flying."""
    return zone.drop.zmax - zone.volume.zmin < 2 * r + 0.02


def _beside(rng: np.random.Generator, variant: RoomVariant, zone: Zone, r: float,
            z_lo: float, z_hi: float
            ) -> tuple[float, float, float, tuple[float, float]] | None:
    """A start beside ``zone``'s drop region, for a zone with no room above it for a long
    enough fall: (x, y, z, the horizontal velocity of the throw). It is thrown to a point
    drawn in the region, fast enough to reach it while falling onto it, or, under a cover
    lower than the object (:func:`_low_cover`), to the floor before the opening at 0.4-1.5
    m/s, on to slide under (the zone's depth at a sliding friction of ~0.4). The side is drawn
    uniformly around the region, the start ``r`` + 5-30 cm (60 under a low cover) outside its
    footprint at a height in [``z_lo``, ``z_hi``]; a side is taken when the start and the
    first 70 % of the throw's path (a parabola down to the zone's support) clear every
    furniture part by ``r`` / 2 (a shelf's side panels, a wall cabinet: only the open side of
    a cavity will do). None when no side of ``BESIDE_TRIES`` does. (Zones under furniture:
    :func:`_landing`.)"""
    parts = BoxSet([p.box for _, p in variant.parts()])
    low = _low_cover(zone, r)
    c, s = math.cos(zone.drop.yaw), math.sin(zone.drop.yaw)
    hx, hy = zone.drop.half[0], zone.drop.half[1]
    lx_room, ly_room = variant.size_m[0], variant.size_m[1]
    for _ in range(BESIDE_TRIES):
        gx, gy = _xy(rng, zone, r)  # where it is thrown to
        a = float(rng.uniform(0, 2 * math.pi))
        off = float(rng.uniform(0.05, 0.60 if low else 0.30))
        z = float(rng.uniform(z_lo, max(z_lo, z_hi)))
        ul = (math.cos(a), math.sin(a))  # in the region's frame
        t = min(hx / max(abs(ul[0]), 1e-9), hy / max(abs(ul[1]), 1e-9)) + r + off
        lx, ly = ul[0] * t, ul[1] * t
        x = zone.drop.center[0] + c * lx - s * ly
        y = zone.drop.center[1] + s * lx + c * ly
        if not (r < x < lx_room - r and r < y < ly_room - r):
            continue
        if low:  # aim at the floor just before the opening: it lands and slides in
            e = t - r - off - 0.02
            gx = zone.drop.center[0] + c * ul[0] * e - s * ul[1] * e
            gy = zone.drop.center[1] + s * ul[0] * e + c * ul[1] * e
        # the throw's path: straight in plan, falling as t^2 to the support
        # (up to 70 % of the way: the end lies in the zone, under its cover, where a low
        # cavity -- under a sofa -- is entered sliding, not flying)
        u = np.linspace(0.0, 0.7, 10)[:, None]
        zs = z + (zone.volume.zmin + r - z) * u[:, 0] ** 2
        path = np.column_stack([x + (gx - x) * u[:, 0], y + (gy - y) * u[:, 0], zs])
        if not parts.any_contains(path, 0.5 * r):
            dx, dy = gx - x, gy - y
            if low:
                k = float(rng.uniform(0.4, 1.5)) / max(math.hypot(dx, dy), 1e-3)
            else:
                t_fall = math.sqrt(2 * max(z - zone.volume.zmin - r, 1e-3) / GRAVITY)
                k = float(rng.uniform(0.7, 1.4)) / t_fall
            return x, y, z, (dx * k, dy * k)
    return None


#: A fall under furniture starts at most this far (m) above its lowest start: knocked off the
#: table top (or the counter, the seat beside it), not thrown from high up.
LANDING_SPAN_M = 0.3
#: ... and lands on the floor this far (m) before the cover's edge (beyond its radius) ...
LANDING_BEFORE_M = (0.02, 0.30)
#: ... moving toward the opening this fast (m/s): enough to slide or roll under.
LANDING_SPEED_MPS = (1.5, 3.0)


def _landing(rng: np.random.Generator, variant: RoomVariant, zone: Zone, r: float,
             z_lo: float, z_hi: float
             ) -> tuple[float, float, float, tuple[float, float]] | None:
    """A start for a fall under furniture: (x, y, z, the horizontal velocity of the throw).
    The object is knocked off something beside the cover at a height in [``z_lo``,
    ``z_hi``] and lands on the floor ``LANDING_BEFORE_M`` (plus ``r``) before the cover's
    edge, moving toward it at ``LANDING_SPEED_MPS``, so that it slides, rolls or bounces in
    (an object falling onto the cover's top or short of the opening stays outside). The side
    is drawn uniformly around the cover's footprint; it is taken when the flight's path, from
    the start to 90 % of the way to the landing (the floor or a rug there), clears every
    furniture part by ``r`` / 2 and the start lies in the room.
    None when no side of ``BESIDE_TRIES`` does.

    Thrown instead beside the cover and aimed at its edge from above it (0.4-1.5 m/s), most
    falls came down on the cover's top or short of the opening: 2-3 % of them ended under a
    sofa (9 cm of clearance) or a coffee table, 20 % under a dining table; thrown so, 18, 23
    and 22 % (the paper-size rooms' first material set, 20-30 trials a zone)."""
    parts = BoxSet([p.box for _, p in variant.parts()])
    c, s = math.cos(zone.drop.yaw), math.sin(zone.drop.yaw)
    hx, hy = zone.drop.half[0], zone.drop.half[1]
    lx_room, ly_room = variant.size_m[0], variant.size_m[1]
    cx, cy = zone.drop.center[0], zone.drop.center[1]
    for _ in range(BESIDE_TRIES):
        a = float(rng.uniform(0, 2 * math.pi))
        z = float(rng.uniform(z_lo, max(z_lo, z_hi)))
        speed = float(rng.uniform(*LANDING_SPEED_MPS))
        ux, uy = math.cos(a), math.sin(a)  # outward, in the region's frame
        edge = min(hx / max(abs(ux), 1e-9), hy / max(abs(uy), 1e-9))
        land = edge + r + float(rng.uniform(*LANDING_BEFORE_M))  # from the centre
        t_fall = math.sqrt(2 * max(z - zone.volume.zmin - r, 1e-3) / GRAVITY)
        out = land + speed * t_fall
        wx, wy = c * ux - s * uy, s * ux + c * uy  # outward, in the room
        x, y = cx + wx * out, cy + wy * out
        if not (r < x < lx_room - r and r < y < ly_room - r):
            continue
        u = np.linspace(0.0, 0.9, 10)  # until it is about to land (on the floor, or a rug)
        path = np.column_stack([x - wx * (out - land) * u, y - wy * (out - land) * u,
                                z + (zone.volume.zmin + r - z) * u ** 2])
        if not parts.any_contains(path, 0.5 * r):
            return x, y, z, (-wx * speed, -wy * speed)
    return None


def _judge(variant: RoomVariant, zone: Zone, res: SettleResult, com: np.ndarray) -> str:
    lx, ly, h = variant.size_m
    if res.unstable or not np.isfinite(com).all():
        return "unstable"
    if not (0 <= com[0] <= lx and 0 <= com[1] <= ly and com[2] <= h):
        return "left_room"
    if com[2] < -0.01 or res.min_z_m < -0.05:
        return "tunnelled"
    if res.gave_up:
        return "outside_zone"  # fell below the zone for good
    if not res.settled:
        return "not_settled"
    if not zone.volume.contains(com[None, :])[0]:
        return "outside_zone"
    return "kept"


@dataclass(frozen=True)
class Replay:
    settle_pos: np.ndarray
    settle_quat: np.ndarray
    settle_com: np.ndarray
    contacts: tuple[ContactEvent, ...]
    settled: bool
    scene: Scene  # the replay's scene (its geom ids are those the contacts name)


def replay(world: World, event: FallEvent, criteria: SettleCriteria = SettleCriteria(),
           agent: AgentBody | None = None) -> Replay:
    """Rebuild a fall event's scene and re-simulate it from its recorded start state, for
    exactly the recorded number of steps. Bit-identical to the rehearsal under the same MuJoCo;
    with a static ``agent`` in the room the fall may change if the object meets it."""
    variant = world.variant(event.room_variant)
    target = instance_of(world, event.target)
    objs = scene_objects(world, target, event.start_pos, event.start_quat, event.distractors,
                          event.occluders)
    res, contacts, com, _, _, scene = _simulate(world, variant, objs, event.start_linvel,
                                         event.start_angvel, criteria, max_steps=event.steps,
                                         agent=agent)
    return Replay(res.pos, res.quat, com, tuple(contacts), res.settled, scene)


def record_drop(world: World, variant_id: str, zone: Zone, target: ObjectSpec, pos, quat,
                steps: int, distractors: tuple[Placement, ...] = (),
                event_id: str = "drop") -> FallEvent:
    """A fall recorded as the rehearsal records one (physics-only scene, the contact recorder)
    but placed by hand: ``target`` let go at rest at ``pos``, ``quat`` over ``zone``, with
    static ``distractors``, for exactly ``steps`` steps; no settle or zone checks. For tests
    and calibration drops."""
    v = world.variant(variant_id)
    inst = instance_of(world, target)
    pos, quat = tuple(map(float, pos)), tuple(map(float, quat))
    scene = build_scene(v, world.materials,
                        scene_objects(world, inst, pos, quat, distractors, ()),
                        settings=PHYSICS)
    m, d = scene.model, scene.data()
    mujoco.mj_forward(m, d)
    body = scene.object_body["target"]
    rec = ContactRecorder(m, body, scene.geom_owner, scene.geom_material)
    rec.step(d, steps)
    return FallEvent(
        event_id=event_id, room_variant=variant_id, room_kind=v.kind, zone=zone.id,
        zone_kind=zone.kind, trial=0, root_seed=0, target=target,
        audio_material=inst.material.audio, mass_kg=inst.mass_kg, start_pos=pos,
        start_quat=quat, start_linvel=(0.0, 0.0, 0.0), start_angvel=(0.0, 0.0, 0.0),
        settle_pos=tuple(map(float, d.qpos[:3])), settle_quat=tuple(map(float, d.qpos[3:7])),
        settle_com=tuple(map(float, d.xipos[body])), settle_time_s=steps * m.opt.timestep,
        steps=steps, distractors=tuple(distractors), occluders=(), contacts=tuple(rec.finish()))
