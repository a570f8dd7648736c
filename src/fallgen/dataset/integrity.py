"""What made every file of a build, whether a file on disk is still what was written, and one
writer per dataset directory: the one rule that ``rehearse``, ``generate``, ``build`` and
``finalize`` share.

**Fingerprints.** A file's *inputs* are a flat dict of everything its bytes depend on: fallgen's
and its libraries' versions, a hash of the source of the packages that shape it (``code.*``),
the config values it reads (``config.*``), the world data files it uses (``world.*``: the
material and category files, the mesh files, the room files of its variants), and for a shard
its fall events (``events.*``: the sha256 of the rehearsal files it replays), its plan
(``plan``: its episodes and the events each may try) and the HRTF file. Its fingerprint is the
hash of its inputs.

- A rehearsal file's inputs sit in its sidecar (``rehearsal/V.stats.json``) with the file's
  sha256 and size; the sidecar's ``fingerprint`` is the part common to every variant
  (:func:`rehearsal_fingerprint`).
- A shard's inputs sit in its write record (``DATASET/.fallgen/shards/NAME.json``) with both
  files' sha256 and size; the shard's Parquet metadata (key ``fallgen``) repeats its
  fingerprint, the build's (:func:`build_inputs`: what every shard shares), its events' hashes
  and the media file's sha256, and the HDF5 file carries the fingerprint as an attribute, so
  that ``fallgen validate`` can check a dataset without the records.

Records carry a checksum of their own content (``check``): an edited record is no record.

**The rule** (:func:`shard_state`, :func:`rehearsal_state`): a file is kept only if its record
exists, its fingerprint is the one the current config, world, code and events give, and its
bytes are those recorded when it was written; a shard that fails is made again, a rehearsal
file made under other inputs is refused (one line naming the file and the difference: rehearsing
again would discard the events the user asked to keep) unless ``--force``, and one whose bytes
changed is rehearsed again (the same bytes: the rehearsal is deterministic).

**One writer per directory** (:func:`writer_lock`): an advisory ``flock`` on
``DATASET/.fallgen/lock`` (its holder's pid and host written in it), exclusive for a whole build,
shared for ``--shard-index`` runs, which also hold their own index's lock; temporary files are
named per writer (pid and a random token).
"""

from __future__ import annotations

import errno
import fcntl
import functools
import hashlib
import json
import os
import platform
import re
import secrets
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fallgen.atomic import write_text
from fallgen.config import check_out, is_card
from fallgen.errors import InputError

if TYPE_CHECKING:
    from fallgen.config import BuildConfig
    from fallgen.world.library import World

#: the build's own state (records, locks) inside the dataset directory; not part of the dataset
STATE_DIR = ".fallgen"
SHARD_FILE = re.compile(r"^(?P<name>(?P<split>[a-z_]+)-(?P<i>\d{5})-of-(?P<n>\d{5}))"
                        r"\.(?P<ext>parquet|h5)$")
PKG = Path(__file__).resolve().parent.parent

#: source that shapes a rehearsal file (the physics and the world it runs in)
REHEARSAL_CODE = ("physics", "world")
#: source that shapes a shard: the episode (replay, spawn, audio, views, maps, the expert's
#: plan), the plan of the build and the writer (this module only hashes: a change to what it
#: hashes changes the fingerprints by itself)
GENERATION_CODE = ("audio", "nav", "physics", "vision", "world", "pipeline/episode.py",
                   "pipeline/settled.py", "pipeline/plan.py", "pipeline/generate.py",
                   "dataset/writer.py", "dataset/schema.py", "__init__.py")


# --- hashing -------------------------------------------------------------------------------------

def digest(obj: Any) -> str:
    """sha256 (20 hex digits) of ``obj`` as canonical JSON."""
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


_SHA: dict[tuple, str] = {}


def sha256(path: str | Path) -> str:
    """A file's sha256, remembered for as long as its size, mtime and inode stay the same (a
    build checks a shard before and after making the others)."""
    st = os.stat(path)
    key = (str(path), st.st_size, st.st_mtime_ns, st.st_ino)
    if key not in _SHA:
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        _SHA[key] = h.hexdigest()
    return _SHA[key]


def file_entry(path: Path) -> dict:
    return {"sha256": sha256(path), "bytes": path.stat().st_size}


