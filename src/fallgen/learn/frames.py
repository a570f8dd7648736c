"""Frames for the visual perception module: what the agent sees in a build's episodes, with the
truth of each pixel.

Each chosen episode gives its step-0 view (the dataset's own rgb, depth and category
segmentation, read from its HDF5 media) and views drawn the way the environment draws them
(:class:`ViewRenderer`: the episode's settled room, its look, the agent's camera):

- ``path`` views along its expert's path (the row's ``expert_poses``): always the path's last
  pose (the first from which the object shows, within 2 m: often only a few of its pixels),
  the others drawn from the rest of the path; each turned by one or two headings with
  probability 1/3 (the object at the edge of the view, or out of it);
- ``look`` views from near: a place where the robot fits 0.5-2 m from the object, facing it
  and tilted toward it (as the modular agent looks at what it goes to claim), one heading off
  with probability 1/4; behind furniture it may not show at all.

Near and far, on rugs and carpets, on shelves and in baskets: wherever the build's falls
ended.

Labels: class 0 is everything but a target category (``other``: furniture, floor, walls,
occluders); classes 1..31 the target categories in sorted order (:func:`class_table`). The
label's bit 7 (:data:`TARGET_BIT`) marks the fallen object's own pixels (its instance: a
distractor may share its category); ``label & CLASS_MASK`` is the class.

Frames are written into a directory (:class:`FrameStore`): ``rgb.npy`` (N, 300, 300, 3)
uint8, ``depth.npy`` (N, 300, 300) float16 metres, ``label.npy`` (N, 300, 300) uint8,
``meta.npz`` (per frame: episode id, path step (0: the step-0 view), the fallen object's own
pixels, its horizontal distance (m) from the camera, its class) and ``frames.json`` (what was
asked for, written last: a store without it, or made for other settings, is made again).
The choice of poses is seeded per episode (``SeedSequence(seed, spawn_key=(episode_id,))``),
so a store is the same whatever the worker count.
"""

from __future__ import annotations

import json
import math
import shutil
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

OTHER = "other"
#: a label's bit for the fallen object's own pixels, and the mask of its class
TARGET_BIT, CLASS_MASK = 128, 127
#: the store's arrays: name -> (dtype, shape after N and the view's rows and columns); the
#: camera (and with it the renderer) is imported only where frames are drawn, so a store can
#: be trained on where nothing renders
ARRAYS = {"rgb": (np.uint8, (3,)), "depth": (np.float16, ()), "label": (np.uint8, ())}
META = ("episode_id", "step", "object_pixels", "distance_m", "object_class")
STORE_FORMAT = "fallgen-frames/1"
#: episodes per unit of work handed to a worker
CHUNK = 8
#: how far (m, horizontally) from the object's centre the look views are taken
LOOK_M = (0.5, 2.0)


def class_table(category_labels: Sequence[str], targets: Sequence[str]
                ) -> tuple[tuple[str, ...], np.ndarray]:
    """(class names: ``other`` then the sorted targets; a lookup table: category segmentation
    value + 1 -> class, so that -1 (nothing) maps to ``other``)."""
    names = (OTHER,) + tuple(sorted(set(targets)))
    lut = np.zeros(len(category_labels) + 1, np.uint8)
    for k, name in enumerate(category_labels):
        if name in names[1:]:
            lut[k + 1] = names.index(name)
    return names, lut


@dataclass(frozen=True)
class FrameSpec:
    """Which frames an episode gives besides its step-0 view: ``path`` views along its
    expert's path and ``look`` views of the object from near; ``seed`` for their poses."""

    path: int = 2
    look: int = 3
    seed: int = 0

    @property
    def per_episode(self) -> int:
        """Frames an episode gives at most (step 0 included)."""
        return 1 + self.path + self.look

    def to_dict(self) -> dict:
        return asdict(self)


def _rng(spec: FrameSpec, episode_id: int, stream: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=(
        int(episode_id), stream)))


