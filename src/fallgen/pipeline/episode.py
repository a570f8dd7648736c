"""One episode from one fall event: spawn, replay, binaural audio, first view, maps, expert.

Everything random comes from the episode's own generator,
``numpy.random.default_rng(SeedSequence(root_seed, spawn_key=(episode_id,)))``, drawn in a fixed
order (spawn, scrape texture, late reverb), so an episode depends on nothing but its id, its event
and the root seed: not on workers, sharding or resume.

- Spawn: a uniformly random free position (the robot's disk, plus ``SPAWN_CLEARANCE_M``, touches
  nothing in the room with the object settled) at least ``MIN_SPAWN_DISTANCE_M`` (2 m, as the
  original) from the object's resting place, and a random heading (one of the 12). A spawn that
  already sees the object (at least ``VISIBLE_PIXELS`` segmentation pixels at step 0) is drawn
  again, up to ``SPAWN_TRIES`` times, because the task is to find the object from its sound;
  if every try sees it the last one is kept and ``spawn_sees_object`` is set.
- Replay: the fall re-simulated with the agent standing there as a static cylinder; it must come
  to rest within 1 mm and 1 degree of the rehearsal, otherwise the episode is skipped
  (:class:`Skip`, with the reason; the caller counts them).
- Audio: the replay's contacts -> located dry sources -> binaural at the head (camera height,
  heading, tilt 0).
- Vision: RGB, depth and segmentation at step 0 (the agent's own body is not rendered).
- Maps: the occupancy grid (0.1 m, the robot's height band) with the object settled; the
  object's cell.
- Expert: :func:`fallgen.nav.expert.expert`, then checked by the action simulator with a render
  of its final view; an expert that fails raises :class:`ExpertFailure` (a bug, not data).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Collection
from dataclasses import dataclass, field

import mujoco
import numpy as np

from fallgen.audio.ambient import DEFAULT_NOISE_DB_A
from fallgen.audio.fall import FallRenderer
from fallgen.audio.impact import radiated_energy_j
from fallgen.audio.mix import Binaural, BinauralClip, Listener
from fallgen.audio.room import RirSettings, RoomAcoustics
from fallgen.nav.agent import HEADINGS, VISIBLE_PIXELS, AgentSpec, Pose, run
from fallgen.nav.expert import Expert, HiddenEverywhere, NoPath, SearchLimit
from fallgen.nav.lattice import position_table, rehash
from fallgen.nav.occupancy import OccupancyGrid
from fallgen.physics.drop import instance_of, replay
from fallgen.physics.events import FallEvent, event_variant
from fallgen.pipeline.settled import SettledRoom
from fallgen.vision.camera import WIDTH, EgoCamera, View, world_category_labels
from fallgen.vision.faces import SceneFaces
from fallgen.vision.gl import GLContext
from fallgen.world.library import World
from fallgen.world.scene import AgentBody

MIN_SPAWN_DISTANCE_M = 2.0
SPAWN_CLEARANCE_M = 0.05
SPAWN_TRIES = 20
SETTLE_TOLERANCE_M = 0.001
SETTLE_TOLERANCE_DEG = 1.0


class Skip(Exception):
    """The event cannot make this episode (replay diverged, no free spawn, no path);
    ``timings_s``: the seconds the attempt spent in each stage before it was given up (set by
    :meth:`EpisodeMaker.make`)."""

    def __init__(self, reason: str, detail: str = "") -> None:
        self.reason = reason
        self.timings_s: dict[str, float] = {}
        super().__init__(f"{reason}: {detail}" if detail else reason)


#: The stage a skip's reason is found in (its time since the stage before is charged there).
SKIP_STAGE = {"no_spawn": "spawn", "no_path": "planning", "search_limit": "planning",
              "replay_diverged": "replay", "inaudible": "audio"}


class ExpertFailure(RuntimeError):
    """The expert's own actions fail the success check: a bug."""


def episode_rng(root_seed: int, episode_id: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(root_seed, spawn_key=(episode_id,)))


def appearance_seed(root_seed: int, episode_id: int) -> int:
    """The seed of an episode's own look (:class:`fallgen.world.look.LookDraw`), when a build
    randomises appearance: a child of the episode's seed sequence, so the episode's other draws
    are the same with and without it."""
    ss = np.random.SeedSequence(root_seed, spawn_key=(episode_id, 1))
    return int(ss.generate_state(1)[0])


@dataclass(frozen=True)
class FallEnergy:
    """The fall's energy account: what its dry sound radiates (every source, J) against the
    mechanical energy the fall loses in its contacts (J)."""

    radiated_j: float
    lost_j: float

    @property
    def ratio(self) -> float:
        return self.radiated_j / self.lost_j if self.lost_j > 0 else float("inf")


