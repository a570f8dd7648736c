"""Writing episodes: one Parquet file of rows and one HDF5 file of arrays per shard.

``DATASET/data/{split}-{i:05d}-of-{n:05d}.parquet``: one row per episode (ids, split, room, zone,
object, poses, spawn, expert actions and path, metrics, the seed, where its arrays are).
``DATASET/media/{split}-{i:05d}-of-{n:05d}.h5``: one episode per chunk, gzip-compressed except
the audio (see ``UNCOMPRESSED``): ``audio`` (N, 2, T) float32 (ear pressure / 20 Pa, see
:mod:`fallgen.audio.mix`), ``rgb`` (N, 300, 300, 3) uint8, ``depth`` (N, 300, 300) float16
metres, ``instance`` and ``category`` (N, 300, 300) int16, and ``occupancy/{row}`` (nx, ny) uint8
per episode (rooms differ in size); with trajectory frames, ``frames/{row}/rgb`` etc.

Files are written under a temporary name of the writer's own (pid and a random token) and
renamed when complete (the media first, then the rows), without timestamps, so a shard's bytes
depend only on its episodes. A shard made by a build carries what made it
(:class:`fallgen.dataset.integrity.Stamp`): its fingerprint in the media file's attributes and in
the rows' metadata (with the build's fingerprint, its events' hashes and the media file's
sha256), and a write record of both files' sha256 (``.fallgen/shards/NAME.json``, written just
before the rows are renamed into place). A write that fails (a full disk) raises ``OSError``
and leaves neither file under its final name.
"""

from __future__ import annotations

import errno
import json
from pathlib import Path

import h5py
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from fallgen.atomic import commit, fault_point, named
from fallgen.dataset.integrity import Stamp, file_entry, record_path, tmp_name, write_record
from fallgen.dataset.schema import COLUMNS
from fallgen.nav.agent import ACTIONS
from fallgen.physics.events import fall_height_m, first_impact_surface

#: gzip's level for the images and maps: 1, the fastest. Twenty paper-size episodes: level 4
#: took 13.4 ms an episode (the RGB image 9.5 of it) for 109 kB, level 1 5.5 ms for 119 kB (of
#: the ~820 kB an episode holds, most of it its audio); the arrays read back are the same.
GZIP = 1
#: Arrays stored without compression: float32 audio is noise in its low mantissa bytes, so
#: gzip saved 19 % of its size (575 of 706 kB per episode) at 17 ms per episode, most of the
#: cost of writing a shard.
UNCOMPRESSED = frozenset({"audio"})
#: key of the shard's own metadata (split, shard, num_shards, dropped) in the Parquet schema
META_KEY = "fallgen"


def shard_meta(schema: pa.Schema) -> dict | None:
    """The metadata :meth:`ShardWriter.close` put in a shard's schema; None when there is none
    (a ValueError when it is not JSON)."""
    raw = (schema.metadata or {}).get(META_KEY.encode())
    return None if raw is None else json.loads(raw)


def shard_name(split: str, i: int, n: int) -> str:
    return f"{split}-{i:05d}-of-{n:05d}"


def _dataset(h5: h5py.Group, name: str, data: np.ndarray) -> None:
    chunks = (1,) + data.shape[1:] if data.ndim > 1 and data.shape[0] > 0 else None
    h5.create_dataset(name, data=data, chunks=chunks, compression="gzip",
                      compression_opts=GZIP, shuffle=True, track_times=False)