def path_poses(row: dict, spec: FrameSpec) -> list[tuple[int, tuple]]:
    """(step along the path, pose ``(x, y, heading, tilt_deg)``) of the ``path`` views: the
    path's last pose first, the others drawn from the rest of it; each turned by one or two
    headings with probability 1/3."""
    from fallgen.nav.agent import HEADINGS

    poses = [tuple(p) for p in row["expert_poses"]]
    if spec.path <= 0 or len(poses) < 2:
        return []
    rng = _rng(spec, row["episode_id"], 0)
    last = len(poses) - 1
    rest = list(range(1, last))
    k = min(spec.path - 1, len(rest))
    steps = [last] + (sorted(int(s) for s in rng.choice(rest, k, replace=False)) if k else [])
    out = []
    for s in steps:
        x, y, h, t = poses[s]
        if rng.random() < 1 / 3:
            h = (int(h) + int(rng.choice([-2, -1, 1, 2]))) % HEADINGS
        out.append((int(s), (float(x), float(y), int(h), int(round(t)))))
    return out


def look_poses(row: dict, grid, centre: np.ndarray, spec: FrameSpec,
               near_m: tuple[float, float] = LOOK_M, tries: int = 40) -> list[tuple]:
    """Poses ``(x, y, heading, tilt_deg)`` of the ``look`` views: places where the robot fits
    (``grid``: the room's occupancy) ``near_m`` from the object's centre (horizontally),
    facing it to the nearest heading (one off with probability 1/4) and tilted toward it to
    the nearest tilt step; where ``tries`` draws find no such place, the expert path's last
    place (always ``spec.look`` poses)."""
    from fallgen.nav.agent import HEADINGS, TURN_DEG, AgentSpec

    a = AgentSpec()
    rng = _rng(spec, row["episode_id"], 1)
    out: list[tuple] = []
    for _ in range(spec.look):
        for _ in range(tries):
            d = float(rng.uniform(*near_m))
            ang = float(rng.uniform(0.0, 2 * math.pi))
            p = centre[:2] + d * np.array([math.cos(ang), math.sin(ang)])
            if grid.free_for(p[None, :], a.radius_m)[0]:
                break
        else:
            p = np.asarray(row["expert_poses"][-1][:2], float)
        v = centre[:2] - p
        d = max(float(np.linalg.norm(v)), 1e-6)
        h = int(round(math.degrees(math.atan2(v[1], v[0])) / TURN_DEG)) % HEADINGS
        if rng.random() < 0.25:
            h = (h + int(rng.choice([-1, 1]))) % HEADINGS
        elev = math.degrees(math.atan2(centre[2] - a.camera_height_m, d))
        t = int(np.clip(round(elev / a.tilt_step_deg) * a.tilt_step_deg, a.tilt_min_deg,
                        a.tilt_max_deg))
        out.append((float(p[0]), float(p[1]), h, t))
    return out


class ViewRenderer:
    """Views of a dataset's episodes from any pose, drawn as :class:`fallgen.env.
    FallenObjectsEnv` draws them (the episode's settled room in the build's look, the agent's
    camera). ``load(episode_id)`` then ``render(x, y, heading, tilt_deg)``; close it after."""

    def __init__(self, ds, world) -> None:
        from fallgen.env.source import EpisodeSource
        from fallgen.vision.camera import WIDTH, world_category_labels

        self.ds, self.world, self.side = ds, world, WIDTH
        self.labels = tuple(world_category_labels(world))
        self.source = EpisodeSource(ds)
        built = ds.generate_settings()
        self.appearance = bool(built.get("appearance", False))
        self.look_root = ds.root_seed if built.get("appearance_randomization", False) else None
        self._gl = None
        self._room = None
        self._static: dict[str, np.ndarray] = {}

    def load(self, episode_id: int) -> dict:
        """Make the episode's room; its row."""
        from fallgen.nav.agent import AgentSpec
        from fallgen.pipeline.episode import appearance_seed
        from fallgen.pipeline.settled import SettledRoom
        from fallgen.vision.gl import GLContext

        if self._room is not None:
            self._room.close()
            self._room = None
        ep = self.source.load(int(episode_id))
        if self._gl is None:
            self._gl = GLContext(self.side)
        variant = ep.row["room_variant"]
        look = None if self.look_root is None else appearance_seed(self.look_root,
                                                                   int(episode_id))
        self._room = SettledRoom(self.world, ep.event, self._gl, self.labels, AgentSpec(),
                                 self._static.get(variant), appearance=self.appearance,
                                 look_seed=look)
        if len(self._static) > 8:
            self._static.clear()
        self._static[variant] = self._room.static
        return ep.row

    @property
    def room(self):
        """The loaded episode's :class:`fallgen.pipeline.settled.SettledRoom`."""
        return self._room

    def render(self, x: float, y: float, heading: int, tilt_deg: int):
        """The :class:`fallgen.vision.camera.View` (rgb, depth, instance and category
        segmentation) from a pose of the loaded episode's room."""
        from fallgen.nav.agent import Pose

        room = self._room
        return room.camera.render(room.data, Pose(x, y, int(heading), int(tilt_deg)), "all")

    def close(self) -> None:
        if self._room is not None:
            self._room.close()
            self._room = None
        if self._gl is not None:
            self._gl.close()
            self._gl = None