@functools.cache
def code_digest(group: str) -> str:
    """Hash of the source of ``group``: a package directory of fallgen (every ``*.py`` under
    it) or one module file."""
    p = PKG / group
    files = [p] if p.suffix == ".py" else sorted(p.rglob("*.py"))
    h = hashlib.sha256()
    for f in files:
        h.update(str(f.relative_to(PKG)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:20]


def _files_digest(files: Iterable[Path], root: Path) -> str:
    h = hashlib.sha256()
    for f in sorted(set(files)):
        name = str(f.relative_to(root)) if f.is_relative_to(root) else str(f)
        h.update(name.encode() + b"\0" + bytes.fromhex(sha256(f)))
    return h.hexdigest()[:20]


@functools.cache
def _versions() -> tuple[tuple[str, str], ...]:
    from fallgen.dataset.manifest import versions

    return tuple(sorted(versions().items()))


def _version_inputs() -> dict[str, str]:
    return {f"version.{k}": v for k, v in _versions()}


def _world_common(world: World) -> dict[str, str]:
    """The world files every file of a build reads: materials, category files and meshes."""
    root = Path(world.root)
    cats = sorted((root / "objects").glob("*.toml"))
    meshes = [v.mesh for c in world.categories for v in c.variants if v.mesh is not None]
    return {"world.materials": _files_digest(world.materials.files, root),
            "world.objects": _files_digest([*cats, *meshes], root)}


def room_file(world: World, variant_id: str) -> Path:
    for spec in world.rooms.values():
        if any(v.id == variant_id for v in spec.variants):
            return Path(spec.file)
    raise KeyError(f"no room variant {variant_id!r}")


def _room_inputs(world: World, variants: Iterable[str]) -> dict[str, str]:
    out = {}
    for vid in variants:
        f = room_file(world, vid)
        out[f"world.rooms/{f.name}"] = sha256(f)[:20]
    return out


def _config(prefix: str, section: Mapping[str, Any], skip: Iterable[str] = ()) -> dict:
    return {f"config.{prefix}.{k}": json.loads(json.dumps(v, default=str))
            for k, v in section.items() if k not in set(skip)}


@dataclass(frozen=True)
class Stamp:
    """What made a file: its inputs (flat, JSON values) and their hash."""

    inputs: dict
    fingerprint: str = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "fingerprint", digest(self.inputs))

    def prefixed(self, prefix: str) -> dict:
        return {k[len(prefix):]: v for k, v in self.inputs.items() if k.startswith(prefix)}


def difference(old: Mapping | None, new: Mapping, most: int = 3) -> str:
    """What differs between two inputs dicts, in a few words, the config's first
    (``config.generate.audio_s 2.0 -> 1.0, the code of fallgen.nav``)."""
    if not old:
        return "no record of what made it"
    parts = []
    order = ("config.", "world.", "events.", "hrtf", "plan", "shard", "variant", "code.")
    for k in sorted(set(old) | set(new),
                    key=lambda k: (next((i for i, o in enumerate(order) if k.startswith(o)),
                                        len(order)), k)):
        a, b = old.get(k), new.get(k)
        if a == b or k == "build":  # "build" hashes the others
            continue
        if k.startswith("code."):
            parts.append(f"the code of fallgen.{k[5:].removesuffix('.py').replace('/', '.')}")
        elif k.startswith(("events.", "world.", "plan", "hrtf")) or a is None or b is None:
            parts.append(f"{k} changed" if a is not None and b is not None else
                         f"{k} {'added' if a is None else 'gone'}")
        else:
            parts.append(f"{k} {a!r} -> {b!r}")
    if not parts:
        return "fingerprint differs"
    more = f" (and {len(parts) - most} more)" if len(parts) > most else ""
    return ", ".join(parts[:most]) + more


# --- what makes a rehearsal file, and a shard ----------------------------------------------------

def rehearsal_common(world: World, cfg: BuildConfig) -> dict:
    import dataclasses

    inputs = {**_version_inputs(), **{f"code.{g}": code_digest(g) for g in REHEARSAL_CODE},
              "config.root_seed": cfg.root_seed,
              **_config("rehearse", dataclasses.asdict(cfg.rehearse), skip=("rooms",)),
              **_world_common(world)}
    return inputs


def rehearsal_fingerprint(world: World, cfg: BuildConfig) -> str:
    """What every variant's rehearsal depends on, hashed (the rooms picked are not part of it;
    each variant's own room file is in its :func:`rehearsal_stamp`)."""
    return digest(rehearsal_common(world, cfg))