@dataclass(frozen=True)
class Episode:
    episode_id: int
    event: FallEvent
    spawn: Pose
    spawn_sees_object: bool
    audio: BinauralClip
    view: View  # step 0
    grid: OccupancyGrid
    target_cell: tuple[int, int]
    expert: Expert
    expert_spl: float
    expert_sna: float
    energy: FallEnergy
    expert_poses: tuple[Pose, ...] = ()  # the spawn, then the pose after each expert action
    frames: tuple[View, ...] = ()  # the view at each of expert_poses (when asked)
    timings_s: dict[str, float] = field(default_factory=dict)
    #: the furnished room's reverberation time per octave band (125 Hz .. 8 kHz), s
    room_rt60_s: tuple[float, ...] = ()


class EpisodeMaker:
    """Makes episodes of one world (keeps the modal models and the HRTF between episodes)."""

    def __init__(self, world: World, binaural: Binaural, spec: AgentSpec = AgentSpec(),
                 rir: RirSettings = RirSettings(), noise_db_a: float = DEFAULT_NOISE_DB_A,
                 min_heard_peak_db_spl: float = 0.0, appearance: bool = False,
                 appearance_randomization: bool = False) -> None:
        self.world, self.binaural, self.spec, self.rir = world, binaural, spec, rir
        self.appearance = appearance  # views with textures and shadows (world.scene.LOOK)
        if appearance_randomization and not appearance:
            raise ValueError("appearance_randomization needs appearance")
        self.appearance_randomization = appearance_randomization  # each episode its own look
        self.min_heard_peak_db_spl = min_heard_peak_db_spl
        self.noise_db_a = noise_db_a
        self.sounds = FallRenderer(world)
        self.labels = world_category_labels(world)  # one segmentation table for a dataset
        self._room_samples: dict[str, np.ndarray] = {}  # variant -> the room's occupancy layer
        self._room_faces: dict[str, SceneFaces] = {}  # variant -> its room's drawn faces
        self._rooms: dict[str, RoomAcoustics] = {}  # variant -> its furnished acoustics
        #: event -> (digest of the cells reachable from a spawn -> the proof that no reachable
        #: pose sees the object), for the event's next attempts from the same cells (a shard
        #: tries an event given up by one episode again for the next: the proof is the
        #: costliest part of an attempt given up)
        self._hidden: dict[str, dict[bytes, str]] = {}
        self._gl: GLContext | None = None  # one GL context for every episode's camera

    def retain_rooms(self, variant_ids: Collection[str]) -> None:
        """Forget what is kept per room variant (occupancy layers, drawn faces, acoustics, the
        sound's compiled rooms, proofs for events) for every variant not in ``variant_ids``:
        a worker moving on to the other room kind's shards does not carry the first kind's
        rooms along (they are made again, the same, if it comes back)."""
        keep = set(variant_ids)
        for d in (self._room_samples, self._room_faces, self._rooms):
            for v in [v for v in d if v not in keep]:
                del d[v]
        for e in [e for e in self._hidden if event_variant(e) not in keep]:
            del self._hidden[e]
        self.sounds.retain_rooms(keep)

    @property
    def rooms_kept(self) -> frozenset[str]:
        """The room variants something is kept for."""
        return frozenset(self._room_samples) | frozenset(self._room_faces) \
            | frozenset(self._rooms) | self.sounds.rooms_kept \
            | frozenset(event_variant(e) for e in self._hidden)

    def close(self) -> None:
        if self._gl is not None:
            self._gl.close()
            self._gl = None

    def make(self, episode_id: int, event: FallEvent, root_seed: int,
             frames: str = "first", spawn: Pose | None = None) -> Episode:
        """The episode ``episode_id`` of ``event``; ``frames="trajectory"`` also renders the
        view after every expert action; ``spawn`` overrides the drawn spawn pose (the draws
        are still made, so the rest of the episode's randomness is unchanged)."""
        t: dict[str, float] = {}
        clock = time.perf_counter()

        def lap(name: str) -> None:
            nonlocal clock
            now = time.perf_counter()
            t[name] = t.get(name, 0.0) + now - clock
            clock = now

        rng = episode_rng(root_seed, episode_id)
        world, spec = self.world, self.spec
        if self._gl is None:
            self._gl = GLContext(WIDTH)
        settled = SettledRoom(world, event, self._gl, self.labels, spec,
                              self._room_samples.get(event.room_variant),
                              appearance=self.appearance,
                              look_seed=appearance_seed(root_seed, episode_id)
                              if self.appearance_randomization else None,
                              room_faces=None if self.appearance_randomization
                              else self._room_faces.get(event.room_variant))
        self._room_samples[event.room_variant] = settled.static
        variant, target = settled.variant, instance_of(world, event.target)
        data, camera, grid = settled.data, settled.camera, settled.grid
        centre = settled.centre
        try:
            lap("maps")
            drawn, sees = self._spawn(rng, grid, centre, camera, data)
            if spawn is None:
                spawn = drawn
            else:
                sees = camera.shows(data, spawn, VISIBLE_PIXELS)
            lap("spawn")
            # The expert comes first: an event that no reachable pose sees (no_path), or whose
            # optimum the search cannot prove within its limits (search_limit), is skipped
            # before its replay, sound and first view are made (the planner draws nothing from
            # rng, so the episode is the same in either order). Both searches of the expert
            # and the simulator's check ask about the same poses: the room renders each once
            # (the scene is static).
            proofs = self._hidden.get(event.event_id)
            # the spawn's cells digested only for an event proven hidden, or once it is
            cells = settled.reachable_key(spawn) if proofs else None
            proven = proofs.get(cells) if proofs else None
            if proven is not None:
                raise Skip("no_path", proven)
            try:
                ex = settled.expert(spawn)
            except SearchLimit as e:  # not proven either way within the search's limits
                raise Skip("search_limit", str(e)) from None
            except HiddenEverywhere as e:
                if not proofs:
                    cells = settled.reachable_key(spawn)
                if cells is not None:
                    self._hidden.setdefault(event.event_id, {})[cells] = str(e)
                raise Skip("no_path", str(e)) from None
            except NoPath as e:
                raise Skip("no_path", str(e)) from None
            lap("planning")
            out = run(spawn, ex.plan.actions, grid, centre, settled.visible, spec)
            if not out.success:
                raise ExpertFailure(f"episode {episode_id}: expert fails ({out})")
            lap("planning")
            if clear_of_fall(event, target, spawn, spec):
                replayed, sound_scene = event, None  # the agent cannot touch the fall
            else:
                rep = replay(world, event, agent=AgentBody(spawn.x, spawn.y, spawn.yaw_rad,
                                                           spec.radius_m, spec.height_m))
                moved = float(np.linalg.norm(np.subtract(rep.settle_pos, event.settle_pos)))
                turned = quat_angle_deg(rep.settle_quat, event.settle_quat)
                if moved > SETTLE_TOLERANCE_M or turned > SETTLE_TOLERANCE_DEG:
                    raise Skip("replay_diverged", f"{moved * 1e3:.1f} mm, {turned:.1f} deg")
                replayed, sound_scene = _with_contacts(event, rep.contacts), rep.scene
            lap("replay")
            sources = self.sounds.render_sources(replayed, rng, sound_scene)
            energy = FallEnergy(sum(radiated_energy_j(src.signal, self.sounds.s.sample_rate)
                                    for src in sources), self.sounds.energy_lost_j(replayed))
            room = self._rooms.get(variant.id)
            if room is None:
                room = self._rooms[variant.id] = RoomAcoustics.furnished(variant, world.materials)
            head = Listener(np.array([spawn.x, spawn.y, spec.camera_height_m]), spawn.yaw_rad)
            clip = self.binaural.mix(room, sources, head, rng, self.rir, self.noise_db_a)
            lap("audio")
            heard = (clip.fall_levels or clip.levels_db_spl())[0]
            if heard < self.min_heard_peak_db_spl:  # a fall the agent cannot hear is no task
                raise Skip("inaudible", f"{heard:.1f} dB SPL peak at the agent")
            view = camera.render(data, spawn)
            lap("render")

            shots: tuple[View, ...] = ()
            if frames == "trajectory":
                shots = tuple(camera.render(data, p) for p in out.poses)
            lap("render")
        except Skip as s:
            lap(SKIP_STAGE.get(s.reason, "other"))
            s.timings_s = dict(t)
            raise
        finally:
            if settled.room_faces is not None and not self.appearance_randomization:
                self._room_faces[event.room_variant] = settled.room_faces
            settled.close()
        return Episode(episode_id, event, spawn, sees, clip, view, grid, grid.cell(centre), ex,
                       out.spl(ex.shortest_m), out.sna(ex.fewest_actions), energy, out.poses,
                       shots, t, tuple(float(x) for x in room.rt60()))

    def compile_ahead(self, event: FallEvent, root_seed: int) -> None:
        """Run once every compiled (Numba) function that making an episode can reach, on
        ``event``: its episode 0 (made and dropped), the fall's replay, and the expert's proof
        that no reachable pose sees the object, from the free cell nearest to it (the proof
        runs only in attempts that are given up). A process that compiles them keeps ~250 MB
        more (LLVM's) than one that loads them from the compiled-code cache
        (:mod:`fallgen.jitcache`): a build calls this in a process of its own before its
        workers start (:func:`fallgen.pipeline.generate.compile_ahead`)."""
        try:
            self.make(0, event, root_seed)
        except Skip:
            pass
        replay(self.world, event)
        settled = SettledRoom(self.world, event, self._gl, self.labels, self.spec,
                              appearance=self.appearance)  # make() has made the GL context
        try:
            xy = self._free_cells(settled.grid)
            if len(xy):
                x, y = xy[int(np.argmin(np.linalg.norm(xy - settled.centre[:2], axis=1)))]
                settled.hidden_cells(Pose(float(x), float(y), 0, 0))
            m = settled.scene.model  # the convexity test of the faces of a mesh
            SceneFaces(m, settled.data, [g for g in range(m.ngeom)
                                         if int(m.geom_type[g]) == mujoco.mjtGeom.mjGEOM_MESH])
        finally:
            settled.close()
        rehash(position_table(2), 8)  # a long search's position table grown

    def _free_cells(self, grid: OccupancyGrid) -> np.ndarray:
        """(N, 2) centres of the cells where the agent's disk, plus ``SPAWN_CLEARANCE_M``,
        touches nothing anywhere within half a cell of the centre."""
        r = grid.resolution
        ii, jj = np.nonzero(grid.clearance >= self.spec.radius_m + SPAWN_CLEARANCE_M + r / 2)
        return np.column_stack([(ii + 0.5) * r, (jj + 0.5) * r])

    def _spawn(self, rng: np.random.Generator, grid: OccupancyGrid, centre: np.ndarray,
               camera: EgoCamera, data: mujoco.MjData) -> tuple[Pose, bool]:
        spec = self.spec
        r = grid.resolution
        xy = self._free_cells(grid)
        far = np.linalg.norm(xy - centre[None, :2], axis=1) >= MIN_SPAWN_DISTANCE_M
        cells = xy[far]
        if len(cells) == 0:
            raise Skip("no_spawn", "no free floor 2 m from the object")
        pose = None
        for _ in range(SPAWN_TRIES):
            c = cells[int(rng.integers(len(cells)))]
            # anywhere inside the cell (the clearance bound above allows half a cell of slack)
            p = c + rng.uniform(-r / 2, r / 2, 2)
            pose = Pose(float(p[0]), float(p[1]), int(rng.integers(HEADINGS)), 0)
            if np.linalg.norm(p - centre[:2]) >= MIN_SPAWN_DISTANCE_M and \
                    not camera.shows(data, pose, VISIBLE_PIXELS):
                return pose, False
        assert pose is not None
        return pose, True