def row_of(ep, split: str, media: str, index: int, root_seed: int,
           skipped: list[tuple[str, str]] = ()) -> dict:
    """The episode's Parquet row (columns in :data:`fallgen.dataset.schema.COLUMNS` order);
    ``skipped``: the (event_id, reason) pairs tried before ``ep.event``."""
    e = ep.event
    plan = ep.expert.plan
    # the fall's own levels (the noise floor is its own column)
    peak, leq = ep.audio.fall_levels or ep.audio.levels_db_spl()
    row = {
        "episode_id": ep.episode_id, "split": split, "event_id": e.event_id,
        "room_variant": e.room_variant, "room_kind": e.room_kind, "zone": e.zone,
        "zone_kind": e.zone_kind, "category": e.target.category, "variant": e.target.variant,
        "material": e.target.material, "audio_material": e.audio_material,
        "scale": e.target.scale, "mass_kg": e.mass_kg,
        "start_pos": list(e.start_pos), "start_quat": list(e.start_quat),
        "settle_pos": list(e.settle_pos), "settle_quat": list(e.settle_quat),
        "settle_time_s": e.settle_time_s, "contacts": len(e.contacts),
        "fall_height_m": fall_height_m(e.contacts, e.start_linvel[2]),
        "spawn_x": ep.spawn.x, "spawn_y": ep.spawn.y, "spawn_heading": ep.spawn.heading,
        "spawn_yaw_rad": ep.spawn.yaw_rad, "spawn_sees_object": ep.spawn_sees_object,
        "expert_actions": list(plan.actions),
        "expert_poses": [[p.x, p.y, float(p.heading), float(p.tilt_deg)]
                         for p in ep.expert_poses],
        "expert_path_m": plan.path_m,
        "shortest_path_m": ep.expert.shortest_m, "fewest_actions": ep.expert.fewest_actions,
        "expert_spl": ep.expert_spl, "expert_sna": ep.expert_sna,
        "goal_x": plan.goal.x, "goal_y": plan.goal.y, "goal_heading": plan.goal.heading,
        "goal_tilt_deg": plan.goal.tilt_deg,
        "target_cell": list(ep.target_cell), "grid_resolution_m": ep.grid.resolution,
        "audio_gain": ep.audio.gain, "audio_peak_db_spl": peak, "audio_leq_db_spl": leq,
        "audio_noise_db_a": ep.audio.noise_db_a,
        "audio_radiated_j": ep.energy.radiated_j, "fall_energy_lost_j": ep.energy.lost_j,
        "audio_energy_ratio": ep.energy.ratio,
        "first_impact_surface": first_impact_surface(e.contacts),
        "room_rt60_s": list(ep.room_rt60_s),
        "sample_rate": ep.audio.sample_rate,
        "instance_labels": json.dumps(list(ep.view.instances)),
        "root_seed": root_seed, "event_attempts": len(skipped) + 1,
        "skipped_events": json.dumps([list(s) for s in skipped]),
        "media_file": media, "media_index": index,
    }
    assert list(row) == list(COLUMNS), "row_of and schema.COLUMNS disagree"
    return row


class ShardWriter:
    """Writes one shard as its episodes are made (only the rows stay in memory: a 250-episode
    shard held whole took ~450 MB). The media go to a temporary file; :meth:`close` renames it
    and then writes the rows, :meth:`abort` removes it: no partial file under a final name.

    ``audio``, ``rgb``, ``depth``, ``instance`` and ``category`` grow by one chunk (one
    episode) per :meth:`add`; ``occupancy/{row}`` and ``frames/{row}/...`` are added per row."""

    def __init__(self, root: Path, split: str, i: int, n: int,
                 category_labels: tuple[str, ...], stamp: Stamp | None = None) -> None:
        self.root, self.split, self.i, self.n, self.stamp = Path(root), split, i, n, stamp
        self.name = name = shard_name(split, i, n)
        self.media = self.root / "media" / f"{name}.h5"
        self.data = self.root / "data" / f"{name}.parquet"
        self.media.parent.mkdir(parents=True, exist_ok=True)
        self.data.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = tmp_name(self.media)
        self._committed: list[Path] = []  # final files close() made (removed by abort())
        self._sink = _Sink(self._tmp, self.media)
        try:
            self._h5 = h5py.File(self._sink, "w", track_order=False)
            self._h5.attrs["actions"] = json.dumps(ACTIONS)
            self._h5.attrs["category_labels"] = json.dumps(list(category_labels))
            if stamp is not None:
                self._h5.attrs["fingerprint"] = stamp.fingerprint
            self._sink.check()
        except BaseException:
            self.abort()
            raise
        self.rows = 0

    def _append(self, name: str, a: np.ndarray) -> None:
        if name not in self._h5:
            packed = {} if name in UNCOMPRESSED else dict(compression="gzip",
                                                         compression_opts=GZIP, shuffle=True)
            self._h5.create_dataset(name, shape=(0, *a.shape), maxshape=(None, *a.shape),
                                    chunks=(1, *a.shape), dtype=a.dtype, track_times=False,
                                    **packed)
        d = self._h5[name]
        d.resize(self.rows + 1, axis=0)
        d[self.rows] = a

    def add(self, ep) -> int:
        """Write an episode's arrays; returns its row (media index)."""
        k = self.rows
        self._append("audio", ep.audio.audio)
        self._append("rgb", ep.view.rgb)
        self._append("depth", ep.view.depth.astype(np.float16))
        self._append("instance", ep.view.instance)
        self._append("category", ep.view.category)
        occ = self._h5.require_group("occupancy")
        _dataset(occ, str(k), ep.grid.occupied.astype(np.uint8)[None])
        if ep.frames:
            g = self._h5.require_group("frames").create_group(str(k), track_order=False)
            _dataset(g, "rgb", np.stack([v.rgb for v in ep.frames]))
            _dataset(g, "depth", np.stack([v.depth for v in ep.frames]).astype(np.float16))
            _dataset(g, "instance", np.stack([v.instance for v in ep.frames]))
        fault_point(self.media)
        self._h5.flush()  # HDF5 writes cached chunks lazily: a full disk shows now
        self._sink.check()
        self.rows += 1
        return k

    def close(self, rows: list[dict], dropped: list = ()) -> tuple[Path, Path]:
        """Finish the media file, then write the rows. ``dropped``: planned episodes no event
        could make, as [episode_id, [[event_id, reason], ...]], kept in the Parquet schema's
        metadata (key ``fallgen``) so that ``validate`` and ``stats`` can account for them.
        On failure the caller calls :meth:`abort`."""
        if len(rows) != self.rows:
            raise ValueError(f"{len(rows)} rows for {self.rows} episodes")
        self._h5.close()
        self._sink.close()
        media = file_entry(self._tmp)
        commit(self._tmp, self.media)
        self._committed.append(self.media)
        table = pa.Table.from_pylist(rows) if rows else \
            pa.table({"episode_id": pa.array([], pa.int64())})
        meta = {"split": self.split, "shard": self.i, "num_shards": self.n,
                "dropped": [list(d) for d in dropped]}
        st = self.stamp
        if st is not None:
            meta.update(fingerprint=st.fingerprint, build=st.inputs["build"],
                        events=st.prefixed("events."), media_sha256=media["sha256"])
        table = table.replace_schema_metadata({META_KEY: json.dumps(meta, sort_keys=True)})
        tmp = tmp_name(self.data)
        try:
            try:
                pq.write_table(table, tmp, compression="zstd")
            except OSError as e:  # pyarrow names no file
                raise named(e, self.data) from None
            if st is not None:
                self._committed.append(record_path(self.root, self.name))
                write_record(self.root, self.name, st, {f"data/{self.data.name}": file_entry(tmp),
                                                        f"media/{self.media.name}": media})
            commit(tmp, self.data)
        finally:
            tmp.unlink(missing_ok=True)
        return self.data, self.media

    def abort(self) -> None:
        """Remove what this writer made: its temporary file and any file :meth:`close` had
        already put under its final name (a shard is both files or neither)."""
        self._sink.discard = True  # HDF5 closes without writing (or failing) again
        h5 = getattr(self, "_h5", None)
        if h5 is not None and h5.id.valid:
            try:
                h5.close()
            except Exception:  # pragma: no cover  (what it reads back may be what was dropped)
                pass
        self._sink.close()
        self._tmp.unlink(missing_ok=True)
        for p in reversed(self._committed):
            p.unlink(missing_ok=True)
        self._committed.clear()