def rehearsal_stamp(world: World, cfg: BuildConfig, variant_id: str) -> Stamp:
    return Stamp({**rehearsal_common(world, cfg), **_room_inputs(world, [variant_id]),
                  "variant": variant_id})


def build_inputs(world: World, cfg: BuildConfig) -> dict:
    """What every shard of a build depends on (the manifest's ``build``)."""
    import dataclasses

    from fallgen.audio.heads import hrtf_id

    g = cfg.generate
    return {**_version_inputs(), **{f"code.{c}": code_digest(c) for c in GENERATION_CODE},
            "config.root_seed": cfg.root_seed, **_config("generate", dataclasses.asdict(g)),
            "hrtf": hrtf_id(g.hrtf), **_world_common(world)}


def shard_stamp(world: World, common: dict, name: str, plan: list, variants: Iterable[str],
                events: Mapping[str, str]) -> Stamp:
    """A shard's inputs: the build's, its plan (``[[episode_id, [event ids tried]], ...]``),
    its events' rehearsal files (their sha256) and its variants' room files."""
    variants = sorted(set(variants))
    return Stamp({**common, "build": digest(common), "shard": name, "plan": digest(plan),
                  **{f"events.{v}": events[v] for v in variants},
                  **_room_inputs(world, variants)})


# --- records -------------------------------------------------------------------------------------

def _checked(d: dict) -> dict:
    body = {k: v for k, v in d.items() if k != "check"}
    return {**body, "check": digest(body)}


def is_checked(d: Any) -> bool:
    """``d`` is a record whose ``check`` matches its content."""
    return isinstance(d, dict) and d.get("check") == digest(
        {k: v for k, v in d.items() if k != "check"})


def checked_json(d: dict) -> str:
    """``d`` with its own checksum, as the JSON text a record or sidecar is written in."""
    return json.dumps(_checked(d), indent=1, sort_keys=True) + "\n"


def record_path(root: Path, name: str) -> Path:
    return Path(root) / STATE_DIR / "shards" / f"{name}.json"


def shard_files(root: Path, name: str) -> tuple[Path, Path]:
    root = Path(root)
    return root / "data" / f"{name}.parquet", root / "media" / f"{name}.h5"


def write_record(root: Path, name: str, stamp: Stamp, files: Mapping[str, dict]) -> Path:
    return write_text(record_path(root, name), checked_json(
        {"name": name, "fingerprint": stamp.fingerprint, "inputs": stamp.inputs,
         "files": dict(files)}))


def read_json(path: Path) -> dict | None:
    """A record's content, None when it is missing, unreadable or fails its own check."""
    try:
        d = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return d if is_checked(d) else None


@dataclass(frozen=True)
class State:
    """A file's state against what should be there: ``ok``, ``missing`` (never made, or
    removed whole), ``stale`` (made from other inputs: ``reason`` says which) or ``corrupt``
    (its bytes are not what was written, or there is no record of them)."""

    status: str
    reason: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def _bytes_state(root: Path, files: Mapping[str, dict]) -> State:
    for rel, want in sorted(files.items()):
        p = Path(root) / rel
        if not p.is_file():
            return State("corrupt", f"{rel} missing")
        if p.stat().st_size != want.get("bytes"):
            return State("corrupt", f"{rel} is {p.stat().st_size} bytes, "
                         f"{want.get('bytes')} were written")
        if sha256(p) != want.get("sha256"):
            return State("corrupt", f"{rel}'s bytes differ from what was written")
    return State("ok")


def shard_state(root: Path, name: str, stamp: Stamp | None) -> State:
    """The shard ``name`` under ``root`` against ``stamp`` (None: any fingerprint will do)."""
    root = Path(root)
    data, media = shard_files(root, name)
    rec_path = record_path(root, name)
    if not data.exists() and not media.exists():
        return State("missing")
    rec = read_json(rec_path)
    if rec is None:
        return State("corrupt", "no record of what was written" if not rec_path.exists() else
                     "its write record is unreadable")
    if not data.exists():
        return State("corrupt", f"data/{data.name} missing")
    if stamp is not None and rec.get("fingerprint") != stamp.fingerprint:
        return State("stale", "made from other inputs: " + difference(rec.get("inputs"),
                                                                        stamp.inputs))
    want = rec.get("files") or {}
    if set(want) != {f"data/{data.name}", f"media/{media.name}"}:
        return State("corrupt", "its write record lists other files")
    return _bytes_state(root, want)