#: Gap (m) between the agent's body and the area a fall swept below which the fall is replayed
#: with the agent standing there (beyond it, the agent's static geom can make no contact, and
#: the simulation is the rehearsal's own, step for step).
REPLAY_MARGIN_M = 0.1


def clear_of_fall(event: FallEvent, target, spawn: Pose, spec: AgentSpec) -> bool:
    """Whether the agent at ``spawn`` stands clear of everything the fall swept: the target's
    body origin's floor-plan box over every step (``event.sweep_xy``), grown by the target's
    bounding radius about its origin, at least ``REPLAY_MARGIN_M`` from the agent's disk.
    False when the event does not record its sweep (an older rehearsal): replay then."""
    if event.sweep_xy is None:
        return False
    g = target.geometry
    radius = target.scale * max(float(np.linalg.norm(v, axis=1).max())
                                for v in (g.vertices, *g.collision))
    x0, y0, x1, y1 = event.sweep_xy
    dx = max(x0 - radius - spawn.x, 0.0, spawn.x - x1 - radius)
    dy = max(y0 - radius - spawn.y, 0.0, spawn.y - y1 - radius)
    return math.hypot(dx, dy) >= spec.radius_m + REPLAY_MARGIN_M


def quat_angle_deg(a, b) -> float:
    """Angle (degrees) of the rotation between two unit quaternions (w, x, y, z)."""
    d = abs(float(np.dot(np.asarray(a, float), np.asarray(b, float))))
    return math.degrees(2 * math.acos(min(1.0, d)))


def _with_contacts(event: FallEvent, contacts) -> FallEvent:
    return dataclasses.replace(event, contacts=tuple(contacts))


__all__ = ["Episode", "EpisodeMaker", "FallEnergy", "Skip", "ExpertFailure", "episode_rng",
           "MIN_SPAWN_DISTANCE_M"]