class _Sink:
    """The media file as HDF5 writes it (h5py's ``fileobj`` driver): a write that fails (a
    full disk) is kept, raised by :meth:`check`, and every later write is dropped, so HDF5
    never sees an error. (Writing to the file itself, HDF5 reported a full disk from the
    destructors of its objects, a traceback each, and a process that went on crashed.)"""

    def __init__(self, path: Path, shown: Path) -> None:
        self.shown = shown  # the file it becomes: what an error names
        self.f = open(path, "w+b")  # noqa: SIM115 (closed by close())
        self.error: OSError | None = None
        self.discard = False

    def _guard(self, fn, *args):
        if self.error is None and not self.discard:
            try:
                return fn(*args)
            except OSError as e:
                self.error = e
        return None

    def write(self, b) -> int:
        n = memoryview(b).nbytes
        self._guard(self.f.write, b)
        return n

    def truncate(self, size: int | None = None) -> int | None:
        self._guard(self.f.truncate, size)
        return size

    def flush(self) -> None:
        self._guard(self.f.flush)

    def seek(self, *args) -> int:
        return self.f.seek(*args)

    def tell(self) -> int:
        return self.f.tell()

    def readinto(self, b) -> int:
        return self.f.readinto(b)

    def read(self, n: int = -1) -> bytes:
        return self.f.read(n)

    def check(self) -> None:
        """Raise the first write error, as the OSError for this file it is."""
        e = self.error
        if e is not None:
            raise OSError(e.errno or errno.EIO, e.strerror or str(e), str(self.shown))

    def close(self) -> None:
        if not self.f.closed:
            self.flush()
            try:
                self.f.close()
            except OSError as e:  # the buffer's last bytes
                self.error = self.error or e
        if not self.discard:
            self.check()


def write_shard(root: Path, split: str, i: int, n: int, episodes: list, rows: list[dict],
                category_labels: tuple[str, ...], dropped: list = (),
                stamp: Stamp | None = None) -> tuple[Path, Path]:
    """Write a whole shard at once (see :class:`ShardWriter`)."""
    w = ShardWriter(root, split, i, n, category_labels, stamp)
    try:
        for ep in episodes:
            w.add(ep)
        return w.close(rows, dropped)
    except BaseException:
        w.abort()
        raise