def rehearsal_state(path: Path, stamp: Stamp) -> State:
    """A rehearsal file (``rehearsal/V.parquet``) against its sidecar and ``stamp``."""
    side = path.with_suffix(".stats.json")
    if not path.exists():
        return State("missing")
    rec = read_json(side)
    if rec is None:
        return State("corrupt", "no sidecar" if not side.exists() else
                     f"{side.name} is unreadable or was edited")
    if rec.get("inputs") != stamp.inputs:
        return State("stale", difference(rec.get("inputs"), stamp.inputs))
    return _bytes_state(path.parent, {path.name: rec.get("parquet") or {}})


def discard_shard(root: Path, name: str) -> None:
    """Remove a shard (its record first: what is left is never taken for a finished shard)."""
    record_path(root, name).unlink(missing_ok=True)
    for p in shard_files(root, name):
        p.unlink(missing_ok=True)


def unfinalize(root: Path) -> None:
    """The directory is no longer a finished build: remove its manifest, then its card."""
    from fallgen.dataset.manifest import CARD, MANIFEST

    root = Path(root)
    (root / MANIFEST).unlink(missing_ok=True)
    card = root / CARD
    if card.is_file() and is_card(card):
        card.unlink()


def tmp_name(path: Path) -> Path:
    """A temporary name for ``path`` of this writer's own (hidden, pid and a random token)."""
    return path.with_name(f".{path.name}.{os.getpid()}-{secrets.token_hex(4)}.tmp")


def remove_temporaries(root: Path, names: Iterable[str] | None = None) -> None:
    """Temporary files left by writers that died: those of the shards ``names`` (their media,
    rows and write records), or all of them (the rehearsal's, the card's and the
    manifest's too: only while the directory is held exclusively)."""
    root = Path(root)
    wanted = None if names is None else set(names)
    for d in (root / "data", root / "media", root / STATE_DIR / "shards"):
        for p in d.glob("*.tmp"):
            stem = p.name.lstrip(".").split(".", 1)[0]
            if wanted is None or stem in wanted:
                p.unlink(missing_ok=True)
    if names is None:
        for p in [*(root / "rehearsal").glob(".*.tmp"), *root.glob(".*.tmp")]:
            p.unlink(missing_ok=True)


def tidy(root: Path, names: set[str], note: Callable[[str], None] | None = None) -> None:
    """Make ``data/`` and ``media/`` hold only the shards ``names`` may become: shards of
    another plan (another split size or shard size) are removed with their records, as are
    records without files and temporary files; any other file is refused (one line)."""
    root = Path(root)
    removed = []
    for d in ("data", "media"):
        for p in sorted((root / d).glob("*")) if (root / d).is_dir() else []:
            if p.name.startswith(".") or p.name.endswith(".tmp"):  # temporaries (removed
                continue                                            # below), hidden files
            m = SHARD_FILE.match(p.name)
            if not m or p.is_dir():
                raise InputError(p, "<file>", "not a file of this build; remove it, or build "
                                 "into another --out")
            if m["name"] not in names:
                removed.append(m["name"])
    for name in sorted(set(removed)):
        discard_shard(root, name)
    for rec in (root / STATE_DIR / "shards").glob("*.json"):
        if rec.stem not in names:
            rec.unlink(missing_ok=True)
    remove_temporaries(root)
    if removed and note:
        shown = ", ".join(sorted(set(removed))[:3])
        more = f" and {len(set(removed)) - 3} more" if len(set(removed)) > 3 else ""
        note(f"removed {len(set(removed))} shards of another plan (split or shard sizes): "
             f"{shown}{more}")


# --- one writer per directory ---------------------------------------------------------------------

_HELD: dict[str, int] = {}


def _holder(state: Path) -> str:
    texts = []
    for p in [state / "lock", *sorted(state.glob("lock-*"))]:
        try:
            t = p.read_text().strip()
        except OSError:
            continue
        if t:
            texts.append(t)
    return "; ".join(texts[:2]) or "a --shard-index run"


def _acquire(path: Path, exclusive: bool, root: Path):
    f = open(path, "a+")
    try:
        fcntl.flock(f, (fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH) | fcntl.LOCK_NB)
    except BlockingIOError:
        f.close()
        raise InputError(root, "lock", f"another fallgen is writing this directory "
                         f"({_holder(path.parent)}); wait for it to finish, or build into "
                         "another --out") from None
    except BaseException:
        f.close()
        raise
    if exclusive:
        f.seek(0)
        f.truncate()
        f.write(f"pid {os.getpid()} on {platform.node()}\n")
        f.flush()
    return f