def _distance(row: dict, x: float, y: float) -> float:
    """Horizontal distance (m) from a camera at (x, y) to where the object came to rest."""
    sx, sy = row["settle_pos"][0], row["settle_pos"][1]
    return float(math.hypot(sx - x, sy - y))


def _label(lut: np.ndarray, category: np.ndarray, target: np.ndarray) -> np.ndarray:
    out = lut[category.astype(np.int64) + 1]
    out[target] |= TARGET_BIT
    return out


def episode_frames(renderer: ViewRenderer, row: dict, spec: FrameSpec, lut: np.ndarray,
                   classes: Sequence[str]) -> list[dict]:
    """The frames of one episode (dicts of the store's arrays and meta fields)."""
    cls = classes.index(row["category"]) if row["category"] in classes else 0
    a = renderer.ds.arrays(row, ("rgb", "depth", "category", "instance"))
    inst = json.loads(row["instance_labels"])
    target = inst.index("obj:target") if "obj:target" in inst else -2
    mine = a["instance"] == target
    out = [{"rgb": a["rgb"], "depth": a["depth"],
            "label": _label(lut, a["category"], mine), "episode_id": row["episode_id"],
            "step": 0,
            "object_pixels": int(mine.sum()),
            "distance_m": _distance(row, row["spawn_x"], row["spawn_y"]), "object_class": cls}]
    if spec.path <= 0 and spec.look <= 0:
        return out
    renderer.load(row["episode_id"])
    room = renderer.room
    views = [(step, pose) for step, pose in path_poses(row, spec)]
    views += [(-1, pose) for pose in look_poses(row, room.grid, room.centre, spec)]
    for step, (x, y, h, t) in views:
        v = renderer.render(x, y, h, t)
        mine = v.instance == v.instances.index("obj:target") if "obj:target" in v.instances \
            else np.zeros(v.instance.shape, bool)
        out.append({"rgb": v.rgb, "depth": v.depth, "label": _label(lut, v.category, mine),
                    "episode_id": row["episode_id"], "step": step,
                    "object_pixels": v.pixels_of("obj:target"),
                    "distance_m": _distance(row, x, y), "object_class": cls})
    return out


# --- workers ------------------------------------------------------------------------------------

_STATE: dict = {}


def _init(root: str, data_dir: str | None, spec: FrameSpec, targets: tuple[str, ...]) -> None:
    from fallgen.dataset.reader import Dataset
    from fallgen.world.library import load_world

    ds = Dataset(root)
    renderer = ViewRenderer(ds, load_world(data_dir))
    classes, lut = class_table(renderer.labels, targets)
    _STATE.update(ds=ds, renderer=renderer, spec=spec, classes=classes, lut=lut)


def _work(ids: Sequence[int]) -> list[dict]:
    s = _STATE
    return [f for i in ids for f in episode_frames(s["renderer"], s["ds"].row(i), s["spec"],
                                                   s["lut"], s["classes"])]


def frames_count(rows: Sequence[dict], spec: FrameSpec) -> int:
    """How many frames ``rows`` give."""
    return sum(1 + len(path_poses(r, spec)) + spec.look for r in rows)


@dataclass
class FrameStore:
    """Frames on disk (see the module's doc), opened read-only (memory-mapped)."""

    root: Path
    rgb: np.ndarray
    depth: np.ndarray
    label: np.ndarray
    meta: dict[str, np.ndarray]
    info: dict

    def __len__(self) -> int:
        return len(self.label)

    @staticmethod
    def open(root: str | Path) -> FrameStore:
        root = Path(root)
        info = json.loads((root / "frames.json").read_text())
        arrays = {k: np.load(root / f"{k}.npy", mmap_mode="r") for k in ARRAYS}
        with np.load(root / "meta.npz") as z:
            meta = {k: z[k] for k in META}
        return FrameStore(root, arrays["rgb"], arrays["depth"], arrays["label"], meta, info)

    @staticmethod
    def matches(root: str | Path, info: dict) -> bool:
        """Whether ``root`` holds a finished store made for ``info``."""
        try:
            have = json.loads((Path(root) / "frames.json").read_text())
        except (OSError, json.JSONDecodeError):
            return False
        return have == info and all((Path(root) / f"{k}.npy").is_file() for k in ARRAYS)


def collect(ds, rows: Sequence[dict], out: str | Path, spec: FrameSpec,
            targets: Sequence[str], workers: int = 1, data_dir: str | Path | None = None,
            progress: Callable[[int], None] | None = None, reuse: bool = True) -> FrameStore:
    """Write the frames of ``rows`` (episodes of ``ds``) into the directory ``out`` and open
    it; a store already there for the same dataset, episodes and settings is reused."""
    from fallgen.dataset.manifest import manifest_sha256
    from fallgen.pipeline.executor import parallel_map
    from fallgen.vision.camera import HEIGHT, WIDTH

    out = Path(out)
    ids = [int(r["episode_id"]) for r in rows]
    info = {"format": STORE_FORMAT, "dataset": str(Path(ds.root).resolve()),
            "manifest_sha256": manifest_sha256(ds.root) or "", "spec": spec.to_dict(),
            "targets": sorted(targets), "episodes": ids}
    if reuse and FrameStore.matches(out, info):
        if progress:
            progress(len(ids))
        return FrameStore.open(out)
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    n = frames_count(rows, spec)
    arrays = {k: np.lib.format.open_memmap(out / f"{k}.npy", mode="w+", dtype=dt,
                                           shape=(n, HEIGHT, WIDTH, *tail))
              for k, (dt, tail) in ARRAYS.items()}
    meta = {k: np.zeros(n, np.float32 if k == "distance_m" else np.int64) for k in META}
    chunks = [ids[k:k + CHUNK] for k in range(0, len(ids), CHUNK)]
    args = (str(ds.root), None if data_dir is None else str(data_dir), spec, tuple(targets))
    i = 0

    def take(frames: list[dict], count: int) -> None:
        nonlocal i
        for f in frames:
            for k in ARRAYS:
                arrays[k][i] = f[k]
            for k in META:
                meta[k][i] = f[k]
            i += 1
        if progress:
            progress(count)

    if workers <= 1 or len(chunks) <= 1:
        _init(*args)
        try:
            for c in chunks:
                take(_work(c), len(c))
        finally:
            _STATE.pop("renderer").close()
            _STATE.clear()
    else:
        for c, frames in zip(chunks, parallel_map(_work, chunks, _init, args,
                                                  min(workers, len(chunks)))):
            take(frames, len(c))
    if i != n:
        raise RuntimeError(f"{out}: {i} frames made, {n} expected")
    for a in arrays.values():
        a.flush()
    arrays.clear()  # the memory maps closed before the store is read back
    np.savez(out / "meta.npz", **meta)
    from fallgen.atomic import write_text

    write_text(out / "frames.json", json.dumps(info, sort_keys=True))
    return FrameStore.open(out)


__all__ = ["OTHER", "TARGET_BIT", "CLASS_MASK", "FrameSpec", "FrameStore", "ViewRenderer",
           "class_table", "collect", "episode_frames", "frames_count", "path_poses",
           "look_poses"]