@contextmanager
def writer_lock(root: Path, part: str | None = None) -> Iterator[None]:
    """Hold ``root`` for writing: exclusively (``part`` None: a whole build, rehearse,
    generate, finalize) or shared with other ``part``s (``--shard-index`` runs, each holding
    ``part`` exclusively). A directory held by another process is an ``InputError`` naming
    the holder. Nested holds in one process (build -> rehearse, generate) are one hold."""
    root = Path(root)
    check_out(root)
    key = str(root.resolve())
    if key in _HELD:
        _HELD[key] += 1
        try:
            yield
        finally:
            _HELD[key] -= 1
        return
    state = root / STATE_DIR
    state.mkdir(parents=True, exist_ok=True)
    files = []
    try:
        files.append(_acquire(state / "lock", part is None, root))
        if part is not None:
            files.append(_acquire(state / f"lock-{part}", True, root))
        _HELD[key] = 1
        yield
    finally:
        _HELD.pop(key, None)
        for f in reversed(files):
            try:
                if f is files[-1] or part is None:
                    f.seek(0)
                    f.truncate()
            except OSError:
                pass
            f.close()


# --- checks before any work ----------------------------------------------------------------------

def preflight(cfg: BuildConfig, world: World, out: Path | None = None,
              build: bool = True) -> None:
    """Every check that can be made before any work: the output directory, the HRTF file,
    the zones the config picks, and (``build``: not for the rehearsal alone) whether they can
    give enough fall events for its splits."""
    from fallgen.config import SPLITS
    from fallgen.pipeline.plan import kind_counts

    check_out(Path(out or cfg.out))
    g = cfg.generate
    if build:
        from fallgen.audio.heads import load_hrtf

        load_hrtf(g.hrtf)
    import fnmatch

    variants = world.variants(cfg.rehearse.rooms)
    if not variants:
        raise InputError(cfg.file, "rehearse.rooms", f"no room variant matches "
                         f"{cfg.rehearse.rooms!r}")
    zones: dict[str, int] = {}
    for v in variants:
        n = sum(fnmatch.fnmatchcase(z.id, cfg.rehearse.zones) for z in v.zones)
        if n:
            zones[v.kind] = zones.get(v.kind, 0) + n
    if not zones:
        raise InputError(cfg.file, "rehearse.zones", f"{cfg.rehearse.zones!r} matches no zone "
                         "of the rooms picked")
    kinds = sorted(zones)
    for kind in kinds if build else ():
        need = sum(1 for n in g.episodes if kind_counts(n, kinds)[kind])
        most = zones[kind] * cfg.rehearse.events_per_zone
        if most < need:
            raise InputError(cfg.file, "rehearse.zones", f"{cfg.rehearse.zones!r} leaves at "
                             f"most {most} {kind} fall events, fewer than the {need} splits "
                             f"({', '.join(SPLITS)}) with {kind} episodes need; pick more "
                             "zones or events_per_zone")


# --- one line for what goes wrong around the build ----------------------------------------------

def one_line(e: BaseException) -> str | None:
    """The one line a command prints for an error of the machine or of a file (a full disk, an
    unwritable or missing directory, a corrupt Parquet or HDF5 file, a worker that died), or
    None for anything else (a bug: its traceback is wanted)."""
    from concurrent.futures.process import BrokenProcessPool

    if isinstance(e, OSError):
        where = e.filename or ""
        what = e.strerror or " ".join(str(e).split())
        if e.errno == errno.ENOSPC:
            what = "no space left on device; free some and run the command again (it resumes)"
        return f"{where}: {what}" if where else what
    if isinstance(e, BrokenProcessPool):
        return ("a worker process ended abruptly (killed, out of memory, or crashed); run the "
                "command again (it resumes)")
    try:
        import pyarrow as pa
    except ImportError:  # pragma: no cover
        return None
    if isinstance(e, pa.ArrowException):
        return f"unreadable Parquet data ({type(e).__name__}: {' '.join(str(e).split())[:160]})"
    return None


__all__ = ["Stamp", "State", "writer_lock", "shard_state", "rehearsal_state", "preflight",
           "tidy", "one_line", "difference", "build_inputs", "shard_stamp", "rehearsal_stamp",
           "rehearsal_fingerprint", "unfinalize"]
